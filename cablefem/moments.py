"""From anchor forces to anchor bending moments: the columns of ``anchors.csv``.

Pure NumPy (no dolfinx), so that ``cablefem post`` can apply it to anchor-force histories
from any string solver. For a clamped anchor at every time (``docs/theory.md``
§3-4):

* the layer's closed form from the anchor force ``N_a`` (:func:`cablefem.asymptotics.layer`),
* plus the string's own curvature at the anchor, ``EI κ_string(0)`` with
  ``κ_string = t × (m a − f) / T`` (``a`` the anchor's acceleration, ``f`` the distributed
  load at the anchor, weight included): ``M(0) = M_a(0) b_a + EI κ_string(0)``.

``moment`` is the magnitude of that vector and ``Mx, My, Mz`` its components (internal
moment in the anchor's direction of travel, into the span); ``moment_layer`` is the layer's
term alone. Slack anchors get ``valid = 0`` and empty moment fields, never a silent zero;
rows outside the method's range (layer too long, not quasi-static, or a force more than
90 degrees from the clamp direction, :data:`MAX_ANCHOR_ANGLE`) get ``valid = 0`` with their
numbers kept, and :func:`anchor_moments` says why in ``invalid_reason``.

Sign convention of the forces: ``N`` is the force of the span on the anchor, i.e. the
tension times the unit tangent from the anchor into the span (``docs/post.md``).
"""

from __future__ import annotations

import numpy as np

from cablefem import asymptotics
from cablefem.io.anchorcsv import ANCHOR_COLUMNS, MOMENT_COLUMNS

__all__ = ["ANCHOR_COLUMNS", "MOMENT_COLUMNS", "MAX_ANCHOR_ANGLE", "anchor_moments"]

#: Largest angle Delta between the clamp direction and the anchor force that the layer
#: describes. The clamp turns the cable by Delta within the layer; beyond 90 degrees the
#: cable would leave the clamp backwards, which no taut cable does: such a force has the
#: wrong sign (the anchor's reaction instead of the span's force) or comes from a
#: mis-oriented clamp.
MAX_ANCHOR_ANGLE = np.pi / 2


def anchor_moments(forces: np.ndarray, direction: np.ndarray, EI: float, EA: float,
                   mass: float, accel: np.ndarray, load: np.ndarray, length: float,
                   omega: float | None = None, form: str = "exact") -> dict[str, np.ndarray]:
    """Anchor moment columns for one clamped anchor over ``n`` times.

    Rows with ``delta`` above :data:`MAX_ANCHOR_ANGLE` are invalid; ``invalid_reason``
    (n,) says why a row is invalid ("" when valid).

    Parameters
    ----------
    forces : (n, 3) force the span transmits at the anchor, into the span, N.
    direction : (3,) clamp direction into the cable.
    EI, EA : N m², N. mass : kg/m. length : stress-free cable length, m.
    accel : (n, 3) acceleration of the anchor, m/s². load : (3,) or (n, 3) distributed
        load per stress-free length at the anchor, weight included, N/m.
    omega : highest excitation circular frequency (rad/s) for the quasi-static check.
    """
    N = np.atleast_2d(np.asarray(forces, float))
    qs = (mass, omega) if omega else None
    lay = asymptotics.layer(N, direction, EI, EA, form=form, length=length, quasi_static=qs)
    kap = asymptotics.string_curvature(lay.tangent, lay.tension, mass, accel, load)
    with np.errstate(invalid="ignore"):
        M = lay.moment_vector + EI * kap
    M = np.where(lay.slack[:, None], np.nan, M)
    with np.errstate(invalid="ignore"):
        backwards = lay.delta > MAX_ANCHOR_ANGLE  # NaN (slack) compares False
        long_ = lay.length_ratio > asymptotics.MAX_LENGTH_RATIO
        dynamic = lay.period_ratio > asymptotics.MAX_PERIOD_RATIO
    valid = lay.valid & ~backwards
    reason = np.select(
        [lay.slack, backwards, ~lay.valid & long_, ~lay.valid & dynamic, ~lay.valid],
        ["slack", "force more than 90 deg from the clamp direction", "layer too long",
         "layer not quasi-static", "undefined layer"], default="")
    return {"delta": lay.delta, "moment": np.linalg.norm(M, axis=1), "Mx": M[:, 0],
            "My": M[:, 1], "Mz": M[:, 2], "psi0": lay.psi0, "layer_length": lay.layer_length,
            "moment_layer": lay.moment, "valid": valid.astype(int),
            "invalid_reason": reason, "tension": lay.tension, "normal": lay.normal,
            "slack": lay.slack}


def composite_field(node_s: np.ndarray, r: np.ndarray, a: np.ndarray, EA: float, EI: float,
                    mass: float, load: np.ndarray, stations: np.ndarray,
                    anchor_s: list[float], deltas: np.ndarray, ells: np.ndarray,
                    normals: np.ndarray, tension_only: bool = True
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Composite curvature along the cable at one time (docs/theory.md §4).

    ``node_s`` (n,), ``r`` (n, 3), ``a`` (n, 3): stations, positions and accelerations of
    the string's nodes; ``stations`` (P,): where to evaluate; ``anchor_s``, ``deltas``,
    ``ells``, ``normals``: the clamped anchors (at ``s = 0`` or ``s = l``) and their layers.
    Returns positions (P, 3) and the composite curvature (P, 3) in 1/m, as vectors in the
    direction of increasing ``s`` (multiply by EI for the moment).
    The string's curvature on each P1 element uses the element's tangent and tension and
    the interpolated acceleration: P1 elements are straight, so their tangent is not
    differentiated.
    """
    pos = np.column_stack([np.interp(stations, node_s, r[:, k]) for k in range(3)])
    acc = np.column_stack([np.interp(stations, node_s, a[:, k]) for k in range(3)])
    e = np.clip(np.searchsorted(node_s, stations, side="right") - 1, 0, node_s.size - 2)
    chord = r[1:] - r[:-1]
    lam = np.linalg.norm(chord, axis=1) / np.diff(node_s)
    T = EA * (lam - 1.0)
    if tension_only:
        T = np.maximum(T, 0.0)
    tang = chord / np.linalg.norm(chord, axis=1)[:, None]
    ks = asymptotics.string_curvature(tang[e], T[e], mass, acc, load)
    ks = np.nan_to_num(ks, nan=0.0)  # slack element: no string curvature from tension
    L = node_s[-1]
    if len(anchor_s) == 0:
        return pos, ks
    sig = np.array([stations - s0 if s0 < 0.5 * L else L - stations for s0 in anchor_s])
    orient = np.array([1.0 if s0 < 0.5 * L else -1.0 for s0 in anchor_s])
    kap = asymptotics.composite_curvature(ks, sig, deltas, ells, normals, orientation=orient)
    return pos, kap
