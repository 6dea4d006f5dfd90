"""What a run reports besides its files: warnings, steady-state statistics, the static sag,
numbers formatted for the log."""

from __future__ import annotations

import logging

import numpy as np

from cablefem.case import Case

log = logging.getLogger(__name__)


def warn(summary: dict, key: str | None, message: str) -> None:
    """Record a warning: logged once (rank 0) and listed under ``summary["warnings"]`` as
    ``{"key": ..., "message": ...}`` (``key``: the case key or run step it concerns)."""
    summary.setdefault("warnings", []).append({"key": key, "message": message})
    log.warning("%s%s", f"{key}: " if key else "", message)


def steady_state_stats(times: np.ndarray, values: np.ndarray, fraction: float = 1 / 3) -> dict:
    """Peak and RMS of ``values`` over the last ``fraction`` of the run (NaNs skipped)."""
    if times.size < 2:
        return {"peak": float(np.nanmax(values)) if values.size else None,
                "rms": None, "window": None}
    t0 = times[-1] - fraction * (times[-1] - times[0])
    sel = times >= t0
    v = values[sel]
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"peak": None, "rms": None, "window": [float(t0), float(times[-1])]}
    return {"peak": float(np.max(np.abs(v))), "rms": float(np.sqrt(np.mean(v * v))),
            "mean": float(np.mean(v)), "window": [float(t0), float(times[-1])]}


def static_sag_ratio(r: np.ndarray, p: np.ndarray, q: np.ndarray, gdir: np.ndarray) -> float:
    """Mid-span sag / chord from nodal positions: the distance along gravity from the chord
    down to the cable where the cable's horizontal projection is at mid-chord."""
    up = -gdir
    d = q - p
    h = d - (d @ up) * up
    span = np.linalg.norm(h)
    if span < 1e-12 * np.linalg.norm(d):
        return float("nan")
    eh = h / span
    x = (r - p) @ eh
    z = (r - p) @ up
    zc = np.interp(0.5 * span, x, z) if np.all(np.diff(x) > 0) else np.nan
    return float((0.5 * (d @ up) - zc) / np.linalg.norm(d))


def _section_name(case: Case, section) -> str | None:
    if case.network is None:
        return None
    return next((n for n, s in case.network.sections.items() if s is section), None)


def _max_excitation(case: Case) -> float | None:
    """Highest circular frequency of the anchor motions and loads (quasi-static check)."""
    om = []
    for a in case.anchors:
        if a.motion is not None:
            d = a.motion.describe()
            w = d.get("omega")
            if w is not None:
                om.append(float(np.max(np.atleast_1d(w))))
    for ld in list(case.loads) + list(case.point_loads):
        d = ld.time.describe() if hasattr(ld.time, "describe") else {}
        if d.get("omega") is not None:
            om.append(float(d["omega"]))
    return max(om) if om else None


def _g(x) -> str:
    return "n/a" if x is None else f"{x:.4g}"
