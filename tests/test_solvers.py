"""The time integrator's automatic linear solver (cablefem.petsc_utils) and its overrides give
the same answer: a block (BAIJ) Jacobian against AIJ, and the lagged-LU GMRES route of large
networks against a fresh direct solve at every Newton step."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from cablefem.cable import CableModel
from cablefem.dynamics import _make_ts, integrate
from cablefem.petsc_utils import LARGE_ABOVE, SNESHistory, linear_solver_options
from cablefem.statics import solve_static

LAGGED = {"ksp_type": "gmres", "ksp_rtol": 1e-12, "ksp_max_it": 500,
          "snes_lag_preconditioner": 10, "snes_lag_preconditioner_persists": True}


@pytest.mark.parametrize("n_dofs,size", [(90, 1), (90, 2), (LARGE_ABOVE + 3, 1),
                                         (LARGE_ABOVE + 3, 2)])
def test_automatic_choice(n_dofs, size):
    """Block matrices always; a direct solve for small systems, the factorisation reused by
    GMRES for large ones; in parallel every rank factors the whole system (redundant)."""
    o = linear_solver_options(n_dofs, size)
    assert o["mat_type"] == "baij"
    assert o["pc_type"] == ("lu" if size == 1 else "redundant")
    assert o["ksp_type"] == ("gmres" if n_dofs > LARGE_ABOVE else "preonly")
    assert ("snes_lag_preconditioner" in o) == (n_dofs > LARGE_ABOVE)


def _history(make_case, options):
    case = make_case(motion={"type": "harmonic", "amplitude": [2e-4, 0, 0], "omega": 32.814},
                     solver={"petsc_options": options})
    model = CableModel(MPI.COMM_WORLD, case)
    solve_static(model)
    model.u.x.array[:] = model.u_static.x.array
    ts, (_, J, _) = _make_ts(model, 0.005, 0.9, SNESHistory())  # F, J, the StepNewton
    mat_type, pc = J.getType(), ts.getSNES().getKSP().getPC().getType()
    ts.destroy()
    hist = np.array([f.copy() for _, f in integrate(model, 0.2, 0.005, 0.9, 5)])
    return hist, mat_type, pc


def test_overrides_give_the_same_forces(make_case):
    """Case A with q moving, 40 steps: the default (BAIJ, direct), AIJ, and GMRES with an LU
    lagged over 10 Jacobians give the same anchor forces to 1e-9 of the tension (25 N): all
    converge Newton to rtol 1e-9 (GMRES to 1e-12), so they differ by solver tolerance, not
    by discretisation. The options reach the matrix and the preconditioner."""
    ref, mat_type, pc = _history(make_case, {})
    assert mat_type in ("seqbaij", "mpibaij")
    assert pc == ("lu" if MPI.COMM_WORLD.size == 1 else "redundant")
    aij, mat_type, _ = _history(make_case, {"mat_type": "aij"})
    assert mat_type in ("seqaij", "mpiaij")
    lagged, _, _ = _history(make_case, LAGGED)
    assert np.abs(ref).max() > 20.0  # the history is the tension's, not zeros
    np.testing.assert_allclose(aij, ref, rtol=0, atol=1e-9 * 25.0)
    np.testing.assert_allclose(lagged, ref, rtol=0, atol=1e-9 * 25.0)
