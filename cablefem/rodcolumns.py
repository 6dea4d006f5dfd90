"""The moment columns of the reference rod (:mod:`cablefem.rod`) at a clamped anchor: the
rod's own moment in place of the asymptotic one, beside the closed form evaluated with the
rod's anchor force (:class:`cablefem.moments.AnchorMoments`)."""

from __future__ import annotations

import numpy as np

from cablefem import asymptotics

__all__ = ["rod_moment_columns"]


def rod_moment_columns(res: dict, M: np.ndarray, direction: np.ndarray) -> dict:
    """A beam run's moment columns: the rod's own moment ``M`` (n, 3) at the anchor replaces
    the asymptotic one; ``psi0`` is the azimuth of the rod's bending plane; ``delta``,
    ``layer_length`` and ``moment_layer`` stay those of the closed form evaluated with the
    beam's anchor force (what the asymptotics would say with the beam's force)."""
    out = dict(res)
    mag = np.linalg.norm(M, axis=1)
    out.update({"moment": mag, "Mx": M[:, 0], "My": M[:, 1], "Mz": M[:, 2]})
    f1, f2 = asymptotics.anchor_frame(direction)
    with np.errstate(invalid="ignore", divide="ignore"):
        tp = np.cross(M / mag[:, None], direction)  # in the bending plane, normal to c
        out["psi0"] = np.where(mag > 0, np.arctan2(tp @ f2, tp @ f1), np.nan)
    out["valid"] = np.isfinite(mag).astype(int)
    # the rod resolves the layer itself: the asymptotic error estimate does not apply
    out["error_estimate"] = np.full(mag.shape, np.nan)
    return out
