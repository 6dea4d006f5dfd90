"""The last stages of a run (:func:`cablefem.app.run.run_case`): the anchors' and kinks'
reports from the recorded histories, the figures and the fatigue report. Each returns a
dataclass; :mod:`cablefem.app.summary` turns them into ``summary.json``."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from cablefem.app.historycheck import history_estimates
from cablefem.app.integration import Dynamics, Resonance
from cablefem.app.output import Histories
from cablefem.app.report import (
    anchor_validity,
    section_name,
    statistics_start,
    steady_state_stats,
    warn,
)
from cablefem.app.stages import Built, Statics, Warnings
from cablefem.app.statistics import warn_drifts
from cablefem.errors import RunError
from cablefem.moments import ERROR_THRESHOLD, MAX_ANCHOR_ANGLE
from cablefem.units import unit

__all__ = ["Reports", "Fatigue", "report", "figures", "fatigue", "SLACK",
           "DAMPER_OFFSET_WARN"]

log = logging.getLogger(__name__)

#: an anchor tension below this fraction of the static one counts as slack (snap loads)
SLACK = 0.05

#: a damper's estimated corner error (cablefem.kinks.damper_offset_estimate) above which the
#: run warns: the anchors' aim
DAMPER_OFFSET_WARN = 0.01


@dataclass
class Reports:
    """The anchors' and kinks' reports: summary.json's ``anchors``, ``statistics_start``
    (None: not given or not reached), ``touchdown``, ``kinks`` and ``dampers`` (None:
    none)."""

    anchors: dict
    statistics_start: float | None = None
    touchdown: dict | None = None
    kinks: dict | None = None
    dampers: dict | None = None
    warnings: Warnings = field(default_factory=Warnings)


def report(b: Built, st: Statics, res: Resonance, static_entries: dict, dyn: Dynamics,
           dynamics_run: bool) -> Reports:
    """Report the anchors (static entries, validity, steady state), the alternation of
    their forces, the touchdown and the kinks from the recorded histories."""
    h = dyn.histories
    # what the validity's warnings read of the run so far
    frag = {**res.entries, "outer_correction": st.outer_correction, "anchors": {},
            "warnings": Warnings()}
    if st.span_bending is not None:
        frag["span_bending"] = st.span_bending
    start = statistics_start(frag, b.case, h.times)
    out = Reports(frag["anchors"], frag.get("statistics_start"), warnings=frag["warnings"])
    for i, a in enumerate(b.model.anchors):
        out.anchors[a.name] = _anchor_entry(b, frag, a, st.result.anchor_forces[i],
                                            static_entries[a.name], h, start)
    case = b.case
    if case.dynamics is not None and dynamics_run and h.times.size > 2:  # steps ringing
        from cablefem.app.alternation import check_alternation

        check_alternation(frag, h.times, h.forces, case.dynamics)
    cuts = (dyn.entries or {}).get("step_cuts")
    if cuts:  # the rest of the run went on at the cut step (cablefem.dynamics)
        first, last = cuts[0], cuts[-1]
        out.warnings.add("dynamics.dt", f"Newton failed at t = {first['time']:g} s and the "
                         f"step was cut ({len(cuts)} cut(s), summary.json dynamics."
                         f"step_cuts): the run went on with dt = {last['dt']:g} s from "
                         f"t = {last['time']:g} s, {case.dynamics.dt / last['dt']:g} steps "
                         "per output step of the nominal grid (its outputs stay on it); "
                         "a smaller dynamics.dt from the start costs the same per step and "
                         "keeps the whole run on one step size")
    if h.touchdown is not None:  # the touchdown's history
        out.touchdown = h.touchdown
        off = out.touchdown.get("cable", {}).get("times_off_the_seabed", 0)
        if off and "touchdown" in st.entries:
            out.warnings.add("seabed", f"the line left the seabed altogether at {off} of "
                             f"{len(h.times)} output times (touchdown.csv: grounded length "
                             "0): a bounce on the contact's stiffness, which the time step "
                             "may not resolve (sqrt(stiffness/mass) dt > 1); more "
                             "seabed.damping or a smaller dynamics.dt, or a smoother "
                             "anchor motion (its ramp)")
    if h.kinks.kinks:
        out.kinks = frag["kinks"] = _kinks(b, h, start, out.warnings)
    if h.dampers is not None:  # the dampers' force, stroke and velocity
        out.dampers = h.dampers.summary(start)
    gaps = b.model.kink_gaps
    if gaps:  # network nodes where a cable kinks but has no kink moment
        k, where, why = gaps[0]
        out.warnings.add("kinks", f"{len(gaps)} node(s) where a cable kinks have no kink "
                         f"moment (e.g. node {k}, {where!r}: {why}): give each cable "
                         "through such a node its own group, of one section (docs/kinks.md)")
    history_estimates(b, frag, res, h, start)
    warn_drifts(frag, warn)
    return out


def _anchor_entry(b: Built, frag: dict, a, F0, static_entry: dict, h: Histories,
                  start: float | None) -> dict:
    """Anchor ``a``'s entry of summary.json (warnings into ``frag``)."""
    case, times = b.case, h.times
    entry = {"kind": a.kind, "position": a.position,
             "section": section_name(case, a.section),
             "direction": a.direction if a.direction is not None else None,
             "static_tension": float(np.linalg.norm(F0[:3]))}
    if a.clamp is not None:  # a side of a clamp a cable runs through
        entry["clamp"] = a.clamp
    entry.update(static_entry)  # tension; moment at a clamped anchor
    if a.name not in h.moments or not len(times):
        return entry
    key = f"anchors.{a.name}"
    mo = h.moments[a.name]
    entry["valid_fraction"] = float(np.mean(mo["valid"]))
    with np.errstate(invalid="ignore"):
        backwards = int(np.count_nonzero(mo["delta"] > MAX_ANCHOR_ANGLE))
    if backwards:
        entry["rows_beyond_90deg"] = backwards
        warn(frag, key, f"{backwards} of {len(times)} rows have the anchor force more than "
             "90 degrees from the clamp direction: outside the method, valid = 0 (check "
             "anchors.direction)")
    fb = h.fallback.get(a.name)
    if fb and any(fb):
        entry["outer_fallback_fraction"] = float(np.mean(fb))
        warn(frag, key, f"{sum(fb)} of {len(fb)} rows with the virtual hinge's layer outside "
             "the tension range it follows (a quarter to twice the static tension; there it "
             "keeps the law at the nearer end): the first-order correction is only partial "
             "there")
    slack = np.linalg.norm(h.forces[a.name], axis=1) < SLACK * entry["static_tension"]
    if np.any(slack) and case.dynamics.rho_inf > 0.5:
        # snap loads are non-smooth: generalised-alpha at rho_inf = 0.9 blew up on a
        # slackening cable where 0.5 stayed bounded on every mesh (docs/theory.md §6)
        entry["slack_rows"] = int(np.count_nonzero(slack))
        warn(frag, key, f"{entry['slack_rows']} of {len(times)} rows with the tension below "
             f"{SLACK:g} of the static one: the cable goes slack and snaps taut, which "
             f"generalised-alpha with dynamics.rho_inf = {case.dynamics.rho_inf:g} may not "
             "damp (check with rho_inf = 0.5)")
    why = h.reasons.get(a.name, [])  # this process's rows (not a resumed run's)
    why = ["(not recorded)"] * (len(times) - len(why)) + why
    entry["validity"] = anchor_validity(frag, a.name, times, {**mo, "invalid_reason": why},
                                        ERROR_THRESHOLD, start=start)
    if len(times) > 1:
        entry["steady_state_moment"] = steady_state_stats(times, mo["moment"], start=start)
    return entry


def _kinks(b: Built, h: Histories, start: float | None, warnings: Warnings) -> dict:
    """The kinks' entries of summary.json, with their damper offsets' estimates."""
    kinks = h.kinks.summary(start)
    for name, entry in kinks.items():
        frac = entry.get("valid_fraction", 1.0)
        if frac < 1.0 or not entry["static_valid"]:
            warnings.add(f"kinks.{name}", f"{100 * (1 - frac):.3g} % of the rows are "
                         "invalid (the layer at this kink is slack, not quasi-static, or "
                         "overlaps a neighbouring kink or anchor): see valid in kinks.csv")
    if not b.kind.resolves_layers:  # the rod resolves its layers
        _damper_offsets(b, kinks, h.kinks.kinks, warnings)
        _corners(b, kinks, h.kinks.kinks, warnings)
        _kink_estimates(b, kinks, h.kinks.kinks, warnings)
    return kinks


def _kink_estimates(b: Built, entries: dict, kinks, warnings: Warnings) -> None:
    """Each kink's ``static_error_estimate`` (:func:`cablefem.junctions.kink_estimate`,
    times the layer's share of the static moment), with a warning where it exceeds
    :data:`ERROR_THRESHOLD`."""
    from cablefem.junctions import kink_estimate

    worst = []
    for k in kinks:
        entry = entries.get(k.name)
        if entry is None:
            continue
        est = kink_estimate(b.model, k, entry.get("static_delta", np.nan),
                            entry.get("layer_length", np.nan))
        # the estimate is the layer's: weighted by its share of the reported moment (a
        # kink straight at rest, a damper's, reports the string's own curvature only)
        M, M_layer = entry.get("static_moment", np.nan), entry.get("static_moment_layer", 0.0)
        if M > 0:
            est = est * min(1.0, abs(M_layer) / M)
        if np.isfinite(est):
            entry["static_error_estimate"] = est
            if est > ERROR_THRESHOLD:
                worst.append((est, k.name))
    if worst:
        est, name = max(worst)
        warnings.add(f"kinks.{name}", f"{len(worst)} kink(s) with an estimated static moment "
                     f"error above {100 * ERROR_THRESHOLD:g} % (max {100 * est:.2g} %): the "
                     "layer is long against the spans next to it, or the cables there do "
                     "not meet at the rod's node (static_error_estimate in summary.json; "
                     "docs/theory.md §6.3)")


def _corners(b: Built, entries: dict, kinks, warnings: Warnings) -> None:
    """A network's kinks: the share of the string corner's offset applied
    (``corner_applied`` in each corrected kink's entry: 1, or ``CAP_RATIO`` elements per
    ``ℓ_r`` over their length where they are shorter), a warning where it is partial, and
    one naming the kinks left at the node (next to a virtual hinge's region)."""
    from cablefem.junctions import CAP_RATIO

    model = b.model
    if model.corner_kinks:
        secs = model.case.network.sections
        partial = []
        for k in kinks:
            entry = entries.get(k.name)
            if k.name not in model.corner_kinks or entry is None:
                continue
            T, ell = entry.get("static_tension", np.nan), entry.get("layer_length", np.nan)
            ell_r = ell * (1.0 + T / secs[k.section].EA)  # sqrt(EI/T) sqrt(1 + T/EA)
            applied = min(1.0, min(k.h) / CAP_RATIO / ell_r) if ell_r > 0 else 1.0
            entry["corner_applied"] = float(applied)
            if applied < 1.0:
                partial.append((applied, k.name))
        if partial:
            share, name = min(partial)
            warnings.add(f"kinks.{name}", f"{len(partial)} kink(s) with elements shorter "
                         f"than {CAP_RATIO:g} layer lengths: the cables there meet "
                         f"{100 * (1 - share):.2g} % (the most) short of the rod's node, "
                         "a first-order error of that share of the junction's effect on "
                         "the anchors' angles and the frequencies (corner_applied in "
                         "summary.json; docs/kinks.md): coarser elements there apply it")
    if model.junction_gaps:
        name, why = model.junction_gaps[0]
        warnings.add("kinks", f"{len(model.junction_gaps)} kink(s) where the cables meet at "
                     f"the string's corner, not at the rod's node (e.g. {name}: {why}): "
                     "a first-order error there (docs/kinks.md)")


def _damper_offsets(b: Built, entries: dict, kinks, warnings: Warnings) -> None:
    """A damper acts at the string's corner where the model does not apply the rod node's
    offset (a network's, the leading order's) or applies part of it (elements shorter
    than 2.5 layer lengths next to the damper, cablefem.dampers.MESH_RATIO): record each
    damper kink's estimate of the error that makes (``damper_offset_estimate`` in its
    summary entry) and warn where it exceeds :data:`DAMPER_OFFSET_WARN`."""
    from cablefem.dampers import MESH_RATIO, applied_offset
    from cablefem.junctions import CAP_RATIO
    from cablefem.kinks import damper_offset_estimate

    model = b.model
    applies = model.applies_damper_offsets()
    worst = []
    for k in kinks:
        entry = entries.get(k.name, {})
        ell = entry.get("layer_length", float("nan"))
        corrected = (applied_offset(ell, min(k.h)) if applies else
                     # a network's corrected kink: its node is the rod's (cablefem.junctions)
                     min(ell, min(k.h) / CAP_RATIO) if k.name in model.corner_kinks else 0.0)
        est = damper_offset_estimate(k, ell, corrected)
        if est is None:
            continue
        entry["damper_offset_estimate"] = est
        if est > DAMPER_OFFSET_WARN:
            worst.append((est, k.name, MESH_RATIO * ell))
    if not worst:
        return
    est, name, needed = max(worst)
    why = (b.kind.damper_note or ("at leading order the dampers act at the string's node"
                                  if not applies else "the elements next to the damper are "
                                  f"shorter than {MESH_RATIO:g} layer lengths, which limits "
                                  f"the offset: elements of at least {needed:.3g} "
                                  f"{unit(model.case.units, 'length')} there apply it in "
                                  "full"))
    warnings.add(f"kinks.{name}", f"{len(worst)} damper(s) are not held at the rod's node, "
                 f"l/2 inside the string's kink ({why}): their damping ratios, forces and "
                 f"kink moments may be off by about {100 * est:.2g} % (the largest; "
                 "damper_offset_estimate in summary.json; docs/dampers.md)")


def figures(b: Built, h: Histories, outdir, comm) -> list[str] | None:
    """The run's figures (None: no history to draw): the anchors' moments (clamped
    anchors) and the histories every kind of case has (:mod:`cablefem.app.historyplots`:
    tensions, touchdown, kinks, dampers)."""
    if len(h.times) < 2:
        return None
    from cablefem.app.historyplots import history_figures
    from cablefem.app.plots import MAX_PANELS, anchor_figures

    out = []
    if h.moments:
        out = anchor_figures(outdir, h.times, h.moments, comm, source=b.kind.moment_source,
                             units=b.case.units)
        if len(h.moments) > MAX_PANELS:
            log.info("figures: the %d most loaded of %d clamped anchors (all are in "
                     "anchors.csv)", MAX_PANELS, len(h.moments))
    out += history_figures(outdir, h, b.case.units, comm)
    return out or None


@dataclass
class Fatigue:
    """The fatigue report: summary.json's ``fatigue`` (None: not asked for or not made)
    and the error that failed the run."""

    entries: dict | None = None
    error: RunError | None = None
    warnings: Warnings = field(default_factory=Warnings)


def fatigue(b: Built, h: Histories, reports: Reports, outdir, comm) -> Fatigue:
    """The case's fatigue report from the histories at clamped anchors and kinks."""
    out = Fatigue()
    case = b.case
    histories = h.moments or h.kinks.kinks  # at clamped anchors or kinks
    if case.fatigue is None:
        return out
    if not (len(h.times) > 1 and histories):
        out.warnings.add("fatigue", "no fatigue report: it needs a time history at a "
                         "clamped anchor or a kink (" + (
                             "neither" if not histories else "no dynamics run") + ")")
        return out
    from cablefem.app.fatigue import run_fatigue

    try:  # samples without a moment (slack anchor) are left out and counted
        # the anchors' sections from the reports: summary.json is not written yet
        reps = run_fatigue(case, outdir, invalid="drop", comm=comm,
                           sections={n: e.get("section")
                                     for n, e in reports.anchors.items()
                                     if e["kind"] == "clamped"})
        out.entries = {n: {k: r.get(k) for k in (
            "damage", "damage_per_year", "time_to_failure", "equivalent_range_N_C",
            "max_range", "dropped_invalid_samples")} for n, r in reps.items()}
    except ValueError as err:  # a step the case asks for failed: so did the run
        out.error = RunError(f"fatigue: {err}")
        log.error("%s", out.error)
        out.entries = {"error": str(err)}
    return out
