"""The steady-state statistics of a history (peak, RMS, mean over the output window), the
whole run's extreme beside them, and the test that the window holds a steady response
(docs/outputs.md, "Steady-state statistics").

The window is the last third of the run, or from ``dynamics.statistics_start`` to the end.
A response still building up (a lightly damped resonance: its time constant is
``1/(zeta omega)``) or decaying in the window gives statistics that are not those of the
steady state, silently low or high: the window's two halves then have different
fluctuations about the window's mean. :func:`drift` measures that change, relative to the
window's RMS (what the reported numbers are), and :func:`warn_drifts` warns above
:data:`DRIFT_LIMIT`.
"""

from __future__ import annotations

import numpy as np

#: Fraction of the run, at its end, that is the output window by default.
FRACTION = 1 / 3
#: Largest change of the fluctuation's RMS between the window's halves, relative to the
#: larger, of a steady response. A steady sinusoid whose half-window holds n periods has
#: half-window RMS within 1/(4 pi n) of its own (the part period left over): at three
#: periods per half 2.7 %, the halves 5.3 % apart at most. A response building up as
#: 1 - exp(-t/tau), seen over the last third of a run of length tau, differs by 12 %
#: (midpoints 0.75 tau and 0.92 tau: 1 - 0.528/0.600): the statistics are 40 % low there.
DRIFT_LIMIT = 0.1
#: Smallest fluctuation (its RMS over the window's RMS) whose drift is judged: a smaller
#: one moves the statistics by less than that much even if it doubles.
MIN_FLUCTUATION = 0.01


def window_start(times: np.ndarray, start: float | None = None,
                 fraction: float = FRACTION) -> float:
    """The output window's first time: ``start`` when given and inside the run (before its
    last time), else the last ``fraction`` of the run."""
    t = np.asarray(times, float)
    if start is not None and t.size and t[0] <= start < t[-1]:
        return float(start)
    if start is not None and t.size and start < t[0]:
        return float(t[0])
    return float(t[-1] - fraction * (t[-1] - t[0]))


def drift(times: np.ndarray, values: np.ndarray) -> tuple[float, float] | None:
    """The change of the fluctuation (about the window's mean, NaNs skipped) between the
    window's halves: ``(r2 - r1) / max(r1, r2)``, ``r1, r2`` its RMS in each half (positive
    for a response still building up, negative for one decaying), and the size of the
    fluctuation, its RMS over the window relative to the window's RMS. None with fewer than
    two finite samples in a half or a window without fluctuation."""
    t, v = np.asarray(times, float), np.asarray(values, float)
    ok = np.isfinite(v)
    t, v = t[ok], v[ok]
    if v.size < 4:
        return None
    rms = float(np.sqrt(np.mean(v * v)))
    dev = v - np.mean(v)
    mid = 0.5 * (t[0] + t[-1])
    first, second = dev[t < mid], dev[t >= mid]
    if first.size < 2 or second.size < 2:
        return None
    r1, r2 = np.sqrt(np.mean(first**2)), np.sqrt(np.mean(second**2))
    if not max(r1, r2) > 0:
        return None
    return float((r2 - r1) / max(r1, r2)), float(np.sqrt(np.mean(dev**2)) / rms)


def steady_state_stats(times: np.ndarray, values: np.ndarray, fraction: float = FRACTION,
                       start: float | None = None) -> dict:
    """Peak (of ``|values|``), RMS and mean of ``values`` over the output window (the last
    ``fraction`` of the run, or from ``start``; NaNs skipped) with the window ``[t0, t1]``,
    its :func:`drift`, and the whole run's peak and its time (``run_peak``,
    ``run_peak_time``): under stochastic loading the largest value may fall before the
    window."""
    times, values = np.asarray(times, float), np.asarray(values, float)
    if times.size < 2:
        return {"peak": float(np.nanmax(values)) if values.size else None,
                "rms": None, "window": None}
    t0 = window_start(times, start, fraction)
    sel = times >= t0
    out: dict = {"window": [t0, float(times[-1])]}
    finite = np.isfinite(values)
    if finite.any():
        k = int(np.nanargmax(np.where(finite, np.abs(values), -np.inf)))
        out["run_peak"], out["run_peak_time"] = float(abs(values[k])), float(times[k])
    v = values[sel]
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"peak": None, "rms": None, **out}
    out = {"peak": float(np.max(np.abs(v))), "rms": float(np.sqrt(np.mean(v * v))),
           "mean": float(np.mean(v)), **out}
    d = drift(times[sel], values[sel])
    if d is not None:
        out["drift"], out["fluctuation"] = d
    return out


def warn_drifts(summary: dict, warn) -> list[str]:
    """Warn (``warn(summary, key, message)``) for every clamped anchor and kink whose
    steady-state moment drifts by more than :data:`DRIFT_LIMIT` in its window, naming it
    and the remedy; returns the keys warned."""
    keys = []
    for group, prefix in (("anchors", "anchors"), ("kinks", "kinks")):
        for name, entry in (summary.get(group) or {}).items():
            st = entry.get("steady_state_moment") or {}
            d = st.get("drift")
            if d is None or abs(d) <= DRIFT_LIMIT or st["fluctuation"] < MIN_FLUCTUATION:
                continue
            t0, t1 = st["window"]
            how = "still building up" if d > 0 else "still decaying"
            keys.append(f"{prefix}.{name}")
            warn(summary, keys[-1], f"the moment is {how} in the statistics window "
                 f"[{t0:.6g}, {t1:.6g}]: the RMS of its fluctuation about the mean changes by "
                 f"{d:+.0%} between the window's halves (steady: within {DRIFT_LIMIT:.0%}; "
                 "a random response: its window may also be too short), so the steady-"
                 f"state peak {st['peak']:.4g} and RMS {st['rms']:.4g} are not those of "
                 "the steady state; run longer (dynamics.t_end: several time constants "
                 "1/(zeta omega) of the responding mode) or start the window later "
                 "(dynamics.statistics_start)")
    return keys
