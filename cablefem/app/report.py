"""What a run reports besides its files: warnings, steady-state statistics, the static sag,
numbers formatted for the log."""

from __future__ import annotations

import logging

import numpy as np

from cablefem.app.statistics import FRACTION, steady_state_stats, window_start
from cablefem.case import Case

__all__ = ["warn", "steady_state_stats", "static_sag_ratio", "anchor_validity",
           "modal_damping_ratios", "statistics_start", "section_name", "max_excitation",
           "damping_ratio"]

log = logging.getLogger(__name__)


def warn(summary: dict, key: str | None, message: str) -> None:
    """Record a warning: logged once (rank 0) and listed under ``summary["warnings"]`` as
    ``{"key": ..., "message": ...}`` (``key``: the case key or run step it concerns)."""
    summary.setdefault("warnings", []).append({"key": key, "message": message})
    log.warning("%s%s", f"{key}: " if key else "", message)


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


def section_name(case: Case, section) -> str | None:
    if case.network is None:
        return None
    return next((n for n, s in case.network.sections.items() if s is section), None)


def max_excitation(case: Case) -> float | None:
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


def damping_ratio(case: Case):
    """The modal damping ratio at omega (rad/s) of the case's damping (0 without)."""
    d = case.damping
    if d is None or getattr(d, "model", "none") == "none":
        return lambda w: 0.0
    return d.ratio_at


def modal_damping_ratios(case: Case, modal) -> np.ndarray:
    """Each mode's damping ratio for the resonance factor: the damped system's own
    (``modal.damping_ratios``, from its complex modes: the ``[damping]`` table, dampers and
    a fluid's linearised drag together), the ``[damping]`` table's ratio at the mode's
    frequency where a mode has no complex partner (NaN) or none was computed."""
    table = damping_ratio(case)
    own = getattr(modal, "damping_ratios", None)
    out = np.array([table(w) for w in np.asarray(modal.omegas, float)], float)
    if own is not None:
        own = np.asarray(own, float)
        out = np.where(np.isfinite(own), own, out)
    return out


def statistics_start(summary: dict, case: Case, times: np.ndarray) -> float | None:
    """The case's ``dynamics.statistics_start`` when the run reached it; None (the last
    third) otherwise, with a warning when it was given (a run cut short by ``--t-end``)."""
    start = getattr(case.dynamics, "statistics_start", None)
    times = np.asarray(times, float)
    if start is None or times.size < 2:
        return None
    if start >= times[-1]:
        warn(summary, "dynamics.statistics_start", f"{start:g} is not before the run's end "
             f"({times[-1]:g}): the statistics are over the last third of the run instead")
        return None
    summary["statistics_start"] = float(start)
    return float(start)


def anchor_validity(summary: dict, name: str, times: np.ndarray, mo: dict,
                    threshold: float, fraction: float = FRACTION,
                    start: float | None = None) -> dict:
    """The validity of clamped anchor ``name``'s moment rows ``mo`` (columns ``valid``,
    ``error_estimate``, optionally ``invalid_reason``) over the output window (the last
    ``fraction`` of the run or from ``start``, as :func:`steady_state_stats`; every row for
    fewer than two
    times): the fraction of invalid rows and of rows whose error estimate is above
    ``threshold``, the maximum and median estimate. Warns (:func:`warn`) naming the anchor,
    the fraction and the reason when any row of the window is invalid or above the
    threshold; loudly when every row of the window is invalid (docs/theory.md §5)."""
    times = np.asarray(times, float)
    sel = np.ones(times.size, bool)
    if times.size > 1:
        sel = times >= window_start(times, start, fraction)
    valid = np.asarray(mo["valid"], float)[sel] > 0
    n = int(valid.size)
    err = np.asarray(mo.get("error_estimate", np.full(times.size, np.nan)), float)[sel]
    known = np.isfinite(err)
    with np.errstate(invalid="ignore"):
        above = known & (err > threshold)
    out = {"window": [float(times[sel][0]), float(times[sel][-1])] if n else None,
           "threshold": threshold,
           "invalid_fraction": float(np.mean(~valid)) if n else None,
           "above_threshold_fraction": float(np.mean(above)) if n else None,
           "max": float(np.max(err[known])) if known.any() else None,
           "median": float(np.median(err[known])) if known.any() else None}
    if not n:
        return out
    key = f"anchors.{name}"
    bad = ~valid
    if bad.any():
        reasons = np.asarray(mo.get("invalid_reason", np.full(times.size, "")), str)[sel]
        why = ", ".join(f"{r or 'outside the method'}: {c}" for r, c in
                        zip(*np.unique(reasons[bad], return_counts=True)))
        head = ("EVERY row of the output window is invalid, no moment at this anchor can be "
                "trusted" if bad.all() else f"{bad.sum()} of {n} rows of the output window "
                f"({out['invalid_fraction']:.0%}) are invalid")
        warn(summary, key, f"{head} ({why}) (valid = 0 in anchors.csv)")
    if above.any():
        warn(summary, key, f"{above.sum()} of {n} rows of the output window "
             f"({out['above_threshold_fraction']:.0%}) have an estimated moment error above "
             f"{threshold:.0%} (max {out['max']:.1%}): the terms this order of the outer "
             "solution neglects (ell/l at this anchor angle, amplified near a resonance by "
             f"the factor {summary.get('error_resonance_factor', 1.0):.3g}) are too large"
             + (" (solver.outer_correction = 'hinge' reduces them)"
                if summary.get("outer_correction") == "none" else "")
             + _resonance_hint(summary) + "; see error_estimate in anchors.csv")
    return out


def _resonance_hint(summary: dict) -> str:
    """The remedy for the resonant mode's frequency error, which the estimate amplifies
    with its sign (docs/theory.md §5.2): the string's mesh puts the mode high by
    ``error_resonance_mesh`` (added at a primary resonance), the span's bending it leaves
    out low by ``error_resonance_shift``. Putting the bending in removes the second only:
    named when that is the larger; more elements when the mesh's is."""
    if not summary.get("error_resonance_factor", 1.0) > 1.0:
        return ""
    mesh = summary.get("error_resonance_mesh") or 0.0
    if summary.get("error_resonance_kind") != "primary":
        mesh = 0.0
    shift = summary.get("error_resonance_shift")
    if summary.get("span_bending") is False and (shift is None or abs(shift) >= abs(mesh)):
        return (" (near a resonance the span's bending, which the string leaves out, moves "
                "the resonant frequency: solver.span_bending = true puts it in)")
    if mesh > 0:
        return (f" (near a resonance the string's mesh puts the resonant mode {mesh:.2%} "
                "high" + (f", more than the span's bending it leaves out puts it low "
                          f"({shift:.2%})" if shift is not None else "")
                + ": more mesh.elements reduce it as their length squared)")
    return ""
