"""Small PETSc helpers shared by the solvers: default options under a prefix, assembly
callbacks, and a record of Newton iterations for error messages."""

from __future__ import annotations

from collections import deque

import numpy as np

from dolfinx import fem
from dolfinx.fem import petsc as fpetsc
from petsc4py import PETSc

__all__ = ["default_options", "case_options", "assemble_residual", "assemble_jacobian",
           "assemble_residual_rows", "assemble_jacobian_rows",
           "SNESHistory",
           "lu_options", "linear_solver_options", "copy_in"]

INSERT, ADD = PETSc.InsertMode.INSERT, PETSc.InsertMode.ADD
FORWARD, REVERSE = PETSc.ScatterMode.FORWARD, PETSc.ScatterMode.REVERSE


#: above this many degrees of freedom the time integrator reuses its factorisations
LARGE_ABOVE = 20_000


def linear_solver_options(n_dofs: int, comm_size: int = 1) -> dict[str, object]:
    """The automatic linear solver of the time integrator's Newton steps.

    Up to :data:`LARGE_ABOVE` degrees of freedom, and in parallel: a direct solve (PETSc's
    LU in serial, MUMPS in parallel). In serial above that size the numeric factorisation
    dominates (measured: 67 ms of a 0.3 s step at 1e5 dofs, ~4 per step), so it is reused:
    GMRES preconditioned by an LU refreshed every 20 Jacobians, across steps
    (``snes_lag_preconditioner``): 0.20 s per step instead of 0.30 s on a 1e5-dof roof
    (``benchmarks/bench_scaling.py``). Measured and rejected on these axially stiff,
    anisotropic systems: algebraic multigrid (GAMG, BoomerAMG: 10-25 times slower),
    block-Jacobi/ILU and additive Schwarz (hundreds of GMRES iterations on 2 ranks), a
    lagged MUMPS (its solves cost 33 ms at 1e5 dofs). Open: MUMPS on 2 ranks (0.49 s per
    step at 1e5 dofs) is slower than PETSc's serial LU (0.19 s) although two independent
    serial runs on this 2-core machine take 0.20 s each: a parallel solver that scales here
    is still to be found. Tried in an experiment (not in the code): PCFIELDSPLIT Schur on the
    partition interface (dofs of cells shared between ranks: 270 at 1e5 dofs; the interior
    block is block-diagonal across ranks, so bjacobi/LU solves it exactly), exact Schur
    complement, preconditioner lagged 20: 0.21 s per step on 2 ranks against 0.18 s for the
    serial default (0.018 s against 0.039 s with MUMPS at 9e3 dofs): the most promising.
    Override with ``-cable_ksp_type``, ``-cable_pc_type``, ``-cable_snes_lag_preconditioner``.
    """
    if n_dofs <= LARGE_ABOVE or comm_size > 1:
        return lu_options(comm_size)
    return {"ksp_type": "gmres", "ksp_rtol": 1e-12, "ksp_max_it": 500, "pc_type": "lu",
            "snes_lag_preconditioner": 20, "snes_lag_preconditioner_persists": "true"}


def lu_options(comm_size: int = 1) -> dict[str, str]:
    """A direct solver: PETSc's own LU in serial (MUMPS costs ~0.3 ms per factorisation of a
    small system, which dominates a 30-element string), MUMPS in parallel."""
    opts = {"ksp_type": "preonly", "pc_type": "lu"}
    if comm_size > 1 and PETSc.Sys.hasExternalPackage("mumps"):
        opts["pc_factor_mat_solver_type"] = "mumps"
    return opts


class default_options:
    """Context manager: put ``defaults`` (and the case file's ``user`` options) under
    ``prefix`` in PETSc's options database for one ``setFromOptions`` call, then take them
    out again, so that they do not leak into the next model built in the same process.
    Options already in the database (the command line) win over both.

    Use::

        with default_options(prefix, {"snes_rtol": 1e-10}, case_options):
            snes.setFromOptions()
    """

    def __init__(self, prefix: str, defaults: dict[str, object],
                 user: dict[str, object] | None = None) -> None:
        self.prefix = prefix
        self.values = {**defaults, **{k.lstrip("-"): v for k, v in (user or {}).items()}}
        self.inserted: list[str] = []

    def __enter__(self):
        opts = PETSc.Options()
        for key, val in self.values.items():
            k = self.prefix + key
            if not opts.hasName(k):
                opts.setValue(k, _fmt(val))
                self.inserted.append(k)
        return self

    def __exit__(self, *exc):
        opts = PETSc.Options()
        for k in self.inserted:
            opts.delValue(k)
        self.inserted.clear()


def case_options(model, solver: str = "") -> dict[str, object]:
    """The case file's ``solver.petsc_options`` meant for one solver: keys that start with
    ``static_`` / ``modal_`` / ``mass_`` go to that solver (without the word), the others to
    the time integrator (``solver=""``)."""
    out = {}
    special = ("static_", "modal_", "mass_")
    for key, val in model.case.solver.petsc_options.items():
        key = key.lstrip("-")
        if solver and key.startswith(solver + "_"):
            out[key[len(solver) + 1:]] = val
        elif not solver and not key.startswith(special):
            out[key] = val
    return out


def _fmt(val: object) -> str:
    if isinstance(val, bool):
        return "true" if val else "false"
    return str(val)


def copy_in(x: PETSc.Vec, f: fem.Function) -> None:
    """Copy a PETSc vector into a Function and update its ghosts."""
    x.copy(f.vector)
    f.vector.ghostUpdate(addv=INSERT, mode=FORWARD)


def assemble_residual(b: PETSc.Vec, F: fem.FormMetaClass, J: fem.FormMetaClass, bcs,
                      x: PETSc.Vec) -> None:
    """Residual with Dirichlet rows ``x - g`` (so Newton drives ``x`` to ``g``)."""
    with b.localForm() as loc:
        loc.set(0.0)
    fpetsc.assemble_vector(b, F)
    fpetsc.apply_lifting(b, [J], [bcs], x0=[x], scale=-1.0)
    b.ghostUpdate(addv=ADD, mode=REVERSE)
    fpetsc.set_bc(b, bcs, x, -1.0)


def assemble_residual_rows(b: PETSc.Vec, F: fem.FormMetaClass, bcs, x: PETSc.Vec) -> None:
    """Residual without lifting; Dirichlet rows hold ``x - g``. Pairs with
    :func:`assemble_jacobian_rows`: Newton is then exact whatever the state of the
    constrained dofs, with no dependence on the Jacobian's parameters (e.g. TS shifts)."""
    with b.localForm() as loc:
        loc.set(0.0)
    fpetsc.assemble_vector(b, F)
    b.ghostUpdate(addv=ADD, mode=REVERSE)
    fpetsc.set_bc(b, bcs, x, -1.0)


def assemble_jacobian_rows(A: PETSc.Mat, J: fem.FormMetaClass, rows: np.ndarray) -> None:
    """Jacobian assembled without boundary conditions, then the constrained *rows* (local
    unrolled indices of owned dofs) replaced by identity rows; their columns are kept."""
    A.zeroEntries()
    fpetsc.assemble_matrix(A, J)
    A.assemble()
    A.zeroRowsLocal(rows, diag=1.0)


def assemble_jacobian(A: PETSc.Mat, J: fem.FormMetaClass, bcs) -> None:
    A.zeroEntries()
    fpetsc.assemble_matrix(A, J, bcs)
    A.assemble()


class SNESHistory:
    """Keeps the last Newton residual norms, for a failure message that says what happened."""

    def __init__(self, maxlen: int = 12) -> None:
        self.norms: deque[tuple[int, float]] = deque(maxlen=maxlen)

    def __call__(self, snes: PETSc.SNES, its: int, norm: float) -> None:
        self.norms.append((its, float(norm)))

    def clear(self) -> None:
        self.norms.clear()

    def text(self) -> str:
        return ", ".join(f"it {i}: |F|={n:.3e}" for i, n in self.norms) or "no iteration"
