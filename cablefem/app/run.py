"""The data path of one run: case -> model -> statics -> modes -> dynamics -> anchor forces
-> asymptotics -> output. Used by the command line and importable by scripts and tests.
"""

from __future__ import annotations

import copy
import logging
import math
import signal
import threading
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from mpi4py import MPI

from cablefem import __version__
from cablefem.app.log import Progress, quiet_compiler
from cablefem.app.modecheck import mode_validity
from cablefem.app.output import RunOutput, rod_moment_columns
from cablefem.app.report import (
    _g,
    _max_excitation,
    _section_name,
    anchor_validity,
    modal_damping_ratios,
    static_sag_ratio,
    statistics_start,
    steady_state_stats,
    warn,
)
from cablefem.app.resources import note_small_problem
from cablefem.app.statistics import warn_drifts
from cablefem.cable import CableModel
from cablefem.case import Case, CaseError, check_table_ends
from cablefem.chain import NOTE as CHAIN_NOTE
from cablefem.dampers import axial_dampers
from cablefem.discretisation import model_frequency_error
from cablefem.dynamics import DynamicsError, DynamicsStats, Interrupted, integrate
from cablefem.errors import RunError, RunInterrupted
from cablefem.io.checkpoint import case_digest, read_checkpoint, write_checkpoint
from cablefem.io.faults import kill_point
from cablefem.io.series import (
    OutputError,
    clean_outputs,
    remove_temporaries,
    write_json,
    write_modes,
)
from cablefem.modal import free_dofs, solve_modes
from cablefem.moments import (
    ERROR_THRESHOLD,
    MAX_ANCHOR_ANGLE,
    resonance,
)
from cablefem.network import NetworkModel
from cablefem.span_bending import AUTO_THRESHOLD, frequency_shifts, is_on
from cablefem.statics import solve_static
from cablefem.units import unit

__all__ = ["RunResult", "RunError", "RunInterrupted", "run_case", "model_from_case",
           "steady_state_stats", "warn", "static_sag_ratio", "rod_moment_columns"]

log = logging.getLogger(__name__)


@dataclass
class RunResult:
    """What a run computed (histories live on every rank)."""

    summary: dict
    times: np.ndarray
    forces: dict[str, np.ndarray]  #: anchor -> (n_t, 3)
    moments: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    model: CableModel | None = None












#: an anchor tension below this fraction of the static one counts as slack (snap loads)
SLACK = 0.05


def model_from_case(comm: MPI.Comm, case: Case, *, model: str = "string",
                    refine: float = 1.0) -> CableModel:
    """The model of a case: its description (a case is one) built as the string
    (:class:`CableModel`, a :class:`NetworkModel` for a network) or, with
    ``model="beam"``, the reference rod (:class:`cablefem.rod.BeamModel`, mesh density
    scaled by ``refine``). Collective on ``comm``."""
    if model not in ("string", "beam"):
        raise ValueError(f"model must be 'string' or 'beam', got {model!r}")
    if model == "beam":
        from cablefem.rod import BeamModel

        return BeamModel(comm, case, refine=refine)
    return (NetworkModel if case.network is not None else CableModel)(comm, case)


def leading_order_summary(case: Case, outdir: str | Path,
                          comm: MPI.Comm = MPI.COMM_WORLD) -> dict:
    """The summary of a statics-and-modes run of ``case`` at the paper's leading order
    (``outer_correction = "none"``) in ``outdir``: what the leading order's closed forms
    (catenary, Irvine, the composite moment) check; the default first-order correction
    moves those numbers by about 2h/l (docs/hinge.md)."""
    lo = copy.deepcopy(case)
    lo.solver.outer_correction = "none"
    return run_case(lo, outdir, comm, dynamics=False, figures=False, progress=False).summary


def run_case(case: Case, outdir: str | Path, comm: MPI.Comm = MPI.COMM_WORLD, **kwargs
             ) -> RunResult:
    """Run a case (see :func:`_run_case` for the keywords and what is written), the C
    compiler's messages kept off the console (:func:`cablefem.jit.quiet_compiler`).

    Before any work (collective): the memory estimate (:func:`cablefem.app.resources.
    check_memory`, CaseError naming ``mesh.elements``) and the output folder's check and
    lock (:func:`cablefem.io.outdir.output_lock`, OutdirError), held until the run ends.
    SIGINT/SIGTERM stop the run at any time with :class:`RunInterrupted`: cleanly, with a
    checkpoint, in the dynamics; before them (build, statics, modes) as soon as Python
    code runs again after the C call in progress, with nothing to resume.
    """
    from cablefem.app.resources import check_memory
    from cablefem.io.outdir import output_lock

    kwargs.setdefault("model", getattr(case.solver, "model", "string"))  # solver.model
    runner = _runner(kwargs["model"])
    check_memory(case, comm, "string" if runner is not _run_case else
                 kwargs["model"])  # "auto" runs the string first
    with output_lock(outdir, comm), _StopOnSignal() as stop:
        try:
            with quiet_compiler():  # no compiler lines on the console
                return runner(case, outdir, comm, **kwargs)
        except (RunInterrupted, CaseError):
            raise
        except BaseException as err:  # noqa: BLE001 - a signal may surface as any error
            if stop.signal is None:
                raise
            raise RunInterrupted(
                f"stopped by {signal.Signals(stop.signal).name} outside the time integration "
                f"(build, statics, modes or the final output): {outdir} holds no complete "
                "result; run again ('--restart' continues from a checkpoint of the "
                "dynamics only)", stop.signal) from err


def _runner(model: str):
    """What runs a case for ``model``: :func:`_run_case`, or for ``"auto"`` the string and
    where needed the rod (:func:`cablefem.app.automodel.run_auto`)."""
    if model != "auto":
        return _run_case
    from functools import partial

    from cablefem.app.automodel import run_auto

    return partial(run_auto, _run_case)


class _Stopped(BaseException):
    """Raised by the signal handler of :class:`_StopOnSignal` (not an Exception: no
    ``except Exception`` on the way up swallows it)."""


class _StopOnSignal:
    """SIGINT/SIGTERM raise :class:`_Stopped` in the main thread (remembering the signal)
    until the dynamics put their own checkpointing handlers in place."""

    def __init__(self) -> None:
        self.signal: int | None = None
        self._old: dict = {}

    def _handler(self, signum, frame):  # noqa: ARG002 - signal API
        self.signal = signum
        raise _Stopped(signum)

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            self._old = {sig: signal.signal(sig, self._handler)
                         for sig in (signal.SIGINT, signal.SIGTERM)}
        return self

    def __exit__(self, *exc):
        for sig, old in self._old.items():
            signal.signal(sig, old)
        return False


@dataclass
class _Probe:
    """The string without the span's bending, solved for the ``"auto"`` decision: reused
    by the run when the decision is off."""

    model: object
    static: object
    modal: object
    shifts: np.ndarray


def _auto_span_bending(comm: MPI.Comm, case: Case, n_modes: int | None):
    """Resolve ``solver.span_bending = "auto"`` (cablefem.span_bending): the case with it
    on or off, the probe to reuse when off (None when on, or when no mode is asked for),
    and the record for ``summary.json``."""
    def with_bending(on: bool) -> Case:
        return replace(case, solver=replace(case.solver, span_bending=on))

    off = with_bending(False)
    if not n_modes:
        return off, None, {"decision": "off", "reason": "no mode computed"}
    log.info("span bending \"auto\": the string without it first (statics and modes)")
    model = model_from_case(comm, off)
    static = solve_static(model)
    n = min(n_modes, free_dofs(model))
    if not n:
        return off, None, {"decision": "off", "reason": "no free degree of freedom"}
    modal = solve_modes(model, n)
    shifts = frequency_shifts(model, modal)
    worst = int(np.nanargmax(np.abs(shifts))) if np.isfinite(shifts).any() else 0
    size = float(abs(shifts[worst])) if np.isfinite(shifts[worst]) else 0.0
    record = {"largest_shift": size, "mode": worst + 1, "threshold": AUTO_THRESHOLD}
    if size > AUTO_THRESHOLD:
        log.info("span bending: on (it would move mode %d by %.3g %%, above %.3g %%): "
                 "solving again with it", worst + 1, 100 * size, 100 * AUTO_THRESHOLD)
        return with_bending(True), None, {"decision": "on", **record}
    log.info("span bending: off (it would move mode %d by %.3g %%, at most %.3g %%)",
             worst + 1, 100 * size, 100 * AUTO_THRESHOLD)
    return off, _Probe(model, static, modal, shifts), {"decision": "off", **record}


def _run_case(case: Case, outdir: str | Path, comm: MPI.Comm = MPI.COMM_WORLD, *,
             modes: int | None = None, dynamics: bool = True, t_end: float | None = None,
             form: str = "exact", progress: bool = True, figures: bool = True,
             restart: bool = False, model: str = "string", refine: float = 1.0
             ) -> RunResult:
    """Run a case: statics, modes, and dynamics when the case has a ``[dynamics]`` table.

    Writes ``summary.json``, ``anchors.csv``, ``string.xdmf``, ``modes.xdmf`` and, with a
    clamped anchor, ``moments.xdmf`` and figures under ``outdir``. On a failure the files
    written so far stay valid, ``summary.json`` says what happened, and :class:`RunError` is
    raised. SIGINT/SIGTERM stop the dynamics cleanly (:class:`RunInterrupted`);
    ``restart=True`` continues a run in ``outdir`` from its last checkpoint (after a signal
    or a kill at any instant), and its files end as those of an uninterrupted run. A new
    run (``restart=False``) first removes an earlier run's outputs from ``outdir``. Until
    the run ends, ``summary.json`` says ``"status": "running"`` with the last checkpoint.
    ``model="beam"`` runs the reference rod (:mod:`cablefem.rod`) instead of the string,
    its mesh density scaled by ``refine``; the anchor moments are then the rod's own.
    """
    wall0 = time.perf_counter()
    outdir = Path(outdir)
    if t_end is not None and case.dynamics is not None and dynamics:  # --t-end: the tables
        ends = check_table_ends(case, t_end)  # must reach it too (before any work)
        if ends:
            raise CaseError(ends, case.source)
    if comm.rank == 0:
        outdir.mkdir(parents=True, exist_ok=True)
    comm.Barrier()
    kind = model
    n_asked = case.modal.modes if modes is None else modes
    probe, auto = None, None
    if kind == "string" and case.solver.span_bending == "auto":
        case, probe, auto = _auto_span_bending(comm, case, n_asked)
    model = probe.model if probe else model_from_case(comm, case, model=kind, refine=refine)
    t_build = time.perf_counter() - wall0
    if restart:  # what a kill left half-written (the series' own parts: see io.Series)
        remove_temporaries(outdir, comm)
    else:  # a new run replaces every output of an earlier one in the folder
        clean_outputs(outdir, comm)
    groups = model.dimensionless_groups()
    log.info("%s: l = %.6g %s, %d elements, eps = %s, eps_b = %s", case.title, model.length,
             unit(case.units, "length"),
             len(model.geometry.stations) - 1, _g(groups.get("eps")),
             _g(groups.get("eps_b")))
    summary: dict = {"cablefem": __version__, "status": "running", "case": case.to_dict(),
                     "mpi_ranks": comm.size, "length": model.length,
                     "model": kind, "elements": len(model.geometry.stations) - 1,
                     "degrees_of_freedom": model.bs * len(model.geometry.stations),
                     "dimensionless": groups, "wall_time": {"build": t_build},
                     "warnings": []}
    if model.string_alone:  # section.EI = 0 (cablefem.chain)
        summary["bending"] = {"EI": 0.0, "moments": False, "note": CHAIN_NOTE}
        log.info("%s", CHAIN_NOTE)
    for key, message in list(case.warnings) + list(model.warnings):
        warn(summary, key, message)
    if kind == "beam":
        st = model.geometry.stations
        summary["beam"] = {"refine": refine, "min_element": float(np.min(np.diff(st))),
                           "max_element": float(np.max(np.diff(st))),
                           "layer_lengths_catenary": {
                               case.anchors[e].name: ell
                               for e, ell in model.layer_lengths.items()},
                           **model.section_values}
    note = note_small_problem(summary["degrees_of_freedom"], comm)
    if note:
        summary["notes"] = [note]
    if summary["elements"] >= model.LOG_PHASES_FROM:
        log.info("statics: %d degrees of freedom", summary["degrees_of_freedom"])
    static = probe.static if probe else solve_static(model)
    r = model.gather_nodal(model.u)
    sag = None
    if comm.rank == 0 and case.gravity.g > 0 and case.network is None:
        a0, a1 = model.anchors
        sag = static_sag_ratio(model.geometry.points + r, a0.position, a1.position,
                               np.asarray(case.gravity.direction, float))
    sag = comm.bcast(sag, root=0)
    summary["static"] = {
        "anchor_forces": {a.name: f[:3] for a, f in zip(model.anchors,
                                                         static.anchor_forces)},
        "newton_iterations": static.newton_iterations,
        "continuation_steps": static.continuation_steps,
        "slack_elements": static.slack_elements, "max_tension": static.max_tension,
        "min_tension": static.min_tension, "sag_ratio": sag}
    summary["wall_time"]["statics"] = static.wall_time
    for key, message in axial_dampers(model):
        warn(summary, key, message)
    if kind == "beam" and static.slack_elements:
        # statics tried the relaxation from the guess and found nothing better
        warn(summary, "statics", f"the rod's static state has {static.slack_elements} "
             f"compressed element(s) (least tension {static.min_tension:.4g}): a buckled "
             "equilibrium, not a reference for a cable; try another --refine")
    summary["outer_correction"] = ("none" if kind == "beam"  # the model's (EI = 0: none)
                                   else model.case.solver.outer_correction)
    if kind != "beam":
        summary["span_bending"] = is_on(case.solver.span_bending)
        if auto is not None:
            summary["span_bending_auto"] = auto
    if model.hinges:
        summary["static"]["virtual_hinges"] = model.hinges.report()
    if getattr(case, "seabed", None) is not None and model.is_network:
        from cablefem.seabed import network_contact  # per cable group

        contact = network_contact(model)
        if contact is None:
            warn(summary, "seabed", "no cable touches the seabed in the static state")
        else:
            summary["static"]["seabed_contact"] = contact
            for group, c in contact.items():
                log.info("seabed: cable %s grounded over %.6g m, %d touchdown point(s)",
                         group, c["grounded_length"], len(c["touchdown"]))
    elif getattr(case, "seabed", None) is not None:  # where the line leaves the seabed
        from cablefem.seabed import touchdown

        td = touchdown(model, static.anchor_forces)
        if td is None:
            warn(summary, "seabed", "the cable does not touch the seabed in the static state")
        else:
            summary["static"]["touchdown"] = td
            from cablefem.app.console import log_touchdown

            log_touchdown(td)
    # a folder found after a kill says what happened: running, last checkpoint (none yet)
    summary["checkpoint"] = None
    if not restart:
        write_json(outdir / "summary.json", summary, comm)

    n_modes = n_asked
    shifts = None  # each mode's span-bending shift, when the string runs without it
    free = free_dofs(model)
    if n_modes and n_modes > free:
        warn(summary, "modal.modes", f"{n_modes} modes asked for, but the model has "
             f"{free} free degrees of freedom: " + (f"computing {free}" if free else
                                                     "no modes computed"))
        n_modes = free
    if n_modes:
        modal = probe.modal if probe else solve_modes(model, n_modes)
        write_modes(model, modal, outdir / "modes.xdmf")
        summary["modes"] = [{"omega": w, "frequency_hz": w / (2 * np.pi), **lab}
                            for w, lab in zip(modal.omegas, modal.labels)]
        if kind == "string" and not is_on(case.solver.span_bending):
            # what the span's bending, left out, would do to each (span_bending.py)
            shifts = probe.shifts if probe else frequency_shifts(model, modal)
            for entry, x in zip(summary["modes"], shifts):
                if np.isfinite(x):
                    entry["span_bending_shift"] = float(x)
        lam = modal.damped_omegas  # |lambda| of the damped system's modes (None: undamped)
        for k, (entry, z) in enumerate(zip(summary["modes"], modal.damping_ratios)):
            if np.isfinite(z):  # from the damped system's complex modes (modal.py)
                entry["damping_ratio"] = float(z)
                if lam is not None and np.isfinite(lam[k]):
                    entry["lambda_abs"] = float(lam[k])
            else:  # no complex mode like it: absent, and said why
                entry["damping_ratio_missing"] = "no complex mode of the damped system " \
                    "matches this mode (overdamped?)"
        if kind != "beam":  # each mode's estimated error and range (the rod resolves)
            mode_validity(summary, model, static, modal, warn, ERROR_THRESHOLD,
                          1 if model.hinges else 0)
        summary["wall_time"]["modal"] = modal.wall_time
        # the static state again: the modal solve does not change model.u, but be explicit
        model.u.x.array[:] = model.u_static.x.array
        if not restart:
            write_json(outdir / "summary.json", summary, comm)

    omega = _max_excitation(case)
    resume = None
    frames = None
    # the dynamics counters of the whole run: those before the checkpoint resumed from
    base = {"newton_iterations": 0, "rejected_steps": 0, "linear_iterations": 0,
            "outputs": 0, "wall_dynamics": 0.0}
    if restart:
        resume = read_checkpoint(outdir, comm)
        if str(resume["digest"]) != case_digest(case):
            raise CaseError([("case", f"{case.source} has changed since the checkpoint in "
                                      f"{outdir}: restart with the same case file")],
                            case.source)
        if t_end is None and "t_stop" in resume:
            t_end = float(resume["t_stop"])
        ck = resume["checkpoint"]
        if "frames_string" not in resume:
            raise RunError(f"{outdir}: the checkpoint was written by an older cablefem "
                           "(without the frame counts of its field series): it cannot be "
                           "resumed; run the case again")
        frames = {"string": int(resume["frames_string"]),
                  "moments": int(resume["frames_moments"])}
        for key, val in base.items():
            base[key] = type(val)(resume[key])
        summary["restarted_from"] = ck.time
        summary["checkpoint"] = {"time": ck.time, "step": ck.step}
        write_json(outdir / "summary.json", summary, comm)
        log.info("restarting from the checkpoint at t = %.6g (step %d)", ck.time, ck.step)
    try:
        emitter = RunOutput(model, outdir, form, omega, static.anchor_forces,
                           None if resume is None else resume["checkpoint"].time, frames)
    except OutputError as err:
        raise RunError(f"{err}; run the case again") from err
    if n_modes and omega and kind != "beam":  # the error estimate near a resonance
        amp, w_r = resonance(omega, modal.omegas, modal_damping_ratios(case, modal))
        bends = is_on(case.solver.span_bending)  # the outer problem has the span's bending
        shift = None  # the resonant mode's own span-bending error, measured on it
        if not bends and w_r is not None and shifts is not None:
            shift = float(shifts[int(np.argmin(np.abs(modal.omegas - w_r)))])
            summary["error_resonance_shift"] = shift
        # the mesh's frequency error, amplified alike at a primary resonance (at a
        # parametric one the response locks its phase to the excitation: theory.md §5.2);
        # the time step's beside it
        parametric = w_r is not None and abs(omega / (2 * w_r) - 1) < abs(omega / w_r - 1)
        disc = None if w_r is None else model_frequency_error(model, static, w_r)
        if w_r is not None:
            summary["error_resonance_kind"] = "parametric" if parametric else "primary"
        if disc is not None:
            summary["error_resonance_mesh"] = disc  # signed: P1 stiffens (theory.md §5.2)
            if parametric:
                disc = None
            elif shift is not None:  # the net the estimate amplifies, string minus rod
                summary["error_resonance_frequency"] = disc - shift
            step = model_frequency_error(model, static, w_r, time_step=True)
            if step is not None:
                summary["error_resonance_time_step"] = step
        emitter.moment_columns.set_resonance(amp, static.anchor_forces,
                                             None if bends else w_r, shift, disc)
        summary["error_resonance_factor"] = amp
    static_entries = _log_static_state(model, static, emitter, form, kind, sag)
    if resume is not None:  # after the emitter, which takes its reference from the statics
        model.scatter_nodal(resume["u"], model.u)
        model.scatter_nodal(resume["v"], model.v)
    stats = DynamicsStats()
    error = None
    stop = {"signal": None}

    def on_signal(signum, frame):  # noqa: ARG001 - signal API
        stop["signal"] = signum

    handlers = {}
    try:
        if case.dynamics is not None and dynamics:
            dyn = case.dynamics
            t_stop = dyn.t_end if t_end is None else t_end
            digest = case_digest(case)
            if threading.current_thread() is threading.main_thread():
                handlers = {sig: signal.signal(sig, on_signal)
                            for sig in (signal.SIGINT, signal.SIGTERM)}

            def checkpoint(ck):
                frames = emitter.checkpoint()
                extra = {"t_stop": t_stop, "model": kind, "refine": refine,
                         "outer_correction": case.solver.outer_correction,
                         "frames_string": frames["string"],
                         "frames_moments": frames["moments"],
                         **_whole_run(base, stats, time.perf_counter() - t_dyn0)}
                write_checkpoint(model, outdir, ck, digest, extra)
                summary["checkpoint"] = {"time": ck.time, "step": ck.step}
                write_json(outdir / "summary.json", summary, comm)

            bar = Progress(t_stop, "dynamics", comm, enabled=progress)
            stride = math.gcd(dyn.output_every, dyn.fields_every)
            start = None if resume is None else resume["checkpoint"]
            t_dyn0 = time.perf_counter()
            for t, forces in integrate(model, t_stop, dyn.dt, dyn.rho_inf, stride, stats,
                                       start=start, checkpoint_every=dyn.checkpoint_every,
                                       on_checkpoint=checkpoint,
                                       should_stop=lambda: stop["signal"] is not None,
                                       initial=dyn.initial):
                step, last = stats.steps, t >= t_stop - 1e-9 * dyn.dt
                if step % dyn.output_every == 0 or last:
                    emitter.add(t, forces)
                if step % dyn.fields_every == 0 or last:
                    emitter.fields(t, forces)
                bar.update(t, f"step {step}")
                kill_point("step")
            bar.close()
            # the whole run's counters (a resumed run adds those before its checkpoint)
            total = _whole_run(base, stats, stats.wall_time)
            summary["dynamics"] = {
                "t_end": t_stop, "dt": dyn.dt, "rho_inf": dyn.rho_inf, "initial": dyn.initial,
                "steps": stats.steps,
                "rejected_steps": total["rejected_steps"],
                "newton_iterations": total["newton_iterations"],
                "linear_iterations": total["linear_iterations"],
                "newton_per_step": total["newton_iterations"] / max(stats.steps, 1),
                "outputs": total["outputs"]}
            summary["wall_time"]["dynamics"] = total["wall_dynamics"]
        else:
            emitter.add(0.0, static.anchor_forces)
            emitter.fields(0.0, static.anchor_forces)
    except Interrupted as err:
        error = err
        sig = stop["signal"]
        summary["status"] = "interrupted"
        summary["signal"] = int(sig) if sig is not None else None
        ck_time = _checkpoint_time(outdir, comm)
        summary["error"] = (f"{err}; resume with: cablefem run --restart {outdir} "
                            f"(continues from the checkpoint at t = {ck_time:g})"
                            if ck_time is not None else
                            f"{err} before the first checkpoint: nothing to resume, run the "
                            "case again")
        log.warning("%s", summary["error"])
    except (DynamicsError, FloatingPointError) as err:
        error = err
        summary["status"] = "failed"
        summary["error"] = str(err)
        log.error("%s", err)
        if isinstance(err, DynamicsError) and emitter.times:
            # the last converged state (left in the model by integrate) goes to string.xdmf
            last = np.array([emitter.forces[a.name][-1] for a in model.anchors])
            try:
                if err.time != emitter.last_fields_time:  # else it is already in the file
                    emitter.fields(err.time, last)
                summary["failure_state_time"] = err.time
            except (FloatingPointError, RuntimeError) as err2:
                log.error("could not write the state at failure: %s", err2)
    finally:
        for sig, old in handlers.items():
            signal.signal(sig, old)
        emitter.close()

    times = np.array(emitter.times)
    forces = {k: np.array(v).reshape(-1, 3) for k, v in emitter.forces.items()}
    moments = {name: {k: np.array(v) for k, v in cols.items()}
               for name, cols in emitter.columns.items()}
    summary["anchors"] = {}
    start = statistics_start(summary, case, times)
    for a in model.anchors:
        entry = {"kind": a.kind, "position": a.position,
                 "section": _section_name(case, a.section),
                 "direction": a.direction if a.direction is not None else None,
                 "static_tension": float(np.linalg.norm(static.anchor_forces[
                     model.anchors.index(a)][:3]))}
        if a.clamp is not None:  # a side of a clamp a cable runs through
            entry["clamp"] = a.clamp
        entry.update(static_entries[a.name])  # tension; moment at a clamped anchor
        if a.name in moments and len(times):
            mo = moments[a.name]
            entry["valid_fraction"] = float(np.mean(mo["valid"]))
            with np.errstate(invalid="ignore"):
                backwards = int(np.count_nonzero(mo["delta"] > MAX_ANCHOR_ANGLE))
            if backwards:
                entry["rows_beyond_90deg"] = backwards
                warn(summary, f"anchors.{a.name}", f"{backwards} of {len(times)} rows have "
                     "the anchor force more than 90 degrees from the clamp direction: "
                     "outside the method, valid = 0 (check anchors.direction)")
            fb = emitter.fallback.get(a.name)
            if fb and any(fb):
                entry["outer_fallback_fraction"] = float(np.mean(fb))
                warn(summary, f"anchors.{a.name}", f"{sum(fb)} of {len(fb)} rows with the "
                     "virtual hinge's layer outside the tension range it follows (a "
                     "quarter to twice the static tension; there it keeps the law at the "
                     "nearer end): the first-order correction is only partial there")
            slack = np.linalg.norm(forces[a.name], axis=1) < SLACK * entry["static_tension"]
            if np.any(slack) and case.dynamics.rho_inf > 0.5:
                # snap loads are non-smooth: generalised-alpha at rho_inf = 0.9 blew up on a
                # slackening cable where 0.5 stayed bounded on every mesh (docs/theory.md §6)
                entry["slack_rows"] = int(np.count_nonzero(slack))
                warn(summary, f"anchors.{a.name}", f"{entry['slack_rows']} of {len(times)} "
                     f"rows with the tension below {SLACK:g} of the static one: the cable "
                     "goes slack and snaps taut, which generalised-alpha with dynamics."
                     f"rho_inf = {case.dynamics.rho_inf:g} may not damp (check with "
                     "rho_inf = 0.5)")
            why = emitter.reasons.get(a.name, [])  # this process's rows (not a resumed run's)
            why = ["(not recorded)"] * (len(times) - len(why)) + why
            entry["validity"] = anchor_validity(summary, a.name, times,
                                                {**mo, "invalid_reason": why}, ERROR_THRESHOLD,
                                                start=start)
            if len(times) > 1:
                entry["steady_state_moment"] = steady_state_stats(times, mo["moment"],
                                                                  start=start)
        summary["anchors"][a.name] = entry
    if case.dynamics is not None and dynamics and times.size > 2:  # steps left ringing
        from cablefem.app.alternation import check_alternation

        check_alternation(summary, times, forces, case.dynamics)
    if emitter.touchdown.active and emitter.touchdown.rows:  # the touchdown's history
        summary["touchdown"] = emitter.touchdown.summary()
        off = summary["touchdown"].get("cable", {}).get("times_off_the_seabed", 0)
        if off and "touchdown" in summary["static"]:
            warn(summary, "seabed", f"the line left the seabed altogether at {off} of "
                 f"{len(times)} output times (touchdown.csv: grounded length 0): a bounce "
                 "on the contact's stiffness, which the time step may not resolve "
                 "(sqrt(stiffness/mass) dt > 1); more seabed.damping or a smaller "
                 "dynamics.dt, or a smoother anchor motion (its ramp)")
    if emitter.kinkout.kinks:
        summary["kinks"] = emitter.kinkout.summary(start)
        for name, entry in summary["kinks"].items():
            frac = entry.get("valid_fraction", 1.0)
            if frac < 1.0 or not entry["static_valid"]:
                warn(summary, f"kinks.{name}", f"{100 * (1 - frac):.3g} % of the rows are "
                     "invalid (the layer at this kink is slack, not quasi-static, or overlaps "
                     "a neighbouring kink or anchor): see valid in kinks.csv")
        if kind != "beam":  # the rod resolves its layers
            _warn_damper_offsets(summary, model, emitter.kinkout.kinks)
    gaps = model.kink_gaps
    if gaps:  # network nodes where a cable kinks but has no kink moment
        k, where, why = gaps[0]
        warn(summary, "kinks", f"{len(gaps)} node(s) where a cable kinks have no kink "
             f"moment (e.g. node {k}, {where!r}: {why}): give each cable through such a "
             "node its own group, of one section (docs/kinks.md)")
    warn_drifts(summary, warn)
    if summary["status"] == "running":
        summary["status"] = "completed"
    if figures and len(times) > 1 and moments:
        from cablefem.app.plots import MAX_PANELS, anchor_figures

        source = ("the rod's own moment (beam model)" if kind == "beam"
                  else "inner solution + string curvature")
        summary["figures"] = anchor_figures(outdir, times, moments, comm, source=source,
                                            units=case.units)
        if len(moments) > MAX_PANELS:
            log.info("figures: the %d most loaded of %d clamped anchors (all are in "
                     "anchors.csv)", MAX_PANELS, len(moments))
    histories = moments or emitter.kinkout.kinks  # at clamped anchors or kinks
    if case.fatigue is not None and error is None and not (len(times) > 1 and histories):
        warn(summary, "fatigue", "no fatigue report: it needs a time history at a clamped "
             "anchor or a kink (" + ("neither" if not histories else "no dynamics run")
             + ")")
    elif case.fatigue is not None and error is None:
        from cablefem.app.fatigue import run_fatigue

        try:  # samples without a moment (slack anchor) are left out and counted
            # the anchors' sections from this summary: summary.json is not written yet
            reps = run_fatigue(case, outdir, invalid="drop", comm=comm,
                               sections={n: e.get("section")
                                         for n, e in summary["anchors"].items()
                                         if e["kind"] == "clamped"})
            summary["fatigue"] = {n: {k: r.get(k) for k in (
                "damage", "damage_per_year", "time_to_failure", "equivalent_range_N_C",
                "max_range", "dropped_invalid_samples")} for n, r in reps.items()}
        except ValueError as err:  # a step the case asks for failed: so did the run
            error = RunError(f"fatigue: {err}")
            log.error("%s", error)
            summary["fatigue"] = {"error": str(err)}
            summary["status"] = "failed"
            summary["error"] = str(error)
    summary["wall_time"]["total"] = time.perf_counter() - wall0
    write_json(outdir / "summary.json", summary, comm)
    log.info("results in %s (%.2f s)", outdir, summary["wall_time"]["total"])
    result = RunResult(summary, times, forces, moments, model)
    if isinstance(error, Interrupted):
        raise RunInterrupted(summary["error"], stop["signal"]) from error
    if isinstance(error, RunError):
        raise error
    if error is not None:
        raise RunError(f"{error} -- results up to t = {times[-1] if times.size else 0:g} "
                       f"are in {outdir}") from error
    return result


#: a damper's estimated corner error (cablefem.kinks.damper_offset_estimate) above which the
#: run warns: the anchors' aim
DAMPER_OFFSET_WARN = 0.01


def _warn_damper_offsets(summary: dict, model, kinks) -> None:
    """A damper acts at the string's corner where the model does not apply the rod node's
    offset (a network's, the leading order's) or applies part of it (elements shorter
    than 2.5 layer lengths next to the damper, cablefem.dampers.MESH_RATIO): record each
    damper kink's estimate of the error that makes (``damper_offset_estimate`` in its
    summary entry) and warn where it exceeds :data:`DAMPER_OFFSET_WARN`."""
    from cablefem.dampers import MESH_RATIO, applied_offset
    from cablefem.kinks import damper_offset_estimate

    applies = model.applies_damper_offsets()
    worst = []
    for k in kinks:
        entry = summary["kinks"].get(k.name, {})
        ell = entry.get("layer_length", float("nan"))
        corrected = applied_offset(ell, min(k.h)) if applies else 0.0
        est = damper_offset_estimate(k, ell, corrected)
        if est is None:
            continue
        entry["damper_offset_estimate"] = est
        if est > DAMPER_OFFSET_WARN:
            worst.append((est, k.name, MESH_RATIO * ell))
    if worst:
        est, name, needed = max(worst)
        why = ("the network's dampers act at the string's node" if model.is_network
               else "at leading order the dampers act at the "
            "string's node" if not applies else "the elements next to the damper are "
            f"shorter than {MESH_RATIO:g} layer lengths, which limits the offset: "
            f"elements of at least {needed:.3g} {unit(model.case.units, 'length')} there "
            "apply it in full")
        warn(summary, f"kinks.{name}", f"{len(worst)} damper(s) are not held at the rod's "
             f"node, l/2 inside the string's kink ({why}): their damping ratios, forces "
             f"and kink moments may be off by about {100 * est:.2g} % (the largest; "
             "damper_offset_estimate in summary.json; docs/dampers.md)")


def _log_static_state(model, static, emitter, form: str, kind: str, sag) -> dict:
    """The anchors' static entries (cablefem.app.console), logged with the kinks' static
    moments and the sag before the dynamics."""
    from cablefem.app.console import log_static_state, static_anchor_entries

    entries = static_anchor_entries(model, static, emitter, form, kind)
    log_static_state(entries, emitter.kinkout, sag, model.case.units, kind)
    return entries


def _whole_run(base: dict, stats: DynamicsStats, wall: float) -> dict:
    """The dynamics counters of the whole run: ``base`` (those before the checkpoint a run
    resumed from; zeros otherwise) plus this run's ``stats`` and dynamics wall time."""
    return {"newton_iterations": base["newton_iterations"] + stats.newton_iterations,
            "rejected_steps": base["rejected_steps"] + stats.rejected_steps,
            "linear_iterations": base["linear_iterations"] + stats.linear_iterations,
            "outputs": base["outputs"] + len(stats.output_times),
            "wall_dynamics": base["wall_dynamics"] + wall}


def _checkpoint_time(outdir: Path, comm: MPI.Comm) -> float | None:
    try:
        return read_checkpoint(outdir, comm)["checkpoint"].time
    except ValueError:
        return None
