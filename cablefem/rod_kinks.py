"""A rod's moment at a kink's node, from its element moments (``--model beam`` on a cable
with point loads or dampers: the rod resolves the kink's layer, ``kinks.csv`` gives its own
moment there)."""

from __future__ import annotations

import numpy as np

__all__ = ["rod_moments_along", "rod_kink_moments"]


def rod_moments_along(model) -> tuple[np.ndarray, np.ndarray]:
    """The rod's element moments along the cable, on every rank (collective): the
    stress-free station of each element's midpoint (n_el,) and its moment vector (n_el, 3),
    in the order of the mesh's elements."""
    f = model.moment_field()
    W = f.function_space
    n_owned = W.dofmap.index_map.size_local
    mid = W.tabulate_dof_coordinates()[:n_owned]
    vals = f.x.array[: 3 * n_owned].reshape(-1, 3)
    parts = model.comm.allgather((mid, vals))
    mid = np.concatenate([p[0] for p in parts])
    vals = np.concatenate([p[1] for p in parts])
    geo = model.geometry
    st = geo.stations
    # each element's midpoint at the mean of its two stations (the reference is straight)
    s_mid = st[:-1] + 0.5 * np.diff(st)
    ref_mid = 0.5 * (geo.points[:-1] + geo.points[1:])
    order = np.array([int(np.argmin(np.linalg.norm(ref_mid - x, axis=1))) for x in mid])
    M = np.full((st.size - 1, 3), np.nan)
    M[order] = vals
    return s_mid, M


def rod_kink_moments(model, kinks: list) -> np.ndarray:
    """The rod's moment magnitude at each kink's node (``kinks``:
    :class:`cablefem.kinks.Kink`; collective): its element moments
    (:func:`rod_moments_along`) extrapolated to the node from each side, quadratically from
    the three nearest elements, the two sides averaged."""
    if not kinks:
        return np.zeros(0)
    s_mid, M = rod_moments_along(model)
    M = np.linalg.norm(M, axis=1)
    out = []
    for k in kinks:
        sides = []
        for cells in (np.arange(k.node - 3, k.node)[::-1], np.arange(k.node, k.node + 3)):
            cells = cells[(cells >= 0) & (cells < M.size)]
            if cells.size < 3:
                sides.append(M[cells[0]])
                continue
            coef = np.polyfit(s_mid[cells] - k.s, M[cells], 2)
            sides.append(np.polyval(coef, 0.0))
        out.append(0.5 * (sides[0] + sides[1]))
    return np.array(out)
