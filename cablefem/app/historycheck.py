"""Each clamped anchor's and kink's ``history_error_estimate``: the error its moment history
gets over the statistics window from the string's frequency errors (:mod:`cablefem.history_error`,
docs/theory.md §5.4; a kink's from its tension and angle, whose layer gives its moment),
with a warning above :data:`HISTORY_WARN` naming what makes it (the
excitation's harmonics near a mode, the free vibration's phase drift) and the remedy, and
one where a harmonic of the excitation that matters lies above the computed modes (no
resonance there can be checked)."""

from __future__ import annotations

import numpy as np

from cablefem.app.report import max_excitation, warn
from cablefem.app.statistics import window_start
from cablefem.asymptotics import layer
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
    """Each clamped anchor's and kink's estimate into its entry of ``frag["anchors"]`` and
    ``frag["kinks"]`` (warnings into ``frag``); one warning for the harmonics above the
    computed modes that matter."""
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
    kink_times = np.asarray(h.kinks.times, float)
    for k, est in _kink_estimates(b, h, kink_times, start, lines, random, spectrum,
                                  covered):
        entry = (frag.get("kinks") or {}).get(k)
        if entry is not None and est is not None:
            _record(frag, f"kinks.{k}", entry, est)
            for nu in est["unchecked"]:
                unchecked.setdefault(round(nu, 6), []).append(k)
    if unchecked:
        where = sorted({k for keys in unchecked.values() for k in keys})
        nus = ", ".join(f"{w:.4g}" for w in sorted(unchecked))
        warn(frag, "modal", f"the anchor forces at {len(where)} clamp(s) (e.g. {where[0]}) "
             f"have harmonics of the excitation at {nus} rad/s, above the highest of the "
             f"{spectrum.omegas.size} computed modes, that would change the moment by more "
             "than 2.5 % with their phase reversed: a resonance there cannot be checked "
             "and is not in history_error_estimate; raise modal.modes until the modes pass "
             "them")


def _kink_moment(EI: float, EA: float, scale: float = 1.0):
    """A kink's moment from its response ``(T cos(δ/2), T sin(δ/2), 0)``: ``scale`` times the
    layer's at the tension ``T`` and half the turn ``δ`` (``kinks.csv``'s ``tension`` and
    ``delta``: each side's layer turns by half of it)."""
    c = np.array([1.0, 0.0, 0.0])

    def moment(t, N):
        return scale * layer(np.asarray(N, float), c, EI, EA).moment
    return moment


def _kink_estimates(b, h, times, start, lines, random, spectrum, covered):
    """``(name, estimate or None)`` of every kink whose moment follows the layer of its
    tension and half its turn to a constant factor within 5 % (the factor: the corners'
    corrections; the rest, ~1 % on the saddle net, the string's own curvature the kink's
    moment adds; a kink whose moment does not follow, a damper's offset kink, is left
    without an estimate). The factor cancels in the estimate, a relative change."""
    if times.size < 2 or not h.kinks.kinks:
        return []
    sel = times >= window_start(times, start)
    case, out = b.case, []
    for k in h.kinks.kinks:
        rows = h.kinks.rows.get(k.name, {})
        if not all(c in rows for c in ("tension", "delta", "moment")):
            continue
        sec = case.network.sections.get(k.section) if case.network is not None and \
            k.section is not None else getattr(case, "section", None)
        if sec is None:
            continue
        T, d = np.asarray(rows["tension"], float), np.asarray(rows["delta"], float)
        N = np.column_stack([T * np.cos(d / 2), T * np.sin(d / 2), np.zeros_like(T)])
        M = np.asarray(rows["moment"], float)
        ok = np.isfinite(M) & np.all(np.isfinite(N), axis=1) & (M > 0)
        if not ok.any():
            continue
        base = _kink_moment(sec.EI, sec.EA)(None, N[ok])
        scale = float(np.median(M[ok] / base))
        if not np.allclose(scale * base, M[ok], rtol=5e-2, atol=0.0):
            continue
        moment_of = _kink_moment(sec.EI, sec.EA, scale)
        out.append((k.name, history_error(times[sel], N[sel], moment_of, lines, random,
                                          spectrum, covered)))
    return out
