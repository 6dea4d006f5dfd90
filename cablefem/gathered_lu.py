"""A direct solve on one rank of several: the preconditioner matrix gathered onto rank 0,
factored there by PETSc's LU, each right-hand side gathered to rank 0, solved there and the
solution scattered back (a ``pc_type python`` preconditioner, :class:`GatheredLU`).

Why, on the cable networks of this project (docs/benchmarks.md, "One factorisation on one
rank"): their systems are 1D chains with little fill, so a sequential LU of the whole system
costs tens of milliseconds at 1e5 unknowns, while the parallel alternatives lose: a parallel
LU (MUMPS) is 2.5-4 times slower, and local or substructuring preconditioners need many
iterations or, exact (BDDC with every interface node primal), several local solves and
hundreds of coarse-basis solves per factorisation. ``pc_type redundant`` factors the whole
system on every rank; on a 2-core machine the two copies compete for the memory bus and
each factorisation and triangular solve takes about three times as long as one alone. Here
only rank 0 factors and solves; the other ranks wait for it (a few milliseconds a solve),
then go on with their share of the assembly, which is what scales.

Options under the PC's prefix followed by ``gathered_`` reach the sequential solver (e.g.
``-cable_gathered_pc_factor_mat_ordering_type amd``). They are read when the PC reads its
options (``setFromOptions``) and kept: cablefem puts a solver's options into PETSc's
database for that call only (:class:`cablefem.petsc_utils.default_options`), while the
sequential solver is made at the first factorisation (and again after a failed one).
"""

from __future__ import annotations

import ctypes
import time

import numpy as np
from petsc4py import PETSc

__all__ = ["GatheredLU", "PYTHON_TYPE"]

#: the ``pc_python_type`` naming :class:`GatheredLU`
PYTHON_TYPE = "cablefem.gathered_lu.GatheredLU"


#: PETSc's ``PCFailedReason`` values used here (petscpc.h)
PC_NOERROR, PC_FACTOR_OTHER = 0, 4


def _petsc_c():
    """PETSc's C library as ctypes sees it through petsc4py's extension module (its
    dependencies' symbols resolve through it), for the two calls petsc4py 3.18 does not
    bind: ``PCSetFailedReason`` and ``PCGetFailedReason``."""
    lib = ctypes.CDLL(PETSc.__file__)
    lib.PCSetFailedReason.argtypes = [ctypes.c_void_p, ctypes.c_int]
    lib.PCGetFailedReason.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_int)]
    return lib


_LIB = _petsc_c()


def set_failed_reason(pc: PETSc.PC, reason: int) -> None:
    """``PCSetFailedReason``: the KSP that applies ``pc`` then reports
    ``DIVERGED_PC_FAILED`` (and sets its solution to infinity), so that a Newton solver
    stops at once with a failed linear solve, as with PETSc's own LU."""
    _LIB.PCSetFailedReason(pc.handle, int(reason))


def failed_reason(pc: PETSc.PC) -> int:
    """``PCGetFailedReason`` of ``pc`` on this rank (0: none)."""
    out = ctypes.c_int(0)
    _LIB.PCGetFailedReason(pc.handle, ctypes.byref(out))
    return out.value


#: seconds a rank sleeps between two tests of the barrier while it waits for rank 0
POLL = 50e-6


def _wait_idle(comm) -> None:
    """A barrier that waits without spinning: MPI's own waits poll at full speed, so a rank
    waiting for rank 0's factorisation or solve would take a core that rank 0 (or another
    job of the machine) could use. Measured on the 94 000-dof roof on a shared 2-core
    machine: docs/benchmarks.md, "One factorisation on one rank"."""
    if comm.size == 1:
        return
    req = comm.Ibarrier()
    while not req.Test():
        time.sleep(POLL)


class GatheredLU:
    """PETSc python preconditioner: an LU of the whole operator on rank 0 only.

    ``setUp`` gathers the preconditioner matrix onto rank 0 (``MatCreateSubMatrices``, the
    gathered copy reused while the global number of nonzeros stays the same) and factors it
    there; ``apply`` gathers ``x`` onto rank 0, solves there and scatters the solution back.
    A failed factorisation is the PC's failure on every rank (``PCSetFailedReason``: the KSP
    reports ``DIVERGED_PC_FAILED`` and its solution is not finite, so the caller's Newton
    stops at once, as with PETSc's own LU); a failed solve gives a NaN solution on every
    rank; either way a fresh sequential solver is made at the next setUp."""

    def __init__(self, options: dict[str, str] | None = None) -> None:
        #: the sequential solver's options (under its own prefix), as read by
        #: :meth:`setFromOptions`
        self.options: dict[str, str] = dict(options or {})
        self.sub: PETSc.Mat | None = None  # the gathered matrix (rank 0: all rows)
        self.nz = -1.0  # the global nonzeros it was gathered with
        self.ksp: PETSc.KSP | None = None  # the sequential solver (rank 0)
        self.scatter = None  # to rank 0, with its work vectors
        self.comm = None  # the operator's communicator (mpi4py)
        self.x0 = self.y0 = None
        self.failed = False

    def setUp(self, pc: PETSc.PC) -> None:
        _, P = pc.getOperators()
        comm = P.getComm().tompi4py()
        rank = comm.rank
        nz = P.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_allocated"]
        n = P.getSize()[0] if rank == 0 else 0
        rows = PETSc.IS().createStride(n, 0, 1, comm=PETSc.COMM_SELF)
        if self.sub is not None and nz == self.nz:
            P.createSubMatrices(rows, rows, submats=[self.sub])
        else:
            if self.sub is not None:
                self.sub.destroy()
            self.sub = P.createSubMatrices(rows, rows)[0]
            self.nz = nz
        rows.destroy()
        if self.ksp is None or self.failed:
            self._new_ksp(pc)
        reason, error = PC_NOERROR, None
        if rank == 0:
            self.ksp.setOperators(self.sub)
            try:  # an error here must not leave the other ranks waiting
                self.ksp.setUp()
                reason = failed_reason(self.ksp.getPC())  # a zero pivot raises nothing
            except PETSc.Error:
                reason = PC_FACTOR_OTHER
            except Exception as exc:  # noqa: BLE001 - raised again below, on every rank
                error = exc
        # every rank learns the outcome (the others sleep meanwhile): a failed
        # factorisation is the PC's failure on every rank (the KSP reports
        # DIVERGED_PC_FAILED, Newton stops at once); before, the ranks went on with a NaN
        # solution, on which a line search evaluated the residual some 40 times
        outcome = (reason, error is not None)
        if comm.size > 1:
            _wait_idle(comm)
            outcome = comm.bcast(outcome if rank == 0 else None, root=0)
        reason, raised = outcome
        if raised:
            if error is not None:
                raise error
            raise RuntimeError("the gathered LU's set-up failed on rank 0 (its error there)")
        self.failed = reason != PC_NOERROR
        set_failed_reason(pc, reason)

    def setFromOptions(self, pc: PETSc.PC) -> None:
        """Keep the options under ``<PC prefix>gathered_`` that are in the database now,
        for the sequential solver made later (:meth:`_new_ksp`)."""
        prefix = (pc.getOptionsPrefix() or "") + "gathered_"
        self.options = {k: v for k, v in PETSc.Options().getAll().items()
                        if k.startswith(prefix)}

    def fresh(self) -> "GatheredLU":
        """A new preconditioner context with the same options (a PC made anew after a
        failure, :func:`cablefem.static_newton.fresh_pc`)."""
        return type(self)(self.options)

    def _new_ksp(self, pc: PETSc.PC) -> None:
        if self.ksp is not None:
            self.ksp.destroy()
        self.failed = False
        ksp = PETSc.KSP().create(PETSc.COMM_SELF)
        ksp.setOptionsPrefix((pc.getOptionsPrefix() or "") + "gathered_")
        ksp.setType(PETSc.KSP.Type.PREONLY)
        ksp.getPC().setType(PETSc.PC.Type.LU)
        opts = PETSc.Options()
        added = [k for k in self.options if not opts.hasName(k)]  # the database's win
        for k in added:
            opts.setValue(k, self.options[k])
        try:
            ksp.setFromOptions()
        finally:
            for k in added:
                opts.delValue(k)
        self.ksp = ksp

    def apply(self, pc: PETSc.PC, x: PETSc.Vec, y: PETSc.Vec) -> None:
        if self.scatter is None:
            self.scatter, self.x0 = PETSc.Scatter.toZero(x)
            self.y0 = self.x0.duplicate()
            self.comm = x.getComm().tompi4py()
        insert, fwd, rev = (PETSc.InsertMode.INSERT, PETSc.ScatterMode.FORWARD,
                            PETSc.ScatterMode.REVERSE)
        _wait_idle(self.comm)  # rank 0 may still be factoring
        self.scatter.scatter(x, self.x0, insert, fwd)
        if self.x0.getSize():  # rank 0
            if not self.failed:
                try:
                    self.ksp.solve(self.x0, self.y0)
                except PETSc.Error:
                    self.failed = True
            if self.failed or self.ksp.getConvergedReason() < 0 or \
                    not np.all(np.isfinite(self.y0.array_r)):
                self.failed = True
                self.y0.set(np.nan)
        _wait_idle(self.comm)  # the other ranks: while rank 0 solves
        self.scatter.scatter(self.y0, y, insert, rev)

    def view(self, pc: PETSc.PC, viewer: PETSc.Viewer) -> None:
        viewer.printfASCII("  LU of the whole operator on rank 0 (gathered), prefix "
                           f"{(pc.getOptionsPrefix() or '')}gathered_\n")

    def destroy(self, pc: PETSc.PC) -> None:
        # references dropped, not destroyed here: PETSc may call this from PetscFinalize
        # (its garbage cleanup), when destroying petsc4py objects is no longer safe
        self.sub = self.ksp = self.scatter = self.x0 = self.y0 = None
        self.nz = -1.0
