"""The output folder of a command: checked before any work, locked while a run writes to it.

:func:`output_lock` is collective. Rank 0 creates the folder if needed, checks that it is a
writable directory, and takes an exclusive ``flock`` on ``<folder>/.cablefem.lock`` (the
file keeps the holder's pid, for the message another run gets); every rank gets the
verdict, and every rank raises :class:`OutdirError` (one line naming the folder and the
problem) when rank 0 could not take it. The lock belongs to the open file: the kernel drops
it when the process ends in any way (also ``kill -9``), so a killed run never leaves a stale
lock, and ``cablefem run --restart DIR`` takes it again. The lock file itself stays.

Within one process the lock is re-entrant (the command line takes it, then
:func:`cablefem.app.run.run_case` takes it again for the same folder); it is released when the
outermost holder leaves.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
from pathlib import Path

from mpi4py import MPI

from cablefem.errors import OutdirError

__all__ = ["OutdirError", "output_lock", "LOCK_NAME"]

LOCK_NAME = ".cablefem.lock"

_held: dict[str, list] = {}  # resolved folder -> [file object, depth] (rank 0 only)


def _take(outdir: Path) -> str | None:
    """Rank 0: check and lock ``outdir``; None on success, else the problem (one line)."""
    if outdir.exists() and not outdir.is_dir():
        return f"output folder {outdir}: not a directory (it is a file)"
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        return f"output folder {outdir}: not a directory (a part of the path is a file)"
    except OSError as err:
        return f"output folder {outdir}: cannot be created ({err.strerror})"
    key = str(outdir.resolve())
    if key in _held:
        _held[key][1] += 1
        return None
    path = outdir / LOCK_NAME
    # os.access says yes to root on a read-only folder: create a file to find out for real
    try:
        fh = open(path, "a+")
    except OSError as err:
        return f"output folder {outdir}: not writable ({err.strerror})"
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as err:
        if err.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
            fh.close()
            return f"output folder {outdir}: cannot be locked ({err.strerror})"
        fh.seek(0)
        pid = fh.read().strip() or "unknown"
        fh.close()
        return (f"output folder {outdir}: in use by another run (pid {pid}); wait for it "
                "to end or choose another folder")
    try:
        fh.seek(0)
        fh.truncate()
        fh.write(f"{os.getpid()}\n")
        fh.flush()
        probe = outdir / f".cablefem.probe.{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as err:
        fh.close()
        return f"output folder {outdir}: not writable ({err.strerror})"
    _held[key] = [fh, 1]
    return None


def _release(outdir: Path) -> None:
    key = str(outdir.resolve())
    entry = _held.get(key)
    if entry is None:
        return
    entry[1] -= 1
    if entry[1] == 0:
        fh = _held.pop(key)[0]
        fcntl.flock(fh.fileno(), fcntl.LOCK_UN)
        fh.close()


@contextlib.contextmanager
def output_lock(outdir: str | Path, comm: MPI.Comm = MPI.COMM_WORLD):
    """Check ``outdir`` and hold its lock for the ``with`` block (collective).

    Args:
        outdir: The output folder (created if needed).
        comm: MPI communicator.

    Raises:
        OutdirError: On every rank, when rank 0 finds a problem.
    """
    outdir = Path(outdir)
    problem = _take(outdir) if comm.rank == 0 else None
    problem = comm.bcast(problem, root=0)
    if problem is not None:
        raise OutdirError(problem)
    try:
        yield outdir
    finally:
        if comm.rank == 0:
            _release(outdir)
