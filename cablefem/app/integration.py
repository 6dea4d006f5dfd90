"""The time stages of a run (:func:`cablefem.app.run.run_case`): the checkpoint a run
resumes from, the error estimate near a resonance, and the dynamics, whose integrator the
output (:class:`cablefem.app.output.RunOutput`) listens to. Each returns a dataclass."""

from __future__ import annotations

import logging
import math
import signal
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from mpi4py import MPI

from cablefem.app.log import Progress
from cablefem.app.output import Histories, RunOutput
from cablefem.app.report import modal_damping_ratios
from cablefem.app.stages import Built, Modes, Statics
from cablefem.case import CaseError
from cablefem.discretisation import mode_mesh_error, model_frequency_error
from cablefem.dynamics import DynamicsError, DynamicsStats, Interrupted, integrate
from cablefem.errors import RunError
from cablefem.history_error import Spectrum
from cablefem.io.checkpoint import case_digest, read_checkpoint, write_checkpoint
from cablefem.io.faults import kill_point
from cablefem.moments import AnchorMoments, resonance
from cablefem.span_bending import is_on

__all__ = ["Resume", "Resonance", "Dynamics", "read_resume", "resonance_estimate",
           "run_dynamics", "COUNTERS"]

log = logging.getLogger(__name__)

#: the dynamics counters of a whole run, zero before any step
COUNTERS = {"newton_iterations": 0, "rejected_steps": 0, "linear_iterations": 0,
            "outputs": 0, "wall_dynamics": 0.0}


@dataclass
class Resume:
    """The checkpoint a run resumes from (``restart=True``)."""

    state: dict  #: what cablefem.io.checkpoint.read_checkpoint read
    t_end: float | None  #: the end time the interrupted run had (``--t-end``), or None
    frames: dict  #: the frames of each field series up to the checkpoint
    base: dict  #: the dynamics counters before the checkpoint (:data:`COUNTERS`' keys)

    @property
    def time(self) -> float:
        return self.state["checkpoint"].time

    @property
    def record(self) -> dict:
        """summary.json's ``checkpoint``."""
        ck = self.state["checkpoint"]
        return {"time": ck.time, "step": ck.step}


def read_resume(outdir: Path, comm: MPI.Comm, case) -> Resume:
    """The checkpoint in ``outdir`` (collective): CaseError when the case changed since,
    RunError when an older cablefem wrote it."""
    state = read_checkpoint(outdir, comm)
    if str(state["digest"]) != case_digest(case):
        raise CaseError([("case", f"{case.source} has changed since the checkpoint in "
                                  f"{outdir}: restart with the same case file")], case.source)
    if "frames_string" not in state:
        raise RunError(f"{outdir}: the checkpoint was written by an older cablefem "
                       "(without the frame counts of its field series): it cannot be "
                       "resumed; run the case again")
    frames = {"string": int(state["frames_string"]), "moments": int(state["frames_moments"])}
    base = {key: type(val)(state[key]) for key, val in COUNTERS.items()}
    ck = state["checkpoint"]
    log.info("restarting from the checkpoint at t = %.6g (step %d)", ck.time, ck.step)
    return Resume(state, float(state["t_stop"]) if "t_stop" in state else None, frames, base)


@dataclass
class Resonance:
    """The moment error estimate near a resonance: summary.json's ``error_resonance_*``
    entries (empty without modes, excitation, or for the rod)."""

    entries: dict = field(default_factory=dict)
    #: the modes' frequencies, errors and damping for the histories' estimate (None:
    #: no mode with an error estimate, or the rod)
    spectrum: Spectrum | None = None
    #: the anchors' moment columns from their forces (cablefem.moments.AnchorMoments)
    columns: AnchorMoments | None = None


def history_spectrum(b: Built, md: Modes) -> Spectrum | None:
    """The modes' frequencies, relative frequency errors (the modal table's
    ``error_estimate``, which holds the mesh's) and damping ratios
    (:func:`modal_damping_ratios`), for :mod:`cablefem.history_error`; None without modes
    or their estimates (the rod resolves its own). The time step's period error is left
    out, as from the rows' estimate (:mod:`cablefem.discretisation`): every run at that
    step shares it, and halving ``dynamics.dt`` measures it."""
    modal, case = md.result, b.case
    if modal is None or b.kind.resolves_layers or not md.entries or case.dynamics is None:
        return None
    est = [e.get("error_estimate") for e in md.entries]
    if any(x is None for x in est):
        return None
    omegas = np.asarray(modal.omegas, float)
    order = np.argsort(omegas)
    return Spectrum(omegas[order], np.abs(np.asarray(est, float))[order],
                    np.nan_to_num(modal_damping_ratios(case, modal), nan=0.0)[order])


def resonance_estimate(b: Built, st: Statics, md: Modes, columns: AnchorMoments,
                       omega: float | None) -> Resonance:
    """Let the error estimate of ``columns`` grow near a resonance of the excitation
    ``omega`` with the modes ``md`` (:meth:`cablefem.moments.AnchorMoments.set_resonance`)
    and report the factor and the frequency errors it amplifies."""
    out = Resonance(spectrum=history_spectrum(b, md), columns=columns)
    modal, model, case = md.result, b.model, b.case
    if not (modal is not None and omega and not b.kind.resolves_layers):
        return out
    e = out.entries
    amp, w_r = resonance(omega, modal.omegas, modal_damping_ratios(case, modal))
    bends = is_on(case.solver.span_bending)  # the outer problem has the span's bending
    shift = None  # the resonant mode's own span-bending error, measured on it
    if not bends and w_r is not None and md.shifts is not None:
        shift = float(md.shifts[int(np.argmin(np.abs(modal.omegas - w_r)))])
        e["error_resonance_shift"] = shift
    # the mesh's frequency error, amplified alike at a primary resonance (at a parametric
    # one the response locks its phase to the excitation: theory.md §5.2); the time
    # step's beside it
    parametric = w_r is not None and abs(omega / (2 * w_r) - 1) < abs(omega / w_r - 1)
    disc = None if w_r is None else mode_mesh_error(
        model, st.result, modal, int(np.argmin(np.abs(np.asarray(modal.omegas) - w_r))))
    if w_r is not None:
        e["error_resonance_kind"] = "parametric" if parametric else "primary"
    if disc is not None:
        e["error_resonance_mesh"] = disc  # signed: P1 stiffens (theory.md §5.2)
        if parametric:
            disc = None
        elif shift is not None:  # the net the estimate amplifies, string minus rod
            e["error_resonance_frequency"] = disc - shift
        step = model_frequency_error(model, st.result, w_r, time_step=True)
        if step is not None:
            e["error_resonance_time_step"] = step
    columns.set_resonance(amp, st.result.anchor_forces, None if bends else w_r, shift, disc)
    e["error_resonance_factor"] = amp
    return out


@dataclass
class Dynamics:
    """What the dynamics (or the static state alone) left: the recorded histories, the
    ``dynamics`` entries of summary.json (None: not run or not finished) and, when they
    stopped, how (``status`` "interrupted" or "failed", the signal, the message)."""

    histories: Histories
    entries: dict | None = None
    wall_time: float | None = None
    status: str | None = None
    signal: int | None = None
    message: str | None = None
    failure_state_time: float | None = None
    error: BaseException | None = None


def whole_run(base: dict, stats: DynamicsStats, wall: float) -> dict:
    """The dynamics counters of the whole run: ``base`` (those before the checkpoint a run
    resumed from; zeros otherwise) plus this run's ``stats`` and dynamics wall time."""
    return {"newton_iterations": base["newton_iterations"] + stats.newton_iterations,
            "rejected_steps": base["rejected_steps"] + stats.rejected_steps,
            "linear_iterations": base["linear_iterations"] + stats.linear_iterations,
            "outputs": base["outputs"] + len(stats.output_times),
            "wall_dynamics": base["wall_dynamics"] + wall}


def checkpoint_time(outdir: Path, comm: MPI.Comm) -> float | None:
    """The time of the checkpoint in ``outdir`` (None: there is none)."""
    try:
        return read_checkpoint(outdir, comm)["checkpoint"].time
    except ValueError:
        return None


def run_dynamics(b: Built, static, output: RunOutput, outdir: Path, *, run: bool,
                 t_end: float | None, resume: Resume | None, progress: bool,
                 on_checkpoint) -> Dynamics:
    """Integrate the case's dynamics (``run``; else record the static state as the only
    row), the output listening at every output and field step; checkpoint as the case
    asks (``on_checkpoint(record)`` then writes the summary). Failures and signals end
    the dynamics with what was recorded (:class:`Dynamics`' ``status``); the output is
    closed on return."""
    model = b.model
    stats = DynamicsStats()
    stop = {"signal": None}
    out = None
    handlers = {}

    def on_signal(signum, frame):  # noqa: ARG001 - signal API
        stop["signal"] = signum

    try:
        if run:
            if threading.current_thread() is threading.main_thread():
                handlers = {sig: signal.signal(sig, on_signal)
                            for sig in (signal.SIGINT, signal.SIGTERM)}
            entries, wall = _integrate(b, output, outdir, stats, stop, t_end, resume,
                                       progress, on_checkpoint)
            out = (entries, wall)
        else:
            output.add(0.0, static.anchor_forces)
            output.fields(0.0, static.anchor_forces)
    except Interrupted as err:
        sig = stop["signal"]
        ck_time = checkpoint_time(outdir, model.comm)
        message = (f"{err}; resume with: cablefem run --restart {outdir} "
                   f"(continues from the checkpoint at t = {ck_time:g})"
                   if ck_time is not None else
                   f"{err} before the first checkpoint: nothing to resume, run the "
                   "case again")
        log.warning("%s", message)
        out = Dynamics(None, status="interrupted", signal=int(sig) if sig is not None
                       else None, message=message, error=err)
    except (DynamicsError, FloatingPointError) as err:
        log.error("%s", err)
        out = Dynamics(None, status="failed", message=str(err), error=err)
        if isinstance(err, DynamicsError) and len(output.times):
            out.failure_state_time = _failure_state(model, output, err)
    finally:
        for sig, old in handlers.items():
            signal.signal(sig, old)
        output.close()
    if not isinstance(out, Dynamics):
        out = Dynamics(None, *(out or (None, None)))
    out.histories = output.histories()
    return out


def _failure_state(model, output: RunOutput, err) -> float | None:
    """Write the last converged state (left in the model by the integrator) to
    ``string.xdmf``: the time it is at, None if that failed too."""
    last = np.array([output.forces[a.name][-1] for a in model.anchors])
    try:
        if err.time != output.last_fields_time:  # else it is already in the file
            output.fields(err.time, last)
        return err.time
    except (FloatingPointError, RuntimeError) as err2:
        log.error("could not write the state at failure: %s", err2)
        return None


def _integrate(b: Built, output: RunOutput, outdir: Path, stats: DynamicsStats, stop: dict,
               t_end: float | None, resume: Resume | None, progress: bool, on_checkpoint):
    """The time loop: summary.json's ``dynamics`` entries and the dynamics' wall time."""
    model, case, dyn = b.model, b.case, b.case.dynamics
    t_stop = dyn.t_end if t_end is None else t_end
    digest = case_digest(case)
    base = dict(COUNTERS) if resume is None else resume.base
    t_dyn0 = time.perf_counter()

    def checkpoint(ck):
        frames = output.checkpoint()
        extra = {"t_stop": t_stop, "model": b.asked, "refine": b.refine,
                 "outer_correction": case.solver.outer_correction,
                 "frames_string": frames["string"],
                 "frames_moments": frames["moments"],
                 **whole_run(base, stats, time.perf_counter() - t_dyn0)}
        write_checkpoint(model, outdir, ck, digest, extra)
        on_checkpoint({"time": ck.time, "step": ck.step})

    bar = Progress(t_stop, "dynamics", model.comm, enabled=progress)
    stride = math.gcd(dyn.output_every, dyn.fields_every)
    start = None if resume is None else resume.state["checkpoint"]
    for t, forces in integrate(model, t_stop, dyn.dt, dyn.rho_inf, stride, stats,
                               start=start, checkpoint_every=dyn.checkpoint_every,
                               on_checkpoint=checkpoint,
                               should_stop=lambda: stop["signal"] is not None,
                               initial=dyn.initial):
        step, last = stats.steps, t >= t_stop - 1e-9 * dyn.dt
        if step % dyn.output_every == 0 or last:
            output.add(t, forces)
        if step % dyn.fields_every == 0 or last:
            output.fields(t, forces)
        bar.update(t, f"step {step}")
        kill_point("step")
    bar.close()
    # the whole run's counters (a resumed run adds those before its checkpoint)
    total = whole_run(base, stats, stats.wall_time)
    entries = {
        "t_end": t_stop, "dt": dyn.dt, "rho_inf": dyn.rho_inf, "initial": dyn.initial,
        "steps": stats.steps,
        "rejected_steps": total["rejected_steps"],
        "newton_iterations": total["newton_iterations"],
        "linear_iterations": total["linear_iterations"],
        "newton_per_step": total["newton_iterations"] / max(stats.steps, 1),
        "outputs": total["outputs"],
        # this run's cuts of the step (a resumed run: since its checkpoint)
        "step_cuts": [{"time": t, "dt": h} for t, h in stats.cuts],
        # the time integrator's assembly: in C (cablefem.native_rows) or in Python
        "assembly": stats.assembly}
    return entries, total["wall_dynamics"]
