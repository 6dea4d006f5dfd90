"""Tests of the case layer: properties, motions, TOML/dict case parsing and its errors.

Pure Python/NumPy (no dolfinx), so they run anywhere. The paper's cases are those of
``docs/theory.md`` §9 in its dimensionless units (l = w = g = 1, m = 1).
"""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from cablefem.case import (
    CASE_KEYS,
    CaseError,
    TableDoc,
    check_table_ends,
    format_case_reference,
    load_case,
    parse_case,
    rayleigh_coefficients,
    startup_time,
)
from cablefem.motion import (
    DEFAULT_RAMP_PERIODS,
    EllipseMotion,
    HarmonicMotion,
    Motion,
    TableMotion,
    TimeFunction,
    ramp_factors,
    read_factor_csv,
    read_motion_csv,
)
from cablefem.properties import Section, dimensionless_groups
from cablefem.timetables import ACCELERATION_STEP_FRACTION

pytestmark = pytest.mark.single_rank  # parsing, no dolfinx: nothing distributed

EPS = np.finfo(float).eps
OMEGA1 = 16.407  # case A: first in-plane frequency (rad per time unit), docs/theory.md §9
OMEGA2 = 9.9815  # case B

CASE_A_TOML = """
title = "Paper case A"

[section]
EA = 17857.14
EI = 4.0e-4
mass = 1.0

[gravity]
g = 1.0

[geometry]
sag_ratio = 0.005

[mesh]
elements = 30

[[anchors]]
name = "p"
position = [0, 0, 0]

[[anchors]]
name = "q"
position = [1.0013333, 0, 0]
[anchors.motion]
type = "harmonic"
amplitude = [2e-4, 0, 0]
omega = 32.814

[damping]
model = "rayleigh"
ratio = 0.005
frequencies = [16.407, 32.814]

[dynamics]
t_end = 30.0
dt = 0.005

[solver]
petsc_options = { ts_type = "alpha2", snes_rtol = 1e-10, ts_adapt_monitor = false }
"""


def case_a() -> dict:
    """Paper case A as a dict (a fresh copy each time)."""
    return {
        "title": "Paper case A",
        "section": {"EA": 17857.14, "EI": 4.0e-4, "mass": 1.0},
        "gravity": {"g": 1.0},
        "geometry": {"sag_ratio": 0.005},
        "anchors": [
            {"name": "p", "position": [0.0, 0.0, 0.0]},
            {"name": "q", "position": [1.0013333, 0.0, 0.0],
             "motion": {"type": "harmonic", "amplitude": [2e-4, 0, 0], "omega": 2 * OMEGA1}},
        ],
        "damping": {"ratio": 0.005, "frequencies": [OMEGA1, 2 * OMEGA1]},
        "dynamics": {"t_end": 30.0, "dt": 0.005},
    }


DELETE = object()


def set_key(data: dict, path: str, value) -> dict:
    """Set (or delete, with ``DELETE``) the value at a key path like 'anchors[1].motion.omega'."""
    *parents, last = re.findall(r"[^.\[\]]+", path)
    node = data
    for token in parents:
        node = node[int(token)] if isinstance(node, list) else node.setdefault(token, {})
    index = int(last) if isinstance(node, list) else last
    if value is DELETE:
        del node[index]
    else:
        node[index] = value
    return data


def problems_of(data: dict, **kwargs) -> list[tuple[str, str]]:
    with pytest.raises(CaseError) as info:
        parse_case(data, **kwargs)
    return info.value.problems


def has_problem(problems: list[tuple[str, str]], key: str, fragment: str) -> bool:
    return any(k == key and fragment in m for k, m in problems)


# ---------------------------------------------------------------------------------------------
# Good cases


def test_case_a_toml(tmp_path):
    path = tmp_path / "case_a.toml"
    path.write_text(CASE_A_TOML)
    case = load_case(path)
    assert case.title == "Paper case A" and case.source == str(path)
    assert (case.section.EA, case.section.EI, case.section.GJ, case.section.mass) == \
        (17857.14, 4.0e-4, 0.0, 1.0)
    assert case.gravity.g == 1.0
    np.testing.assert_array_equal(case.gravity.vector, [0.0, 0.0, -1.0])
    assert (case.geometry.kind, case.geometry.value, case.geometry.length) == \
        ("sag_ratio", 0.005, None)
    assert (case.mesh.elements, case.mesh.grading) == (30, 1.0)
    p, q = case.anchors
    assert (p.name, q.name, p.kind, q.kind) == ("p", "q", "clamped", "clamped")
    # docs/theory.md §9: clamped along the chord, c_p = +X, c_q = -X (exact: unit chord)
    np.testing.assert_array_equal(p.direction, [1.0, 0.0, 0.0])
    np.testing.assert_array_equal(q.direction, [-1.0, 0.0, 0.0])
    assert p.motion is None and isinstance(q.motion, HarmonicMotion)
    assert isinstance(q.motion, Motion)
    np.testing.assert_array_equal(q.motion.omega, [32.814] * 3)
    assert case.damping.model == "rayleigh" and case.damping.ratios == (0.005, 0.005)
    assert (case.dynamics.t_end, case.dynamics.dt, case.dynamics.rho_inf,
            case.dynamics.output_every) == (30.0, 0.005, 0.9, 1)
    assert case.modal.modes == 6 and case.solver.tension_only is True
    assert case.solver.petsc_options == {"ts_type": "alpha2", "snes_rtol": 1e-10,
                                         "ts_adapt_monitor": False}
    assert case.loads == [] and case.point_masses == [] and case.point_loads == []
    echo = json.loads(json.dumps(case.to_dict()))
    # no ramp given: the documented default, DEFAULT_RAMP_PERIODS periods 2 pi/omega (the
    # same expression as in the code: equal to the last bit)
    assert echo["anchors"][1]["motion"] == {"type": "harmonic", "amplitude": [2e-4, 0.0, 0.0],
                                            "omega": [32.814] * 3, "phase": [0.0] * 3,
                                            "ramp": DEFAULT_RAMP_PERIODS * 2 * math.pi / 32.814}
    assert echo["damping"]["alpha"] == case.damping.alpha


def test_parse_case_equals_load_case(tmp_path):
    path = tmp_path / "a.toml"
    path.write_text(CASE_A_TOML)
    from_file = load_case(path).to_dict()
    from_dict = parse_case(case_a()).to_dict()
    for d in (from_file, from_dict):
        d.pop("source"), d.pop("solver")
        d["anchors"][1]["motion"].pop("omega")  # 2 * 16.407 differs from 32.814 in the last bit
        d["anchors"][1]["motion"].pop("ramp")  # the default ramp, 2 pi/omega: the same
    assert from_file == from_dict


def test_case_b_ellipse_motion():
    data = case_a()
    set_key(data, "anchors[1].motion", {"type": "ellipse", "omega": OMEGA2, "ramp": 0.0,
                                        "axis_sin": [0, 0, 1e-3], "axis_cos": [0, 5e-4, 0]})
    motion = parse_case(data).anchors[1].motion
    assert isinstance(motion, EllipseMotion)
    for t in (0.0, 0.3, 2.7, 29.9):
        # docs/theory.md §9, case B: u_Z = 1e-3 sin(w2 t), u_Y = 5e-4 (cos(w2 t) - 1);
        # both sides evaluate the same expressions, so equality is to a few ulp of 1e-3
        expected = [0.0, 5e-4 * (math.cos(OMEGA2 * t) - 1), 1e-3 * math.sin(OMEGA2 * t)]
        np.testing.assert_allclose(motion.displacement(t), expected, rtol=0, atol=1e-18)
    np.testing.assert_array_equal(motion.displacement(0.0), np.zeros(3))


def test_polyline_fills_anchor_positions_and_length():
    data = case_a()
    data["geometry"] = {"polyline": [[0, 0, 0], [0.5, 0, -0.1], [1, 0, 0]]}
    for anchor in data["anchors"]:
        anchor.pop("position")
    case = parse_case(data)
    np.testing.assert_array_equal(case.anchors[0].position, [0, 0, 0])
    np.testing.assert_array_equal(case.anchors[1].position, [1, 0, 0])
    # two segments of length sqrt(0.5^2 + 0.1^2); a few ulp of round-off
    assert case.geometry.length == pytest.approx(2 * math.hypot(0.5, 0.1), rel=1e-15)
    assert case.geometry.polyline.shape == (3, 3)


def test_optional_sections_and_normalisation(tmp_path):
    (tmp_path / "f.csv").write_text("time, factor\n0, 0\n1, 1\n")
    data = case_a()
    data.update(
        gravity={"g": 9.81, "direction": [0, 0, -2]},
        mesh={"elements": 40, "grading": 3},
        loads=[{"value": [0, 1.0, 0]},
               {"value": [0, 0, 1], "time": {"type": "harmonic", "omega": 2.0, "phase": 0.5}}],
        point_masses=[{"s": 0.5, "mass": 2.0}],
        point_loads=[{"s": 0.25, "value": [0, 0, -10.0], "time": {"type": "table",
                                                                   "file": "f.csv",
                                                                   "hold": True}}],
        modal={"modes": 3}, solver={"tension_only": False})
    data["anchors"][0].update(type="pinned")
    data["anchors"][1].update(direction=[-3, 0, 4])
    case = parse_case(data, base_dir=tmp_path)
    np.testing.assert_array_equal(case.gravity.direction, [0, 0, -1])
    # (-3, 0, 4)/5: one division and a norm, each within an ulp of values <= 1
    np.testing.assert_allclose(case.anchors[1].direction, [-0.6, 0, 0.8], rtol=0, atol=2 * EPS)
    assert case.anchors[0].kind == "pinned" and case.anchors[0].direction is None
    assert (case.mesh.elements, case.mesh.grading) == (40, 3.0)
    assert case.loads[0].time.value(123.0) == 1.0
    assert case.loads[1].time.value(0.25) == math.sin(2.0 * 0.25 + 0.5)
    # a spline through 2 rows is their straight line: 0.5 up to a few ulp
    assert case.point_loads[0].time.value(0.5) == pytest.approx(0.5, rel=4 * EPS)
    assert case.point_loads[0].time.value(7.0) == 1.0  # held after the end (hold = true)
    assert (case.point_masses[0].s, case.point_masses[0].mass) == (0.5, 2.0)
    assert case.modal.modes == 3 and case.solver.tension_only is False
    json.dumps(case.to_dict())


def test_no_damping_section_means_none():
    data = case_a()
    del data["damping"], data["dynamics"]
    case = parse_case(data)
    assert (case.damping.model, case.damping.alpha, case.damping.beta) == ("none", 0.0, 0.0)
    assert case.dynamics is None


# ---------------------------------------------------------------------------------------------
# Damping


@pytest.mark.parametrize("omega", [OMEGA1, OMEGA2])
def test_rayleigh_equal_ratios_closed_form(omega):
    data = case_a()
    zeta, w1, w2 = 0.005, omega, 2 * omega
    data["damping"] = {"ratio": zeta, "frequencies": [w1, w2]}
    damping = parse_case(data).damping
    # docs/theory.md §2 closed form for equal ratios; both sides are a handful of flops,
    # so they agree to a few ulp: 1e-12 relative is far above round-off
    assert damping.alpha == pytest.approx(2 * zeta * w1 * w2 / (w1 + w2), rel=1e-12)
    assert damping.beta == pytest.approx(2 * zeta / (w1 + w2), rel=1e-12)
    for w in (w1, w2):
        # zeta(w) = alpha/(2 w) + beta w/2 reproduces the ratio (round-off only, ~1e-18)
        assert abs(damping.ratio_at(w) - zeta) < 1e-12


def test_rayleigh_unequal_ratios_reproduce_both():
    data = case_a()
    data["damping"] = {"ratios": [0.01, 0.02], "frequencies": [30.0, 3.0]}
    damping = parse_case(data).damping
    assert damping.ratios == (0.01, 0.02) and damping.frequencies == (30.0, 3.0)
    # round-off of the formula (a few ulp of ratios ~1e-2): far below 1e-12
    assert abs(damping.ratio_at(30.0) - 0.01) < 1e-12
    assert abs(damping.ratio_at(3.0) - 0.02) < 1e-12
    assert (damping.alpha, damping.beta) == rayleigh_coefficients((0.01, 0.02), (30.0, 3.0))


def test_damping_direct_and_axial():
    data = case_a()
    data["damping"] = {"alpha": 0.1}
    damping = parse_case(data).damping
    assert (damping.model, damping.alpha, damping.beta, damping.ratios) == \
        ("rayleigh", 0.1, 0.0, None)
    data["damping"] = {"model": "axial", "beta": 0.002}
    damping = parse_case(data).damping
    assert (damping.model, damping.alpha, damping.beta) == ("axial", 0.0, 0.002)


# ---------------------------------------------------------------------------------------------
# Motions and time functions


def assert_derivatives(motion, times, h, d3, d4, amp):
    """Central differences of the displacement against the analytic velocity/acceleration.

    ``d3``, ``d4``: bounds of |u'''|, |u''''| per component; ``amp``: bound of |u|.
    Truncation: |(u(t+h) - u(t-h))/(2h) - u'| <= h^2/6 max|u'''| and
    |(u(t+h) - 2u + u(t-h))/h^2 - u''| <= h^2/12 max|u''''| (Taylor with remainder).
    Round-off: each u carries an absolute error <= delta = amp eps (4 + |t| omega_max), the
    phase error of sin(omega t) included; it enters the quotients as delta/h and 4 delta/h^2.
    A factor 4 on the round-off terms covers the few extra flops.
    """
    for t in times:
        delta = amp * EPS * (4 + abs(t) * 40.0)  # omega_max <= 40 rad/s in these tests
        v_fd = (motion.displacement(t + h) - motion.displacement(t - h)) / (2 * h)
        a_fd = (motion.displacement(t + h) - 2 * motion.displacement(t)
                + motion.displacement(t - h)) / h**2
        tol_v = h**2 / 6 * d3 + 4 * delta / h
        tol_a = h**2 / 12 * d4 + 16 * delta / h**2
        assert np.all(np.abs(motion.velocity(t) - v_fd) <= tol_v), (t, tol_v)
        assert np.all(np.abs(motion.acceleration(t) - a_fd) <= tol_a), (t, tol_a)


TIMES = (0.0, 0.013, 0.5, 1.7, 9.99, 29.3)


def test_harmonic_derivatives():
    amplitude, omega = np.array([2e-4, 1e-3, 5e-4]), np.array([32.814, OMEGA2, 20.0])
    motion = HarmonicMotion(amplitude, omega, [0.0, 0.3, -1.0])
    assert_derivatives(motion, TIMES, 1e-4, amplitude * omega**3, amplitude * omega**4,
                       amplitude)
    # the scalar omega broadcasts; u_k = A_k sin(w t + phi_k)
    scalar = HarmonicMotion([1.0, 2.0, 3.0], 2.0, 0.5)
    # np.sin and math.sin may differ by an ulp: 4 eps relative
    np.testing.assert_allclose(scalar.displacement(1.0), np.array([1, 2, 3]) * math.sin(2.5),
                               rtol=4 * EPS, atol=0)


def test_ellipse_derivatives():
    a_sin, a_cos = np.array([0.0, 0.0, 1e-3]), np.array([0.0, 5e-4, 0.0])
    motion = EllipseMotion(OMEGA2, a_sin, a_cos)
    bound = np.abs(a_sin) + np.abs(a_cos)  # |a_s sin + a_c cos| <= |a_s| + |a_c|
    assert_derivatives(motion, TIMES, 1e-4, bound * OMEGA2**3, bound * OMEGA2**4, 2 * bound)


def test_table_motion_is_a_c2_spline():
    """A table motion is the C2 cubic spline through its rows with not-a-knot ends: it passes
    through every row, its velocity and acceleration are its own derivatives (central
    differences), continuous across the rows (the linear interpolation before had a velocity
    jump at every row and zero acceleration), the third derivative is the same on the first
    two and on the last two segments (not-a-knot), and the motion is held outside."""
    times = np.array([0.0, 0.1, 0.25, 0.4, 0.5, 0.8])
    values = np.array([[0, 0, 0], [1e-3, 0, -2e-3], [0, 5e-4, 1e-3], [2e-3, 0, 0],
                       [1e-3, 1e-3, 0], [0, 0, 2e-3]])
    motion = TableMotion(times, values)
    for t, u in zip(times, values):  # through the rows, to round-off of |u| <= 2e-3
        np.testing.assert_allclose(motion.displacement(t), u, rtol=0, atol=64 * EPS * 2e-3)
    # the third derivative (jerk) of each segment's cubic: the slope of its acceleration
    jerks = [(motion.acceleration(b - 1e-12) - motion.acceleration(a + 1e-12)) / (b - a)
             for a, b in zip(times[:-1], times[1:])]
    jerk = float(np.max(np.abs(jerks)))
    acc_max = max(float(np.max(np.abs(motion.acceleration(t)))) for t in times)
    # inside a segment the spline is a cubic: central differences are exact but for the
    # velocity's truncation h^2/6 |u'''| and round-off (|u| <= 1e-2 here, amplified by 1/h
    # and 1/h^2; the acceleration's truncation is h^2/12 |u''''| = 0)
    h = 1e-4
    for t in (0.05, 0.17, 0.3, 0.45, 0.7):
        v_fd = (motion.displacement(t + h) - motion.displacement(t - h)) / (2 * h)
        a_fd = (motion.displacement(t + h) - 2 * motion.displacement(t)
                + motion.displacement(t - h)) / h**2
        np.testing.assert_allclose(motion.velocity(t), v_fd, rtol=0,
                                   atol=h**2 / 6 * jerk + 16 * EPS * 1e-2 / h)
        np.testing.assert_allclose(motion.acceleration(t), a_fd, rtol=0,
                                   atol=64 * EPS * 1e-2 / h**2)
    # continuity across the interior rows: left and right limits at distance d differ by at
    # most 2 d times the bound of the next derivative (plus round-off)
    d = 1e-9
    v_max = max(float(np.max(np.abs(motion.velocity(t)))) for t in np.linspace(0, 0.8, 801))
    for t in times[1:-1]:
        np.testing.assert_allclose(motion.displacement(t - d), motion.displacement(t + d),
                                   rtol=0, atol=2 * d * v_max + 64 * EPS * 2e-3)
        np.testing.assert_allclose(motion.velocity(t - d), motion.velocity(t + d), rtol=0,
                                   atol=2 * d * acc_max + 64 * EPS * v_max)
        np.testing.assert_allclose(motion.acceleration(t - d), motion.acceleration(t + d),
                                   rtol=0, atol=2 * d * jerk + 64 * EPS * acc_max)
    # not-a-knot: one cubic on the first two segments, one on the last two (same jerk; the
    # jerks above are differences over 1e-12 of accelerations: 1e-6 relative covers that)
    np.testing.assert_allclose(jerks[0], jerks[1], rtol=0, atol=1e-6 * jerk)
    np.testing.assert_allclose(jerks[-2], jerks[-1], rtol=0, atol=1e-6 * jerk)
    assert not np.allclose(jerks[1], jerks[2], rtol=0, atol=1e-3 * jerk)  # a knot there
    # held outside the table, with zero velocity and acceleration
    np.testing.assert_array_equal(motion.displacement(-1.0), values[0])
    np.testing.assert_array_equal(motion.displacement(5.0), values[-1])
    for t in (-1.0, 5.0):
        np.testing.assert_array_equal(motion.velocity(t), np.zeros(3))
        np.testing.assert_array_equal(motion.acceleration(t), np.zeros(3))


def test_table_of_a_smooth_motion_matches_it():
    """A table sampled from a sine every dh. Away from the ends (5 rows: the influence of
    the end conditions decays by about 2 - sqrt(3) = 0.27 per row, to 1e-3) the error is
    within the complete cubic spline's bounds (constants 5/384, 1/24, 3/8 (Hall and Meyer
    1976) times the sine's 4th derivative A w^4); over the whole table, not-a-knot ends
    included, it converges as dh^4, dh^3, dh^2 (observed orders from dh and dh/2, within
    0.5). Linear interpolation missed the velocity by up to A w^2 dh/2 and had no
    acceleration."""
    A, w = 2e-4, 32.814
    exact = HarmonicMotion([A, 0, 0], w)
    kinds = ("displacement", "velocity", "acceleration")
    grid = np.linspace(0.0, 1.0, 4001)
    errs = []
    for dh in (0.01, 0.005):
        t = np.arange(0.0, 1.0 + dh / 2, dh)
        table = TableMotion(t, np.array([exact.displacement(x) for x in t]))
        e = {k: np.array([abs(getattr(table, k)(x)[0] - getattr(exact, k)(x)[0])
                          for x in grid]) for k in kinds}
        inner = (grid >= 5 * dh) & (grid <= 1 - 5 * dh)
        d4 = A * w**4
        for k, c in zip(kinds, (5 / 384 * dh**4, dh**3 / 24, 3 / 8 * dh**2)):
            assert np.max(e[k][inner]) <= c * d4, k
        errs.append({k: np.max(e[k]) for k in kinds})
    for k, order in zip(kinds, (4, 3, 2)):
        assert abs(np.log2(errs[0][k] / errs[1][k]) - order) < 0.5, (k, errs)
    assert 3 / 8 * 0.01**2 * A * w**4 < 0.1 * A * w**2  # dh = 0.01: 10 % of the amplitude


def test_ramp_function():
    """r = 10 x^3 - 15 x^4 + 6 x^5 over the ramp: 0 -> 1, first and second derivatives zero
    at both ends (continuous with the constants outside), derivatives equal to central
    differences of r inside (truncation h^2/6 |r'''| <= h^2/6 60/T^3 and h^2/12 |r''''| <=
    h^2/12 360/T^4; round-off 4 eps/h and 16 eps/h^2), monotonic."""
    T = 0.7
    assert ramp_factors(0.0, T) == (0.0, 0.0, 0.0) and ramp_factors(T, T) == (1.0, 0.0, 0.0)
    assert ramp_factors(-1.0, T) == (0.0, 0.0, 0.0) and ramp_factors(5.0, T) == (1.0, 0.0, 0.0)
    assert ramp_factors(0.3, 0.0) == (1.0, 0.0, 0.0)  # no ramp
    d = 1e-7  # just inside: r <= 10 (d/T)^3, r' <= 30 d^2/T^3, |r''| <= 60 d/T^3 (and at T - d)
    r, dr, ddr = ramp_factors(d, T)
    assert r <= 10 * (d / T) ** 3 and dr <= 30 * d**2 / T**3 and ddr <= 60 * d / T**3
    r, dr, ddr = ramp_factors(T - d, T)
    assert 1 - r <= 10 * (d / T) ** 3 + EPS and dr <= 30 * d**2 / T**3 and \
        abs(ddr) <= 60 * d / T**3
    h = 1e-4
    for t in np.linspace(0.01, T - 0.01, 13):
        rm, r0, rp = (ramp_factors(x, T)[0] for x in (t - h, t, t + h))
        _, dr, ddr = ramp_factors(t, T)
        assert abs((rp - rm) / (2 * h) - dr) <= h**2 / 6 * 60 / T**3 + 4 * EPS / h
        assert abs((rp - 2 * r0 + rm) / h**2 - ddr) <= h**2 / 12 * 360 / T**4 + 16 * EPS / h**2
    rs = [ramp_factors(x * T, T)[0] for x in np.linspace(0, 1, 101)]
    assert np.all(np.diff(rs) >= 0)


@pytest.mark.parametrize("kind", ["harmonic", "ellipse"])
def test_ramped_motion_starts_at_rest_and_is_smooth(kind):
    """A ramped motion starts at zero displacement, velocity and acceleration (even with a
    phase); its velocity and acceleration (product rule) are the derivatives of its
    displacement (central differences; bounds of the product's 3rd and 4th derivatives by
    Leibniz from |r'| <= 1.875/T, |r''| <= 5.78/T^2, |r'''| <= 60/T^3, |r''''| <= 360/T^4
    and |u0^(k)| <= amp w^k); they are continuous at the end of the ramp; after it the
    motion is the unramped one."""
    T, w = 0.5, 20.0
    if kind == "harmonic":
        amp = np.array([2e-4, 1e-3, 5e-4])
        ramped = HarmonicMotion(amp, w, [0.0, 0.7, -1.0], ramp=T)
        plain = HarmonicMotion(amp, w, [0.0, 0.7, -1.0])
    else:
        ramped = EllipseMotion(w, [0, 0, 1e-3], [0, 5e-4, 0], ramp=T)
        plain = EllipseMotion(w, [0, 0, 1e-3], [0, 5e-4, 0])
        amp = np.array([0.0, 1e-3, 1e-3])  # |a_s sin + a_c (cos - 1)| <= |a_s| + 2 |a_c|
    for f in ("displacement", "velocity", "acceleration"):
        np.testing.assert_array_equal(getattr(ramped, f)(0.0), np.zeros(3))
    assert np.any(plain.velocity(0.0) != 0)  # what the ramp removes: the jump at t = 0
    b = [1.0, 1.875 / T, 5.78 / T**2, 60 / T**3, 360 / T**4]
    d3 = amp * sum(math.comb(3, k) * b[k] * w ** (3 - k) for k in range(4))
    d4 = amp * sum(math.comb(4, k) * b[k] * w ** (4 - k) for k in range(5))
    h = 1e-4  # times at least 100 h away from t = T, where the 3rd derivative jumps
    assert_derivatives(ramped, [0.013, 0.1, 0.25, 0.37, T - 0.01, T + 0.01, 0.9, 1.7], h,
                       d3, d4, amp)
    d = 1e-9
    d1 = amp * (w + b[1])
    d2 = amp * (w**2 + 2 * b[1] * w + b[2])
    for f, nxt in (("displacement", d1), ("velocity", d2), ("acceleration", d3)):
        np.testing.assert_allclose(getattr(ramped, f)(T - d), getattr(ramped, f)(T + d),
                                   rtol=0, atol=2 * d * float(np.max(nxt)) + 1e-15)
    for t in (T, T + 0.3, 2.0):
        for f in ("displacement", "velocity", "acceleration"):
            np.testing.assert_array_equal(getattr(ramped, f)(t), getattr(plain, f)(t))


def test_case_ramp_default_and_explicit():
    """No ramp key: DEFAULT_RAMP_PERIODS periods of the lowest omega of a moving component;
    ramp = 0 keeps the motion itself (the paper's definition); the ramp is echoed."""
    data = case_a()
    set_key(data, "anchors[1].motion.omega", [32.814, 5.0, 1.0])  # uy, uz do not move
    motion = parse_case(data).anchors[1].motion
    assert motion.ramp == DEFAULT_RAMP_PERIODS * 2 * math.pi / 32.814
    set_key(data, "anchors[1].motion.amplitude", [2e-4, 1e-4, 0.0])
    assert parse_case(data).anchors[1].motion.ramp == DEFAULT_RAMP_PERIODS * 2 * math.pi / 5.0
    set_key(data, "anchors[1].motion.ramp", 0)
    motion = parse_case(data).anchors[1].motion
    assert motion.ramp == 0.0
    np.testing.assert_array_equal(motion.velocity(0.0), [2e-4 * 32.814, 1e-4 * 5.0, 0.0])
    set_key(data, "anchors[1].motion", {"type": "ellipse", "omega": OMEGA2,
                                        "axis_sin": [0, 0, 1e-3]})
    case = parse_case(data)
    assert case.anchors[1].motion.ramp == DEFAULT_RAMP_PERIODS * 2 * math.pi / OMEGA2
    assert case.to_dict()["anchors"][1]["motion"]["ramp"] == case.anchors[1].motion.ramp
    for bad, fragment in ((-1.0, "must be >= 0"), ("x", "expected a number")):
        set_key(data, "anchors[1].motion.ramp", bad)
        assert has_problem(problems_of(data), "anchors[1].motion.ramp", fragment)
    set_key(data, "anchors[1].motion", {"type": "table", "file": "m.csv", "ramp": 1.0})
    assert has_problem(problems_of(data), "anchors[1].motion.ramp", "does not apply")
    # a frequency whose default ramp overflows (found by the fuzz test: a ValueError
    # traceback before) is a problem of omega; a given ramp needs none
    for kind, extra in (("ellipse", {"axis_sin": [0, 0, 1e-3]}),
                        ("harmonic", {"amplitude": [0, 0, 1e-3]})):
        set_key(data, "anchors[1].motion", {"type": kind, "omega": 5e-324, **extra})
        assert has_problem(problems_of(data), "anchors[1].motion.omega", "too small")
        set_key(data, "anchors[1].motion.ramp", 2.0)
        assert parse_case(data).anchors[1].motion.ramp == 2.0


def test_startup_time_rules():
    """The end of the start-up (the default fatigue window's start): the longest ramp; a
    motion that jumps at t = 0 (ramp = 0) counts DEFAULT_RAMP_PERIODS of its periods; none
    without such a motion (no motion, or ramp = 0 with a motion starting at rest)."""
    data = case_a()
    assert startup_time(parse_case(data))[0] == DEFAULT_RAMP_PERIODS * 2 * math.pi / (
        2 * OMEGA1)
    set_key(data, "anchors[1].motion.ramp", 2.5)
    t0, why = startup_time(parse_case(data))
    assert t0 == 2.5 and "anchors[1].motion.ramp" in why
    set_key(data, "anchors[1].motion.ramp", 0.0)
    t0, why = startup_time(parse_case(data))
    assert t0 == DEFAULT_RAMP_PERIODS * 2 * math.pi / (2 * OMEGA1) and "jumps" in why
    set_key(data, "anchors[1].motion", {"type": "ellipse", "omega": OMEGA2, "ramp": 0.0,
                                        "axis_cos": [0, 5e-4, 0]})  # u = v = 0 at t = 0
    assert startup_time(parse_case(data))[0] == 0.0
    set_key(data, "anchors[1].motion", DELETE)
    assert startup_time(parse_case(data))[0] == 0.0


def _table_case(tmp_path, rows: np.ndarray, dt: float, t_end: float, hold=None,
                where: str = "motion") -> dict:
    """case_a with a table (an anchor motion, or a point load's factor) of ``rows``."""
    data = case_a()
    data["dynamics"] = {"t_end": t_end, "dt": dt}
    table = {"type": "table", "file": "m.csv"}
    if where == "motion":
        text = "time,ux,uy,uz\n" + "".join(f"{r[0]!r},{r[1]!r},0,0\n" for r in rows)
        set_key(data, "anchors[1].motion", table)
    else:
        text = "time,factor\n" + "".join(f"{r[0]!r},{r[1]!r}\n" for r in rows)
        data["point_loads"] = [{"s": 0.5, "value": [0, 0, -1.0], "time": table}]
    if hold is not None:
        table["hold"] = hold
    (tmp_path / "m.csv").write_text(text)
    return data


SMOOTH_T = np.linspace(0.0, 2.0, 201)
SMOOTH = np.column_stack([SMOOTH_T, 1e-3 * (1 - np.cos(SMOOTH_T))**2])  # at rest at t = 0


@pytest.mark.parametrize("where,key", [("motion", "anchors[1].motion"),
                                       ("load", "point_loads[0].time")])
def test_table_ending_before_t_end_is_refused_unless_held(tmp_path, where, key):
    """A table that ends before dynamics.t_end was held silently: now a problem naming the
    table's file key (and pointing to hold), unless hold = true."""
    problems = problems_of(_table_case(tmp_path, SMOOTH, 0.01, 3.0, where=where),
                           base_dir=tmp_path)
    assert has_problem(problems, f"{key}.file", "ends at t = 2 s") and \
        has_problem(problems, f"{key}.file", f"{key}.hold = true")
    case = parse_case(_table_case(tmp_path, SMOOTH, 0.01, 3.0, hold=True, where=where),
                      base_dir=tmp_path)
    table = case.anchors[1].motion if where == "motion" else case.point_loads[0].time
    assert table.hold is True
    reaches = parse_case(_table_case(tmp_path, SMOOTH, 0.01, 2.0, where=where),
                         base_dir=tmp_path)
    # run_case checks a longer --t-end the same way, before any work
    assert check_table_ends(reaches, 2.0) == []
    assert [k for k, _ in check_table_ends(reaches, 2.5)] == [f"{key}.file"]
    data = _table_case(tmp_path, SMOOTH, 0.01, 2.0, hold=1, where=where)
    assert has_problem(problems_of(data, base_dir=tmp_path), f"{key}.hold", "boolean")


def test_table_ends_are_checked_against_the_runs_end(tmp_path):
    """A table ending at t = 2 s with dynamics.t_end = 3 s was refused for a run that ends
    before it (--t-end 1.5) or has no dynamics (--static-only): the check is against the
    run's end (``t_end``) and skipped without dynamics; a later end is still refused."""
    data = _table_case(tmp_path, SMOOTH, 0.01, 3.0)
    assert has_problem(problems_of(data, base_dir=tmp_path), "anchors[1].motion.file",
                       "end of the run t = 3 s")
    assert parse_case(data, base_dir=tmp_path, t_end=1.5).anchors[1].motion.hold is False
    parse_case(data, base_dir=tmp_path, dynamics=False)
    assert has_problem(problems_of(data, base_dir=tmp_path, t_end=2.5),
                       "anchors[1].motion.file", "end of the run t = 2.5 s")


def test_table_resolution_warnings(tmp_path):
    """A smooth table, rows every 0.01 s, at rest at t = 0: no warning with dt = 0.01. With
    dt = 0.02 its rows are closer than dt. A fast table (w = 30 rad/s: its acceleration
    changes by ~ w dt/2 of its range in a step) with dt = 0.05 > 0.2/w: the spline's
    acceleration changes by more than ACCELERATION_STEP_FRACTION of its range in a step. A
    motion table that starts away from zero or moving warns too; all name the file key."""
    assert parse_case(_table_case(tmp_path, SMOOTH, 0.01, 2.0),
                      base_dir=tmp_path).warnings == []
    warned = parse_case(_table_case(tmp_path, SMOOTH, 0.02, 2.0), base_dir=tmp_path).warnings
    assert [k for k, _ in warned] == ["anchors[1].motion.file"]
    assert "shorter than dynamics.dt = 0.02 s" in warned[0][1]
    w = 30.0
    coarse = np.linspace(0.0, 2.0, 41)  # rows every 0.05 = dt: no spacing warning
    fast = np.column_stack([coarse, 1e-3 * (1 - np.cos(w * coarse))])
    assert w * 0.05 / 2 > ACCELERATION_STEP_FRACTION
    for where, key in (("motion", "anchors[1].motion.file"),
                       ("load", "point_loads[0].time.file")):
        warned = parse_case(_table_case(tmp_path, fast, 0.05, 2.0, where=where),
                            base_dir=tmp_path).warnings
        assert any(k == key and "acceleration" in m and "dt <=" in m for k, m in warned), warned
        assert not any("shorter than" in m for _, m in warned)
    moved = np.column_stack([SMOOTH_T, 1e-3 + 1e-3 * np.sin(SMOOTH_T)])  # u(0), v(0) != 0
    warned = parse_case(_table_case(tmp_path, moved, 0.01, 2.0), base_dir=tmp_path).warnings
    assert any("displacement at t = 0" in m for _, m in warned)
    assert any("velocity at t = 0" in m for _, m in warned)


def test_time_functions():
    assert TimeFunction.constant().value(7.0) == 1.0
    assert TimeFunction.harmonic(3.0, 0.2).value(1.5) == math.sin(3.0 * 1.5 + 0.2)
    table = TimeFunction.table([0.0, 2.0], [1.0, 3.0])  # 2 rows: the straight line
    assert (table.value(-1.0), table.value(9.0)) == (1.0, 3.0)
    assert table.value(1.0) == pytest.approx(2.0, rel=4 * EPS)
    with pytest.raises(ValueError):
        TimeFunction.harmonic(0.0)
    with pytest.raises(ValueError):
        TimeFunction.table([0.0, 0.0], [1.0, 2.0])


def test_motion_csv_roundtrip(tmp_path):
    path = tmp_path / "m.csv"
    path.write_text("# anchor q\n time , ux,uy , uz \n0,0,0,0\n\n0.5, 1e-3, 0, -1e-3\n1,0,0,0\n")
    motion = read_motion_csv(path)
    np.testing.assert_array_equal(motion.times, [0.0, 0.5, 1.0])
    # 3 rows: the not-a-knot spline is their parabola, 4e-3 t (1 - t) at 0.25: 7.5e-4
    np.testing.assert_allclose(motion.displacement(0.25), [7.5e-4, 0.0, -7.5e-4], rtol=1e-14,
                               atol=0)
    assert motion.describe()["rows"] == 3 and motion.describe()["file"] == str(path)
    factor = tmp_path / "f.csv"
    factor.write_text("time,factor\n0,0\n2,1\n")
    assert read_factor_csv(factor).value(1.0) == pytest.approx(0.5, rel=4 * EPS)


# ---------------------------------------------------------------------------------------------
# Bad input: one problem each, naming the right key

BAD = [
    ("section.EA", -1.0, "section.EA", "must be > 0 (N)"),
    ("section.EA", "abc", "section.EA", "expected a number, got string 'abc'"),
    ("section.EI", True, "section.EI", "got boolean true"),
    ("section.EA", math.inf, "section.EA", "must be finite"),
    ("section.GJ", -1.0, "section.GJ", "must be >= 0 (N m^2)"),
    ("section.mass", DELETE, "section.mass", "missing required key"),
    ("section.diameter", 0.0, "section.diameter", "must be > 0 (m)"),
    ("gravity.g", -9.81, "gravity.g", "must be >= 0 (m/s^2)"),
    ("gravity.direction", [0, 0, 0], "gravity.direction", "non-zero"),
    ("gravity.direction", [0, 0], "gravity.direction", "expected 3 numbers"),
    ("geometry.length", 1.0, "geometry", "got length and sag_ratio"),
    ("geometry.sag_ratio", DELETE, "geometry", "give exactly one of"),
    ("geometry.sag_ratio", 11.0, "geometry.sag_ratio", "must be > 0 and <= 10"),
    ("geometry.sag_ratio", math.nan, "geometry.sag_ratio", "must be finite"),
    ("gravity.g", 0.0, "geometry.sag_ratio", "needs gravity.g > 0"),
    ("mesh.elements", 0, "mesh.elements", "must be >= 1"),
    ("mesh.elements", 2.5, "mesh.elements", "expected an integer, got number 2.5"),
    ("mesh.elements", True, "mesh.elements", "expected an integer, got boolean true"),
    ("mesh.elements", 10**8, "mesh.elements", "<= 10000000"),
    ("mesh.grading", 0.9, "mesh.grading", "must be >= 1"),
    ("anchors", {"name": "p"}, "anchors", "expected an array of tables ([[anchors]])"),
    ("anchors[1].name", "p", "anchors[1].name", "duplicate anchor name 'p'"),
    ("anchors[0].name", "a b", "anchors[0].name", "characters"),
    ("anchors[0].name", DELETE, "anchors[0].name", "missing required key"),
    ("anchors[1].position", [0, 0, 0], "anchors[1].position", "anchors 'p' and 'q' coincide"),
    ("anchors[1].position", DELETE, "anchors[1].position", "missing required key"),
    ("anchors[1].position", [1, 0, "x"], "anchors[1].position[2]", "expected a number"),
    ("anchors[0].type", "fixed", "anchors[0].type", "must be one of 'clamped', 'pinned'"),
    ("anchors[1].direction", [0, 0, 0], "anchors[1].direction", "non-zero"),
    ("anchors[1].motion.type", "circle", "anchors[1].motion.type", "must be one of"),
    ("anchors[1].motion.omega", -1.0, "anchors[1].motion.omega", "must be > 0 (rad/s)"),
    ("anchors[1].motion.omega", [1, 0, 1], "anchors[1].motion.omega[1]", "must be > 0"),
    ("anchors[1].motion.amplitude", DELETE, "anchors[1].motion.amplitude",
     "missing required key for a harmonic motion"),
    ("anchors[1].motion.axis_sin", [0, 0, 1], "anchors[1].motion.axis_sin",
     "does not apply to a harmonic motion"),
    ("anchors[1].motion.phase", "0", "anchors[1].motion.phase", "expected a number"),
    ("anchors[1].motion", {"type": "ellipse", "omega": 1.0}, "anchors[1].motion",
     "axis_sin and/or axis_cos"),
    ("anchors[1].motion", {"type": "ellipse", "omega": [1, 1, 1], "axis_sin": [0, 0, 1]},
     "anchors[1].motion.omega", "expected a number"),
    ("anchors[1].motion", {"type": "table"}, "anchors[1].motion.file", "missing required key"),
    ("loads", [{"time": {"type": "constant"}}], "loads[0].value", "missing required key"),
    ("loads", [{"value": [0, 1, 0], "time": {"type": "harmonic"}}], "loads[0].time.omega",
     "missing required key for a harmonic time function"),
    ("loads", [{"value": [0, 1, 0], "time": {"type": "harmonic", "omega": 0}}],
     "loads[0].time.omega", "must be > 0 (rad/s)"),
    ("loads", [{"value": [0, 1, 0], "time": {"type": "constant", "omega": 1}}],
     "loads[0].time.omega", "does not apply to a constant time function"),
    ("point_masses", [{"s": 0.0, "mass": 1.0}], "point_masses[0].s", "must be > 0 (m)"),
    ("point_masses", [{"s": 0.5, "mass": -1.0}], "point_masses[0].mass", "must be > 0 (kg)"),
    ("point_loads", [{"s": 0.5, "value": "down"}], "point_loads[0].value",
     "expected 3 numbers, got string 'down'"),
    ("damping.ratio", 1.0, "damping.ratio", "must be >= 0 and < 1"),
    ("damping.frequencies", [10.0, 10.0], "damping.frequencies", "distinct"),
    ("damping.frequencies", DELETE, "damping.frequencies", "missing required key"),
    ("damping.ratios", [0.01, 0.01], "damping", "exactly one of ratio and ratios"),
    ("damping.alpha", 0.1, "damping", "not both"),
    ("damping", {"model": "rayleigh"}, "damping", "give alpha and/or beta"),
    ("damping", {"ratios": [0.05, 0.001], "frequencies": [1.0, 10.0]}, "damping",
     "negative coefficient"),
    ("damping.model", "viscous", "damping.model", "must be one of"),
    ("damping", {"model": "axial", "alpha": 0.1, "beta": 0.1}, "damping.alpha",
     "does not apply to axial damping"),
    ("damping", {"model": "axial"}, "damping.beta", "missing required key for axial damping"),
    ("dynamics.dt", 50.0, "dynamics.dt", "must be <= t_end"),
    ("dynamics.t_end", DELETE, "dynamics.t_end", "missing required key"),
    ("dynamics.rho_inf", 1.5, "dynamics.rho_inf", "must be >= 0 and <= 1"),
    ("dynamics.output_every", 0, "dynamics.output_every", "must be >= 1"),
    ("modal.modes", -1, "modal.modes", "must be >= 0"),
    ("solver.tension_only", 1, "solver.tension_only", "expected a boolean"),
    ("solver.petsc_options", {"cable_ts_type": "alpha2"}, "solver.petsc_options.cable_ts_type",
     "without '-' or the 'cable_' prefix"),
    ("solver.petsc_options", {"ts_dt": math.nan}, "solver.petsc_options.ts_dt", "finite"),
    ("solver.petsc_options", {"ts_type": ["a"]}, "solver.petsc_options.ts_type",
     "expected a string, number or boolean"),
    ("title", 3, "title", "expected a string, got integer 3"),
]


@pytest.mark.parametrize("path, value, key, fragment", BAD,
                         ids=[f"{b[0]}={b[1]!r}" for b in BAD])
def test_bad_input_names_key(path, value, key, fragment):
    problems = problems_of(set_key(case_a(), path, value))
    assert has_problem(problems, key, fragment), problems


def test_bad_geometry_combinations():
    data = case_a()
    data["geometry"] = {"horizontal_tension": 25.0}
    data["anchors"][1]["position"] = [0.0, 0.0, -2.0]  # vertical chord
    assert has_problem(problems_of(data), "geometry.horizontal_tension", "not parallel")
    data["geometry"] = {"polyline": [[0, 0, 0]]}
    assert has_problem(problems_of(data), "geometry.polyline", "at least 2 points")
    data["geometry"] = {"polyline": [[0, 0, 0], [0, 0, 0], [1, 0, 0]]}
    assert has_problem(problems_of(data), "geometry.polyline[1]", "zero-length segment")
    data = case_a()
    data["geometry"] = {"length": 1.0}
    data["point_masses"] = [{"s": 1.5, "mass": 1.0}]
    assert has_problem(problems_of(data), "point_masses[0].s", "must be < l = 1 (m)")
    data["anchors"].append({"name": "r", "position": [2, 0, 0]})
    assert has_problem(problems_of(data), "anchors", "expected exactly 2 anchors, got 3")
    data["anchors"] = []
    assert has_problem(problems_of(data), "anchors", "expected exactly 2 anchors, got 0")


def test_pinned_with_direction():
    data = case_a()
    data["anchors"][0].update(type="pinned", direction=[1, 0, 0])
    assert has_problem(problems_of(data), "anchors[0].direction",
                       "direction only applies to clamped anchors")


def test_all_problems_reported_at_once():
    data = case_a()
    set_key(data, "section.EA", -1.0)
    set_key(data, "mesh.elemnts", 10)
    set_key(data, "anchors[1].motion.omega", "fast")
    set_key(data, "dynamics.rho_inf", 2.0)
    set_key(data, "damping.ratio", True)
    with pytest.raises(CaseError) as info:
        parse_case(data, source="case.toml")
    keys = [k for k, _ in info.value.problems]
    assert keys == ["section.EA", "mesh.elemnts", "anchors[1].motion.omega", "damping.ratio",
                    "dynamics.rho_inf"]
    lines = str(info.value).splitlines()
    assert len(lines) == 5 and all(line.startswith("case.toml: ") for line in lines)
    assert lines[0] == "case.toml: section.EA: must be > 0 (N), got -1.0"


@pytest.mark.parametrize("path, wrong, right", [
    ("", "secton", "section"),
    ("", "dampng", "damping"),
    ("mesh", "elemnts", "elements"),
    ("section", "ea", "EA"),
    ("anchors[1].motion", "amplitud", "amplitude"),
    ("anchors[0]", "postion", "position"),
    ("damping", "frequency", "frequencies"),
    ("dynamics", "rho_infinity", "rho_inf"),
])
def test_misspelt_key_suggestion(path, wrong, right):
    data = case_a()
    set_key(data, f"{path}.{wrong}" if path else wrong, 1.0)
    key = f"{path}.{wrong}" if path else wrong
    problems = problems_of(data)
    assert (key, f"unknown key '{wrong}'; did you mean '{right}'?") in problems, problems


def test_unknown_key_without_match_lists_known():
    problems = problems_of(set_key(case_a(), "modal.zzz", 1))
    assert ("modal.zzz", "unknown key 'zzz' (known keys: modes)") in problems


# ---------------------------------------------------------------------------------------------
# Files: TOML and CSV errors name the file and the line


def write_table_case(tmp_path, csv_text: str | None):
    text = CASE_A_TOML.replace('type = "harmonic"\namplitude = [2e-4, 0, 0]\nomega = 32.814',
                               'type = "table"\nfile = "data/motion.csv"\nhold = true')
    case_path = tmp_path / "case.toml"
    case_path.write_text(text)
    if csv_text is not None:
        (tmp_path / "data").mkdir()
        (tmp_path / "data" / "motion.csv").write_text(csv_text)
    return case_path


def test_table_motion_from_case_file(tmp_path):
    case = load_case(write_table_case(tmp_path, "time,ux,uy,uz\n0,0,0,0\n1,1e-3,0,0\n"))
    motion = case.anchors[1].motion
    assert isinstance(motion, TableMotion)
    assert motion.source == str(tmp_path / "data" / "motion.csv")


@pytest.mark.parametrize("csv_text, fragment", [
    (None, "cannot read the file"),
    ("", "the file is empty"),
    ("t,ux,uy,uz\n0,0,0,0\n1,0,0,0\n", "line 1: expected the header 'time,ux,uy,uz'"),
    ("time,ux,uy,uz\n0,0,0,0\n1,abc,0,0\n", "line 3: column 'ux': expected a number, got 'abc'"),
    ("time,ux,uy,uz\n0,0,0,0\n1,0,0\n", "line 3: expected 4 columns, got 3"),
    ("time,ux,uy,uz\n0,0,0,0\n", "expected at least 2 data rows"),
    ("time,ux,uy,uz\n0,0,0,0\n1,0,0,0\n1,0,0,0\n", "line 4: times must be strictly increasing"),
    ("time,ux,uy,uz\n0,0,0,0\n\n1,nan,0,0\n", "line 4: column 'ux': must be finite"),
])
def test_bad_motion_csv_names_file_and_line(tmp_path, csv_text, fragment):
    case_path = write_table_case(tmp_path, csv_text)
    with pytest.raises(CaseError) as info:
        load_case(case_path)
    csv_path = str(tmp_path / "data" / "motion.csv")
    assert [k for k, _ in info.value.problems] == ["anchors[1].motion.file"]
    message = info.value.problems[0][1]
    assert csv_path in message and fragment in message, message
    assert str(info.value).startswith(f"{case_path}: anchors[1].motion.file: ")


def test_csv_reader_standalone_errors(tmp_path):
    path = tmp_path / "f.csv"
    path.write_text("time,factor\n0,1\nx,2\n3,inf\n")
    with pytest.raises(CaseError) as info:
        read_factor_csv(path)
    assert info.value.source == str(path)
    assert info.value.problems == [
        ("file", "line 3: column 'time': expected a number, got 'x'"),
        ("file", "line 4: column 'factor': must be finite, got 'inf'")]


def test_toml_syntax_error_and_missing_file(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("[section]\nEA = \n")
    with pytest.raises(CaseError) as info:
        load_case(path)
    assert str(info.value).startswith(f"{path}: line 2, column") and "not a valid TOML" in str(
        info.value)
    with pytest.raises(CaseError, match="cannot read the case file"):
        load_case(tmp_path / "absent.toml")


# ---------------------------------------------------------------------------------------------
# Reference text, sections and dimensionless groups


def all_key_paths(keys: dict, prefix: str = "") -> list[str]:
    out = []
    for name, doc in keys.items():
        path = f"{prefix}.{name}" if prefix else name
        out.append(path)
        if isinstance(doc, TableDoc):
            out += all_key_paths(doc.keys, path)
    return out


def test_case_reference_documents_every_key():
    text, markdown = format_case_reference(), format_case_reference(markdown=True)
    paths = all_key_paths(CASE_KEYS)
    assert "anchors.motion.axis_cos" in paths and "point_loads.time.file" in paths
    for path in paths:
        assert re.search(rf"^ *\[*{re.escape(path)}\]* ", text, re.M), path
        assert f"`{path}`" in markdown or f"`[{path}]`" in markdown or \
            f"`[[{path}]]`" in markdown, path
    assert max(len(line) for line in text.splitlines()) <= 100


def test_section_and_groups():
    section = Section(EA=17857.14, EI=4.0e-4, GJ=3.0e-4, mass=1.0)
    groups = dimensionless_groups(section, 1.0, 1.0)
    # docs/theory.md §9, case A: eps = 0.02, eps_b = 5.6e-5 (printed to 2 digits)
    assert groups["eps"] == pytest.approx(0.02, rel=1e-12)  # sqrt(4e-4) = 0.02, round-off only
    assert groups["eps_b"] == pytest.approx(5.6e-5, rel=1e-6)  # 1/17857.14 = 5.6000002e-5
    assert groups["gamma"] == pytest.approx(0.75, rel=1e-15)  # 3e-4/4e-4: one division
    assert (groups["time_unit"], groups["force_unit"], groups["moment_unit"]) == (1.0, 1.0, 1.0)
    steel = Section(EA=2e8, EI=50.0, GJ=40.0, mass=8.0)
    g = dimensionless_groups(steel, 100.0, 9.81)
    # units: w = 78.48 N/m, force w l, moment w l^2, time sqrt(l/g); a few ulp
    assert g["moment_unit"] == pytest.approx(78.48 * 1e4, rel=1e-14)
    assert g["time_unit"] == pytest.approx(math.sqrt(100.0 / 9.81), rel=1e-14)
    zero_g = dimensionless_groups(steel, 100.0, 0.0)
    assert zero_g["gamma"] == 0.8 and zero_g["eps"] is None and zero_g["force_unit"] is None
    with pytest.raises(ValueError, match="EA must be > 0"):
        Section(EA=0.0, EI=1.0, GJ=0.0, mass=1.0)
    with pytest.raises(ValueError, match="length must be > 0"):
        dimensionless_groups(steel, 0.0, 9.81)
