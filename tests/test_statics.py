"""Statics of the string against the elastic catenary (docs/theory.md §8) and global
equilibrium; run serially and under mpirun -n 2 (same numbers)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import observed_order
from mpi4py import MPI

from cablefem.cable import CableModel
from cablefem.case import parse_case
from cablefem.catenary import catenary_between
from cablefem.statics import solve_static


def inclined_case(elements: int, **extra) -> dict:
    # an inclined cable in a general direction: chord 100 m horizontal span, 30 m rise,
    # out of the x-z plane; steel strand-like section (SI units)
    d = {"section": {"EA": 2.0e8, "EI": 1.0e3, "mass": 50.0}, "gravity": {"g": 9.81},
         "geometry": {"length": 112.0}, "mesh": {"elements": elements},
         "anchors": [{"name": "a", "position": [0.0, 0.0, 0.0]},
                     {"name": "b", "position": [80.0, 60.0, 30.0]}],
         "solver": {"outer_correction": "none"}}  # the leading order's closed forms
    d.update(extra)
    return d


def _errors(n: int) -> tuple[float, float]:
    model = CableModel(MPI.COMM_WORLD, parse_case(inclined_case(n)))
    solve_static(model)
    u = model.gather_nodal(model.u)
    cat = catenary_between([0, 0, 0], [80, 60, 30], 112.0, 50.0 * 9.81, 2.0e8)
    err_pos = err_t = None
    if model.comm.rank == 0:
        s = model.geometry.stations
        r = model.geometry.points + u
        err_pos = float(np.max(np.linalg.norm(r - cat.position(s), axis=1)))
        chord = np.linalg.norm(np.diff(r, axis=0), axis=1)
        T = 2.0e8 * (chord / np.diff(s) - 1.0)
        s_mid = 0.5 * (s[1:] + s[:-1])
        err_t = float(np.max(np.abs(T - cat.tension(s_mid))) / np.max(cat.tension(s_mid)))
    return model.comm.bcast((err_pos, err_t), root=0)


def test_catenary_convergence_order():
    """Node positions and element tensions converge to the elastic catenary at second order.

    P1 elements with a uniform load are a chain of straight links loaded at the nodes; its
    nodes deviate from the catenary by O(h^2) (the sag of a parabolic arc over one link),
    and the element tension at mid-element is a midpoint value, also O(h^2). The observed
    order over the three finest meshes must lie in [1.8, 2.2] (an order-2 method seen
    through a least-squares fit of 3 points with higher-order terms of relative size h).
    """
    ns = np.array([8, 16, 32, 64])
    errs = np.array([_errors(int(n)) for n in ns])
    h = 1.0 / ns
    p_pos = observed_order(h[1:], errs[1:, 0])
    p_t = observed_order(h[1:], errs[1:, 1])
    assert 1.8 < p_pos < 2.2, (errs, p_pos)
    assert 1.8 < p_t < 2.2, (errs, p_t)
    # absolute size on the finest mesh: 64 links over a 112 m cable with 1.2 m relative
    # sag per link... the estimate h^2 |r''| / 8 with |r''| ~ w/T ~ 1e-2 /m gives ~4e-3 m
    assert errs[-1, 0] < 4e-3


def test_global_equilibrium_and_reactions():
    """The consistent reactions balance the total weight to round-off, and approach the
    catenary's end forces at second order (checked at 1e-3 relative on 40 elements: the
    reaction's O(h^2) error is (h/l)^2 ~ 6e-4 times the tension)."""
    case = parse_case(inclined_case(40))
    model = CableModel(MPI.COMM_WORLD, case)
    st = solve_static(model)
    W = np.array([0, 0, -50.0 * 9.81 * 112.0])
    total = st.anchor_forces.sum(axis=0)
    # the forces of the span at the anchors point into the span: the anchors hold the cable
    # up, N_a + N_b = weight vector (pointing down), to solver tolerance (rtol 1e-10)
    np.testing.assert_allclose(total, W, atol=1e-8 * np.linalg.norm(W))
    cat = catenary_between([0, 0, 0], [80, 60, 30], 112.0, 50.0 * 9.81, 2.0e8)
    Tmax = np.linalg.norm(cat.force_at_p())
    np.testing.assert_allclose(st.anchor_forces[0], cat.force_at_p(), atol=1e-3 * Tmax)
    np.testing.assert_allclose(st.anchor_forces[1], cat.force_at_q(), atol=1e-3 * Tmax)
    assert st.slack_elements == 0


def test_point_mass_kink_and_continuation():
    """A point mass 30 times the cable's weight: Newton from the bare catenary is far off,
    load continuation finds the equilibrium. At the mass the tension vectors of the two
    adjacent elements jump by exactly the mass's weight (nodal equilibrium; the cable's own
    weight there is carried by the consistent load, which is O(h) and accounted for)."""
    d = inclined_case(40)
    d["point_masses"] = [{"s": 56.0, "mass": 30 * 50.0 * 112.0}]
    case = parse_case(d)
    model = CableModel(MPI.COMM_WORLD, case)
    st = solve_static(model)
    W = 9.81 * (50.0 * 112.0 + 30 * 50.0 * 112.0)
    np.testing.assert_allclose(st.anchor_forces.sum(axis=0), [0, 0, -W], atol=1e-8 * W)
    u = model.gather_nodal(model.u)
    if model.comm.rank == 0:
        s = model.geometry.stations
        k = model.geometry.node_at(56.0)
        r = model.geometry.points + u
        t_left, t_right = r[k] - r[k - 1], r[k + 1] - r[k]
        T_left = 2.0e8 * (np.linalg.norm(t_left) / (s[k] - s[k - 1]) - 1)
        T_right = 2.0e8 * (np.linalg.norm(t_right) / (s[k + 1] - s[k]) - 1)
        jump = T_right * t_right / np.linalg.norm(t_right) - T_left * t_left / np.linalg.norm(
            t_left)
        w_node = 50.0 * 9.81 * 0.5 * (s[k + 1] - s[k - 1])  # consistent load at the node
        expected = np.array([0, 0, 30 * 50.0 * 112.0 * 9.81 + w_node])
        # round-off: the tensions are differences of O(1e6) N forces: 1e-9 relative
        np.testing.assert_allclose(jump, expected, rtol=1e-9, atol=1e-9 * expected[2])


def test_taut_weightless_cable_uniform_tension():
    """No gravity, stress-free length shorter than the chord: a straight cable with the
    uniform tension EA (L/l - 1), exactly (the P1 solution is exact for a uniform strain)."""
    d = inclined_case(10, gravity={"g": 0.0})
    d["geometry"] = {"length": 99.0}
    model = CableModel(MPI.COMM_WORLD, parse_case(d))
    st = solve_static(model)
    L = np.linalg.norm([80.0, 60.0, 30.0])
    T = 2.0e8 * (L / 99.0 - 1.0)
    assert st.max_tension == pytest.approx(T, rel=1e-10)
    assert st.min_tension == pytest.approx(T, rel=1e-10)


def test_newton_stops_at_the_round_off_floor_above_its_tolerance():
    """Where the residual's round-off floor lies above ``atol`` (an estimate: the
    94 000-dof roof's floor was 1.4 times its ``atol``), Newton stops once it reaches the
    floor (an iteration without contraction, within ``STAGNATION`` atol), instead of
    wandering there until the noise dips below ``atol`` or ``max_it`` is reached. The floor
    is measured first: Newton (full steps) from the catenary guess with every tolerance
    off, its last 10 of 30 norms; then ``atol`` a tenth of the floor's median: the solve
    must converge within two iterations of the first that reached the floor (Newton's
    quadratic phase ends there; before, it ran to ``max_it`` and failed)."""
    from cablefem.petsc_utils import SNESHistory
    from cablefem.static_newton import make_snes, try_solve

    model = CableModel(MPI.COMM_WORLD, parse_case(inclined_case(40)))

    def solve(options):
        history = SNESHistory(maxlen=100)
        model.scatter_nodal(model.initial_guess(), model.u)
        x = model.u.vector.copy()
        snes, work = make_snes(model, history, petsc_options={
            "snes_rtol": 0.0, "snes_stol": 0.0, "snes_max_it": 30,
            "snes_linesearch_type": "basic", **options})  # full steps: none refused
        try:
            ok, its = try_solve(snes, x, history)
        finally:
            for obj in (snes, *work, x):
                obj.destroy()
        return ok, its, [n for _, n in history.norms]

    _, _, norms = solve({"snes_atol": 0.0})
    assert len(norms) == 31  # every tolerance off: all 30 iterations
    floor = float(np.median(norms[-10:]))
    reached = next(k for k, n in enumerate(norms) if n <= 10.0 * floor)
    ok, its, norms2 = solve({"snes_atol": 0.1 * floor})
    assert ok, norms2
    assert its <= reached + 2, (its, reached, norms2)


@pytest.mark.parametrize("blocks", [False, True])
def test_a_singular_jacobian_at_the_start_goes_to_compression_allowed_at_once(monkeypatch,
                                                                               blocks):
    """The virtual hinges' Newton (``HingeSteps.solve``) from a state whose tension-only
    Jacobian cannot be factored: two neighbouring elements slack (each 10 % shorter than
    stress-free), so their shared node has no stiffness at all (the span's bending off).
    Full steps fail at the first factorisation; the next attempt is compression allowed,
    not the line search, which starts from the same state and would meet the same singular
    Jacobian (on the 94 000-dof roof: a second failed factorisation, and on 2 ranks a new
    gathered LU). Then the tension-only solve converges from the bilateral equilibrium.
    ``blocks``: the static Jacobian a block matrix, as above ``LARGE_ABOVE`` unknowns (its
    block LU must report the singular block as a failed factorisation too)."""
    import cablefem.static_newton as sn
    from cablefem.petsc_utils import SNESHistory
    from cablefem.reactions import AnchorReactions

    if blocks:
        monkeypatch.setattr(sn, "LARGE_ABOVE", 0)
    model = CableModel(MPI.COMM_WORLD, parse_case(inclined_case(
        40, solver={"outer_correction": "none", "span_bending": False})))
    assert model.tension_only
    solve_static(model)
    X = model.V.tabulate_dof_coordinates()  # owned and ghost nodes
    u = model.u.x.array.reshape(-1, 3)
    r = X + u
    k = 20  # the middle node: its neighbours pulled towards it by a tenth of an element
    s = model.geometry.stations
    L0 = float(s[1] - s[0])
    p = model.geometry.points
    idx = {j: np.flatnonzero(np.all(np.isclose(X, p[j], atol=1e-9), axis=1)) for j in
           (k - 1, k, k + 1)}  # this rank's copies of the three nodes
    nodal = model.gather_nodal(model.u)  # collective: rank 0 gets every node
    rk = model.comm.bcast(p[k] + nodal[k] if model.comm.rank == 0 else None, root=0)
    for j in (k - 1, k + 1):
        for i in idx[j]:
            d = rk - r[i]
            u[i] += d * (1.0 - 0.9 * L0 / np.linalg.norm(d))  # 0.9 L0 from node k
    x = model.u.vector.copy()
    model.u.x.scatter_forward()
    history = SNESHistory()
    snes, work = sn.make_snes(model, history)
    assert ("baij" in snes.getJacobian()[0].getType()) == blocks
    calls = []
    real = sn.try_solve

    def counted(s_, x_, h_):
        out = real(s_, x_, h_)
        calls.append((s_, out[0], out[1]))
        return out

    monkeypatch.setattr(sn, "try_solve", counted)
    with AnchorReactions(model) as reaction:
        steps = sn.HingeSteps(model, snes, x, history, reaction)
        try:
            ok, its = steps.solve(1)
            assert ok
            assert calls[0][0] is steps.full and calls[0][1:] == (False, 0)
            assert calls[1][0] is steps.bilateral  # not the line search from the same x
        finally:
            steps.destroy()
            for obj in (snes, *work, x):
                obj.destroy()


def test_a_large_models_static_jacobian_is_a_block_matrix(monkeypatch):
    """Above ``LARGE_ABOVE`` unknowns statics assembles and factors its Jacobian in blocks
    of the node's unknowns (``static_matrix``: cheaper factorisations), here forced on a
    40-element cable: the same equilibrium as with AIJ, the anchor forces within Newton's
    tolerance (1e-10 of the force scale; the two factorisations round differently)."""
    import cablefem.static_newton as sn
    from cablefem.statics import StaticProblem

    case = parse_case(inclined_case(40))
    plain = CableModel(MPI.COMM_WORLD, case)
    with StaticProblem(plain) as problem:
        assert "baij" not in problem.snes.getJacobian()[0].getType()
        F_aij = np.array(problem.solve().anchor_forces)
    monkeypatch.setattr(sn, "LARGE_ABOVE", 0)
    blocked = CableModel(MPI.COMM_WORLD, case)
    with StaticProblem(blocked) as problem:
        assert "baij" in problem.snes.getJacobian()[0].getType()
        F_baij = np.array(problem.solve().anchor_forces)
    assert np.allclose(F_baij, F_aij, rtol=0.0, atol=1e-9 * np.abs(F_aij).max())
