"""Inner (boundary-layer) and composite solutions at clamped cable anchors.

Pure NumPy, no dolfinx: the functions post-process the anchor forces of any string solver.
References: ``docs/theory.md`` §3-4 ("step n" = the numbered steps of §3) and the paper it
cites (Eq. numbers below).

Conventions
-----------
* ``N`` is the force that the span transmits at the anchor, pointing into the span (step 1);
  ``c`` is the unit clamp direction, pointing from the anchor into the cable.
* ``sigma`` is the stress-free arc distance from the anchor. Curvatures are per unit
  stress-free length, as in the paper (Eq. 10, 14): ``M = EI kappa``.
* A curvature or moment *vector* depends on the direction of travel along the cable (it is
  ``t x dt/ds``). ``layer`` and ``string_curvature`` (when given the tangent pointing into
  the span) work in the anchor's own direction (away from the anchor), where the layer's
  moment is ``+moment * normal``. ``composite_curvature`` works in the direction of the
  station coordinate ``s`` and flips the layer term of an anchor at the ``s = l`` end.
* Units: any consistent set (SI: N, m, N m, N m^2); the paper's dimensionless case is
  ``l = w = g = 1``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

# the layer's far field (the virtual hinge, the second order) has its own module; its names
# stay available here, where the layer's users look for them
from cablefem.farfield import (
    far_field_offsets,
    far_field_second_order,
    gradient_integrals,
    gradient_moment_factor,
    virtual_hinge,
)

__all__ = [
    "AnchorLayer", "anchor_frame", "layer", "angle_profile", "curvature_profile",
    "moment_profile", "exact_angle_profile", "exact_curvature_profile", "string_curvature",
    "composite_curvature", "graded_stations", "far_field_offsets", "virtual_hinge",
    "gradient_integrals", "far_field_second_order", "gradient_moment_factor", "wrap_azimuth",
]

#: ``|c x t|`` below this: the bending plane (step 4) is undefined.
PLANE_TOL = 1e-14
#: Largest ``ell/l`` for a valid layer. The layer must be thin compared with the span: the
#: inner solution neglects terms of relative size O(ell/l) (the paper's O(epsilon)), and at
#: ell/l = 0.1 the layer term has decayed to exp(-10) ~ 5e-5 of its anchor value at the far
#: end, so the two anchors' layers do not interact.
MAX_LENGTH_RATIO = 0.1
#: Largest (layer period) / (excitation period) for a quasi-static layer (Eq. 21-24).
MAX_PERIOD_RATIO = 0.1


@dataclass
class AnchorLayer:
    """Inner solution at clamped anchors (docs/theory.md §3, steps 2-8); arrays of shape ``(...)``.

    Attributes:
        tension: T = |N| [N].
        tangent: (..., 3) string tangent t = N/T at the anchor [-] (NaN where slack).
        delta: anchor angle Delta = atan2(|c x t|, c.t) in [0, pi] [rad] (step 3).
        normal: (..., 3) bending-plane normal b = (c x t)/|c x t| (step 4); zeros where Delta ~ 0
            (the moment vanishes there), NaN where Delta ~ pi (plane undefined while the moment is
            not small) or slack.
        psi0: azimuth of the bending plane about c in the anchor frame (e1, e2, c), the direction of
            t's projection on the plane normal to c, in (-pi, pi] [rad] (Eq. 25, 32); NaN where
            Delta ~ 0, Delta ~ pi or slack.
        layer_length: ell = sqrt(EI / (T (1 + T/EA))) [m] (step 5, Eq. 38).
        moment: anchor moment magnitude M(0) from the layer alone [N m] (step 8).
        moment_vector: (..., 3) moment * normal [N m], in the anchor's direction of travel.
        slack: True where T <= tension_floor or T is not finite: no layer, NaN results.
        valid: not slack, finite, ell/l <= MAX_LENGTH_RATIO (if ``length`` was given) and
            period_ratio <= MAX_PERIOD_RATIO (if ``quasi_static`` was given).
        length_ratio: ell / l [-] (NaN when ``length`` was not given).
        period_ratio: layer period / excitation period = omega ell^2 sqrt(m/EI) [-] (NaN when
            ``quasi_static`` was not given).
    """

    tension: np.ndarray
    tangent: np.ndarray
    delta: np.ndarray
    normal: np.ndarray
    psi0: np.ndarray
    layer_length: np.ndarray
    moment: np.ndarray
    moment_vector: np.ndarray
    slack: np.ndarray
    valid: np.ndarray
    length_ratio: np.ndarray
    period_ratio: np.ndarray


def _unit(v: ArrayLike, name: str) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if v.shape[-1:] != (3,):
        raise ValueError(f"{name} must have a last axis of length 3, got shape {v.shape}")
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    if not np.all(np.isfinite(n)) or np.any(n == 0.0):
        raise ValueError(f"{name} must be a nonzero finite vector, got {v.tolist()}")
    return v / n


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum(a * b, axis=-1)


def anchor_frame(c: ArrayLike, e1: ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Fixed anchor frame: unit e1, e2 with (e1, e2, c) right-handed orthonormal.

    Default e1: the global Z axis (0, 0, 1) projected on the plane normal to c and
    normalised, or the global X axis if that projection is shorter than 1e-8 (c vertical).
    It fixes what psi0 = 0 means: for a horizontal clamp psi0 = 0 is "up". A user-given
    ``e1`` is projected on that plane instead. e2 = c x e1.

    Args:
        c: (..., 3) clamp direction (normalised here; must be nonzero).
        e1: optional (..., 3) reference direction for psi0 = 0.
    """
    c = _unit(c, "c")
    if e1 is not None:
        p = np.asarray(e1, dtype=float) - _dot(np.asarray(e1, float), c)[..., None] * c
        if np.any(np.linalg.norm(p, axis=-1) < 1e-8):
            raise ValueError("e1 must not be parallel to the clamp direction c")
    else:
        pz = np.array([0.0, 0.0, 1.0]) - c[..., 2:3] * c
        px = np.array([1.0, 0.0, 0.0]) - c[..., 0:1] * c
        p = np.where(np.linalg.norm(pz, axis=-1, keepdims=True) > 1e-8, pz, px)
    e1 = p / np.linalg.norm(p, axis=-1, keepdims=True)
    return e1, np.cross(c, e1)


def wrap_azimuth(psi: ArrayLike, ref: float) -> np.ndarray:
    """The azimuths ``psi`` on the branch ``(ref - pi, ref + pi]`` (``ref`` NaN: ``(-pi,
    pi]``, :func:`layer`'s own); a value already on it is returned bit for bit, the others
    moved by 2 pi. A history's azimuths on the branch centred on its first row's keep
    their bending plane's swings about that row continuous: ``(-pi, pi]`` put the cut at
    "down", where a sagging cable's static bending plane lies (case B's anchors' ``psi0``
    jumped by 2 pi at 208 rows of 6001)."""
    psi = np.asarray(psi, float)
    ref = 0.0 if not np.isfinite(ref) else float(ref)
    with np.errstate(invalid="ignore"):
        return np.where(psi - ref > np.pi, psi - 2.0 * np.pi,
                        np.where(psi - ref <= -np.pi, psi + 2.0 * np.pi, psi))


def layer(N: ArrayLike, c: ArrayLike, EI: ArrayLike, EA: ArrayLike, *, form: str = "exact",
          e1: ArrayLike | None = None, length: float | None = None,
          tension_floor: float = 0.0,
          quasi_static: tuple[float, float] | None = None) -> AnchorLayer:
    """Boundary layer at clamped anchors from the anchor forces (docs/theory.md §3, steps 2-8).

    Args:
        N: (..., 3) force transmitted by the span at the anchor, pointing into the span [N].
        c: (3,) or (..., 3) clamp direction from the anchor into the cable (normalised here).
        EI, EA: bending [N m^2] and axial [N] stiffness; ``EA = np.inf`` for inextensible.
        form: "exact": M(0) = 2 sqrt(EI T) sin(Delta/2) sqrt(1 + (T/EA) cos^2(Delta/2)), the slope
            of the first integral (Eq. 35); "explicit": M(0) = 2 sqrt(EI T (1 + T/EA)) sin(Delta/2),
            the slope of the explicit profile (Eq. 38-39). They differ by the relative amount (T/EA)
            sin^2(Delta/2) / 2 to leading order.
        e1: reference direction for psi0 = 0 (see ``anchor_frame``).
        length: stress-free cable length l [m], for the check ell/l <= MAX_LENGTH_RATIO.
        tension_floor: anchors with T <= tension_floor [N] are slack.
        quasi_static: (m [kg/m], omega [rad/s]) of the excitation, for the check that the layer
            responds quasi-statically (Eq. 21-24). Its period is taken as 2 pi ell^2 sqrt(m/EI), so
            that period_ratio = omega ell^2 sqrt(m/EI), the square root of the neglected transverse
            inertia relative to bending, m omega^2 ell^4/EI, on the layer's length scale. A
            cantilever of length ell (period 2 pi ell^2 sqrt(m/EI)/1.875^2) gives 3.5 times less, a
            wave of wavenumber 1/ell on a beam under T = EI/ell^2 sqrt(2) times less: this choice
            errs towards flagging. Required: period_ratio <= MAX_PERIOD_RATIO = 0.1 (neglected
            inertia ~1 %).
    """
    if form not in ("exact", "explicit"):
        raise ValueError(f"form must be 'exact' or 'explicit', got {form!r}")
    N = np.asarray(N, dtype=float)
    if N.shape[-1:] != (3,):
        raise ValueError(f"N must have a last axis of length 3, got shape {N.shape}")
    c = _unit(c, "c")
    EI, EA = np.asarray(EI, dtype=float), np.asarray(EA, dtype=float)
    if np.any(~(EI > 0)) or np.any(~(EA > 0)):
        raise ValueError("EI and EA must be positive (EA may be np.inf)")
    shape = np.broadcast_shapes(N.shape[:-1], c.shape[:-1], EI.shape, EA.shape)
    N, c = np.broadcast_to(N, shape + (3,)), np.broadcast_to(c, shape + (3,))
    T = np.linalg.norm(N, axis=-1)
    slack = ~(np.isfinite(T) & (T > tension_floor))
    nan = np.full(shape, np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        Tl = np.where(slack, np.nan, T)                       # NaN propagates to all results
        t = N / Tl[..., None]                                 # step 2
        cxt = np.cross(c, t)
        sin_d, cos_d = np.linalg.norm(cxt, axis=-1), _dot(c, t)
        delta = np.arctan2(sin_d, cos_d)                      # step 3
        plane = sin_d >= PLANE_TOL
        normal = np.where(plane[..., None], cxt / sin_d[..., None], 0.0)   # step 4
        undefined = (~plane & ~(cos_d > 0)) | slack           # Delta ~ pi, or slack
        normal = np.where(undefined[..., None], np.nan, normal)
        f1, f2 = anchor_frame(c, e1)
        psi0 = np.arctan2(_dot(t, f2), _dot(t, f1))       # np.sum never gives -0.: > -pi
        psi0 = np.where(plane, psi0, np.nan)
        beta = Tl / EA                                        # T/EA, the paper's eps_b f_p
        ell = np.sqrt(EI / (Tl * (1 + beta)))                 # step 5
        if form == "exact":                                   # Eq. 35 at the anchor
            M = 2 * np.sqrt(EI * Tl) * np.sin(delta / 2) * np.sqrt(
                1 + beta * np.cos(delta / 2) ** 2)
        else:                                                 # Eq. 38-39, step 8
            M = 2 * EI / ell * np.sin(delta / 2)
        finite = np.isfinite(M) & np.isfinite(ell) & np.all(np.isfinite(normal), axis=-1)
        valid = ~slack & finite
        length_ratio, period_ratio = nan.copy(), nan.copy()
        if length is not None:
            if not length > 0:
                raise ValueError(f"length must be positive, got {length}")
            length_ratio = ell / length
            valid &= length_ratio <= MAX_LENGTH_RATIO
        if quasi_static is not None:
            m, omega = (float(x) for x in quasi_static)
            if not (m > 0 and omega >= 0):
                raise ValueError(f"quasi_static must be (m > 0, omega >= 0), got {quasi_static}")
            period_ratio = omega * ell**2 * np.sqrt(m / EI)
            valid &= period_ratio <= MAX_PERIOD_RATIO
    return AnchorLayer(tension=T, tangent=t, delta=delta, normal=normal, psi0=psi0,
                       layer_length=ell, moment=M, moment_vector=M[..., None] * normal,
                       slack=np.asarray(slack), valid=np.asarray(valid),
                       length_ratio=np.asarray(length_ratio),
                       period_ratio=np.asarray(period_ratio))


def angle_profile(sigma: ArrayLike, delta: ArrayLike, ell: ArrayLike) -> np.ndarray:
    """Explicit layer profile phi(sigma) = 4 arctan(tan(Delta/4) exp(-sigma/ell)) [rad].

    The angle between rod and string tangents (Eq. 38-39, step 6). ``sigma`` (..., P) >= 0
    [m] broadcasts against ``delta`` (...) [rad] and ``ell`` (...) [m] (a stations axis is
    appended to them).

    Args:
        sigma: (..., P) stress-free distance from the anchor [m], >= 0.
        delta: (...) anchor angle [rad].
        ell: (...) layer length [m].

    Returns:
        (..., P) angle [rad].
    """
    d, el = np.asarray(delta, float)[..., None], np.asarray(ell, float)[..., None]
    return 4 * np.arctan(np.tan(d / 4) * np.exp(-np.asarray(sigma, float) / el))


def curvature_profile(sigma: ArrayLike, delta: ArrayLike, ell: ArrayLike) -> np.ndarray:
    """Explicit layer curvature kappa(sigma) = (2/ell) sin(phi(sigma)/2) [1/m] (step 7).

    Args:
        sigma: (..., P) stress-free distance from the anchor [m], >= 0.
        delta: (...) anchor angle [rad].
        ell: (...) layer length [m].

    Returns:
        (..., P) curvature [1/m].
    """
    phi = angle_profile(sigma, delta, ell)
    return 2 / np.asarray(ell, float)[..., None] * np.sin(phi / 2)


def moment_profile(sigma: ArrayLike, delta: ArrayLike, ell: ArrayLike,
                   EI: ArrayLike) -> np.ndarray:
    """Explicit layer moment M(sigma) = EI kappa(sigma) [N m] (step 7).

    Args:
        sigma: (..., P) stress-free distance from the anchor [m], >= 0.
        delta: (...) anchor angle [rad].
        ell: (...) layer length [m].
        EI: (...) bending stiffness [N m^2].

    Returns:
        (..., P) moment [N m].
    """
    return np.asarray(EI, float)[..., None] * curvature_profile(sigma, delta, ell)


def exact_angle_profile(sigma: ArrayLike, delta: ArrayLike, T: ArrayLike, EI: ArrayLike,
                        EA: ArrayLike) -> np.ndarray:
    """Layer profile phi(sigma) [rad] from the exact first integral (Eq. 35-37).

    Solves dphi/dsigma = -(2/ell0) sin(phi/2) sqrt(1 + beta cos^2(phi/2)), phi(0) = Delta,
    ell0 = sqrt(EI/T), beta = T/EA. With q = sqrt(1 + beta) the implicit relation Eq. 37,
    artanh(q cos(phi/2) / sqrt(1 + beta cos^2(phi/2))) = x0 + sigma/ell (ell = ell0/q, x0
    from phi(0) = Delta, i.e. the paper's B), inverts in closed form: tan(phi/2) = q /
    sinh(x), x = x0 + sigma/ell, sinh(x0) = q cot(Delta/2). Exact for all beta, Delta in
    [0, pi]; no iteration, and accurate in the exponentially small tail. beta = 0 gives
    the explicit profile. Broadcasting as in ``angle_profile`` (T, EI, EA like delta).

    Args:
        sigma: (..., P) stress-free distance from the anchor [m], >= 0.
        delta: (...) anchor angle [rad].
        T: (...) tension [N].
        EI, EA: (...) bending [N m^2] and axial [N] stiffness.

    Returns:
        (..., P) angle [rad].
    """
    d = np.asarray(delta, float)[..., None]
    T = np.asarray(T, float)[..., None]
    beta = T / np.asarray(EA, float)[..., None]
    q = np.sqrt(1 + beta)
    ell = np.sqrt(np.asarray(EI, float)[..., None] / (T * (1 + beta)))
    with np.errstate(divide="ignore", over="ignore"):
        x = np.arcsinh(q / np.tan(d / 2)) + np.asarray(sigma, float) / ell
        return 2 * np.arctan2(q, np.sinh(x))


def exact_curvature_profile(sigma: ArrayLike, delta: ArrayLike, T: ArrayLike,
                            EI: ArrayLike, EA: ArrayLike) -> np.ndarray:
    """Exact layer curvature |dphi/dsigma| = (2/ell0) sin(phi/2) sqrt(1 + beta cos^2(phi/2)).

    [1/m], along ``exact_angle_profile`` (Eq. 35); times EI it is the exact moment profile.

    Args:
        sigma: (..., P) stress-free distance from the anchor [m], >= 0.
        delta: (...) anchor angle [rad].
        T: (...) tension [N].
        EI, EA: (...) bending [N m^2] and axial [N] stiffness.

    Returns:
        (..., P) curvature [1/m].
    """
    phi = exact_angle_profile(sigma, delta, T, EI, EA)
    T = np.asarray(T, float)[..., None]
    beta = T / np.asarray(EA, float)[..., None]
    ell0 = np.sqrt(np.asarray(EI, float)[..., None] / T)
    return 2 / ell0 * np.sin(phi / 2) * np.sqrt(1 + beta * np.cos(phi / 2) ** 2)


def string_curvature(tangent: ArrayLike, tension: ArrayLike, mass: ArrayLike,
                     accel: ArrayLike, load: ArrayLike) -> np.ndarray:
    """The string's own curvature vector kappa_s = t x dt/dsigma [1/m] (docs/theory.md §4).

    From the string's balance of forces (Eq. 16), dt/dsigma = (m a - f)_perp / T, so
    kappa_s = t x (m a - f) / T (the cross product removes the part along t).

    Args:
        tangent: (..., 3) string tangent, normalised here; its direction of travel is the one of the
            result (at an anchor: pointing into the span, away from the anchor).
        tension: (...) T [N]; NaN is returned where T <= 0.
        mass: (...) or scalar, m per unit stress-free length [kg/m].
        accel: (..., 3) acceleration of the point [m/s^2].
        load: (..., 3) distributed load per unit stress-free length, weight included (f = m g_vec)
            [N/m].
    """
    t = np.asarray(tangent, float)
    T = np.asarray(tension, float)[..., None]
    F = np.asarray(mass, float)[..., None] * np.asarray(accel, float) - np.asarray(load, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = t / np.linalg.norm(t, axis=-1, keepdims=True)
        return np.where(T > 0, np.cross(t, F) / np.where(T > 0, T, 1.0), np.nan)


def composite_curvature(kappa_string: ArrayLike, sigmas: ArrayLike, deltas: ArrayLike,
                        ells: ArrayLike, normals: ArrayLike, *,
                        orientation: ArrayLike | None = None) -> np.ndarray:
    """Composite curvature kappa(s) = kappa_string(s) + sum_a o_a kappa_a(sigma_a(s)) b_a.

    docs/theory.md §4 (the paper's Eq. 40 with one B_a per anchor, see its §9), with
    the explicit layer profile (step 7). Vectors are in the direction of travel of the
    station coordinate s, the one ``kappa_string`` was computed in. An anchor's layer
    vector kappa_a b_a is in its own direction (away from the anchor), so it enters with
    o_a = d sigma_a/ds: +1 for an anchor at the s = 0 end, -1 at the s = l end. Multiply
    by EI for the moment; at an anchor (o_a = +1) that is M_a(0) b_a + EI kappa_string(0).

    Args:
        kappa_string: (..., P, 3) string curvature at P stations [1/m].
        sigmas: (A, P) stress-free distance [m] of every station from each anchor.
        deltas, ells: (..., A) anchor angles [rad] and layer lengths [m]; NaN delta (slack)
            contributes nothing.
        normals: (..., A, 3) bending-plane normals b_a.
        orientation: (A,) values +-1 = d sigma_a/ds; by default inferred from the monotony of each
            row of ``sigmas`` (ValueError when a row is not monotone).
    """
    ks = np.asarray(kappa_string, float)
    sig = np.asarray(sigmas, float)
    d, el = np.asarray(deltas, float), np.asarray(ells, float)
    if sig.ndim != 2 or d.shape[-1:] != sig.shape[:1]:
        raise ValueError(f"sigmas must be (A, P) with A = deltas.shape[-1], got {sig.shape}")
    if orientation is None:
        dif = np.diff(sig, axis=-1)
        inc = np.all(dif >= 0, axis=-1) & np.any(dif > 0, axis=-1)
        dec = np.all(dif <= 0, axis=-1) & np.any(dif < 0, axis=-1)
        if not np.all(inc | dec):
            raise ValueError("cannot infer orientation from sigmas (rows not monotone): "
                             "pass orientation = d sigma_a/ds (+1 or -1 per anchor)")
        o = np.where(inc, 1.0, -1.0)
    else:
        o = np.asarray(orientation, float)
        if o.shape != sig.shape[:1] or not np.all(np.abs(o) == 1):
            raise ValueError(f"orientation must be +-1 of shape {sig.shape[:1]}")
    active = np.isfinite(d)
    kap = np.where(active[..., None], curvature_profile(sig, d, el), 0.0) * o[:, None]
    nrm = np.where(active[..., None], np.asarray(normals, float), 0.0)
    return ks + np.einsum("...ap,...ak->...pk", kap, nrm)


def _geometric_steps(n: int, total: float, h0: float) -> np.ndarray:
    """n steps growing by a constant ratio r >= 1, the first h0, summing to total."""
    if total <= n * h0:
        return np.full(n, total / n)
    lo, hi = 1.0, 2.0
    while h0 * (hi**n - 1) / (hi - 1) < total:
        hi *= 2
    for _ in range(100):                                     # bisection to round-off
        r = 0.5 * (lo + hi)
        lo, hi = (r, hi) if h0 * (r**n - 1) / (r - 1) < total else (lo, r)
    steps = h0 * r ** np.arange(n)
    return steps * (total / steps.sum())


def graded_stations(length: float, anchor_s: ArrayLike, ells: ArrayLike, *,
                    n_layer: int = 24, layer_factor: float = 5.0,
                    n_span: int = 60) -> np.ndarray:
    """Stress-free stations s in [0, length] [m] for evaluating the composite field.

    For every anchor at s = anchor_s[i] with layer length ells[i] (pass the smallest ell
    over time; NaN: no grading), n_layer + 1 stations lie within min(layer_factor ell,
    room) of the anchor, spaced geometrically from ell/50 at the anchor; the growth then
    continues with the same ratio up to the span spacing h = length/n_span; every gap
    wider than h (the span, and a grading coarser than h when ell ~ length) is then split
    into equal parts <= h. Sorted, strictly increasing, both ends included, no spacing
    above h. Works for ell << h as well as ell ~ length.

    Args:
        length: The cable's stress-free length [m], > 0.
        anchor_s: Stations of the anchors [m], in [0, length].
        ells: Their layer lengths [m], > 0 (NaN: no grading there).
        n_layer: Stations in each layer, >= 2.
        layer_factor: The graded zone's length in layer lengths.
        n_span: The span's spacing is ``length/n_span``.

    Returns:
        The stations [m].

    Raises:
        ValueError: Arguments out of range.
    """
    if not (np.isfinite(length) and length > 0):
        raise ValueError(f"length must be positive and finite, got {length}")
    s_a = np.atleast_1d(np.asarray(anchor_s, float))
    el = np.broadcast_to(np.asarray(ells, float), s_a.shape)
    if np.any((s_a < 0) | (s_a > length)) or np.any(el <= 0) or n_layer < 2 or n_span < 1:
        raise ValueError("need 0 <= anchor_s <= length, ells > 0, n_layer >= 2, n_span >= 1")
    h = length / n_span
    graded, tol = [np.array([0.0, length])], 1e-3 * h
    for sa, ell in zip(s_a, el):
        if not np.isfinite(ell):
            continue
        h0 = ell / 50
        tol = min(tol, 1e-3 * h0)
        for sign, room in ((1.0, length - sa), (-1.0, sa)):
            if room <= 0:
                continue
            steps = list(_geometric_steps(n_layer, min(layer_factor * ell, room), h0))
            r, pos = max(steps[-1] / steps[-2], 1.2), sum(steps)
            while steps[-1] * r < h and pos + steps[-1] * r < room:     # smooth transition
                steps.append(steps[-1] * r)
                pos += steps[-1]
            graded.append(sa + sign * np.concatenate([[0.0], np.cumsum(steps)]))
    g = np.unique(np.clip(np.concatenate(graded), 0.0, length))
    g = g[np.concatenate([[True], np.diff(g) > tol])]         # merge near-duplicates
    g[-1] = length
    k = np.ceil(np.diff(g) / h * (1 - 1e-12)).astype(int)     # gaps > h: equal parts <= h
    fill = [g[i] + (g[i + 1] - g[i]) * np.arange(1, k[i]) / k[i] for i in np.flatnonzero(k > 1)]
    return np.sort(np.concatenate([g, *fill]))
