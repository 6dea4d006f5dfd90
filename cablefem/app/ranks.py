"""How many of the launched MPI ranks a command's run uses (``solver.ranks``).

Below about :data:`~cablefem.app.resources.MIN_DOFS_PER_RANK` degrees of freedom per rank a
second rank makes a run slower, not faster: its step is Python and MPI latency, not
arithmetic (the measurements are in :mod:`cablefem.app.resources`). So ``cablefem run`` and
``cablefem modes`` started on several ranks (``solver.ranks = "auto"``, the default) run a
case whose size is known before it is built (a single cable's string: 3 unknowns a node; a
network: 3 a node of its mesh file) and too small for two ranks on rank 0 alone
(``MPI.COMM_SELF``): the very numbers of a run on one rank. The others wait without
spinning (a non-blocking broadcast polled every :data:`POLL` s) for the exit
code, which every rank returns. A run that keeps fewer ranks says so on the console and in
``summary.json`` (``mpi_ranks``, ``mpi_ranks_launched`` and a note). ``solver.ranks =
"all"`` runs on every rank whatever the size; so does a case of unknown size (the rod).
"""

from __future__ import annotations

import logging
import signal
import time

import numpy as np
from mpi4py import MPI

from cablefem.app.resources import MIN_DOFS_PER_RANK

__all__ = ["POLL", "estimate_dofs", "mesh_nodes", "ranks_for", "choose_ranks", "on_ranks",
           "run_sized"]

log = logging.getLogger(__name__)

#: seconds between two polls of a waiting rank (the exit comes at most this much later)
POLL = 0.02


def mesh_nodes(path) -> int | None:
    """The number of nodes a gmsh file declares (the line after ``$Nodes``: its count in
    format 2, its second number in format 4), read without reading the nodes; None when
    the file cannot be read so (a binary format-4 file, a missing one)."""
    try:
        with open(path, "rb") as fh:
            for line in fh:
                if line.strip() == b"$Nodes":
                    head = fh.readline().split()
                    return int(head[1] if len(head) >= 4 else head[0])
    except (OSError, ValueError, IndexError):
        return None
    return None


def estimate_dofs(case, model: str = "string") -> int | None:
    """The degrees of freedom of ``case``'s string (``model`` "string", or "auto" which
    runs it first): 3 a node, ``mesh.elements + 1`` nodes for a single cable, the mesh
    file's nodes for a network; None when not known before the build (the rod)."""
    if model not in ("string", "auto"):
        return None
    if case.network is not None:
        nodes = mesh_nodes(case.network.mesh)
        return None if nodes is None else 3 * nodes
    return 3 * (int(case.mesh.elements) + 1)


def ranks_for(dofs: int | None, size: int) -> int:
    """The ranks that pay off for ``dofs`` unknowns out of ``size``: one when two would
    have fewer than :data:`MIN_DOFS_PER_RANK` each, else all (also when the size is
    unknown). Between the two (8 ranks launched for 30 000 unknowns) all run, with the
    note of :func:`cablefem.app.resources.note_small_problem`."""
    if dofs is None or size == 1 or dofs >= 2 * MIN_DOFS_PER_RANK:
        return size
    return 1


def choose_ranks(case, comm: MPI.Comm, model: str = "string") -> tuple[int, str | None]:
    """How many of ``comm``'s ranks run ``case`` and the note that says why when fewer
    than all (collective: rank 0 reads the mesh file, every rank gets its answer)."""
    if comm.size == 1 or case.solver.ranks == "all":
        return comm.size, None
    dofs = comm.bcast(estimate_dofs(case, model) if comm.rank == 0 else None, root=0)
    used = ranks_for(dofs, comm.size)
    if used == comm.size:
        return used, None
    note = (f"about {dofs} degrees of freedom: run on {used} of the {comm.size} ranks "
            f"launched (below about {MIN_DOFS_PER_RANK} per rank more ranks make a run "
            "slower, not faster); solver.ranks = \"all\" uses every rank")
    return used, note


def _wait(req: MPI.Request) -> None:
    """Complete ``req`` without spinning: poll, sleep between polls. SIGINT and SIGTERM
    are left to the ranks that run (they stop the run and send the exit code)."""
    old = {}
    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            old[sig] = signal.signal(sig, signal.SIG_IGN)
    except ValueError:  # not the main thread: signals stay as they are
        pass
    try:
        while not req.Test():
            time.sleep(POLL)
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


def on_ranks(comm: MPI.Comm, used: int, run) -> int:
    """``run(sub)`` on ``used`` ranks of ``comm``: all of them (``sub`` is ``comm``) or
    rank 0 alone (``sub`` is ``MPI.COMM_SELF``); returns its exit code, rank 0's, on every
    rank of ``comm``. Collective. An exception on rank 0 propagates there (the command
    line's own guard turns it into a code); the code the others return is then 1.

    PETSc and SLEPc are initialised on every rank first: SLEPc initialised on rank 0
    alone (its modes) made rank 0's exit wait in PETSc's garbage collection for a
    collective duplication of ``comm`` that the others, already finalising, never joined
    (PETSc 3.18, Open MPI 4.1)."""
    if used >= comm.size:
        return run(comm)
    if used != 1:
        raise ValueError(f"on_ranks: {used} of {comm.size} ranks (1 or all)")
    from petsc4py import PETSc  # noqa: F401 - initialised on every rank (collective)
    from slepc4py import SLEPc  # noqa: F401

    code = np.array([1], dtype=np.int32)
    try:
        if comm.rank == 0:
            code[0] = run(MPI.COMM_SELF)
    finally:
        _wait(comm.Ibcast(code, root=0))
    return int(code[0])


def run_sized(case, model: str, run, comm: MPI.Comm = MPI.COMM_WORLD) -> int:
    """``run(sub, ranks)`` on the ranks of ``comm`` that pay off for ``case``
    (:func:`choose_ranks`, the note logged on rank 0; ``ranks``: None on all of them, else
    ``{"launched": comm.size, "note": ...}`` for :func:`cablefem.app.run.run_case`); its
    exit code on every rank (:func:`on_ranks`)."""
    used, note = choose_ranks(case, comm, model)
    if note and comm.rank == 0:
        log.info("note: %s", note)
    ranks = {"launched": comm.size, "note": note} if note else None
    return on_ranks(comm, used, lambda sub: run(sub, ranks))
