"""Elastic catenary of one cable: closed forms, solvers and verification oracles.

Pure NumPy/SciPy (no dolfinx), see ``docs/theory.md`` §2 and §8. 2D convention: anchor
``p`` at (0, 0), other end ``q`` at (``span``, ``rise``), ``span > 0`` horizontal, ``rise``
vertical (up positive), ``s`` the stress-free arc length from ``p``. ``H > 0`` is the
horizontal tension component, ``V(s) = V_q - w (l - s)`` the vertical one (up positive),
``T = sqrt(H^2 + V^2)``. With ``a = V(s)/H``, ``b = V(0)/H`` (so ``a - b = w s/H``) the
closed forms of docs/theory.md §8 are evaluated without cancellation as

    x(s) = s Q asinh(D)/D + H s/EA,        z(s) = s (a + b)/(c_a + c_b) + (s/EA) (V(0) + w s/2),

with ``c_a = sqrt(1 + a^2)``, ``D = sinh(asinh a - asinh b) = a c_b - b c_a = (a - b) Q`` and
``Q = (a + b)/(a c_b + b c_a)`` if ``a b > 0``, else ``(a c_b - b c_a)/(a - b)`` (a weighted
mean of ``c_a`` and ``c_b``). Round-off then stays at eps times the lengths involved, also
for taut (``w l << H``), weightless (``w = 0``) and near-vertical cables, where the textbook
differences of ``asinh`` and ``sqrt`` terms lose all digits.
``EA = inf`` gives the inextensible catenary.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from cablefem.roots import brent

__all__ = ["Catenary2D", "Catenary3D", "solve_catenary", "catenary_between",
           "length_for_horizontal_tension", "length_for_sag_ratio", "irvine_lambda2",
           "irvine_symmetric_frequency"]

_EPS = float(np.finfo(float).eps)


def _check(name: str, value: float, lo: float = -math.inf, strict: bool = True,
           allow_inf: bool = False) -> float:
    """Return ``float(value)`` or raise ValueError naming the parameter."""
    v = float(value)
    if math.isnan(v) or (math.isinf(v) and not allow_inf) or (v <= lo if strict else v < lo):
        need = "finite" if lo == -math.inf else f"{'>' if strict else '>='} {lo}"
        raise ValueError(f"{name} must be {need}, got {value!r}")
    return v


def _plane(span, rise, w, EA) -> tuple[float, float, float, float, float]:
    """Checked ``span, rise, w, EA`` and the chord length."""
    L, h = _check("span", span, 0.0), _check("rise", rise)
    w, EA = _check("w", w, 0.0, strict=False), _check("EA", EA, 0.0, allow_inf=True)
    return L, h, w, EA, math.hypot(L, h)


def _asinhc(d: np.ndarray, minus_one: bool = False) -> np.ndarray:
    """``asinh(d)/d`` (or that minus 1); series below ``|d| = 1e-3`` (truncation < 1e-19)."""
    small = np.abs(d) < 1e-3
    ds = np.where(small, 1.0, d)
    d2 = d * d
    series = d2 * (-1.0 / 6.0 + 0.075 * d2)
    if minus_one:
        return np.where(small, series, np.arcsinh(ds) / ds - 1.0)
    return np.where(small, 1.0 + series, np.arcsinh(ds) / ds)


def _terms(s, H, V_q, l, w):
    """``a, b, sqrt(1+a^2), sqrt(1+b^2), Q, D`` at stress-free arc length ``s``."""
    s = np.asarray(s, dtype=float)
    b = (V_q - w * l) / H
    dab = w * s / H  # a - b, exactly
    a = b + dab
    ca, cb = np.hypot(1.0, a), np.hypot(1.0, b)
    with np.errstate(divide="ignore", invalid="ignore"):
        q_same = (a + b) / (a * cb + b * ca)  # a, b of one sign: no cancellation
        # opposite signs: a cb - b ca is a sum of positive terms, |a|, |b| <= a - b
        q_opp = np.where(dab > 0, (a * cb - b * ca) / dab, 1.0)
    Q = np.where(a * b > 0, q_same, q_opp)
    return a, b, ca, cb, Q, dab * Q


def _xz(s, H, V_q, l, w, EA):
    """Elastic catenary coordinates ``x(s), z(s)`` (docs/theory.md §8)."""
    s = np.asarray(s, dtype=float)
    a, b, ca, cb, Q, D = _terms(s, H, V_q, l, w)
    x = s * Q * _asinhc(D) + H * s / EA
    z = s * (a + b) / (ca + cb) + s * (V_q - w * l + 0.5 * w * s) / EA
    return x, z


def _out(r: np.ndarray):
    return float(r) if np.ndim(r) == 0 else r


@dataclass(frozen=True)
class Catenary2D:
    """Solved elastic catenary in its vertical plane (SI units: m, N, N/m).

    Attributes:
        span, rise: Horizontal and vertical position [m] of q relative to p.
        length: Stress-free length [m].
        w: Weight [N/m of stress-free length].
        EA: Axial stiffness [N].
        H: Horizontal tension [N].
        V_q: Vertical tension component at q [N] (up positive, V_F of docs/theory.md §8).
    """

    span: float
    rise: float
    length: float
    w: float
    EA: float
    H: float
    V_q: float

    def vertical_force(self, s: ArrayLike) -> np.ndarray | float:
        """Vertical tension component ``V(s) = V_q - w (l - s)`` [N], up positive."""
        return _out(self.V_q - self.w * (self.length - np.asarray(s, dtype=float)))

    def x(self, s: ArrayLike) -> np.ndarray | float:
        """Horizontal coordinate [m] at stress-free arc length ``s`` [m]."""
        return _out(_xz(s, self.H, self.V_q, self.length, self.w, self.EA)[0])

    def z(self, s: ArrayLike) -> np.ndarray | float:
        """Vertical coordinate [m] (up positive) at stress-free arc length ``s`` [m]."""
        return _out(_xz(s, self.H, self.V_q, self.length, self.w, self.EA)[1])

    def tension(self, s: ArrayLike) -> np.ndarray | float:
        """Tension ``T(s) = sqrt(H^2 + V(s)^2)`` [N]."""
        return _out(np.hypot(self.H, self.vertical_force(s)))

    def tangent_angle(self, s: ArrayLike) -> np.ndarray | float:
        """Angle [rad] of the tangent to the horizontal, ``atan2(V(s), H)``."""
        return _out(np.arctan2(self.vertical_force(s), self.H))

    def sag(self) -> float:
        """Mid-span sag [m]: chord height minus cable height at ``x = span/2`` (> 0 below)."""
        l, half = self.length, 0.5 * self.span
        s = brent(lambda t: self.x(t) - half, 0.0, l, xtol=1e-15 * l, rtol=4 * _EPS)
        T = self.tension(s)  # one Newton polish, dx/ds = H/T + H/EA
        s -= (self.x(s) - half) / (self.H / T + self.H / self.EA)
        return 0.5 * self.rise - self.z(min(max(s, 0.0), l))

    def sag_ratio(self) -> float:
        """Sag divided by the chord length ``sqrt(span^2 + rise^2)`` [-]."""
        return self.sag() / math.hypot(self.span, self.rise)


def _initial_guess(L: float, h: float, l: float, w: float, EA: float) -> tuple[float, float]:
    """(H, V_q) of an inextensible catenary whose length ``l_s`` is ``l`` plus the stretch
    ``int T ds / EA`` of that same catenary; parametrised by ``lam = w L / (2 H)``."""
    def parts(lam):
        sc = 1.0 + lam * lam / 6.0 if lam < 1e-4 else math.sinh(lam) / lam
        ls = math.hypot(h, L * sc)
        # int T ds = (H^2/2w)(2 lam + cosh(2m) sinh(2 lam)), cosh 2m = (ls^2+h^2)/(L sc)^2
        stretch = 0.25 * w * (L * L / lam + (ls * ls + h * h) / math.tanh(lam)) / EA
        return ls, ls - l - stretch * l / ls

    lo = hi = 1.0
    for _ in range(500):
        if parts(lo)[1] < 0:
            break
        lo *= 0.5
    for _ in range(8):
        if parts(hi)[1] > 0:
            break
        hi *= 2.0
    if parts(lo)[1] < 0 < parts(hi)[1]:
        lam = brent(lambda t: parts(t)[1], lo, hi, rtol=1e-10)
    else:  # very extensible cable (w l ~ EA): start from a moderate sag
        lam = 0.5
    H = w * L / (2 * lam)
    sc = math.sinh(lam) / lam
    m = math.asinh(h / (L * sc))
    V_mean = 0.5 * H * (math.sinh(m + lam) + math.sinh(m - lam))
    return H, V_mean + 0.5 * w * l


def solve_catenary(span: float, rise: float, length: float, w: float, EA: float, *,
                   tol: float = 1e-13) -> Catenary2D:
    """Solve ``x(l) = span``, ``z(l) = rise`` for ``(H, V_q)``.

    Newton on ``(ln H, V_q)`` with the analytic Jacobian and a backtracking line search,
    from an inextensible-catenary guess corrected for the stretch. ``w = 0`` is solved in
    closed form (straight, uniform tension). ``tol`` bounds the residual of ``x(l), z(l)``
    relative to ``chord + length (1 + w length/EA)`` (the size of the terms summed).

    Args:
        span: Horizontal distance [m] from p to q, > 0.
        rise: Height [m] of q above p.
        length: Stress-free length [m], > 0.
        w: Weight [N/m of stress-free length], >= 0.
        EA: Axial stiffness [N], > 0 (``inf`` for an inextensible cable).
        tol: Bound on the relative residual (above).

    Returns:
        The solved :class:`Catenary2D`.

    Raises:
        ValueError: Bad inputs, or no taut equilibrium exists.
        RuntimeError: The iteration fails (not seen in 20 000 random cases, near-vertical
            hairpins included).
    """
    L, h, w, EA, c = _plane(span, rise, w, EA)
    l, tol = _check("length", length, 0.0), _check("tol", tol, 0.0)
    if w == 0.0 or math.isinf(EA):
        if (w == 0.0 and l >= c) or (w > 0.0 and l <= c):
            kind = "weightless" if w == 0.0 else "inextensible"
            need = "< chord" if w == 0.0 else "> chord"
            raise ValueError(f"no taut equilibrium for a {kind} cable: length {l!r} must be "
                             f"{need} {c!r}")
        if w == 0.0:
            if math.isinf(EA):
                raise ValueError("EA must be finite for a weightless cable (tension undefined)")
            T = EA * (c / l - 1.0)
            return Catenary2D(L, h, l, w, EA, T * L / c, T * h / c)
    H0, V0 = _initial_guess(L, h, l, w, EA)
    y, nf = _newton(np.array([math.log(H0), V0]), L, h, l, w, EA, tol)
    if nf > tol:  # rare (near-vertical hairpins, w l ~ EA): bisection, then Newton again
        y, nf = _newton(_bisect(L, h, l, w, EA), L, h, l, w, EA, tol)
    if nf > tol:
        raise RuntimeError(f"elastic catenary did not converge (scaled residual {nf:.3e})")
    return Catenary2D(L, h, l, w, EA, math.exp(y[0]), float(y[1]))


def _scale(L, h, l, w, EA) -> float:
    """Size of the terms summed in ``x(l), z(l)``: chord + length (1 + w length/EA)."""
    return math.hypot(L, h) + l * (1.0 + w * l / EA)


def _resid(y, L, h, l, w, EA):
    x, z = _xz(l, math.exp(y[0]), y[1], l, w, EA)
    return np.array([x - L, z - h]) / _scale(L, h, l, w, EA)


def _newton(y, L, h, l, w, EA, tol) -> tuple[np.ndarray, float]:
    """Damped Newton on ``y = (ln H, V_q)``; returns ``y`` and the scaled residual norm."""
    f = _resid(y, L, h, l, w, EA)
    for _ in range(100):
        nf = float(np.linalg.norm(f))
        if nf <= tol or not np.isfinite(nf):
            break
        H, V = math.exp(y[0]), y[1]
        a, b, ca, cb, Q, D = _terms(l, H, V, l, w)
        k = ca * cb
        # w dx/dH = asinh D - D/k = int_beta^alpha tanh^2 (a = sinh alpha, b = sinh beta):
        # two forms, each free of cancellation in its range
        if max(abs(a), abs(b)) < 0.5:
            dxdH = l / H * Q * (_asinhc(D, True) + (a * a + b * b + a * a * b * b) / ((k + 1) * k))
        else:
            dxdH = (math.asinh(D) - D / k) / w
        off = -l / H * (a + b) / ((ca + cb) * k)  # dx/dV = dz/dH (symmetric flexibility)
        J = np.array([[H * (dxdH + l / EA), off], [H * off, l / H * Q / k + l / EA]])
        dy = -np.linalg.solve(J / _scale(L, h, l, w, EA), f)
        dy *= min(1.0, 2.0 / max(abs(dy[0]), 1e-300))  # at most a factor e^2 on H per step
        alpha = 1.0
        while alpha > 1e-12:
            f_new = _resid(y + alpha * dy, L, h, l, w, EA)
            if np.all(np.isfinite(f_new)) and np.linalg.norm(f_new) < (1 - 1e-4 * alpha) * nf:
                break
            alpha *= 0.5
        else:
            break  # no descent: at the round-off floor, or a bad start
        y, f = y + alpha * dy, f_new
    return y, float(np.linalg.norm(f))


def _expand(g, x0: float, step: float) -> tuple[float, float]:
    """Bracket of a sign change of the increasing ``g``, widening ``x0 -+ step`` by 2."""
    lo, hi = x0 - step, x0 + step
    for _ in range(2000):
        if g(lo) < 0 < g(hi):
            return lo, hi
        if g(lo) >= 0:
            lo -= step
        else:
            hi += step
        step *= 2
    raise RuntimeError("elastic catenary: no bracket found")


def _bisect(L, h, l, w, EA) -> np.ndarray:
    """Robust ``(ln H, V_q)``: for each H, ``z(l)`` increases with ``V_q`` (its root by
    Brent's method); ``x(l)`` then increases with ``H`` (the flexibility matrix is positive
    definite)."""
    def V_of(lnH):
        zf = lambda V: _xz(l, math.exp(lnH), V, l, w, EA)[1] - h  # noqa: E731
        return brent(zf, *_expand(zf, 0.5 * w * l, w * l), xtol=1e-300, rtol=4 * _EPS)

    xf = lambda lnH: _xz(l, math.exp(lnH), V_of(lnH), l, w, EA)[0] - L  # noqa: E731
    lnH = brent(xf, *_expand(xf, math.log(w * l), 2.0), xtol=1e-15, rtol=4 * _EPS)
    return np.array([lnH, V_of(lnH)])


def _solve_length(fun, target: float, name: str, c: float, EA: float, sign: float) -> float:
    """Root in ``length`` of ``fun(length) = target``, ``sign * fun`` increasing.

    Bracket, within lengths where the solution is meaningful in floating point: taut side
    halving from ``c/2`` down to ``2^-30 c`` (strain 1e9), or ``c (1 + 10^-k)`` down to
    ``1e-13`` above the chord ``c`` when ``EA = inf``; slack side doubling from ``2 c`` up to
    ``2^20 c`` (a million chords).
    """
    if math.isinf(EA):
        los = [c * (1.0 + 10.0**-k) for k in range(3, 14)]
    else:
        los = [c * 0.5**k for k in range(1, 31)]
    his = [c * 2.0**k for k in range(1, 21)]
    g = lambda l: sign * (fun(l) - target)  # noqa: E731
    lo = next((v for v in los if g(v) < 0), None)
    hi = next((v for v in his if g(v) > 0), None)
    if lo is None or hi is None:
        raise ValueError(f"{name}={target!r} cannot be reached: lengths from {los[-1]!r} to "
                         f"{his[-1]!r} give {name} from {fun(los[-1])!r} to {fun(his[-1])!r}")
    return brent(g, lo, hi, xtol=1e-15 * lo, rtol=4 * _EPS)


def length_for_horizontal_tension(span: float, rise: float, H: float, w: float,
                                  EA: float) -> float:
    """Stress-free length [m] for which the catenary has horizontal tension ``H`` [N].

    ``H`` decreases with the length, from infinity at the taut limit to 0 (only
    logarithmically for an inextensible cable); the ValueError for an unreachable ``H`` (or
    ``H <= 0``) gives the range reached within the bracket of ``_solve_length``. For ``w = 0``
    the closed form of a straight cable is used.

    Args:
        span, rise: Horizontal and vertical position [m] of the second end from the first.
        H: The horizontal tension [N], > 0.
        w: Weight [N/m], >= 0.
        EA: Axial stiffness [N] (``inf``: inextensible).

    Raises:
        ValueError: ``H`` out of the reachable range (which the message gives).
    """
    L, h, w, EA, c = _plane(span, rise, w, EA)
    H = float(H)
    if not H > 0 or math.isinf(H):
        raise ValueError(f"H must be finite and > 0 (reachable range (0, inf)), got {H!r}")
    if w == 0.0:
        if math.isinf(EA):
            raise ValueError("H cannot be set for a weightless inextensible cable: any H > 0 "
                             "gives length = chord")
        return c / (1.0 + H * c / (L * EA))
    return _solve_length(lambda l: solve_catenary(L, h, l, w, EA).H, H, "H", c, EA, -1.0)


def length_for_sag_ratio(span: float, rise: float, sag_ratio: float, w: float,
                         EA: float) -> float:
    """Stress-free length [m] giving mid-span ``sag / chord`` = ``sag_ratio`` [-].

    The sag ratio grows with the length, from 0 at the taut limit; a weightless cable has no
    sag. The ValueError for an unreachable target gives the range reached. The result is
    ill-conditioned for tiny ratios: relative error ~ eps |rise|/sag from the definition of
    the sag, and ~ eps l/(l - chord) for inextensible cables.

    Args:
        span, rise: Horizontal and vertical position [m] of the second end from the first.
        sag_ratio: Mid-span sag over chord length [-], > 0.
        w: Weight [N/m], > 0.
        EA: Axial stiffness [N] (``inf``: inextensible).

    Raises:
        ValueError: ``sag_ratio`` out of the reachable range (which the message gives).
    """
    L, h, w, EA, c = _plane(span, rise, w, EA)
    r = float(sag_ratio)
    if not r > 0 or math.isinf(r):
        raise ValueError(f"sag_ratio must be finite and > 0 (reachable range (0, inf)), "
                         f"got {sag_ratio!r}")
    if w == 0.0:
        raise ValueError("sag_ratio cannot be reached with w = 0: a weightless cable has no "
                         "sag (reachable range {0})")
    return _solve_length(lambda l: solve_catenary(L, h, l, w, EA).sag_ratio(), r,
                         "sag_ratio", c, EA, 1.0)


@dataclass(frozen=True, eq=False)
class Catenary3D:
    """A cable between points ``p`` and ``q`` [m] in 3D, gravity along ``gravity_dir``.

    ``cat`` is the solution in the vertical plane through the chord (``x`` along
    ``e_h``, ``z`` along ``up = -gravity_dir``), or None for a straight cable (vertical
    chord or ``w = 0``), then ``T(s) = T(0) + w (e . up) s`` along ``e = (q - p)/|q - p|``.

    Attributes:
        p, q: The ends [m], read-only (3,) arrays.
        gravity_dir: Unit direction of gravity.
        cat: The plane solution, or None (straight cable).
        length: Stress-free length [m].
        w: Weight [N/m].
        EA: Axial stiffness [N].
    """

    p: np.ndarray
    q: np.ndarray
    gravity_dir: np.ndarray
    cat: Catenary2D | None
    length: float
    w: float
    EA: float

    @property
    def up(self) -> np.ndarray:
        """Unit vertical, ``-gravity_dir``."""
        return -self.gravity_dir

    @property
    def e_h(self) -> np.ndarray:
        """Unit horizontal direction from p towards q (chord direction if straight)."""
        d = self.q - self.p
        if self.cat is None:
            return d / np.linalg.norm(d)
        dh = d - np.dot(d, self.up) * self.up
        return dh / np.linalg.norm(dh)

    def _straight(self) -> tuple[float, float]:
        """(T(0), e . up) of the straight cable: int (1 + T/EA) ds = chord."""
        c, l = float(np.linalg.norm(self.q - self.p)), self.length
        k = float(np.dot(self.q - self.p, self.up)) / c
        return self.EA * (c - l) / l - 0.5 * self.w * k * l, k

    def position(self, s: ArrayLike) -> np.ndarray:
        """Current positions [m], shape ``(len(s), 3)``."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        if self.cat is None:
            T0, k = self._straight()
            along = s + (T0 * s + 0.5 * self.w * k * s * s) / self.EA
            return self.p + along[:, None] * self.e_h
        x, z = _xz(s, self.cat.H, self.cat.V_q, self.length, self.w, self.EA)
        return self.p + x[:, None] * self.e_h + z[:, None] * self.up

    def tension(self, s: ArrayLike) -> np.ndarray:
        """Tension [N] at stress-free arc lengths ``s`` [m], shape ``(len(s),)``."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        if self.cat is None:
            T0, k = self._straight()
            return T0 + self.w * k * s
        return np.atleast_1d(self.cat.tension(s))

    def _force(self, s: float) -> np.ndarray:
        """Tension vector ``T t`` [N] at ``s``, ``t`` the unit tangent towards increasing s."""
        if self.cat is None:
            return self.tension(s)[0] * self.e_h
        return self.cat.H * self.e_h + self.cat.vertical_force(s) * self.up

    def force_at_p(self) -> np.ndarray:
        """Force [N] the span transmits at p, pointing into the span: ``T(0) t(0)``."""
        return self._force(0.0)

    def force_at_q(self) -> np.ndarray:
        """Force [N] the span transmits at q, pointing into the span: ``-T(l) t(l)``."""
        return -self._force(self.length)


def catenary_between(p: ArrayLike, q: ArrayLike, length: float, w: float, EA: float,
                     gravity_dir: ArrayLike = (0.0, 0.0, -1.0)) -> Catenary3D:
    """Elastic catenary of stress-free ``length`` [m], weight ``w`` [N/m], stiffness ``EA``
    [N] between points ``p`` and ``q`` [m]; ``gravity_dir`` need not be normalised.

    A chord within ``1e-12`` (relative) of the vertical, or ``w = 0``, gives a straight
    cable (``cat = None``); it needs a finite ``EA`` and no compression anywhere.

    Args:
        p, q: The ends [m], (3,).
        length: Stress-free length [m], > 0.
        w: Weight [N/m of stress-free length], >= 0.
        EA: Axial stiffness [N], > 0 (``inf``: inextensible, not for a straight cable).
        gravity_dir: Direction of gravity (normalised here).

    Returns:
        The :class:`Catenary3D`.

    Raises:
        ValueError: Bad inputs, or no taut equilibrium (a straight cable that would be
            compressed at its lower end).
    """
    p = np.array(p, dtype=float).reshape(3)
    q = np.array(q, dtype=float).reshape(3)
    g = np.array(gravity_dir, dtype=float).reshape(3)
    for name, v in (("p", p), ("q", q), ("gravity_dir", g)):
        if not np.all(np.isfinite(v)):
            raise ValueError(f"{name} must be finite, got {v}")
    if np.linalg.norm(g) == 0:
        raise ValueError("gravity_dir must be a non-zero vector")
    g = g / np.linalg.norm(g)
    l = _check("length", length, 0.0)
    w = _check("w", w, 0.0, strict=False)
    EA = _check("EA", EA, 0.0, allow_inf=True)
    d = q - p
    c = float(np.linalg.norm(d))
    if c == 0:
        raise ValueError("p and q coincide: the chord length must be > 0")
    rise = float(-np.dot(d, g))
    span = float(np.linalg.norm(d + rise * g))
    for v in (p, q, g):
        v.setflags(write=False)
    if span >= 1e-12 * c and w > 0:
        return Catenary3D(p, q, g, solve_catenary(span, rise, l, w, EA), l, w, EA)
    if math.isinf(EA):
        raise ValueError("EA must be finite for a straight (vertical or weightless) cable: "
                         "the tension of an inextensible straight cable is undetermined")
    cab = Catenary3D(p, q, g, None, l, w, EA)
    T0, k = cab._straight()
    if min(T0, T0 + w * k * l) < 0:
        l_max = 2 * c / (1 + math.sqrt(1 + 2 * w * c / EA))  # lower-end tension = 0
        raise ValueError(f"length {l!r} too long for a straight cable of chord {c!r}: it would "
                         f"be slack (compressed) at its lower end; length must be <= {l_max!r}")
    return cab


def irvine_lambda2(span: float, H: float, m: float, g: float, EA: float, sag: float) -> float:
    """Irvine's parameter ``lambda^2 = (m g L/H)^2 L / (H L_e/EA)`` [-] with
    ``L_e = L (1 + 8 (d/L)^2)`` (docs/theory.md §8).

    Args:
        span: Span ``L`` [m], > 0.
        H: Horizontal tension [N], > 0.
        m: Mass [kg/m], > 0.
        g: Gravitational acceleration [m/s^2], > 0.
        EA: Axial stiffness [N] (``inf``: inextensible).
        sag: Mid-span sag ``d`` [m], >= 0.
    """
    L, H = _check("span", span, 0.0), _check("H", H, 0.0)
    m, g = _check("m", m, 0.0), _check("g", g, 0.0)
    EA, d = _check("EA", EA, 0.0, allow_inf=True), _check("sag", sag, 0.0, strict=False)
    L_e = L * (1.0 + 8.0 * (d / L) ** 2)
    return (m * g * L / H) ** 2 * L * EA / (H * L_e)


def irvine_symmetric_frequency(lambda2: float, n: int = 1) -> float:
    """``omega_bar = omega L / sqrt(H/m)`` of the n-th symmetric in-plane mode [-].

    Root of ``tan(x) = x - (4/lambda2) x^3``, ``x = omega_bar/2``. ``F = tan(x) - x +
    (4/lambda2) x^3`` has ``F' = tan^2 x + 12 x^2/lambda2 > 0``, so there is exactly one root
    per branch ``((2n-1) pi/2, (2n+1) pi/2)``; it is bracketed exactly by the pole-free
    ``G = sin x - (x - 4 x^3/lambda2) cos x``, which equals ``+-1`` at the branch ends.
    ``lambda2 = inf`` (inextensible limit) gives ``tan x = x``: 2.8606 pi for n = 1.

    Args:
        lambda2: Irvine's parameter (:func:`irvine_lambda2`), > 0 or ``inf``.
        n: Number of the symmetric mode, >= 1.
    """
    lam2 = _check("lambda2", lambda2, 0.0, allow_inf=True)
    if int(n) != n or n < 1:
        raise ValueError(f"n must be an integer >= 1, got {n!r}")
    c = 0.0 if math.isinf(lam2) else 4.0 / lam2
    G = lambda x: math.sin(x) - (x - c * x**3) * math.cos(x)  # noqa: E731
    x = brent(G, (2 * n - 1) * math.pi / 2, (2 * n + 1) * math.pi / 2, xtol=1e-15,
               rtol=4 * _EPS)
    return 2.0 * x
