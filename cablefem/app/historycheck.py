"""Each clamped anchor's ``history_error_estimate``: the error its moment history gets over
the statistics window from the string's frequency errors (:mod:`cablefem.history_error`,
docs/theory.md §5.3), with a warning above :data:`HISTORY_WARN` naming what makes it (the
excitation's harmonics near a mode, the free vibration's phase drift) and the remedy, and
one where a harmonic of the excitation that matters lies above the computed modes (no
resonance there can be checked)."""

from __future__ import annotations

import numpy as np

from cablefem.app.report import max_excitation, warn
from cablefem.app.statistics import window_start
from cablefem.history_error import excitation, history_error

__all__ = ["HISTORY_WARN", "history_estimates"]

#: the estimated history error above which the run warns
HISTORY_WARN = 0.05


def _record(frag: dict, key: str, entry: dict, est: dict) -> None:
    """Put ``est`` into ``entry`` and warn (into ``frag``) above :data:`HISTORY_WARN`."""
    entry["history_error_estimate"] = est["estimate"]
    entry["history_error"] = {k: v for k, v in est.items() if k != "estimate"}
    if est["estimate"] <= HISTORY_WARN:
        return
    if est["lines_error"] >= est["free_error"]:
        worst = max((x for x in est["lines"] if not x.get("in_rows")),
                    key=lambda x: x["share"] * x["change"])
        why = (f"the anchor force's part at {worst['omega']:.4g} rad/s (a harmonic of the "
               f"excitation, {worst['share']:.0%} of its fluctuation) is near mode "
               f"{worst['mode']}, whose frequency error changes it by {worst['change']:.0%}")
    else:
        why = (f"the anchor force's free vibration ({est['free_share']:.0%} of its "
               "fluctuation: the start's transient, or a random response) drifts in phase "
               "by the modes' frequency errors (a longer run or a later "
               "dynamics.statistics_start lets a transient decay)")
    warn(frag, key, f"the moment history has an estimated error of {est['estimate']:.1%} "
         f"in the statistics window from the string's frequency errors: {why}; more "
         "mesh elements reduce the errors as their length squared (history_error_estimate "
         "and history_error in summary.json)")


def history_estimates(b, frag: dict, res, h, start: float | None) -> None:
    """Each clamped anchor's estimate into its entry of ``frag["anchors"]`` (warnings into
    ``frag``); one warning for the harmonics above the computed modes that matter."""
    spectrum, columns = getattr(res, "spectrum", None), getattr(res, "columns", None)
    times = np.asarray(h.times, float)
    if spectrum is None or columns is None or times.size < 2 or b.case.dynamics is None:
        return
    sel = times >= window_start(times, start)
    lines, random = excitation(b.case)
    top = max_excitation(b.case)  # the rows' estimate holds its primary and parametric lines
    covered = () if top is None else (top, 0.5 * top)
    unchecked: dict[float, list[str]] = {}
    for name in h.moments:
        entry = frag["anchors"].get(name)
        if entry is None:
            continue
        est = history_error(times[sel], np.asarray(h.forces[name])[sel],
                            lambda t, F, n=name: columns.anchor(n, t, F)["moment"],
                            lines, random, spectrum, covered)
        if est is None:
            continue
        _record(frag, f"anchors.{name}", entry, est)
        for nu in est["unchecked"]:
            unchecked.setdefault(round(nu, 6), []).append(name)
    if unchecked:
        where = sorted({k for keys in unchecked.values() for k in keys})
        nus = ", ".join(f"{w:.4g}" for w in sorted(unchecked))
        warn(frag, "modal", f"the anchor forces at {len(where)} clamp(s) (e.g. {where[0]}) "
             f"have harmonics of the excitation at {nus} rad/s, above the highest of the "
             f"{spectrum.omegas.size} computed modes, that would change the moment by more "
             "than 2.5 % with their phase reversed: a resonance there cannot be checked "
             "and is not in history_error_estimate; raise modal.modes until the modes pass "
             "them")
