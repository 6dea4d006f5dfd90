"""The problem objects own their PETSc objects (reachable, under their options prefixes,
destroyed by ``destroy``, a ``with`` block or the end of ``integrate``); stepping by hand,
running and restoring a checkpoint give the same anchor forces; the anchor reactions and
moments are library objects that give what ``run_case`` writes."""

from __future__ import annotations

import csv

import numpy as np
import pytest
from conftest import level_case
from mpi4py import MPI
from petsc4py import PETSc

from cablefem import dynamics
from cablefem.cable import CableModel
from cablefem.case import parse_case
from cablefem.dynamics import DynamicProblem, Interrupted, integrate
from cablefem.modal import ModalProblem, solve_modes
from cablefem.moments import MOMENT_COLUMNS, AnchorMoments
from cablefem.reactions import AnchorReactions
from cablefem.statics import StaticProblem, solve_static

MOTION = {"type": "harmonic", "amplitude": [2e-4, 0, 0], "omega": 32.814}
DAMPING = {"ratio": 0.005, "frequencies": [16.407, 32.814]}
DT = 0.005


def _model(elements=8, **kw):
    case = parse_case(level_case(elements=elements, motion=MOTION, damping=DAMPING, **kw))
    model = CableModel(MPI.COMM_WORLD, case)
    solve_static(model)
    return model


def _same_on_all_ranks(x) -> bool:
    parts = MPI.COMM_WORLD.allgather(x)
    return all(p == parts[0] for p in parts)


# ---------------------------------------------------------------------------- statics
def test_statics_says_its_route_once(caplog):
    """Newton failing from the catenary is part of the method, not news: with at most 1
    Newton iteration (the cable below needs 2), statics takes the relaxation and logs one
    line at INFO, the converged one, naming the route, with no Newton history (before: a
    line per failed attempt with its whole history; three before a converged relaxation
    on a mooring line, 334 iterations); the histories stay at DEBUG."""
    import logging

    model = _model()
    top = logging.getLogger("cablefem")  # it does not propagate after setup_logging
    if not top.propagate:
        top.addHandler(caplog.handler)
    try:
        with caplog.at_level(logging.DEBUG, logger="cablefem"), \
                StaticProblem(model, petsc_options={"snes_max_it": 1}) as problem:
            res = problem.solve()
    finally:
        top.removeHandler(caplog.handler)
    assert res.continuation_steps > 0
    mine = [r for r in caplog.records if r.name == "cablefem.statics"]
    info = [r.getMessage() for r in mine if r.levelno >= logging.INFO]
    assert len(info) == 1 and info[0].startswith("statics: converged"), info
    assert "Newton failed from the elastic catenary, then relaxation from the guess, then " \
           "equilibrium after" in info[0], info
    assert "|F|=" not in info[0]
    assert any("|F|=" in r.getMessage() for r in mine if r.levelno == logging.DEBUG)


def test_static_problem_owns_its_snes_under_its_prefix():
    """Newton from the catenary needs 2 iterations on this cable (the sampled catenary is
    not the discrete equilibrium) and there is no extra load to ramp: with at most 1
    iteration, given through ``petsc_options``, the options database or a prefix of the
    user's, Newton fails and statics takes the relaxation's steps (its own SNES under
    ``<prefix>relax_``) to the same equilibrium (1e-9: both stop at Newton's tolerance);
    without, it converges to solve_static's result exactly (the same operations)."""
    model = _model()
    ref = solve_static(model).anchor_forces

    def relaxed(problem):
        res = problem.solve()
        assert res.continuation_steps > 0  # Newton alone did not get there
        np.testing.assert_allclose(res.anchor_forces, ref, rtol=1e-9, atol=0)

    with StaticProblem(model) as problem:
        assert problem.snes.getOptionsPrefix() == "cable_static_"
        assert problem.snes.getTolerances()[3] == 50  # the default max_it
        res = problem.solve()
        assert res.continuation_steps == 0
        np.testing.assert_array_equal(res.anchor_forces, ref)
    assert problem.snes.handle == 0  # the with block destroyed it
    with StaticProblem(model, petsc_options={"snes_max_it": 1}) as problem:
        assert problem.snes.getTolerances()[3] == 1
        relaxed(problem)
    opts = PETSc.Options()
    opts["cable_static_snes_max_it"] = 1
    try:
        with StaticProblem(model) as problem:
            relaxed(problem)
    finally:
        opts.delValue("cable_static_snes_max_it")
    opts["mine_snes_max_it"] = 1
    try:
        with StaticProblem(model, petsc_options_prefix="mine_") as problem:
            assert problem.snes.getOptionsPrefix() == "mine_"
            relaxed(problem)
        with StaticProblem(model) as problem:  # the default prefix does not see it
            np.testing.assert_array_equal(problem.solve().anchor_forces, ref)
    finally:
        opts.delValue("mine_snes_max_it")


def test_flag_options_without_a_value():
    """``petsc_options={"snes_monitor": None}``: a flag, as ``-cable_static_snes_monitor``
    on the command line (docs/library.md). Before, None became the text "None" and PETSc
    refused the viewer (error 56) before solving. The solve is the same as without it."""
    model = _model()
    ref = solve_static(model).anchor_forces
    with StaticProblem(model, petsc_options={"snes_converged_reason": None,
                                             "snes_monitor": None}) as problem:
        np.testing.assert_array_equal(problem.solve().anchor_forces, ref)


# ---------------------------------------------------------------------------- modes
def test_modal_problem_owns_its_eps():
    """The EPS is reachable with its prefix and options; the frequencies equal
    solve_modes's exactly (the same operations)."""
    model = _model(elements=12)
    ref = solve_modes(model, 3).omegas
    with ModalProblem(model, 3) as problem:
        assert problem.eps.getOptionsPrefix() == "cable_modal_"
        assert problem.eps.getTolerances()[0] == 1e-12  # the default
        np.testing.assert_array_equal(problem.solve().omegas, ref)
    assert problem.eps.handle == 0 and problem.K.handle == 0
    with ModalProblem(model, 3, petsc_options_prefix="m_",
                      petsc_options={"eps_tol": 1e-8}) as problem:
        assert problem.eps.getOptionsPrefix() == "m_"
        assert problem.eps.getTolerances()[0] == 1e-8


# ---------------------------------------------------------------------------- dynamics
def test_dynamic_problem_owns_its_ts_under_its_prefix():
    model = _model()
    with DynamicProblem(model, DT) as problem:
        assert problem.ts.getType() == "alpha2"
        assert problem.ts.getOptionsPrefix() == "cable_"
        assert problem.ts.getSNES().getTolerances()[0] == 1e-9  # the default snes_rtol
    assert problem.ts.handle == 0 and problem.reactions.ksp.handle == 0
    with DynamicProblem(model, DT, petsc_options={"snes_rtol": 1e-7}) as problem:
        assert problem.ts.getSNES().getTolerances()[0] == 1e-7
    opts = PETSc.Options()
    opts["dyn_snes_rtol"] = 1e-6
    try:
        with DynamicProblem(model, DT, petsc_options_prefix="dyn_") as problem:
            assert problem.ts.getOptionsPrefix() == "dyn_"
            assert problem.ts.getSNES().getTolerances()[0] == 1e-6
    finally:
        opts.delValue("dyn_snes_rtol")


def test_breaking_out_of_integrate_destroys_the_ts(monkeypatch):
    """integrate's problem is destroyed when its generator is closed (a ``break``)."""
    made = []

    class Recording(DynamicProblem):
        def __init__(self, *args, **kw):
            super().__init__(*args, **kw)
            made.append(self)

    monkeypatch.setattr(dynamics, "DynamicProblem", Recording)
    model = _model()
    gen = integrate(model, 1.0, DT)
    for k, _ in enumerate(gen):
        if k == 3:
            break
    assert made[0].ts.handle != 0  # still alive: the generator is suspended
    gen.close()
    assert made[0].ts.handle == 0 and made[0].reactions.ksp.handle == 0


def test_step_run_break_and_resume_give_the_same_forces():
    """step() by hand, run() in one go, and run() left with a break and called again
    perform the same operations in the same order: the same anchor forces bit for bit."""
    t_end = 20 * DT
    model = _model()
    u0, v0 = model.u.x.array.copy(), model.v.x.array.copy()

    def reset():
        model.u.x.array[:] = u0
        model.v.x.array[:] = v0

    with DynamicProblem(model, DT) as problem:
        ref = np.array([f for _, f in problem.run(t_end)])
    reset()
    with DynamicProblem(model, DT) as problem:
        by_hand = [problem.anchor_forces()]
        while problem.time < t_end - 1e-9 * DT:
            problem.step(t_end)
            by_hand.append(problem.anchor_forces())
    np.testing.assert_array_equal(np.array(by_hand), ref)
    reset()
    with DynamicProblem(model, DT) as problem:
        parts = []
        for k, (_, f) in enumerate(problem.run(t_end)):
            parts.append(f)
            if k == 7:
                break
        parts += [f for _, f in problem.run(t_end)]
    np.testing.assert_array_equal(np.array(parts), ref)
    assert ref.shape == (21, 2, 3)


def test_checkpoint_restore_is_bit_identical():
    """A problem made from a checkpoint repeats the run that took it, bit for bit (the
    integrator re-estimates its acceleration from (u, v) at the checkpoint in both)."""
    t_end = 30 * DT
    model = _model()
    with DynamicProblem(model, DT) as problem:
        for _ in problem.run(10 * DT):
            pass
        ck = problem.checkpoint()
        ref = np.array([f for _, f in problem.run(t_end)])
    model.u.x.array[:] = 0.0  # the checkpoint holds the state
    model.v.x.array[:] = 0.0
    with DynamicProblem(model, DT, start=ck) as problem:
        assert problem.step_number == 10 and problem.time == ck.time
        again = np.array([f for _, f in problem.run(t_end)])
    assert again.shape == (20, 2, 3)
    np.testing.assert_array_equal(again, ref)
    with DynamicProblem(model, DT) as problem:  # restore() into a running problem
        problem.step()
        problem.restore(ck)
        np.testing.assert_array_equal(np.array([f for _, f in problem.run(t_end)]), ref)


def test_stop_request_stops_all_ranks_after_the_same_step():
    """should_stop True on rank 0 only, from step 3 on: Interrupted on every rank after
    the same step; on one rank at once, on several one step later (the reduction started
    after step 3 is completed after step 4, without a blocking collective per step)."""
    model = _model()
    comm = model.comm
    with DynamicProblem(model, DT) as problem:
        with pytest.raises(Interrupted) as err:
            for _ in problem.run(1.0, should_stop=lambda: comm.rank == 0
                                 and problem.step_number >= 3):
                pass
        step = problem.step_number
    assert _same_on_all_ranks(step) and _same_on_all_ranks(err.value.time)
    assert step == (3 if comm.size == 1 else 4)


# ---------------------------------------------------------------------------- reactions
def test_anchor_reactions_object():
    """The static reaction balances the cable's weight (sum of the anchor forces = -W e_z
    to the Newton tolerance); every rank gets the same array, a new one at every call."""
    model = _model()
    with AnchorReactions(model) as reactions:
        a = reactions.compute(0.0, dynamic=False)
        b = reactions.compute(0.0, dynamic=False)
    assert a is not b and _same_on_all_ranks(a.tolist())
    np.testing.assert_array_equal(a, b)
    # weight m g l = 1; the residual is converged to ~1e-10 of the force scale (25)
    np.testing.assert_allclose(a.sum(axis=0), [0.0, 0.0, -1.0], atol=1e-8)
    assert reactions.ksp.handle == 0


# ---------------------------------------------------------------------------- moments
def test_anchor_moments_give_the_columns_of_anchors_csv(mpi_tmp_path):
    """Case A's anchors.csv from run_case, its forces put through AnchorMoments built from
    the model: the same moment columns (anchors.csv holds the shortest repr of each double,
    read back exactly; the same operations: 1e-12 relative leaves room for none)."""
    from pathlib import Path

    from cablefem.app.report import max_excitation
    from cablefem.app.run import run_case
    from cablefem.case import load_case

    case = load_case(Path(__file__).resolve().parents[1] / "demos" / "paper_inplane.toml")
    res = run_case(case, mpi_tmp_path / "out", MPI.COMM_WORLD, t_end=0.1, modes=0,
                   progress=False, figures=False)
    rows = None
    if MPI.COMM_WORLD.rank == 0:
        with open(mpi_tmp_path / "out" / "anchors.csv", newline="") as fh:
            rows = list(csv.DictReader(fh))
    rows = MPI.COMM_WORLD.bcast(rows, root=0)
    names = [a.name for a in res.model.anchors]
    times = np.array([float(r["time"]) for r in rows if r["anchor"] == names[0]])
    forces = np.array([[float(r[k]) for k in ("Nx", "Ny", "Nz")] for r in rows]
                      ).reshape(times.size, len(names), 3)
    cols = AnchorMoments.from_model(res.model, max_excitation(case)).compute(times, forces)
    assert times.size == 21 and sorted(cols) == ["p", "q"]
    for name, out in cols.items():
        csv_cols = {k: np.array([float(r[k]) if r[k] else np.nan for r in rows
                                 if r["anchor"] == name]) for k in MOMENT_COLUMNS}
        for k in MOMENT_COLUMNS:
            np.testing.assert_allclose(out[k], csv_cols[k], rtol=1e-12, atol=0,
                                       err_msg=f"{name}.{k}")
