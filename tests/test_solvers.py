"""The time integrator's automatic linear solver (cablefem.petsc_utils) and its overrides give
the same answer: a block (BAIJ) Jacobian against AIJ and GMRES on a lagged LU, and the route
of large networks (the Jacobian and its factorisation kept over steps) against a fresh direct
solve at every Newton step."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from cablefem.cable import CableModel
from cablefem.dynamics import integrate
from cablefem.gathered_lu import PYTHON_TYPE as GATHERED
from cablefem.petsc_utils import (
    GATHER_ABOVE,
    LARGE_ABOVE,
    SNESHistory,
    keeps_factorisation,
    linear_solver_options,
)
from cablefem.statics import solve_static
from cablefem.timestepper import make_ts

LAGGED = {"ksp_type": "gmres", "ksp_rtol": 1e-12, "ksp_max_it": 500,
          "snes_lag_preconditioner": 10, "snes_lag_preconditioner_persists": True}


@pytest.mark.parametrize("n_dofs,size", [(90, 1), (90, 2), (LARGE_ABOVE + 3, 1),
                                         (LARGE_ABOVE + 3, 2)])
def test_automatic_choice(n_dofs, size):
    """Block matrices and a direct solve always; in parallel every rank factors a small
    system (redundant), a large one is factored on rank 0 only (cablefem.gathered_lu); a
    large system's factorisation is kept over steps (modified Newton: one triangular solve
    an iteration), no longer GMRES on an LU lagged over 10 Jacobians (7 to 8 applications
    of the factorisation a step on the 94 000-dof roof instead of 2.5)."""
    o = linear_solver_options(n_dofs, size)
    assert o["mat_type"] == "baij"
    if size == 1:
        assert o["pc_type"] == "lu"
    elif n_dofs > GATHER_ABOVE:
        assert (o["pc_type"], o["pc_python_type"]) == ("python", GATHERED)
    else:
        assert o["pc_type"] == "redundant"
    assert o["ksp_type"] == "preonly"
    assert "snes_lag_preconditioner" not in o
    assert keeps_factorisation(n_dofs) == (n_dofs > LARGE_ABOVE)
    assert not keeps_factorisation(n_dofs, reuse=False)  # the rod: fresh every iteration


@pytest.mark.single_rank  # the choice of options, the same on any number of ranks
def test_a_large_model_keeps_its_factorisation_over_steps(make_case):
    """A cable of 7 000 elements (21 006 unknowns, above LARGE_ABOVE): its time integrator
    solves directly and keeps the Jacobian over steps (StepNewton's reuse), which a small
    one without a fluid, a seabed or kink corners does not (its Jacobian costs about a
    residual)."""
    from cablefem.stepnewton import JACOBIAN_REUSE

    for elements, reuse in ((7000, JACOBIAN_REUSE), (30, 0)):
        model = CableModel(MPI.COMM_WORLD, make_case(elements=elements))
        assert (3 * (elements + 1) > LARGE_ABOVE) == (elements == 7000)
        ts, (F, J, newton), _ = make_ts(model, 0.005, 0.9, SNESHistory())
        assert ts.getSNES().getKSP().getType() == "preonly"
        assert newton.reuse == reuse
        ts.destroy()


def _history(make_case, options):
    case = make_case(motion={"type": "harmonic", "amplitude": [2e-4, 0, 0], "omega": 32.814},
                     solver={"petsc_options": options})
    model = CableModel(MPI.COMM_WORLD, case)
    solve_static(model)
    model.u.x.array[:] = model.u_static.x.array
    ts, (_, J, _), _ = make_ts(model, 0.005, 0.9, SNESHistory())  # F, J, StepNewton; rows
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


def _roof_net(path):
    """A 2 x 2 saddle net (meshes/make_roof.py, 4 elements per bay, 40 m plan, 1 m saddle),
    written by rank 0 into a folder every rank sees."""
    import importlib.util
    from pathlib import Path

    import meshio

    if MPI.COMM_WORLD.rank == 0:
        root = Path(__file__).resolve().parents[1]
        spec = importlib.util.spec_from_file_location("make_roof",
                                                      root / "meshes" / "make_roof.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        meshio.write(path, mod.roof(2, 4, 40.0, 1.0), file_format="gmsh22", binary=False)
    MPI.COMM_WORLD.Barrier()
    return path


def _net_history(case, comm, options):
    from cablefem.dynamics import DynamicProblem
    from cablefem.network import NetworkModel

    model = NetworkModel(comm, case)
    assert model.node_terms  # the kink corners: their Jacobian is the costly part
    solve_static(model)
    forces = []
    with DynamicProblem(model, 0.005, petsc_options=options) as problem:
        forces.append(problem.anchor_forces().copy())
        for _ in range(40):
            problem.step()
            forces.append(problem.anchor_forces().copy())
        newton = problem.ts.getSNESIterations()
        assemblies = problem.newton.assemblies
        pc = problem.ts.getSNES().getKSP().getPC()
        assert pc.getType() == options.get("pc_type", pc.getType())  # the route asked for
    return np.array(forces), newton, assemblies


def _saddle_case(mesh, petsc_options=None):
    from cablefem.case import parse_case

    return parse_case({
        "title": "roof", "network": {"mesh": str(mesh)},
        "sections": [{"name": "s", "EA": 2e8, "EI": 2e3, "mass": 10.0}],
        "cables": [{"group": "cables_x", "section": "s", "pretension": 1e5},
                   {"group": "cables_y", "section": "s", "pretension": 1e5}],
        "gravity": {"g": 9.81}, "anchors": [{"name": "anchors_x"}, {"name": "anchors_y"}],
        "loads": [{"value": [0.0, 0.0, 1500.0], "time": {"type": "harmonic", "omega": 8.0}}],
        "solver": {"span_bending": False, "petsc_options": petsc_options or {}}})


def _route_against_direct(mpi_tmp_path, route_options, case_options=None):
    """The saddle net's anchor forces over 40 steps on ``route_options`` (all ranks)
    against a fresh Jacobian and a direct solve at every Newton iteration on one rank,
    within the bound of :func:`test_network_route_equals_the_direct_solve`."""
    from cablefem.stepnewton import INCREMENT_RTOL

    mesh = _roof_net(mpi_tmp_path / "roof.msh")
    direct, _, _ = _net_history(_saddle_case(mesh), MPI.COMM_SELF,
                                {"newton_jacobian_reuse": 0, "ksp_type": "preonly"})
    route, newton, assemblies = _net_history(
        _saddle_case(mesh, case_options), MPI.COMM_WORLD, route_options)
    assert assemblies < newton  # the Jacobian kept over steps
    variation = np.abs(np.diff(direct, axis=0)).sum(axis=0)
    assert variation.max() > 1e3  # the load moves the anchor forces (N)
    bound = 10 * 2 * INCREMENT_RTOL * variation + 1e-9 * np.abs(direct).max()
    print("max |route - direct| / bound:", np.max(np.abs(route - direct) / bound))
    assert np.all(np.abs(route - direct) <= bound)


def test_network_route_equals_the_direct_solve(mpi_tmp_path):
    """A saddle net with its kink corners under a harmonic uplift, 40 steps: the route of
    large networks (a direct solve, the Jacobian and its factorisation kept over steps
    while Newton contracts: the default with kink corners), on all ranks (partitioned
    under mpirun), gives the anchor forces of a fresh Jacobian and a direct solve at every
    Newton iteration on one rank. Both stop Newton once its estimated error is below
    INCREMENT_RTOL of the step's displacement increment; a force error of that share of
    each step's force change, summed over the steps, bounds the difference (x 2: both
    runs; x 10: the test is an estimate of the error, not a bound). The default reuses the
    Jacobian: fewer assemblies than Newton iterations (one per iteration before)."""
    _route_against_direct(mpi_tmp_path, {})


def test_lagged_gmres_route_equals_the_direct_solve(mpi_tmp_path):
    """The same with the route large networks took before (GMRES to a tenth of Newton's
    increment test on an LU lagged over 10 Jacobians), still there as an override."""
    from cablefem.stepnewton import INCREMENT_RTOL

    _route_against_direct(mpi_tmp_path, {**LAGGED, "ksp_rtol": 0.1 * INCREMENT_RTOL})


def test_gathered_lu_route_equals_the_direct_solve(mpi_tmp_path):
    """The same with the factorisation of large networks on several ranks: the whole
    system gathered onto rank 0 and factored there (cablefem.gathered_lu), for the time
    steps and for the statics before them (``static_`` options), partitioned under mpirun:
    the anchor forces of the direct solve on one rank, within the same bound."""
    gathered = {"pc_type": "python", "pc_python_type": GATHERED}
    _route_against_direct(mpi_tmp_path, gathered,
                          {"static_" + k: v for k, v in gathered.items()})
