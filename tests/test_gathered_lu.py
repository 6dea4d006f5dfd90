"""The direct solve on rank 0 of several (cablefem.gathered_lu): the answer of an LU, again
after the matrix's values change, and a failed factorisation reported and then recovered."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from cablefem.gathered_lu import PYTHON_TYPE, GatheredLU

N = 60  # block rows of 3 unknowns, a chain as a cable's


def _chain(shift: float) -> PETSc.Mat:
    """A block-tridiagonal (BAIJ, 3 x 3 blocks) matrix ``shift I + K`` with ``K`` a chain's
    stiffness (1D Laplacian, one row of nodes), distributed over the ranks."""
    A = PETSc.Mat().createBAIJ(((PETSc.DECIDE, 3 * N), (PETSc.DECIDE, 3 * N)), 3, nnz=(3, 2),
                               comm=MPI.COMM_WORLD)
    lo, hi = (r // 3 for r in A.getOwnershipRange())
    for i in range(lo, hi):
        for j in (i - 1, i, i + 1):
            if 0 <= j < N:
                w = (shift + 2.0) if i == j else -1.0
                A.setValuesBlocked([i], [j], w * np.eye(3) + (0.1 * (i == j)) * np.ones(3))
    A.assemble()
    return A


def _solver(A: PETSc.Mat) -> PETSc.KSP:
    opts = PETSc.Options()
    for key, val in {"ksp_type": "preonly", "pc_type": "python",
                     "pc_python_type": PYTHON_TYPE}.items():
        opts.setValue("glu_" + key, val)
    ksp = PETSc.KSP().create(MPI.COMM_WORLD)
    ksp.setOptionsPrefix("glu_")
    ksp.setOperators(A)
    ksp.setFromOptions()
    for key in ("ksp_type", "pc_type", "pc_python_type"):
        opts.delValue("glu_" + key)
    return ksp


def _error(ksp: PETSc.KSP, A: PETSc.Mat) -> float:
    """The relative error of the solve against a known solution."""
    x_true, b = A.createVecs()
    lo, hi = x_true.getOwnershipRange()
    x_true.array[:] = np.sin(0.37 * np.arange(lo, hi)) + 2.0
    A.mult(x_true, b)
    x = x_true.duplicate()
    ksp.setOperators(A)
    ksp.solve(b, x)
    x.axpy(-1.0, x_true)
    return x.norm() / x_true.norm()


def _solve_singular(ksp: PETSc.KSP, A: PETSc.Mat) -> None:
    """Solve with ``A`` whose first node's rows are zero (singular): the solution is not
    finite and the KSP reports the PC's failure, on every rank."""
    S = A.duplicate(copy=True)
    if S.getOwnershipRange()[0] == 0:
        S.setValuesBlocked([0], [0, 1], np.zeros((3, 6)))
    S.assemble()
    x, b = S.createVecs()
    b.set(1.0)
    ksp.setOperators(S)
    ksp.solve(b, x)
    assert not np.any(np.isfinite(x.array))  # on every rank
    # the KSP says so on every rank, as it does for PETSc's own LU (a Newton solver then
    # stops at once instead of line-searching along a NaN direction)
    assert ksp.getConvergedReason() == PETSc.KSP.ConvergedReason.DIVERGED_PCSETUP_FAILED
    for obj in (S, x, b):
        obj.destroy()


def test_gathered_lu_is_a_direct_solve():
    """The solution of a block chain matrix to round-off (its condition number is below 10
    for shift 1: Gershgorin bounds the spectrum to [1, 5.3]; an LU's error is then a few
    1e-16), on any number of ranks; the same after new values in the same pattern (the
    gathered copy reused), with the new matrix's solution, not the old one's."""
    A = _chain(1.0)
    ksp = _solver(A)
    assert ksp.getPC().getType() == "python"
    assert _error(ksp, A) < 1e-13
    B = _chain(3.0)  # other values, same pattern: copied into A
    B.copy(A, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
    assert _error(ksp, A) < 1e-13
    ksp.destroy()


def test_gathered_lu_reports_a_failed_factorisation_then_recovers():
    """A singular matrix (a zero block row) gives a NaN solution on every rank (the caller's
    Newton sees a failed solve, never a wrong finite answer); the next regular matrix is
    solved again to round-off (a fresh factorisation)."""
    A = _chain(1.0)
    ksp = _solver(A)
    assert _error(ksp, A) < 1e-13
    _solve_singular(ksp, A)
    assert _error(ksp, A) < 1e-13
    ksp.destroy()


def test_newton_stops_at_once_when_the_gathered_factorisation_fails():
    """A Newton solver (backtracking line search, as the statics') whose Jacobian cannot
    be factored stops with a failed linear solve after its first residual, as with PETSc's
    own LU. Before, the gathered LU gave a NaN direction without saying so, and the line
    search evaluated the residual at ever shorter NaN steps (41 residuals on the
    94 000-dof roof's statics, on 2 ranks only)."""
    A = _chain(1.0)
    S = A.duplicate(copy=True)
    if S.getOwnershipRange()[0] == 0:
        S.setValuesBlocked([0], [0, 1], np.zeros((3, 6)))  # singular: a zero block row
    S.assemble()
    calls = [0]

    def F(snes, x, f):  # the linear residual S x - 1
        calls[0] += 1
        S.mult(x, f)
        f.shift(-1.0)

    def J(snes, x, jac, pre):
        pass  # S itself

    snes = PETSc.SNES().create(MPI.COMM_WORLD)
    snes.setOptionsPrefix("glusnes_")
    opts = PETSc.Options()
    for key, val in {"snes_linesearch_type": "bt", "ksp_type": "preonly",
                     "pc_type": "python", "pc_python_type": PYTHON_TYPE}.items():
        opts.setValue("glusnes_" + key, val)
    f, x = S.createVecs()
    snes.setFunction(F, f)
    snes.setJacobian(J, S)
    snes.setFromOptions()
    for key in ("snes_linesearch_type", "ksp_type", "pc_type", "pc_python_type"):
        opts.delValue("glusnes_" + key)
    x.set(0.0)
    snes.solve(None, x)
    assert snes.getConvergedReason() == PETSc.SNES.ConvergedReason.DIVERGED_LINEAR_SOLVE
    assert snes.getKSP().getConvergedReason() == \
        PETSc.KSP.ConvergedReason.DIVERGED_PCSETUP_FAILED
    assert calls[0] == 1  # the initial residual only
    for obj in (snes, S, A, f, x):
        obj.destroy()


def test_an_error_in_the_set_up_on_rank_0_is_raised_on_every_rank(monkeypatch):
    """A Python error inside rank 0's part of the set-up (here: a broken check after the
    factorisation) reaches every rank as a failed solve, instead of leaving the other ranks
    waiting for rank 0 (they waited before, in the first collective of the solve)."""
    import cablefem.gathered_lu as glu

    def broken(pc):
        raise ValueError("broken on purpose")

    monkeypatch.setattr(glu, "failed_reason", broken)
    A = _chain(1.0)
    ksp = _solver(A)
    x, b = A.createVecs()
    b.set(1.0)
    # rank 0: its own error; the others: a RuntimeError naming rank 0's set-up
    with pytest.raises(ValueError if MPI.COMM_WORLD.rank == 0 else RuntimeError):
        ksp.solve(b, x)
    monkeypatch.undo()
    assert _error(ksp, A) < 1e-13  # and the next solve works
    for obj in (ksp, A, x, b):
        obj.destroy()


def test_every_direct_solve_of_a_network_on_the_gathered_route(mpi_tmp_path, monkeypatch):
    """The route taken by every direct solve of a large network on several ranks (statics,
    the modal analysis's shift-invert, the reactions' mass solve), forced on the weightless
    fan of tests/test_network.py: its frequencies are the stays' taut-string ones within
    that test's tolerance (the consistent-mass error (pi/k)^2/24 and 3e-4), the modal
    analysis's solves run through the gathered LU."""
    from test_network import fan_case, fan_mesh

    import cablefem.petsc_utils as pu
    from cablefem.case import parse_case
    from cablefem.modal import solve_modes
    from cablefem.network import NetworkModel
    from cablefem.statics import solve_static

    monkeypatch.setattr(pu, "GATHER_ABOVE", 0)
    assert pu.lu_options(2, 10)["pc_python_type"] == PYTHON_TYPE
    mesh = fan_mesh(str(mpi_tmp_path / "fan.msh"))
    model = NetworkModel(MPI.COMM_WORLD, parse_case(fan_case(mesh)))
    calls = []
    monkeypatch.setattr(GatheredLU, "apply", _counted(GatheredLU.apply, calls))
    solve_static(model)
    om = solve_modes(model, 6).omegas
    if MPI.COMM_WORLD.size > 1:  # one rank: PETSc's own LU, as before
        assert len(calls) > 0
    lam = 1 + 2e6 / 9e8
    expected = []
    for xd, zt in [(15.0, 60.0), (30.0, 58.5), (45.0, 57.0)]:
        L = np.hypot(xd - 0.5, zt)
        expected += [np.pi * np.sqrt(2e6 / (37.0 / lam)) / L] * 2
    np.testing.assert_allclose(om, np.sort(expected) * (1 + (np.pi / 10) ** 2 / 24),
                               rtol=3e-4)


def _counted(method, calls):
    def wrapped(self, *args):
        calls.append(1)
        return method(self, *args)
    return wrapped


def test_options_given_for_one_setfromoptions_reach_the_gathered_solver():
    """cablefem puts a solver's options into PETSc's database for its ``setFromOptions``
    call only (:class:`cablefem.petsc_utils.default_options`), e.g. the ``amd`` ordering
    of a large model's LU. The sequential solver on rank 0 is made later (at the first
    factorisation, and again after a failed one): it must still get them. Here the
    sequential KSP's type (observable) stands for them, before and after a failure."""
    from cablefem.petsc_utils import default_options

    A = _chain(1.0)
    ksp = PETSc.KSP().create(MPI.COMM_WORLD)
    ksp.setOptionsPrefix("glu2_")
    ksp.setOperators(A)
    with default_options("glu2_", {"ksp_type": "preonly", "pc_type": "python",
                                   "pc_python_type": PYTHON_TYPE,
                                   "gathered_ksp_type": "richardson",
                                   "gathered_ksp_max_it": 1}):
        ksp.setFromOptions()
    assert not PETSc.Options().hasName("glu2_gathered_ksp_type")  # taken out again
    assert _error(ksp, A) < 1e-13  # richardson, one iteration, LU: exact
    ctx = ksp.getPC().getPythonContext()
    if MPI.COMM_WORLD.rank == 0:
        assert ctx.ksp.getType() == "richardson"
    _solve_singular(ksp, A)  # a failed factorisation: a new sequential solver
    assert _error(ksp, A) < 1e-13
    if MPI.COMM_WORLD.rank == 0:
        assert ctx.ksp.getType() == "richardson"
    ksp.destroy()
