"""A root of a scalar function in a bracket: Brent's method (R. P. Brent, *Algorithms for
Minimization without Derivatives*, 1973, chapter 4), for the catenaries and the seabed's
grounded line.

Brent's method keeps a bracket ``[b, c]`` with ``f(b) f(c) <= 0`` and ``|f(b)| <= |f(c)|``;
each step tries inverse quadratic interpolation through the last three points (the secant
through two when only two differ) and takes it when it falls well inside the bracket and
shrinks it fast enough, otherwise bisects. It needs no derivative and never leaves the
bracket; it converges superlinearly on smooth functions and at worst like bisection.

Here rather than SciPy's ``brentq`` (the same method, the same tolerances) because
importing ``scipy.optimize`` cost every command about 0.04 s of CPU beyond the SciPy modules
it loads anyway (``python -X importtime``: 0.10 s alone; importing ``cablefem.app.run``:
0.716 -> 0.680 s, median of 12 alternated pairs).
"""

from __future__ import annotations

import math
from typing import Callable

__all__ = ["brent"]

_EPS = 2.220446049250313e-16


def brent(f: Callable[[float], float], a: float, b: float, xtol: float = 2e-12,
          rtol: float = 4 * _EPS, maxiter: int = 200) -> float:
    """A root of ``f`` in ``[a, b]``, within ``xtol + rtol |x|`` of a sign change of ``f``
    (the tolerances of SciPy's ``brentq``).

    Args:
        f: A continuous function with ``f(a)`` and ``f(b)`` of opposite signs (or zero).
        a, b: The bracket.
        xtol, rtol: Absolute and relative tolerance on the root; ``rtol >= 4 eps``.
        maxiter: Iterations before RuntimeError.

    Raises:
        ValueError: ``f(a)`` and ``f(b)`` of the same sign, or a tolerance out of range.
        RuntimeError: No convergence in ``maxiter`` iterations.
    """
    if xtol <= 0.0 or rtol < 4 * _EPS:
        raise ValueError(f"xtol must be > 0 and rtol >= 4 eps, got {xtol!r}, {rtol!r}")
    fa, fb = f(a), f(b)
    if fa == 0.0:
        return a
    if fb == 0.0:
        return b
    if (fa > 0.0) == (fb > 0.0):
        raise ValueError(f"f(a) = {fa!r} and f(b) = {fb!r} have the same sign")
    c, fc = a, fa  # the other end of the bracket
    d = e = b - a  # the last step and the one before
    for _ in range(maxiter):
        if (fb > 0.0) == (fc > 0.0):  # the sign change is between a and b: c takes a
            c, fc = a, fa
            d = e = b - a
        if abs(fc) < abs(fb):  # b the best estimate
            a, fa, b, fb, c, fc = b, fb, c, fc, b, fb
        tol = 0.5 * (xtol + rtol * abs(b))
        m = 0.5 * (c - b)  # bisection step
        if abs(m) <= tol or fb == 0.0:
            return b
        if abs(e) >= tol and abs(fa) > abs(fb):  # interpolate
            s = fb / fa
            if a == c:  # secant
                p, q = 2.0 * m * s, 1.0 - s
            else:  # inverse quadratic through a, b, c
                q, r = fa / fc, fb / fc
                p = s * (2.0 * m * q * (q - r) - (b - a) * (r - 1.0))
                q = (q - 1.0) * (r - 1.0) * (s - 1.0)
            if p > 0.0:
                q = -q
            else:
                p = -p
            # accepted when well inside the bracket and shorter than half the step before
            if 2.0 * p < min(3.0 * m * q - abs(tol * q), abs(e * q)):
                e, d = d, p / q
            else:
                d = e = m
        else:
            d = e = m
        a, fa = b, fb
        b += d if abs(d) > tol else math.copysign(tol, m)
        fb = f(b)
    raise RuntimeError(f"no root found in {maxiter} iterations (bracket [{b!r}, {c!r}])")
