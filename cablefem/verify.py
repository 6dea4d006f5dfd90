"""Closed-form references for a two-anchor cable at rest, to check a run against.

:func:`closed_form_anchor_moments` evaluates the composite anchor moment of docs/theory.md §4
(the layer's closed form plus the string-curvature correction) with the *exact* elastic
catenary's anchor forces, so that a finite-element run can be checked to the accuracy of
its reaction forces (O(h^2)). Pure NumPy.
"""

from __future__ import annotations

import numpy as np

from cablefem.catenary import catenary_between
from cablefem.description import CableDescription, stress_free_length
from cablefem.moments import anchor_moments

__all__ = ["closed_form_anchor_moments"]


def closed_form_anchor_moments(case: CableDescription, form: str = "exact") -> dict[str, dict]:
    """Static anchor-moment columns (as in anchors.csv) of every clamped anchor, from the
    exact elastic catenary of the bare cable (no point masses or extra loads)."""
    sec = case.section
    length = stress_free_length(case)
    gdir = np.asarray(case.gravity.direction, float)
    w = sec.mass * case.gravity.g
    a0, a1 = case.anchors
    cat = catenary_between(a0.position, a1.position, length, w, sec.EA, gdir)
    out = {}
    for anc, N in ((a0, cat.force_at_p()), (a1, cat.force_at_q())):
        if anc.kind != "clamped":
            continue
        res = anchor_moments(N[None, :], anc.direction, sec.EI, sec.EA, sec.mass,
                             np.zeros((1, 3)), w * gdir, length, None, form)
        out[anc.name] = {k: (v[0] if np.ndim(v) else v) for k, v in res.items()}
    return out
