"""Checkpoints and restarts: a long run never loses what it computed.

Every ``dynamics.checkpoint_every`` steps the state (nodal displacement and velocity in
station order, time, step, the step-cutting state) goes to ``checkpoint.npz``, written by
rank 0 to a temporary file and renamed (never half written), after ``anchors.csv`` has been
flushed and the field series (``string.xdmf``, ``moments.xdmf``) have closed their current
part and listed it (:class:`cablefem.io.series.Series`); it also holds the run's cumulative
counters and the number of frames of each series. ``cablefem run --restart DIR`` rebuilds
the model from the same case file (its SHA-256 must match), truncates ``anchors.csv`` to
the checkpoint's time, keeps the series' frames up to it (and checks their number),
discards whatever a kill left after it, and continues; the result equals an uninterrupted
run to round-off (see :func:`cablefem.dynamics.integrate`), whether the run stopped on a
signal or was killed at any instant.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np
from mpi4py import MPI

from cablefem.dynamics import Checkpoint
from cablefem.io.faults import kill_point

__all__ = ["CHECKPOINT", "case_digest", "write_checkpoint", "read_checkpoint",
           "run_status"]

CHECKPOINT = "checkpoint.npz"


def case_digest(case) -> str:
    """SHA-256 of the case file's text (or of its echo for a case built in Python)."""
    src = Path(case.source)
    data = src.read_bytes() if src.is_file() else repr(case.to_dict()).encode()
    return hashlib.sha256(data).hexdigest()


def write_checkpoint(model, outdir: Path, ck: Checkpoint, digest: str, extra: dict) -> None:
    """Collective: gather the state and write ``checkpoint.npz`` atomically on rank 0."""
    u = model.gather_all(model.u)
    v = model.gather_all(model.v)
    if model.comm.rank == 0:
        tmp = Path(outdir) / (CHECKPOINT + ".tmp.npz")
        np.savez(tmp, u=u, v=v, time=ck.time, step=ck.step, level=ck.level, calm=ck.calm,
                 digest=digest, case=str(model.case.source), **extra)
        kill_point("checkpoint")
        os.replace(tmp, Path(outdir) / CHECKPOINT)
    model.comm.Barrier()


def read_checkpoint(outdir: Path, comm: MPI.Comm = MPI.COMM_WORLD) -> dict:
    """The checkpoint's content on every rank; ValueError if there is none."""
    path = Path(outdir) / CHECKPOINT
    data = None
    if comm.rank == 0 and path.is_file():
        with np.load(path) as z:
            data = {k: z[k] for k in z.files}
    data = comm.bcast(data, root=0)
    if data is None and not comm.bcast(Path(outdir).is_dir() if comm.rank == 0 else None):
        raise ValueError(f"{outdir}: no such folder (--restart takes the output folder of "
                         "an earlier run)")
    if data is None:
        raise ValueError(f"{path}: no checkpoint to restart from (a run writes one every "
                         "dynamics.checkpoint_every steps)")
    data["checkpoint"] = Checkpoint(float(data["time"]), int(data["step"]),
                                    int(data["level"]), int(data["calm"]))
    return data


def run_status(outdir: Path, comm: MPI.Comm = MPI.COMM_WORLD) -> dict:
    """The ``status`` and ``dynamics.t_end`` of the run in ``outdir`` from its
    ``summary.json`` (``{}`` when there is none or it is unreadable); same on every rank."""
    out = None
    if comm.rank == 0:
        import json

        try:
            s = json.loads((Path(outdir) / "summary.json").read_text())
            out = {"status": s.get("status"),
                   "t_end": (s.get("dynamics") or {}).get("t_end")}
        except (OSError, ValueError):
            out = {}
    return comm.bcast(out, root=0)
