"""Brent's root finder (cablefem.roots.brent) against SciPy's brentq, the same method with the
same tolerances: on smooth, steep, flat and kinked functions both roots lie within the
tolerance ``xtol + rtol |x|`` of the exact one (tolerances met, by each, independently),
and the errors of the interface are the same."""

from __future__ import annotations

import math

import pytest
from scipy.optimize import brentq

from cablefem.roots import brent

EPS = 2.220446049250313e-16

# (function, bracket, exact root)
CASES = [
    (lambda x: x * x - 2.0, (0.0, 2.0), math.sqrt(2.0)),
    (lambda x: math.cos(x) - x, (0.0, 1.0), 0.7390851332151607),
    (lambda x: math.exp(x) - 1e6, (0.0, 50.0), math.log(1e6)),
    (lambda x: (x - 1.0) ** 3, (-3.0, 2.5), 1.0),  # flat at the root: bisection's pace
    (lambda x: math.copysign(abs(x - 0.3) ** 0.1, x - 0.3), (-1.0, 1.0), 0.3),  # steep
    (lambda x: -1.0 if x < 0.25 else 1.0, (0.0, 1.0), 0.25),  # a jump: its place
    (lambda x: math.atan(1e4 * (x - 1e-3)), (-10.0, 10.0), 1e-3),
    (lambda x: math.sinh(x) - 1e-300, (-1.0, 1.0), 1e-300),  # a root near zero: xtol
]


@pytest.mark.parametrize("xtol,rtol", [(2e-12, 4 * EPS), (1e-300, 4 * EPS), (1e-15, 1e-10)])
@pytest.mark.parametrize("k", range(len(CASES)))
def test_both_roots_within_the_tolerance_of_the_exact_one(k, xtol, rtol):
    f, (a, b), root = CASES[k]
    tol = xtol + rtol * abs(root)
    # the tolerance the method guarantees for its bracket, plus the root's own rounding
    # (the exact root is a real number; a float function changes sign within an ulp or so)
    slack = tol + 4 * EPS * abs(root)
    for x in (brent(f, a, b, xtol, rtol), brentq(f, a, b, xtol=xtol, rtol=rtol, maxiter=200)):
        assert abs(x - root) <= slack, (x, root)


def test_the_interface_errors():
    with pytest.raises(ValueError, match="same sign"):
        brent(lambda x: x * x + 1.0, -1.0, 1.0)
    with pytest.raises(ValueError, match="rtol"):
        brent(lambda x: x, -1.0, 1.0, rtol=1e-17)
    assert brent(lambda x: x, 0.0, 1.0) == 0.0  # a root at an end
    with pytest.raises(RuntimeError, match="no root"):
        brent(lambda x: math.cos(x) - x, 0.0, 1.0, xtol=1e-300, rtol=4 * EPS, maxiter=2)
