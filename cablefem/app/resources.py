"""What a run will need, checked before it starts: memory, and whether MPI ranks pay off.

Memory model of the string (a single cable), from the peak resident memory of
``cablefem run`` (statics, 2 modes, 2 time steps with field output, no figures) on the
development machine (Debian 12, dolfinx 0.5.2, one rank)::

    elements   peak RSS
      10 000     188 MB
     100 000     611 MB
     300 000    1559 MB

The least-squares line through them: ``139 MB + 4.73 kB per element`` (the 300 000 point lies
within 0.6 % of the line through the two others: the cost is linear). Every extra rank
adds its own interpreter, dolfinx and PETSc (the constant). A run is refused when the
estimate times :data:`SAFETY` = 1.5 exceeds ``MemAvailable`` (``/proc/meminfo``) of a node:
the margin covers what the measurement did not include (more modes, figures, a longer
history in memory, other processes starting meanwhile).
"""

from __future__ import annotations

import logging

from mpi4py import MPI

from cablefem.case import Case, CaseError

__all__ = ["BASE_BYTES", "BYTES_PER_ELEMENT", "SAFETY", "estimate_memory", "check_memory",
           "mem_available", "MIN_DOFS_PER_RANK", "note_small_problem"]

log = logging.getLogger(__name__)

BASE_BYTES = 139e6  #: per rank: interpreter, dolfinx, PETSc, compiled forms
BYTES_PER_ELEMENT = 4.73e3  #: measured on one rank, see the module's docstring
SAFETY = 1.5

#: below this many degrees of freedom per rank, more ranks cost more in communication than
#: they gain. Time per step of the dynamics (level cable, 50 steps, summary.json's
#: wall_time) on the development machine (2 cores, shared: load 1.2-2.6 from other work,
#: so +-20 % noise), 1 rank -> 2 ranks:
#:
#: ======  ==========  ===================  ==============
#: dofs    per rank    ms/step 1 -> 2       2 ranks
#: ======  ==========  ===================  ==============
#:    198          99  2.8 -> 3.3, 3.8      1.2-1.4 x slower (demos/fan.toml)
#:  6 003       3 002  9.8 -> 13.9          1.4 x slower
#: 15 003       7 502  18.7 -> 71.2         3.8 x slower
#: 30 003      15 002  45.5 -> 37.4         1.2 x faster
#: 60 003      30 002  67.8 -> 62.9         1.08 x faster
#: 120 003     60 002  200 -> 393, 144 -> 324  2-2.2 x slower (*)
#: ======  ==========  ===================  ==============
#:
#: (*) with the other work using the second core: on this machine a second rank pays off
#: only when a core is free, and then little. Hence the note below about 10 000 per rank,
#: where a second rank did not pay off in any measurement; above it the note stays silent
#: (whether a rank pays off there depends on the machine, not on the problem alone).
MIN_DOFS_PER_RANK = 10_000


def estimate_memory(elements: int, ranks: int = 1) -> float:
    """Estimated peak memory (bytes, all ranks together) of a string run."""
    return ranks * BASE_BYTES + BYTES_PER_ELEMENT * elements


def mem_available() -> float | None:
    """``MemAvailable`` of this node in bytes, None when /proc/meminfo has no such line."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def check_memory(case: Case, comm: MPI.Comm = MPI.COMM_WORLD, model: str = "string"
                 ) -> float | None:
    """Refuse a single-cable string case whose estimate (times :data:`SAFETY`) does not fit
    in the available memory of a node: CaseError naming ``mesh.elements`` on every rank.
    Collective. Returns the estimate (bytes) or None when the model is not covered (a
    network's size is known only from its mesh file; the rod has its own graded mesh)."""
    if model != "string" or case.network is not None or case.mesh is None:
        return None
    n = int(case.mesh.elements)
    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    try:
        # the share of this node: its ranks, each with the base and 1/size of the elements
        need = node.size * (BASE_BYTES + BYTES_PER_ELEMENT * n / comm.size)
        avail = mem_available() if node.rank == 0 else None
    finally:
        node.Free()
    found = comm.gather((need, avail), root=0)
    problem = None
    if comm.rank == 0:
        worst = min(((a, nd) for nd, a in found if a is not None), default=None,
                    key=lambda p: p[0] - SAFETY * p[1])
        if worst is not None and SAFETY * worst[1] > worst[0]:
            a, nd = worst
            problem = (f"{n} elements need about {nd / 1e9:.3g} GB on a node "
                       f"({BASE_BYTES / 1e6:.0f} MB per rank + {BYTES_PER_ELEMENT / 1e3:.2f} "
                       f"kB per element), {SAFETY:g} x that is more than the "
                       f"{a / 1e9:.3g} GB available (MemAvailable); use fewer elements "
                       "(at most about "
                       f"{max(0, int((a / SAFETY - BASE_BYTES * comm.size) / BYTES_PER_ELEMENT)):d}"
                       " here) or more nodes")
    problem = comm.bcast(problem, root=0)
    if problem is not None:
        raise CaseError([("mesh.elements", problem)], case.source)
    return estimate_memory(n, comm.size)


def note_small_problem(dofs: int, comm: MPI.Comm = MPI.COMM_WORLD) -> str | None:
    """A note (logged on rank 0, and returned) when the problem has fewer than
    :data:`MIN_DOFS_PER_RANK` degrees of freedom per rank on more than one rank."""
    if comm.size < 2 or dofs >= MIN_DOFS_PER_RANK * comm.size:
        return None
    msg = (f"{dofs} degrees of freedom on {comm.size} ranks ({dofs // comm.size} per rank): "
           f"below about {MIN_DOFS_PER_RANK} per rank, more ranks make a run slower, not "
           "faster (communication outweighs the work); one rank is likely faster")
    log.info("note: %s", msg)
    return msg
