"""``cablefem batch``: every case and seed of a load-case set, on one process or many.

The ranks of the communicator split into groups of ``ranks_per_case`` (``comm.Split``);
the groups take runs (a case and a seed) from a queue as they finish: the queue is a
counter in an MPI window on rank 0 that each group's leader increments atomically
(``Fetch_and_op``, passive target), so the work spreads over the ranks however long each
run takes, and nothing but MPI is involved (any launcher, any number of machines). Each
run goes into ``DIR/<case>/seed<k>/`` with the usual outputs of ``cablefem run`` and
its case as ``case.json`` (the base case with the overrides and the seed). A leader sends
rank 0 of the world a message per finished run; rank 0 prints the progress line (done/total,
the run's wall time, ETA) when it learns of it: after its own run, or while it waits at the
end. When all groups are done, rank 0 builds the records (:func:`cablefem.design.
case_record`), writes ``DIR/design.json`` (:func:`cablefem.design.assemble_design`) and its
figures, and the console gives the governing location's design damage and life.

Resume: a run whose folder has ``summary.json`` with status "completed" and the same
``case.json`` is not run again; one with the same ``case.json`` and a ``checkpoint.npz``
resumes from it (:func:`cablefem.app.run.run_case` with ``restart=True``); any other is run
from the start. docs/loadsets.md.
"""

from __future__ import annotations

import json
import logging
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from mpi4py import MPI

from cablefem.case.loadset import LoadSet, case_text
from cablefem.design import FINISHED, assemble_design, case_record, write_design_figures

__all__ = ["BatchResult", "run_batch"]

log = logging.getLogger(__name__)
_TAG = 32
_POLL = 0.01  # s between two looks of a rank that waits for the others


def _wait(comm: MPI.Comm) -> None:
    """A barrier that sleeps while it waits (MPI's own spins a core: on a shared node it
    would take CPU from the groups still running)."""
    req = comm.Ibarrier()
    while not req.Test():
        time.sleep(_POLL)


@dataclass
class BatchResult:
    """What a batch did (the same on every rank)."""

    design: dict
    statuses: dict = field(default_factory=dict)  #: "case/seed" -> status of this command
    signal: int | None = None  #: the signal that stopped a run, if any

    @property
    def failed(self) -> list[str]:
        return [k for k, s in self.statuses.items() if s not in FINISHED + ("skipped",)]


class _Queue:
    """A shared counter on rank 0 of ``comm``: :meth:`take` returns 0, 1, 2, ... once each."""

    def __init__(self, comm: MPI.Comm) -> None:
        self.win = MPI.Win.Allocate(8 if comm.rank == 0 else 0, 8, comm=comm)
        if comm.rank == 0:
            self.win.Lock(0, MPI.LOCK_EXCLUSIVE)
            np.frombuffer(self.win.tomemory(), dtype=np.int64)[0] = 0
            self.win.Unlock(0)
        comm.Barrier()

    def take(self) -> int:
        one, got = np.ones(1, np.int64), np.zeros(1, np.int64)
        self.win.Lock(0, MPI.LOCK_SHARED)
        self.win.Fetch_and_op(one, got, 0, 0, MPI.SUM)
        self.win.Unlock(0)
        return int(got[0])

    def free(self) -> None:
        self.win.Free()


def _folder(outdir: Path, ls: LoadSet, idx: int) -> tuple[Path, str, int]:
    i, k = ls.runs[idx]
    return outdir / ls.cases[i].name / f"seed{k}", ls.cases[i].name, k


def _prepare(folder: Path, text: str) -> tuple[bool, bool]:
    """Rank 0 of a group: (skip, restart) for a run in ``folder`` with case text ``text``,
    and ``case.json`` written when it differs."""
    from cablefem.io.checkpoint import CHECKPOINT

    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "case.json"
    same = path.is_file() and path.read_text() == text
    status = None
    try:
        status = json.loads((folder / "summary.json").read_text()).get("status")
    except (OSError, ValueError):
        pass
    if same and status == "completed":
        return True, False
    if not same:
        tmp = folder / "case.json.tmp"
        tmp.write_text(text)
        os.replace(tmp, path)
    return False, same and (folder / CHECKPOINT).is_file()


def _run_one(ls: LoadSet, outdir: Path, idx: int, group: MPI.Comm, figures: bool
             ) -> tuple[str, float, int, int | None]:
    """Run (or skip) run ``idx`` on ``group``: (status, wall time, warnings, signal)."""
    from cablefem.app.run import run_case
    from cablefem.case import parse_case
    from cablefem.errors import CableFemError, RunInterrupted

    wall0 = time.perf_counter()
    folder, _, k = _folder(outdir, ls, idx)
    data = ls.cases[ls.runs[idx][0]].cases[k]
    skip, restart = group.bcast(_prepare(folder, case_text(data)) if group.rank == 0
                                else None, root=0)
    if skip:
        return "skipped", 0.0, 0, None
    case = parse_case(data, base_dir=ls.base.parent, source=str(folder / "case.json"))
    logger = logging.getLogger("cablefem")
    level = logger.level
    logger.setLevel(max(level, logging.ERROR))  # a line per run (its warnings counted)
    try:
        try:
            res = run_case(case, folder, group, figures=figures, progress=False,
                           restart=restart)
        except RunInterrupted:
            raise
        except CableFemError:
            if not restart:
                raise
            log.warning("%s: could not resume from its checkpoint: run again", folder)
            res = run_case(case, folder, group, figures=figures, progress=False)
    except RunInterrupted as err:
        return "interrupted", time.perf_counter() - wall0, 0, err.signal or 2
    except CableFemError as err:
        log.warning("%s failed: %s", folder, str(err).splitlines()[0])
        return "failed", time.perf_counter() - wall0, 0, None
    finally:
        logger.setLevel(level)
    return (str(res.summary.get("status", "completed")), time.perf_counter() - wall0,
            len(res.summary.get("warnings") or []), None)


class _Progress:
    """Rank 0 of the world: one line per finished run (done/total, its wall time, ETA)."""

    def __init__(self, ls: LoadSet, outdir: Path) -> None:
        self.ls, self.outdir, self.done = ls, outdir, 0
        self.total = len(ls.runs)
        self.t0 = time.perf_counter()
        self.statuses: dict[str, str] = {}
        self.groups_done, self.signal = 0, None  # the other groups' "done" messages

    def report(self, idx: int, status: str, wall: float, warned: int) -> None:
        self.done += 1
        _, name, k = _folder(self.outdir, self.ls, idx)
        self.statuses[f"{name}/{k}"] = status
        elapsed = time.perf_counter() - self.t0
        eta = elapsed * (self.total - self.done) / self.done
        what = ("finished earlier: skipped" if status == "skipped"
                else f"{status} in {wall:.1f} s")
        extra = f", {warned} warning(s) in its summary.json" if warned else ""
        log.info("[%d/%d] %s seed %d: %s%s; elapsed %.1f s, ETA %.1f s", self.done,
                 self.total, name, k, what, extra, elapsed, eta)


def _work(ls, outdir, comm, group, queue, figures, progress):
    """The loop of one group: take a run, run it, tell rank 0; returns the signal that
    stopped a run, if any. Rank 0 also reports the messages of the other groups."""
    sig = None
    while True:
        idx = group.bcast(queue.take() if group.rank == 0 else None, root=0)
        if idx >= len(ls.runs):
            break
        status, wall, warned, sig = _run_one(ls, outdir, idx, group, figures)
        if group.rank == 0:
            if comm.rank == 0:
                progress.report(idx, status, wall, warned)
                _drain(comm, progress, block=False)
            else:
                comm.send(("run", idx, status, wall, warned), dest=0, tag=_TAG)
        if sig is not None:
            break
    if group.rank == 0 and comm.rank != 0:
        comm.send(("done", sig), dest=0, tag=_TAG)
    return sig


def _drain(comm, progress, block: bool, groups: int = 0) -> int | None:
    """Rank 0: report the other groups' messages (all waiting ones; with ``block``, until
    ``groups`` leaders said they are done). Returns a signal a group reported."""
    while (block and progress.groups_done < groups) or comm.Iprobe(
            source=MPI.ANY_SOURCE, tag=_TAG):
        if not comm.Iprobe(source=MPI.ANY_SOURCE, tag=_TAG):
            time.sleep(_POLL)  # not a blocking recv: MPI would spin a core while it waits
            continue
        msg = comm.recv(source=MPI.ANY_SOURCE, tag=_TAG)
        if msg[0] == "run":
            progress.report(*msg[1:])
        else:
            progress.groups_done += 1
            progress.signal = progress.signal or msg[1]
    return progress.signal


def run_batch(ls: LoadSet, outdir: str | Path, comm: MPI.Comm = MPI.COMM_WORLD, *,
              ranks_per_case: int = 1, figures: bool = True) -> BatchResult:
    """Run every case and seed of ``ls`` into ``outdir`` and write ``design.json`` and
    its figures (collective; see the module docstring).

    Args:
        ls: The load-case set (:func:`cablefem.case.loadset.load_loadset`).
        outdir: The batch's folder.
        comm: The ranks to use.
        ranks_per_case: Ranks per group, dividing ``comm.size``.
        figures: Each run's figures (the design's are always drawn).

    Raises:
        ValueError: ``ranks_per_case`` does not divide the number of ranks.
        OutdirError: The folder cannot be used or another batch holds it.
    """
    from cablefem.io.outdir import output_lock
    from cablefem.io.summary import write_json

    if ranks_per_case < 1 or comm.size % ranks_per_case:
        raise ValueError(f"--ranks-per-case {ranks_per_case} must be >= 1 and divide the "
                         f"number of ranks ({comm.size})")
    outdir = Path(outdir)
    with output_lock(outdir, comm):
        comm = comm.Dup()  # the batch's own messages apart from anything else's
        group = comm.Split(comm.rank // ranks_per_case, comm.rank)
        queue = _Queue(comm)
        progress = _Progress(ls, outdir) if comm.rank == 0 else None
        if comm.rank == 0:
            log.info("batch %s: %d run(s) of %d case(s) on %d group(s) of %d rank(s)",
                     ls.source, len(ls.runs), len(ls.cases), comm.size // ranks_per_case,
                     ranks_per_case)
        sig = _work(ls, outdir, comm, group, queue, figures, progress)
        if comm.rank == 0:
            sig = _drain(comm, progress, True, comm.size // ranks_per_case - 1) or sig
        _wait(comm)
        queue.free()
        group.Free()
        design = _design(ls, outdir, progress) if comm.rank == 0 else None
        write_json(outdir / "design.json", design or {}, comm)
        write_design_figures(design, outdir, comm=comm)
        statuses = comm.bcast(progress.statuses if comm.rank == 0 else None, root=0)
        sig = comm.allreduce(sig or 0, op=MPI.MAX) or None
        design = comm.bcast(design, root=0)
        comm.Free()
    return BatchResult(design, statuses, sig)


def _design(ls: LoadSet, outdir: Path, progress: _Progress) -> dict:
    """Rank 0: the records of every run and the design (logged)."""
    records = []
    for idx in range(len(ls.runs)):
        folder, name, k = _folder(outdir, ls, idx)
        rec = case_record(folder, name, k, ls.cases[ls.runs[idx][0]].hours_per_year,
                          relative_to=outdir)
        said = progress.statuses.get(f"{name}/{k}")
        if said not in (None, "skipped") and said not in FINISHED:
            rec.status = said  # the run's own word over a summary it could not finish
        records.append(rec)
    design = assemble_design(records, ls.design_life, extreme_duration=ls.extreme_duration)
    design["loadset"] = {"source": ls.source, "base": str(ls.base), "t_end": ls.t_end}
    fat = design["fatigue"]
    if fat:
        loc = max(fat, key=lambda k: fat[k]["damage"])
        f = fat[loc]
        life = (f"life {f['life_years']:.4g} years, governing case {f['governing_case']}"
                if "life_years" in f else "no damage")
        log.info("design damage over %g years: %.4g at %s (the largest), %s%s",
                 ls.design_life, f["damage"], loc, life,
                 "" if design["complete"] else " (INCOMPLETE: a lower bound)")
    for w in design["warnings"]:
        log.warning("%s", w)
    log.info("design in %s", outdir / "design.json")
    return design
