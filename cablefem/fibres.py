"""The worst fibre of a section under a moment vector history: its plane, scan and search.

The bending stress of the fibre of direction ``w`` is ``M . w / W`` (``docs/theory.md`` §7).
The directions lie in the plane of the moment vectors, ``w(a) = cos(a) e1 + sin(a) e2``
(:func:`fibre_plane`); the damage ``D(a)`` of the stress history at ``w(a)`` is scanned at
``fibres`` directions and their opposites (:func:`scan_angles`: a set that no sign of ``e1``
or ``e2`` changes), then the best one is refined by a golden-section search over its
neighbourhood (:func:`worst_angle`): the continuous worst direction, whatever the count.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

__all__ = ["fibre_plane", "scan_angles", "scan_bound", "WorstFibre", "worst_angle",
           "ANGLE_TOL"]

#: the golden-section search stops when its bracket is narrower than this [rad]: a smooth
#: maximum D(a*) (1 - c (a - a*)^2) is then found to a relative 1e-14 (c ~ m/2 <= 3)
ANGLE_TOL = 1e-7


def _signed(v: np.ndarray) -> np.ndarray:
    """``v`` with its largest-magnitude component positive (the first of equal ones)."""
    return v if v[np.argmax(np.abs(v))] > 0 else -v


def fibre_plane(M: np.ndarray, ok: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``e1, e2``: the eigenvectors of the two largest eigenvalues of ``S = sum M M^T`` over
    the rows ``ok`` of ``M`` (n, 3) (not centred: a constant moment's direction stays in the
    plane), each signed so that its largest-magnitude component is positive. For a moment in
    one plane, ``e1`` is its direction (``e2`` then any unit vector normal to it).

    Args:
        M: (n, 3) moment vectors.
        ok: (n,) bool mask of the rows to use, or None (all).

    Returns:
        ``(e1, e2)``, unit (3,) vectors.
    """
    M = np.asarray(M, float).reshape(-1, 3)
    if ok is not None:
        M = M[np.asarray(ok, bool)]
    _, vec = np.linalg.eigh(M.T @ M if M.size else np.eye(3))
    return _signed(vec[:, 2]), _signed(vec[:, 1])


def scan_angles(fibres: int) -> np.ndarray:
    """The scanned angles from ``e1`` [rad]: ``2 pi k/fibres`` (k = 0..fibres-1) and their
    opposites ``+ pi``: for an even count the same ``fibres`` angles, for an odd one the
    ``2 fibres`` angles ``pi j/fibres``. The set is its own mirror image about ``e1``
    (``a -> -a``) and about ``e2`` (``a -> pi - a``): the sign of neither eigenvector moves it.

    Args:
        fibres: Number of directions, an integer >= 1.
    """
    if isinstance(fibres, bool) or int(fibres) != fibres or fibres < 1:
        raise ValueError(f"fibres must be an integer >= 1 (got {fibres!r})")
    n = int(fibres) * (1 if fibres % 2 == 0 else 2)
    return 2 * np.pi * np.arange(n) / n


def scan_bound(fibres: int, m: float) -> float:
    """Lower bound of ``D_scan / D_worst`` for a history whose varying bending lies in one
    plane (a constant moment in any direction besides): the worst direction is within
    ``delta = pi/n`` of a scanned one (n = :func:`scan_angles` count), where every stress
    range is ``cos(delta)`` times the worst's; the damage per cycle falls at most as
    ``range^m`` (m: the curve's steepest slope), so ``D_scan >= cos(delta)^m D_worst`` while no
    range falls below a cut-off.

    Args:
        fibres: Number of scanned directions.
        m: The S-N curve's steepest slope.
    """
    n = scan_angles(fibres).size
    return math.cos(math.pi / n) ** m if n > 1 else 0.0


@dataclass(frozen=True)
class WorstFibre:
    """The search's result: ``angle`` [rad, in [0, 2 pi)] and ``damage`` of the continuous
    worst direction; the best scanned angle, its damage, the smallest scanned damage, and
    the number of damage evaluations.

    Attributes:
        angle: Worst direction [rad from e1, in [0, 2 pi)].
        damage: Its damage.
        scan_angle, scan_damage: The best scanned angle [rad] and its damage.
        scan_min: The smallest scanned damage.
        evaluations: Number of damage evaluations.
    """

    angle: float
    damage: float
    scan_angle: float
    scan_damage: float
    scan_min: float
    evaluations: int


def worst_angle(damage: Callable[[float], float], fibres: int,
                tol: float = ANGLE_TOL) -> WorstFibre:
    """Maximise ``damage(a)`` over the angle: the :func:`scan_angles`, then a golden-section
    search on ``[a_k - h, a_k + h]`` around the best scanned ``a_k`` (h: the scan spacing)
    down to a bracket of ``tol`` rad. The result is the largest damage evaluated (never below
    the scan's). Without damage at any scanned angle there is nothing to refine.

    Args:
        damage: The damage at an angle [rad] from e1.
        fibres: Number of scanned directions.
        tol: Final bracket [rad].
    """
    angles = scan_angles(fibres)
    d = np.array([damage(float(a)) for a in angles])
    k = int(np.argmax(d))
    best = [float(d[k]), float(angles[k])]
    evals = angles.size
    if d[k] > 0:
        g = (math.sqrt(5.0) - 1) / 2
        h = 2 * math.pi / angles.size
        lo, hi = best[1] - h, best[1] + h
        x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
        f1, f2 = damage(x1), damage(x2)
        evals += 2
        for f, x in ((f1, x1), (f2, x2)):
            best = max(best, [f, x], key=lambda p: p[0])
        while hi - lo > tol:
            if f1 >= f2:
                hi, x2, f2 = x2, x1, f1
                x1 = hi - g * (hi - lo)
                f1, x = damage(x1), x1
                f = f1
            else:
                lo, x1, f1 = x1, x2, f2
                x2 = lo + g * (hi - lo)
                f2, x = damage(x2), x2
                f = f2
            evals += 1
            if f > best[0]:
                best = [f, x]
    return WorstFibre(best[1] % (2 * math.pi), best[0], float(angles[k]), float(d[k]),
                      float(d.min()), evals)
