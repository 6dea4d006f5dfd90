"""Tests of cablefem.catenary against closed forms (docs/theory.md §8 and §9).

Every tolerance is derived in a comment: solver tolerances, finite-difference truncation
bounds computed from the exact third derivatives, neglected terms of asymptotic expansions,
or half a unit in the last digit of a number printed in docs/theory.md.
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from cablefem.catenary import (
    Catenary2D,
    catenary_between,
    irvine_lambda2,
    irvine_symmetric_frequency,
    length_for_horizontal_tension,
    length_for_sag_ratio,
    solve_catenary,
)

pytestmark = pytest.mark.single_rank  # pure NumPy: nothing distributed

EPS = np.finfo(float).eps

# (span, rise, length, w, EA): slack level, inclined, steep and descending, taut (length <
# chord), inextensible, near-vertical; lengths within 1.5 chords and w l/EA <= 1e-2.
CASES = [
    (100.0, 0.0, 102.0, 10.0, 1e6),
    (100.0, 30.0, 110.0, 10.0, 1e5),
    (20.0, -60.0, 70.0, 3.0, 5e4),
    (100.0, 20.0, 101.5, 10.0, 2e5),
    (100.0, 20.0, 101.0, 1.0, 1e6),
    (50.0, 10.0, 50.5, 2.0, 1e4),
    (100.0, 0.0, 99.9, 10.0, 1e6),
    (80.0, 25.0, 90.0, 2.0, math.inf),
    (1e-3, 40.0, 39.98, 5.0, 1e6),
]


def third_derivative_bound(cat: Catenary2D) -> tuple[float, float]:
    """max over s of |x'''| and |z'''| for the elastic catenary.

    x' = H/T + H/EA and z' = V/T + V/EA with V' = w, T' = w V/T, so (the EA terms are
    linear in s) x''' = -H w^2 (T^2 - 3 V^2)/T^5 and z''' = -3 w^2 H^2 V/T^5.
    """
    s = np.linspace(0.0, cat.length, 20001)
    V, T, H, w = cat.vertical_force(s), cat.tension(s), cat.H, cat.w
    x3 = H * w**2 * np.abs(T**2 - 3 * V**2) / T**5
    z3 = 3 * w**2 * H**2 * np.abs(V) / T**5
    # the maxima are sampled on a grid of 2e4 intervals: |x''''| l / 2e4 is far below them,
    # the factor 1.01 covers it
    return 1.01 * x3.max(), 1.01 * z3.max()


# ---------------------------------------------------------------- closed-form consistency


@pytest.mark.parametrize("case", CASES)
def test_end_conditions_and_tension(case):
    span, rise, l, w, EA = case
    cat = solve_catenary(*case)
    c = math.hypot(span, rise)
    # Newton stops when |residual| <= 1e-13 (chord + l (1 + w l/EA)) <= 1e-13 * 2.6 c for
    # these cases (l <= 1.5 c, w l/EA <= 1e-2): well inside the required 1e-12 c
    assert abs(cat.x(l) - span) <= 1e-12 * c
    assert abs(cat.z(l) - rise) <= 1e-12 * c
    assert cat.x(0.0) == 0.0 and cat.z(0.0) == 0.0
    assert cat.H > 0
    s = np.linspace(0, l, 101)
    V = cat.V_q - w * (l - s)
    # T = sqrt(H^2 + V^2) and T (cos, sin)(angle) = (H, V): a few roundings of numbers of
    # size T (cos and sin of an angle rounded to eps are off by <= eps in absolute terms)
    T = cat.tension(s)
    np.testing.assert_allclose(cat.vertical_force(s), V, rtol=1e-14, atol=1e-14 * w * l)
    np.testing.assert_allclose(T, np.sqrt(cat.H**2 + V**2), rtol=1e-14)
    angle = cat.tangent_angle(s)
    np.testing.assert_allclose(T * np.cos(angle), cat.H, rtol=0, atol=8 * EPS * T.max())
    np.testing.assert_allclose(T * np.sin(angle), V, rtol=0, atol=8 * EPS * T.max())
    # vectorised and scalar calls agree
    assert isinstance(cat.x(0.3 * l), float)
    assert cat.x(s).shape == s.shape
    assert cat.z(s)[30] == cat.z(s[30])


@pytest.mark.parametrize("case", CASES[:8])
def test_equilibrium_and_stretch_by_finite_differences(case):
    span, rise, l, w, EA = case
    cat = solve_catenary(*case)
    h = 1e-3 * l
    s = np.linspace(h, l - h, 401)
    xp = (cat.x(s + h) - cat.x(s - h)) / (2 * h)
    zp = (cat.z(s + h) - cat.z(s - h)) / (2 * h)
    T = cat.tension(s)
    lam = 1 + T / EA
    x3, z3 = third_derivative_bound(cat)
    R = l + abs(rise)  # size of the coordinates: each is rounded to within ~4 eps R
    rnd = 4 * EPS * R / h  # round-off of a central difference
    # central difference: f' + h^2/6 f''' + h^4/120 f^(5) + ...; the largest error is where
    # |f'''| is largest and equals h^2/6 max|f'''| there to ~1 % (observed: 0.75-0.99 of
    # the bound). The next term is smaller by ~ (h w/H)^2 <= 2e-4 (H >= 0.07 w l here), so a
    # 10 % margin covers it
    ex = 1.1 * h**2 / 6 * x3 + rnd
    ez = 1.1 * h**2 / 6 * z3 + rnd
    # stretch |dr/ds| = 1 + T/EA
    np.testing.assert_array_less(np.abs(np.hypot(xp, zp) - lam), math.hypot(ex, ez))
    # internal force N = T r'/lambda: horizontal component constant = H ...
    np.testing.assert_array_less(np.abs(T * xp / lam - cat.H), T * ex)
    # ... and vertical component V(s) = V_q - w (l - s), i.e. dV/ds = w everywhere
    Nz = T * zp / lam
    np.testing.assert_array_less(np.abs(Nz - (cat.V_q - w * (l - s))), T * ez)
    # slope of Nz by a second central difference (spacing 2 dh): the O(h^2) error of Nz is
    # a smooth function (h^2/6) T z'''/lambda whose derivative is bounded by
    # (T z''')' = -3 w^3 H^2 (T^2 - 4 V^2)/T^6, |.| <= 9 w^3/H^2 (up to O(T/EA) <= 1 %
    # from lambda; observed errors are 0.04-0.33 of the bound); round-off of Nz (<= T rnd)
    # is amplified by 1/(2 dh)
    dh = s[20] - s[0]  # differences over every 20th point
    slope = (Nz[40:] - Nz[:-40]) / (2 * dh)
    tol = h**2 / 6 * 9 * w**3 / cat.H**2 + 2 * T.max() * rnd / (2 * dh)
    np.testing.assert_array_less(np.abs(slope - w), tol)


def test_robustness_sweep():
    """Seeded random cables: chords 1e-3..1e4 m at any inclination (a fifth within 1e-12..
    0.1 rad of the vertical), w 1e-4..1e4 N/m, EA from 0.03 w c to 1e12 w c or infinite,
    lengths from 1e-12 to 100 chords shorter or longer (near-vertical hairpins included)."""
    rng = np.random.default_rng(1)
    for i in range(300):
        c = 10 ** rng.uniform(-3, 4)
        ang = rng.uniform(-1.57, 1.57)
        if i % 5 == 0:
            ang = math.copysign(math.pi / 2 - 10 ** rng.uniform(-12, -1), ang)
        span, rise = c * math.cos(ang), c * math.sin(ang)
        w = 10 ** rng.uniform(-4, 4)
        EA = math.inf if i % 7 == 0 else w * c * 10 ** rng.uniform(-1.5, 12)
        l = c * (1 + rng.choice([-1, 1]) * 10 ** rng.uniform(-12, 2))
        if l <= 0 or (math.isinf(EA) and l <= c):
            continue
        cat = solve_catenary(span, rise, l, w, EA)
        # the solver's own stopping test, |residual| <= 1e-13 (chord + l (1 + w l/EA)),
        # re-evaluated with the public methods (identical arithmetic)
        scale = math.hypot(span, rise) + l * (1 + w * l / EA)
        assert math.hypot(cat.x(l) - span, cat.z(l) - rise) <= 1e-13 * scale
        assert cat.H > 0


def test_level_cable_is_symmetric():
    cat = solve_catenary(100.0, 0.0, 103.0, 10.0, 1e5)
    l = cat.length
    # level cable: the vertex is at s = l/2 (V = 0), where x = span/2; sag = -z(l/2).
    # V(l/2) = V_q - w l/2 is rounded relative to w l; sag agrees to round-off of z
    assert abs(cat.vertical_force(l / 2)) <= 1e-12 * cat.w * l
    assert abs(cat.x(l / 2) - 50.0) <= 1e-12 * l
    assert abs(cat.sag() + cat.z(l / 2)) <= 1e-12 * l
    assert cat.sag_ratio() == pytest.approx(cat.sag() / 100.0, rel=1e-15)


# ---------------------------------------------------------------- classical limits


def test_inextensible_level_catenary():
    """x = L/2 + a asinh((s - l/2)/a), z = sqrt(a^2 + (s-l/2)^2) - sqrt(a^2 + (l/2)^2),
    l = 2 a sinh(L/2a), sag = a (cosh(L/2a) - 1), with a = H/w."""
    a, L, w = 50.0, 80.0, 2.0
    u = L / (2 * a)
    l = 2 * a * math.sinh(u)
    dl_da = 2 * math.sinh(u) - (L / a) * math.cosh(u)  # sensitivity of l to a at fixed L
    dL_da = 2 * math.asinh(l / (2 * a)) - (l / a) / math.hypot(1, l / (2 * a))  # fixed l
    s = np.linspace(0, l, 41)
    cat = solve_catenary(L, 0.0, l, w, math.inf)
    # a residual of <= 1e-13 (L + l) in x(l) shifts a by that over |dL/da|
    assert abs(cat.H / w - a) <= 1e-13 * (L + l) / abs(dL_da) + 4 * EPS * a
    # the shape formulas against the classical ones, with the solved a (V(l/2) = 0 to
    # round-off for this level cable): round-off of coordinates of size L + l only
    a_s = cat.H / w
    assert abs(cat.vertical_force(l / 2)) <= 4 * EPS * w * l
    x_ex = L / 2 + a_s * np.arcsinh((s - l / 2) / a_s)
    z_ex = np.hypot(a_s, s - l / 2) - math.hypot(a_s, l / 2)
    np.testing.assert_allclose(cat.x(s), x_ex, rtol=0, atol=8 * EPS * (L + l))
    np.testing.assert_allclose(cat.z(s), z_ex, rtol=0, atol=8 * EPS * (L + l))
    assert abs(cat.sag() - a_s * (math.cosh(L / (2 * a_s)) - 1)) <= 8 * EPS * (L + l)

    # huge but finite EA: the stretch, between l H/EA and l T_max/EA, acts as an extra
    # length and lowers a (dl/da < 0) by stretch/|dl/da| to first order; 10 % margins for
    # the second order (the stretch is 1e-8 of l) and the solver tolerance
    EA = 1e10
    cat = solve_catenary(L, 0.0, l, w, EA)
    T_max = float(np.max(cat.tension(s)))
    da = a - cat.H / w
    assert 0.9 * l * cat.H / (EA * abs(dl_da)) <= da <= 1.1 * l * T_max / (EA * abs(dl_da))


@pytest.mark.parametrize("ratio", [1e-2, 1e-3, 1e-4])
def test_parabolic_small_sag_limit(ratio):
    """H = w L^2/(8 d) (1 - (4/3)(d/L)^2 + O((d/L)^4)) for a level inextensible cable:
    with u = w L/(2H), d/L = (cosh u - 1)/(2u) = u/4 + O(u^3) and
    w L^2/(8 d H) = (u^2/2)/(cosh u - 1) = 1 - u^2/12 + O(u^4) = 1 - (4/3)(d/L)^2 + ..."""
    L, w = 100.0, 5.0
    l = length_for_sag_ratio(L, 0.0, ratio, w, math.inf)
    cat = solve_catenary(L, 0.0, l, w, math.inf)
    d = cat.sag()
    # the inverse finds l to ~4 eps; d ~ sqrt(l - L) amplifies that by d ln d/d ln l =
    # l/(2 (l - L)) (3.8e7 at ratio 1e-4): a round-off-level inverse gives this bound
    assert abs(d / L / ratio - 1) <= 8 * EPS * l / (l - L)
    parabolic = w * L**2 / (8 * d)
    rel = parabolic / cat.H - 1
    # the neglected term is -(4/3)(d/L)^2; the next one, O((d/L)^4), is below 1 % of it
    # for d/L <= 1e-2, so 2x the leading term is a safe bound
    assert abs(rel) <= 2 * (4 / 3) * ratio**2
    if ratio >= 1e-3:  # the coefficient itself (rel known to ~1e-12 from the solves)
        assert rel / ratio**2 == pytest.approx(-4 / 3, abs=0.01 + 1e-11 / ratio**2)


# ---------------------------------------------------------------- inverse functions


@pytest.mark.parametrize("case", CASES[:8])
def test_round_trip_horizontal_tension(case):
    span, rise, l, w, EA = case
    H = solve_catenary(*case).H
    l2 = length_for_horizontal_tension(span, rise, H, w, EA)
    # H is exact to a residual 1e-13 (chord + l) in x(l), which the inverse reads as a
    # length error of the same relative size times d ln H/d ln span over d ln H/d ln l
    # (O(1) for these cables); brentq adds 4 eps. 1e-11 leaves a factor ~40 for that ratio.
    assert abs(l2 - l) <= 1e-11 * l
    assert solve_catenary(span, rise, l2, w, EA).H == pytest.approx(H, rel=1e-9)


@pytest.mark.parametrize("case", CASES[:8])
def test_round_trip_sag_ratio(case):
    span, rise, l, w, EA = case
    r = solve_catenary(*case).sag_ratio()
    l2 = length_for_sag_ratio(span, rise, r, w, EA)
    # as above: sag and length are related with O(1) relative sensitivity except for taut
    # cables, where d ln sag/d ln l ~ (EA/T) (l - chord)/l... is large and helps
    assert abs(l2 - l) <= 1e-11 * l


def test_weightless_closed_forms():
    span, rise, EA, H = 30.0, 40.0, 1e6, 2e3
    c = 50.0
    l = length_for_horizontal_tension(span, rise, H, 0.0, EA)
    T = H * c / span  # straight cable: H = T span/c, T = EA (c/l - 1)
    assert l == pytest.approx(c / (1 + T / EA), rel=4 * EPS)
    cat = solve_catenary(span, rise, l, 0.0, EA)
    assert cat.H == pytest.approx(H, rel=1e-9)  # EA (c/l - 1): cancellation EA/T * eps
    np.testing.assert_allclose(cat.tension([0, l / 2, l]), T, rtol=1e-9)
    # straight: z/x = rise/span everywhere (round-off only)
    s = np.linspace(0, l, 11)
    np.testing.assert_allclose(cat.z(s), cat.x(s) * rise / span, rtol=0, atol=1e-13 * c)


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: length_for_horizontal_tension(10, 0, 0.0, 1, 1e3), "H"),
        (lambda: length_for_horizontal_tension(10, 0, -5.0, 1, 1e3), "H"),
        (lambda: length_for_horizontal_tension(10, 0, 5.0, 0.0, math.inf), "H"),
        (lambda: length_for_sag_ratio(10, 0, 0.0, 1, 1e3), "sag_ratio"),
        (lambda: length_for_sag_ratio(10, 0, -0.1, 1, 1e3), "sag_ratio"),
        (lambda: length_for_sag_ratio(10, 0, 0.1, 0.0, 1e3), "sag_ratio"),
        (lambda: length_for_sag_ratio(0.0, 1, 0.1, 1.0, 1e3), "span"),
        (lambda: solve_catenary(-1.0, 0, 1, 1, 1), "span"),
        (lambda: solve_catenary(1.0, math.nan, 1, 1, 1), "rise"),
        (lambda: solve_catenary(1.0, 0, 0.0, 1, 1), "length"),
        (lambda: solve_catenary(1.0, 0, 1, -1.0, 1), "w"),
        (lambda: solve_catenary(1.0, 0, 1, 1, 0.0), "EA"),
        (lambda: solve_catenary(1.0, 0, 1.5, 0.0, 1e3), "length"),  # slack weightless
        (lambda: solve_catenary(1.0, 0, 0.9, 1.0, math.inf), "length"),  # short inext.
        (lambda: irvine_symmetric_frequency(0.0), "lambda2"),
        (lambda: irvine_symmetric_frequency(1.0, n=0), "n"),
        (lambda: irvine_lambda2(1.0, -1.0, 1, 1, 1, 0.01), "H"),
    ],
)
def test_bad_inputs_raise(call, name):
    with pytest.raises(ValueError, match=name):
        call()


# ------------------------------------------------------------------- docs/theory.md §9


def chord_for_sag_ratio(ratio, EA, l=1.0, w=1.0):
    """Level chord L with sag/L = ratio for fixed stress-free length (sag ratio decreases
    with the span: bracket from a slack 0.5 l to a strained 1.5 l)."""
    return brentq(lambda L: solve_catenary(L, 0.0, l, w, EA).sag_ratio() - ratio, 0.5, 1.5,
                  xtol=1e-14, rtol=4 * EPS)


def test_paper_case_A():
    EA = 17857.14  # as printed in docs/theory.md §9
    L = chord_for_sag_ratio(0.005, EA)
    cat = solve_catenary(L, 0.0, 1.0, 1.0, EA)
    # printed values: half a unit in the last printed digit
    assert abs(L - 1.0013333) <= 0.5e-7
    assert abs(cat.H - 25) <= 0.5
    assert abs(abs(cat.tangent_angle(0.0)) - 0.02) <= 0.005  # Delta ~ 0.02 rad
    # omega_1 = 16.407: Irvine's first symmetric frequency of this string, m = g = 1
    lam2 = irvine_lambda2(L, cat.H, 1.0, 1.0, EA, cat.sag())
    omega = irvine_symmetric_frequency(lam2) * math.sqrt(cat.H / 1.0) / L
    assert abs(omega - 16.407) <= 0.5e-3


def test_paper_case_B():
    EA = 1e4
    L = chord_for_sag_ratio(0.05, EA)
    cat = solve_catenary(L, 0.0, 1.0, 1.0, EA)
    assert abs(L - 0.9936571) <= 0.5e-7
    # omega_2 = 9.9815 = 2 pi sqrt(H/m)/L, the first antisymmetric in-plane frequency
    assert abs(2 * math.pi * math.sqrt(cat.H) / L - 9.9815) <= 0.5e-4


# ---------------------------------------------------------------- Irvine


@pytest.mark.parametrize(
    "lambda2, expected",
    [(0.01, 1.0004), (1.0, 1.0402), (4.0, 1.1518), (10.0, 1.3451), (20.0, 1.6095),
     (4 * math.pi**2, 2.0000), (100.0, 2.5972), (math.inf, 2.8606)],
)
def test_irvine_table(lambda2, expected):
    wbar = irvine_symmetric_frequency(lambda2)
    assert abs(wbar / math.pi - expected) <= 0.5e-4  # table printed to 4 decimals
    # the root satisfies the transcendental equation to round-off (|tan| <= ~1e3 here)
    x = wbar / 2
    rhs = x if math.isinf(lambda2) else x - 4 / lambda2 * x**3
    assert abs(math.sin(x) - rhs * math.cos(x)) <= 1e-12 * max(1.0, abs(rhs))


def test_irvine_limits_and_higher_modes():
    # lambda2 = 4 pi^2: tan(pi) = 0 = pi - pi exactly, so omega_bar = 2 pi; brentq stops
    # within 1e-15 + 4 eps x and F' = 12 x^2/lambda2 = 3 there: 1e-13 is round-off level
    wbar = irvine_symmetric_frequency(4 * math.pi**2)
    assert wbar == pytest.approx(2 * math.pi, abs=1e-13)
    # lambda2 -> inf: the cubic term 4 x^3/lambda2 -> 0; at 1e14 it moves the root by
    # ~ 4 x^3/lambda2 / (1 + tan^2 x) < 1e-12
    assert irvine_symmetric_frequency(1e14) == pytest.approx(
        irvine_symmetric_frequency(math.inf), abs=1e-11)
    # lambda2 -> 0: omega_bar -> (2n - 1) pi from above; taut-string-like symmetric modes
    for n in (1, 2, 3):
        wbar = irvine_symmetric_frequency(1e-8, n)
        assert (2 * n - 1) * math.pi < wbar < (2 * n - 1) * math.pi * (1 + 1e-6)
        # n-th root lies in the n-th branch of tan
        wbar = irvine_symmetric_frequency(50.0, n)
        assert (2 * n - 1) * math.pi <= wbar <= (2 * n + 1) * math.pi
    # irvine_lambda2 formula: (m g L/H)^2 L EA/(H L_e), L_e = L (1 + 8 (d/L)^2), here
    # m g L/H = 0.2, EA/H = 100, d/L = 0.1 so L/L_e = 1/1.08 (a few roundings: 1e-14)
    assert irvine_lambda2(100.0, 1e4, 2.0, 10.0, 1e6, 10.0) == pytest.approx(
        0.2**2 * 100 / 1.08, rel=1e-14)
    assert irvine_lambda2(100.0, 1e4, 2.0, 10.0, math.inf, 10.0) == math.inf


# ---------------------------------------------------------------- 3D wrapper


def random_rotation(seed):
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


@pytest.mark.parametrize("case", [CASES[1], CASES[2], CASES[5], CASES[7]])
def test_3d_rotation_invariance_and_equilibrium(case):
    span, rise, l, w, EA = case
    R = random_rotation(7)
    p = np.array([3.0, -2.0, 5.0])
    q = p + R @ np.array([span, 0.0, rise])
    cab = catenary_between(p, q, l, w, EA, gravity_dir=2.5 * (R @ [0.0, 0.0, -1.0]))
    cat = solve_catenary(span, rise, l, w, EA)
    c = math.hypot(span, rise)
    s = np.linspace(0, l, 31)
    expected = p + (R @ np.vstack([cat.x(s), 0 * s, cat.z(s)])).T
    # span and rise are recomputed from rotated vectors (a few ulps of c); the solution's
    # sensitivity to them is O(1) here; rotation round-off ~ 10 eps (|p| + c): 1e-11 (|p|+c)
    scale = np.linalg.norm(p) + c
    np.testing.assert_allclose(cab.position(s), expected, rtol=0, atol=1e-11 * scale)
    assert cab.position(s).shape == (31, 3)
    np.testing.assert_allclose(cab.tension(s), cat.tension(s), rtol=1e-10)
    np.testing.assert_allclose(cab.position([l])[0], q, rtol=0, atol=1e-12 * scale)
    # global equilibrium of the cable: the anchor forces on it (-F_p, -F_q) balance its
    # weight w l along gravity; V_q - V(0) = w l exactly up to round-off: 1e-10
    Fp, Fq = cab.force_at_p(), cab.force_at_q()
    g = cab.gravity_dir
    T_max = cab.tension(s).max()
    assert np.linalg.norm(Fp + Fq - w * l * g) <= 1e-10 * (w * l + T_max)
    # forces: magnitude T and direction of the tangent into the span. One-sided
    # second-order difference (-3 r0 + 4 r1 - r2)/(2h) = r' - h^2/3 r''' + ...:
    x3, z3 = third_derivative_bound(cat)
    h = 1e-4 * l
    r0, r1, r2 = cab.position([0.0, h, 2 * h])
    rp = (-3 * r0 + 4 * r1 - r2) / (2 * h)
    tol = h**2 / 3 * math.hypot(x3, z3) + 8 * EPS * scale / h
    np.testing.assert_allclose(Fp / np.linalg.norm(Fp), rp / np.linalg.norm(rp), atol=2 * tol)
    r0, r1, r2 = cab.position([l, l - h, l - 2 * h])
    rm = (-3 * r0 + 4 * r1 - r2) / (2 * h)  # derivative towards decreasing s
    np.testing.assert_allclose(Fq / np.linalg.norm(Fq), rm / np.linalg.norm(rm), atol=2 * tol)
    assert np.linalg.norm(Fp) == pytest.approx(cat.tension(0.0), rel=1e-12)
    assert np.linalg.norm(Fq) == pytest.approx(cat.tension(l), rel=1e-12)


def test_3d_vertical_chord():
    c, l, w, EA = 10.0, 9.99, 2.0, 1e5
    p, q = np.array([1.0, 2.0, c]), np.array([1.0, 2.0, 0.0])  # q below p
    cab = catenary_between(p, q, l, w, EA)
    assert cab.cat is None
    s = np.linspace(0, l, 21)
    T = cab.tension(s)
    # going down from p the tension drops by w per unit stress-free length
    np.testing.assert_allclose(np.diff(T), -w * np.diff(s), rtol=1e-10)
    # int_0^l (1 + T/EA) ds = chord (T linear: exact), so the cable ends at q
    assert l + 0.5 * (T[0] + T[-1]) * l / EA == pytest.approx(c, rel=1e-14)
    pos = cab.position(s)
    np.testing.assert_allclose(pos[:, :2], np.tile(p[:2], (21, 1)), rtol=0, atol=0)
    np.testing.assert_allclose(pos[-1], q, rtol=0, atol=1e-13 * c)
    assert T[-1] > 0
    Fp, Fq = cab.force_at_p(), cab.force_at_q()
    np.testing.assert_allclose(Fp + Fq, w * l * np.array([0, 0, -1.0]), atol=1e-10 * T[0])
    # continuity with a chord tilted by delta at fixed chord length: the transverse weight
    # w delta gives a sag w delta l^2/(8 T), extra length (8/3) sag^2/l, hence a tension
    # change EA w^2 delta^2 l^2/(24 T^2); the axial weight changes by w l delta^2/2 at
    # most; factor 2 margin for the non-uniform tension and higher orders
    for delta in (1e-3, 1e-4):
        qt = p + c * np.array([math.sin(delta), 0.0, -math.cos(delta)])
        tilt = catenary_between(p, qt, l, w, EA)
        assert tilt.cat is not None
        Tm = T.mean()
        bound = 2 * (EA * w**2 * delta**2 * l**2 / (24 * Tm**2) + w * l * delta**2 / 2)
        np.testing.assert_array_less(np.abs(tilt.tension(s) - T), bound)
    # too long: slack at the lower end
    with pytest.raises(ValueError, match="length"):
        catenary_between(p, q, 10.5, w, EA)


def test_3d_weightless_and_bad_inputs():
    p, q, l, EA = np.zeros(3), np.array([3.0, 4.0, 12.0]), 12.9, 1e4
    cab = catenary_between(p, q, l, 0.0, EA)
    assert cab.cat is None
    T = EA * (13.0 / l - 1)  # uniform tension of a stretched straight cable
    np.testing.assert_allclose(cab.tension([0, l / 2, l]), T, rtol=1e-12)
    np.testing.assert_allclose(cab.position([l])[0], q, atol=1e-13 * 13)
    np.testing.assert_allclose(cab.force_at_p(), T * q / 13, rtol=1e-12)
    np.testing.assert_allclose(cab.force_at_q(), -T * q / 13, rtol=1e-12)
    with pytest.raises(ValueError, match="length"):
        catenary_between(p, q, 13.5, 0.0, EA)  # slack weightless
    with pytest.raises(ValueError, match="gravity_dir"):
        catenary_between(p, q, l, 1.0, EA, gravity_dir=(0, 0, 0))
    with pytest.raises(ValueError, match="chord"):
        catenary_between(p, p, l, 1.0, EA)
    with pytest.raises(ValueError, match="length"):
        catenary_between(p, q, -1.0, 1.0, EA)
    with pytest.raises(ValueError, match="EA"):
        catenary_between(p, [0, 0, 5.0], 5.0, 1.0, math.inf)  # straight inextensible
