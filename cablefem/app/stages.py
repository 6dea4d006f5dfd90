"""The first stages of a run (:func:`cablefem.app.run.run_case`): build the model, solve
the statics, compute the modes. Each returns a dataclass of what it found, warnings
included (``{"key", "message"}`` records, logged when found); :mod:`cablefem.app.summary`
turns them into ``summary.json``."""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from mpi4py import MPI

from cablefem.app.kinds import ModelKind, kind_of
from cablefem.app.modecheck import mode_validity
from cablefem.app.report import static_sag_ratio, warn
from cablefem.app.resources import note_small_problem
from cablefem.case import Case
from cablefem.chain import NOTE as CHAIN_NOTE
from cablefem.create import model_from_case
from cablefem.dampers import axial_dampers
from cablefem.modal import free_dofs, solve_modes
from cablefem.moments import ERROR_THRESHOLD
from cablefem.span_bending import AUTO_THRESHOLD, frequency_shifts, is_on
from cablefem.statics import solve_static
from cablefem.units import unit

__all__ = ["Built", "Statics", "Modes", "build", "statics", "modes"]

log = logging.getLogger(__name__)


class Warnings(list):
    """A stage's warnings: :func:`cablefem.app.report.warn` records (logged when added)."""

    def add(self, key: str | None, message: str) -> None:
        frag = {"warnings": self}
        warn(frag, key, message)


@dataclass
class Probe:
    """The string without the span's bending, solved for the ``"auto"`` decision: reused
    by the run when the decision is off."""

    model: object
    static: object
    modal: object
    shifts: np.ndarray


@dataclass
class Built:
    """The model of a case and what is known before any solve."""

    case: Case  #: the case as run ("auto" span bending resolved)
    model: object
    asked: str  #: the model asked for: "string" or "beam"
    refine: float
    kind: ModelKind  #: the model's kind (cablefem.app.kinds)
    wall_time: float
    groups: dict  #: the dimensionless groups
    n_modes: int | None  #: the modes asked for
    probe: Probe | None = None
    auto: dict | None = None  #: the "auto" span-bending record
    #: where the statics' Newton starts ("auto" span bending on: the probe's equilibrium,
    #: before its virtual hinges; nodal (n, bs) on every rank; None: the model's guess)
    start: np.ndarray | None = None
    bending: dict | None = None  #: EI = 0: the string alone (cablefem.chain)
    beam: dict | None = None  #: the rod's mesh and section
    notes: list = field(default_factory=list)
    warnings: Warnings = field(default_factory=Warnings)
    launched: int | None = None  #: the ranks launched, when the run uses fewer

    @property
    def elements(self) -> int:
        return len(self.model.geometry.stations) - 1

    @property
    def dofs(self) -> int:
        """The degrees of freedom."""
        return self.model.bs * len(self.model.geometry.stations)


@dataclass
class Statics:
    """The static state's report."""

    result: object  #: cablefem.statics' result (anchor forces, counters, wall time)
    entries: dict  #: summary.json's ``static``
    outer_correction: str
    span_bending: bool | None  #: None for the rod (not reported)
    warnings: Warnings = field(default_factory=Warnings)


@dataclass
class Modes:
    """The modes' report (``result`` None: no mode computed)."""

    result: object | None
    entries: list | None  #: summary.json's ``modes``
    shifts: np.ndarray | None  #: each mode's span-bending shift (string without it)
    wall_time: float | None
    warnings: Warnings = field(default_factory=Warnings)


def _g(x) -> str:
    return "n/a" if x is None else f"{x:.4g}"


def _auto_span_bending(comm: MPI.Comm, case: Case, n_modes: int | None):
    """Resolve ``solver.span_bending = "auto"`` (cablefem.span_bending): the case with it
    on or off, the probe to reuse when off (None when on, or when no mode is asked for),
    the record for ``summary.json`` and, when on, the probe's equilibrium (nodal, every
    rank; before its virtual hinges): the statics with the span's bending start there (a
    few Newton iterations instead of the whole way from the catenary)."""
    def with_bending(on: bool) -> Case:
        return replace(case, solver=replace(case.solver, span_bending=on))

    off = with_bending(False)
    if not n_modes:
        return off, None, {"decision": "off", "reason": "no mode computed"}, None
    log.info("span bending \"auto\": the string without it first (statics and modes)")
    model = model_from_case(comm, off)
    static = solve_static(model)
    n = min(n_modes, free_dofs(model))
    if not n:
        return off, None, {"decision": "off", "reason": "no free degree of freedom"}, None
    modal = solve_modes(model, n)
    shifts = frequency_shifts(model, modal)
    worst = int(np.nanargmax(np.abs(shifts))) if np.isfinite(shifts).any() else 0
    size = float(abs(shifts[worst])) if np.isfinite(shifts[worst]) else 0.0
    record = {"largest_shift": size, "mode": worst + 1, "threshold": AUTO_THRESHOLD}
    if size > AUTO_THRESHOLD:
        log.info("span bending: on (it would move mode %d by %.3g %%, above %.3g %%): "
                 "solving again with it", worst + 1, 100 * size, 100 * AUTO_THRESHOLD)
        start = static.before_hinges  # the virtual hinges' fixed point its usual way
        if start is None:
            start = comm.bcast(model.gather_all(model.u_static), root=0)
        return with_bending(True), None, {"decision": "on", **record}, start
    log.info("span bending: off (it would move mode %d by %.3g %%, at most %.3g %%)",
             worst + 1, 100 * size, 100 * AUTO_THRESHOLD)
    return off, Probe(model, static, modal, shifts), {"decision": "off", **record}, None


def build(comm: MPI.Comm, case: Case, asked: str, refine: float, n_modes: int | None,
          wall0: float, before_report=None) -> Built:
    """Build the model of ``case`` (``asked``: "string" or "beam"); "auto" span bending
    solves the string without it first (:func:`_auto_span_bending`). ``before_report()``
    runs once the model is built, before anything is reported (the output folder's
    cleaning)."""
    probe, auto, start = None, None, None
    if asked == "string" and case.solver.span_bending == "auto":
        case, probe, auto, start = _auto_span_bending(comm, case, n_modes)
    model = probe.model if probe else model_from_case(comm, case, model=asked, refine=refine)
    wall = time.perf_counter() - wall0
    if before_report is not None:
        before_report()
    groups = model.dimensionless_groups()
    log.info("%s: l = %.6g %s, %d elements, eps = %s, eps_b = %s", case.title, model.length,
             unit(case.units, "length"),
             len(model.geometry.stations) - 1, _g(groups.get("eps")),
             _g(groups.get("eps_b")))
    out = Built(case, model, asked, refine, kind_of(model), wall, groups, n_modes, probe,
                auto, start=start)
    if model.string_alone:  # section.EI = 0 (cablefem.chain)
        out.bending = {"EI": 0.0, "moments": False, "note": CHAIN_NOTE}
        log.info("%s", CHAIN_NOTE)
    for key, message in list(case.warnings) + list(model.warnings):
        out.warnings.add(key, message)
    if out.kind.resolves_layers:  # the rod: its mesh and section
        out.beam = {"refine": refine, **model.mesh_record(), **model.section_values}
    note = note_small_problem(out.dofs, comm)
    if note:
        out.notes = [note]
    return out


def statics(b: Built) -> Statics:
    """Solve the statics (the probe's, with "auto" span bending off) and report them."""
    model, case = b.model, b.case
    if b.elements >= model.LOG_PHASES_FROM:
        log.info("statics: %d degrees of freedom", b.dofs)
    static = b.probe.static if b.probe else solve_static(model, start=b.start)
    r = model.gather_nodal(model.u)
    sag = None
    if model.comm.rank == 0 and case.gravity.g > 0 and case.network is None:
        a0, a1 = model.anchors
        sag = static_sag_ratio(model.geometry.points + r, a0.position, a1.position,
                               np.asarray(case.gravity.direction, float))
    sag = model.comm.bcast(sag, root=0)
    entries = {
        "anchor_forces": {a.name: f[:3] for a, f in zip(model.anchors,
                                                         static.anchor_forces)},
        "newton_iterations": static.newton_iterations,
        "continuation_steps": static.continuation_steps,
        "slack_elements": static.slack_elements, "max_tension": static.max_tension,
        "min_tension": static.min_tension, "sag_ratio": sag}
    rod = b.kind.resolves_layers
    out = Statics(static, entries, "none" if rod else model.case.solver.outer_correction,
                  None if rod else is_on(case.solver.span_bending))
    for key, message in axial_dampers(model):
        out.warnings.add(key, message)
    if rod and static.slack_elements:
        # statics tried the relaxation from the guess and found nothing better
        out.warnings.add("statics", f"the rod's static state has {static.slack_elements} "
                         f"compressed element(s) (least tension {static.min_tension:.4g}): "
                         "a buckled equilibrium, not a reference for a cable; try another "
                         "--refine")
    if model.hinges:
        entries["virtual_hinges"] = model.hinges.report()
    if getattr(case, "seabed", None) is not None:
        _seabed(b, static, out)
    return out


def _seabed(b: Built, static, out: Statics) -> None:
    """The static contact with the seabed: per cable group (a network) or the single
    line's touchdown."""
    if b.kind.seabed_per_group:
        from cablefem.seabed import network_contact  # per cable group

        contact = network_contact(b.model)
        if contact is None:
            out.warnings.add("seabed", "no cable touches the seabed in the static state")
        else:
            out.entries["seabed_contact"] = contact
            for group, c in contact.items():
                log.info("seabed: cable %s grounded over %.6g m, %d touchdown point(s)",
                         group, c["grounded_length"], len(c["touchdown"]))
        return
    from cablefem.seabed import touchdown  # where the line leaves the seabed

    td = touchdown(b.model, static.anchor_forces)
    if td is None:
        out.warnings.add("seabed", "the cable does not touch the seabed in the static state")
    else:
        out.entries["touchdown"] = td
        from cablefem.app.console import log_touchdown

        log_touchdown(td)


def modes(b: Built, st: Statics, outdir) -> Modes:
    """Compute the modes asked for (at most the free degrees of freedom; the probe's with
    "auto" span bending off), write ``modes.xdmf`` and report them."""
    from cablefem.io.series import write_modes

    model, case = b.model, b.case
    out = Modes(None, None, None, None)
    n_modes = b.n_modes
    free = free_dofs(model)
    if n_modes and n_modes > free:
        out.warnings.add("modal.modes", f"{n_modes} modes asked for, but the model has "
                         f"{free} free degrees of freedom: " + (
                             f"computing {free}" if free else "no modes computed"))
        n_modes = free
    if not n_modes:
        return out
    modal = b.probe.modal if b.probe else solve_modes(model, n_modes)
    write_modes(model, modal, Path(outdir) / "modes.xdmf")
    entries = [{"omega": w, "frequency_hz": w / (2 * np.pi), **lab}
               for w, lab in zip(modal.omegas, modal.labels)]
    if not b.kind.resolves_layers and not is_on(case.solver.span_bending):
        # what the span's bending, left out, would do to each (span_bending.py)
        out.shifts = b.probe.shifts if b.probe else frequency_shifts(model, modal)
        for entry, x in zip(entries, out.shifts):
            if np.isfinite(x):
                entry["span_bending_shift"] = float(x)
    lam = modal.damped_omegas  # |lambda| of the damped system's modes (None: undamped)
    for k, (entry, z) in enumerate(zip(entries, modal.damping_ratios)):
        if np.isfinite(z):  # from the damped system's complex modes (modal.py)
            entry["damping_ratio"] = float(z)
            if lam is not None and np.isfinite(lam[k]):
                entry["lambda_abs"] = float(lam[k])
        else:  # no complex mode like it: absent, and said why
            entry["damping_ratio_missing"] = "no complex mode of the damped system " \
                "matches this mode (overdamped?)"
    if not b.kind.resolves_layers:  # each mode's estimated error and range
        frag = {"modes": entries, "warnings": out.warnings}
        mode_validity(frag, model, st.result, modal, warn, ERROR_THRESHOLD,
                      1 if model.hinges else 0)
    out.result, out.entries, out.wall_time = modal, entries, modal.wall_time
    # the static state again: the modal solve does not change model.u, but be explicit
    model.u.x.array[:] = model.u_static.x.array
    return out
