"""One run of a case as a function that returns its results (:func:`run_case`), used by
the command line and importable by scripts and tests: a short sequence of stages, each a
function returning a dataclass (build, statics, modes: :mod:`cablefem.app.stages`; the
error near a resonance and the dynamics, which the output listens to:
:mod:`cablefem.app.integration`; the anchors' and kinks' reports, figures, fatigue:
:mod:`cablefem.app.reports`), ``summary.json`` assembled from them
(:mod:`cablefem.app.summary`).
"""

from __future__ import annotations

import copy
import logging
import signal
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from mpi4py import MPI

from cablefem.app import integration, reports, stages
from cablefem.app.log import quiet_compiler
from cablefem.app.output import RunOutput, rod_moment_columns
from cablefem.app.report import max_excitation, static_sag_ratio, steady_state_stats, warn
from cablefem.app.summary import StageResults, assemble
from cablefem.cable import CableModel
from cablefem.case import Case, CaseError, check_table_ends
from cablefem.create import model_from_case
from cablefem.dynamics import Interrupted
from cablefem.errors import RunError, RunInterrupted
from cablefem.io.series import OutputError, clean_outputs, remove_temporaries, write_json
from cablefem.moments import AnchorMoments

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


def _run_case(case: Case, outdir: str | Path, comm: MPI.Comm = MPI.COMM_WORLD, *,
              modes: int | None = None, dynamics: bool = True, t_end: float | None = None,
              form: str = "exact", progress: bool = True, figures: bool = True,
              restart: bool = False, model: str = "string", refine: float = 1.0,
              ranks: dict | None = None) -> RunResult:
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
    ``ranks``: ``{"launched": N, "note": text}`` when the command line runs the case on
    fewer ranks than it was launched on (:mod:`cablefem.app.ranks`), for ``summary.json``.

    The stages (each returns a dataclass; :func:`cablefem.app.summary.assemble` makes
    ``summary.json`` of them): :func:`~cablefem.app.stages.build`,
    :func:`~cablefem.app.stages.statics`, :func:`~cablefem.app.stages.modes`,
    :func:`~cablefem.app.integration.resonance_estimate`,
    :func:`~cablefem.app.integration.run_dynamics`, :func:`~cablefem.app.reports.report`,
    :func:`~cablefem.app.reports.figures`, :func:`~cablefem.app.reports.fatigue`.
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

    def clean():
        if restart:  # what a kill left half-written (the series' own parts: see io.Series)
            remove_temporaries(outdir, comm)
        else:  # a new run replaces every output of an earlier one in the folder
            clean_outputs(outdir, comm)

    n_asked = case.modal.modes if modes is None else modes
    b = stages.build(comm, case, model, refine, n_asked, wall0, clean)
    if ranks:
        b.launched = ranks["launched"]
        b.notes = [ranks["note"], *b.notes]
    r = StageResults(b)

    def save() -> None:  # a folder found after a kill says how far the run got
        write_json(outdir / "summary.json", assemble(r), comm)

    r.statics = stages.statics(b)
    if not restart:
        save()
    r.modes = stages.modes(b, r.statics, outdir)
    if r.modes.result is not None and not restart:
        save()
    if restart:
        r.resume = integration.read_resume(outdir, comm, b.case)
        t_end = r.resume.t_end if t_end is None else t_end
        r.checkpoint = r.resume.record
        save()
    output, static_entries = _open_output(b, r, outdir, form)
    run = b.case.dynamics is not None and dynamics

    def on_checkpoint(record: dict) -> None:
        r.checkpoint = record
        save()

    r.dynamics = integration.run_dynamics(
        b, r.statics.result, output, outdir, run=run, t_end=t_end, resume=r.resume,
        progress=progress, on_checkpoint=on_checkpoint)
    h = r.dynamics.histories
    r.reports = reports.report(b, r.statics, r.resonance, static_entries, r.dynamics, run)
    if figures:
        r.figures = reports.figures(b, h, outdir, comm)
    error = r.dynamics.error
    if error is None:
        r.fatigue = reports.fatigue(b, h, r.reports, outdir, comm)
        error = r.fatigue.error
    r.wall_total = time.perf_counter() - wall0
    summary = assemble(r)
    write_json(outdir / "summary.json", summary, comm)
    log.info("results in %s (%.2f s)", outdir, summary["wall_time"]["total"])
    result = RunResult(summary, h.times, h.forces, h.moments, b.model)
    if isinstance(error, Interrupted):
        raise RunInterrupted(summary["error"], r.dynamics.signal) from error
    if isinstance(error, RunError):
        raise error
    if error is not None:
        raise RunError(f"{error} -- results up to t = {h.times[-1] if h.times.size else 0:g} "
                       f"are in {outdir}") from error
    return result


def _open_output(b: stages.Built, r: StageResults, outdir: Path, form: str):
    """Open the run's output in the static state, let the moments' error estimate grow
    near a resonance, log the static state and put a resumed run's state in the model:
    the output and the anchors' static entries (:func:`cablefem.app.console.
    static_anchor_entries`)."""
    from cablefem.app.console import log_static_state, static_anchor_entries

    model, static = b.model, r.statics.result
    columns = AnchorMoments.from_model(model, max_excitation(b.case), form)
    try:
        output = RunOutput(model, outdir, columns, b.kind.name, static.anchor_forces,
                           None if r.resume is None else r.resume.time,
                           None if r.resume is None else r.resume.frames)
    except OutputError as err:
        raise RunError(f"{err}; run the case again") from err
    r.resonance = integration.resonance_estimate(b, r.statics, r.modes, columns,
                                                 columns.omega)
    entries = static_anchor_entries(model, static, columns, form, b.asked)
    log_static_state(entries, output.kinkout.history(), r.statics.entries["sag_ratio"],
                     model.case.units, b.asked)
    if r.resume is not None:  # after the output, which takes its reference from the statics
        model.scatter_nodal(r.resume.state["u"], model.u)
        model.scatter_nodal(r.resume.state["v"], model.v)
    return output, entries
