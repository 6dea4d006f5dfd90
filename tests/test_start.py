"""The start of the dynamics at a moving anchor (cablefem.dynamics.initial_velocity): the
cable starts from its static state with the quasi-static velocity field of its anchors'
motion, so the first output row is the static state plus the damping force of that
quasi-static motion (docs/rod.md, "The rod's start-up") and nothing else: no impulse.

Runs serially and on 2 MPI ranks (every model is built on COMM_WORLD; the anchor forces are
the same on every rank)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from cablefem.cable import CableModel
from cablefem.case import load_case, parse_case
from cablefem.dynamics import integrate
from cablefem.rod import BeamModel
from cablefem.statics import solve_static

DEMOS = Path(__file__).resolve().parents[1] / "demos"


def _taut_rod(EA, EI, m, L0, e, beta, A, omega):
    """A weightless rod of stress-free length L0 clamped along its chord L0 (1 + e) (tension
    T = EA e), its end q moving across the chord, u = A sin(omega t) e_z; damping beta K_t
    (= K0 at the static state, where the start is)."""
    return parse_case({
        "title": "taut rod, end moving across", "section": {"EA": EA, "EI": EI, "mass": m},
        "gravity": {"g": 0.0}, "geometry": {"length": L0},
        "damping": {"alpha": 0.0, "beta": beta},
        "anchors": [{"name": "p", "position": [0, 0, 0], "direction": [1.0, 0, 0]},
                    {"name": "q", "position": [L0 * (1 + e), 0, 0], "direction": [-1.0, 0, 0],
                     "motion": {"type": "harmonic", "amplitude": [0, 0, A], "omega": omega,
                                "ramp": 0.0}}]})  # a velocity jump at t = 0, tested


def test_rod_first_rows_are_static_plus_the_quasi_static_damping_force():
    """Taut weightless rod, end q moving across the chord with velocity v0 = A omega at t = 0.

    Quasi-static start: the rod is at its static state (straight, tension T = EA e, no
    moment) and moves with the velocity of the clamped-clamped rod under tension whose end
    q is displaced across the chord. Along the stress-free arc length s (w_s = (1+e) theta,
    M = EI theta_s, transverse force C constant) theta solves
    EI theta_ss - (1+e) T theta = -(1+e) C with theta(0) = theta(L0) = 0, so with
    k^2 = (1+e) T/EI:
        theta = (C/T) (1 - cosh(k (s - L0/2))/cosh(k L0/2)),
        delta = (1+e) (C/T) (L0 - (2/k) tanh(k L0/2))      (the end's displacement),
        M(0) = EI k tanh(k L0/2) C/T.
    The first row is then the static reaction plus the damping force of that motion,
    beta K0 v: a transverse force beta C v0/delta and a moment beta M(0) v0/delta at each
    anchor (opposite forces, equal moments), no change of tension (a transverse motion
    changes it at second order); the acceleration at t = 0 is 0 (a sine's; beta K0 v and
    the static residual vanish in the free rows). The old start (rod at rest, its end
    moving) gave at q a transverse force of 1e3 T, decaying by rho_inf per step.

    Tolerances: the jump to 1e-4 (the rod's shear compliance T/GA = 1e-5; the mesh: the
    jump is the same to 6 digits at refine 0.5, 1, 2); the other components to 1e-9 T
    (Newton's tolerances)."""
    EA, EI, m, L0, e, beta, A, omega = 1e4, 1e-2, 1.0, 1.0, 0.01, 1e-3, 1e-3, 10.0
    T = EA * e
    model = BeamModel(MPI.COMM_WORLD, _taut_rod(EA, EI, m, L0, e, beta, A, omega))
    static = solve_static(model).anchor_forces
    # the static state: straight, tension T, no moment
    np.testing.assert_allclose(static[0], [T, 0, 0, 0, 0, 0], atol=1e-9 * T)
    np.testing.assert_allclose(static[1], [-T, 0, 0, 0, 0, 0], atol=1e-9 * T)

    k = np.sqrt((1 + e) * T / EI)
    C = T / ((1 + e) * (L0 - 2 / k * np.tanh(k * L0 / 2)))  # transverse force per delta
    M0 = EI * k * np.tanh(k * L0 / 2) * C / T  # anchor moment per delta
    v0 = A * omega
    dt = 0.002
    rows = [(t, f.copy()) for t, f in integrate(model, 5 * dt, dt, 0.9, 1)]
    t0, f0 = rows[0]
    assert t0 == 0.0
    jump = f0 - static
    # p is pulled towards +z, q towards -z (the force of the span at the anchor)
    assert jump[0, 2] == pytest.approx(beta * C * v0, rel=1e-4)
    assert jump[1, 2] == pytest.approx(-beta * C * v0, rel=1e-4)
    for i in range(2):
        assert np.linalg.norm(jump[i, 3:]) == pytest.approx(beta * M0 * v0, rel=1e-4)
        np.testing.assert_allclose(jump[i, :2], 0.0, atol=1e-9 * T)
    # both moments turn the same way (the rod's S shape is antisymmetric)
    assert jump[0, 3:] @ jump[1, 3:] > 0
    # the next rows follow the motion smoothly: the tension changes at second order in the
    # end's displacement w <= A omega t, by EA w^2/(2 L0^2) (the chord's stretch) plus
    # inertia's share, inside EA w^2/L0^2; no component changes by more than twice the
    # quasi-static increment over a step (stiffness per delta times A omega dt): inertia's
    # share is inside the factor 2 (the rod's first frequency ~ 31 rad/s, omega = 10)
    step_force = 2 * C * v0 * dt
    step_moment = 2 * M0 * v0 * dt
    prev = f0
    for t, f in rows[1:]:
        dT = EA * (A * omega * t / L0) ** 2 + 1e-9 * T
        assert np.all(np.abs(np.abs(f[:, 0]) - T) < dT)
        assert np.all(np.abs(f[:, 2] - prev[:, 2]) < step_force)
        assert np.all(np.linalg.norm(f[:, 3:] - prev[:, 3:], axis=1) < step_moment)
        prev = f


def _static_forces(model, anc, position):
    """Static anchor forces with ``anc`` moved to ``position`` (the same mesh)."""
    anc.position = position
    model.invalidate_time()
    return solve_static(model).anchor_forces


@pytest.mark.parametrize("kind", ["string", "beam"])
def test_first_row_on_case_a_is_static_plus_damping_of_the_quasi_static_motion(kind):
    """Case A (anchor q moving along the chord, 2e-4 sin(32.814 t)), string and rod.

    At t = 0 the cable is in its static state and moves quasi-statically with q's
    velocity v0 = 2e-4 * 32.814: the first row is the static reaction R_s plus the Rayleigh
    damping force beta K0 v (K0 v is the quasi-static reaction rate, dR/dg v0, computed here
    by central differences of two static solutions with q moved by -+eps along the chord)
    plus the mass-proportional part alpha (M v)_anchor - the mass at the anchor moves with
    v0 -, at most alpha m h1 v0 (h1 the first element), below 1e-8 w l here. So:
        R(0) = R_s + beta v0 dR/dg        to 1e-3 of the jump + alpha m h1 v0
    (1e-3: central differences, error (eps dT/dg / T)^2 ~ 1e-7 with eps = 1e-5 l, and the
    static solutions' Newton tolerance, 1e-10 of the tension, divided by 2 eps). The jump is
    0.09 % of the tension. The old start (cable at rest, q moving) added beta EA v0/h1: 3.6 %
    of the tension on the string (h1 = l/30), 230 % on the rod (h1 = l_a/8), and 77 % of
    the rod's moment at q."""
    case = load_case(DEMOS / "paper_inplane.toml")
    model = (BeamModel(MPI.COMM_WORLD, case, refine=0.5) if kind == "beam"
             else CableModel(MPI.COMM_WORLD, case))
    q = model.anchors[1]
    pos0 = q.position.copy()
    chord = pos0 - model.anchors[0].position
    chord /= np.linalg.norm(chord)
    eps = 1e-5
    plus = _static_forces(model, q, pos0 + eps * chord)
    minus = _static_forces(model, q, pos0 - eps * chord)
    static = _static_forces(model, q, pos0)
    motion = case.anchors[1].motion
    v0 = float(np.asarray(motion.velocity(0.0)) @ chord)
    assert v0 == pytest.approx(2e-4 * 32.814, rel=1e-12)
    damping = case.damping
    expected = static + damping.beta * v0 * (plus - minus) / (2 * eps)
    jump = expected - static
    h_max = float(np.diff(model.geometry.stations).max())  # >= h1
    slack = damping.alpha * case.section.mass * h_max * v0  # the mass-proportional part
    dt = case.dynamics.dt
    t0, f0 = next(iter(integrate(model, dt, dt, case.dynamics.rho_inf, 1)))
    assert t0 == 0.0
    T = np.linalg.norm(static[:, :3], axis=1)
    assert np.all(np.linalg.norm(jump[:, :3], axis=1) > 5e-4 * T)  # a jump is tested
    for i in range(2):
        tol = 1e-3 * np.linalg.norm(jump[i, :3]) + slack
        np.testing.assert_allclose(f0[i, :3], expected[i, :3], rtol=0, atol=tol)
        if kind == "beam":  # the moment, jump ~ -beta v0 M/(2 T) dT/dg: 4e-4 M
            # (the clamp does not turn: the rotation rows carry no mass-proportional part)
            Mj = np.linalg.norm(jump[i, 3:])
            assert Mj > 1e-4 * np.linalg.norm(static[i, 3:])
            np.testing.assert_allclose(f0[i, 3:], expected[i, 3:], rtol=0, atol=1e-3 * Mj)


def _spy_on_the_start(monkeypatch) -> dict:
    """Record what the run passes to ``integrate`` and the velocity at its first output
    (t = 0), gathered on rank 0 (None elsewhere)."""
    import cablefem.app.integration as run_module  # where the run's dynamics stage runs

    seen: dict = {}
    real = run_module.integrate

    def spy(model, *args, **kw):
        seen["initial"] = kw.get("initial")
        for i, (t, forces) in enumerate(real(model, *args, **kw)):
            if i == 0:
                seen["t"], seen["v"] = t, model.gather_nodal(model.v)
            yield t, forces

    monkeypatch.setattr(run_module, "integrate", spy)
    return seen


def _taut_string(initial: str | None) -> dict:
    """A taut weightless string (T = EA e = 100 N, 10 elements) between pinned anchors, q
    moving across the chord, z = A sin(omega t) from t = 0 (velocity A omega at once)."""
    d = {"title": "taut string", "section": {"EA": 1e4, "EI": 1e-6, "mass": 1.0},
         "gravity": {"g": 0.0}, "geometry": {"length": 1.0}, "mesh": {"elements": 10},
         "anchors": [{"name": "p", "position": [0, 0, 0], "type": "pinned"},
                     {"name": "q", "position": [1.01, 0, 0], "type": "pinned",
                      "motion": {"type": "harmonic", "amplitude": [0, 0, 1e-3],
                                 "omega": 10.0, "ramp": 0.0}}],
         "dynamics": {"t_end": 0.004, "dt": 0.002}}
    if initial is not None:
        d["dynamics"]["initial"] = initial
    return d


@pytest.mark.parametrize("initial", [None, "quasi-static", "rest"])
def test_the_start_is_chosen_in_the_case_file(initial, mpi_tmp_path, monkeypatch):
    """dynamics.initial reaches the time integration (default "quasi-static") and is
    echoed in summary.json. On a taut string whose end q starts moving across the chord
    with v0 = A omega: the quasi-static start gives every node the velocity v0 s/l (the
    string follows its end as a straight line: the transverse static tangent is the
    discrete Laplacian T/h, whose solution with v(0) = 0, v(l) = v0 is linear, exact for
    P1), the rest start 0 everywhere but at q; to 1e-9 v0 (the linear solve)."""
    from cablefem.app.run import run_case

    seen = _spy_on_the_start(monkeypatch)
    res = run_case(parse_case(_taut_string(initial)), mpi_tmp_path / "out", figures=False,
                   progress=False)
    want = initial or "quasi-static"
    assert seen["initial"] == want and seen["t"] == 0.0
    assert res.summary["dynamics"]["initial"] == want
    assert res.summary["case"]["dynamics"]["initial"] == want
    if MPI.COMM_WORLD.rank == 0:
        v0 = 1e-3 * 10.0
        s = res.model.geometry.stations
        expected = np.zeros((s.size, 3))
        expected[:, 2] = v0 * s / s[-1] if want == "quasi-static" else 0.0
        expected[-1, 2] = v0
        np.testing.assert_allclose(seen["v"], expected, rtol=0, atol=1e-9 * v0)


def test_a_bad_start_is_refused_naming_the_key():
    from cablefem.case import CaseError

    with pytest.raises(CaseError, match=r"dynamics\.initial"):
        parse_case(_taut_string("at rest"))


@pytest.mark.parametrize("initial", ["quasi-static", "rest"])
def test_the_rod_and_a_network_take_the_start(initial, mpi_tmp_path, monkeypatch):
    """The rod (--model beam) and a network take dynamics.initial as the string does: at
    rest, every node but the moving anchor's has zero velocity (translations and the rod's
    rotations); quasi-static, the network of two cables in line whose two ends move
    together moves as a rigid body (K 1 = 0: every node at v0, exact), and the rod's free
    nodes move (a clamped rod follows its end with bending: no closed form here, only that
    it is not the rest start)."""
    from dataclasses import replace

    from test_network import case_dict, write_mesh

    from cablefem.app.run import run_case
    from cablefem.case.schema import DynamicsSpec

    v0 = 1e-3 * 10.0
    # the rod: the taut rod of the test above, its end q moving across
    seen = _spy_on_the_start(monkeypatch)
    case = replace(_taut_rod(1e4, 1e-2, 1.0, 1.0, 0.01, 1e-3, 1e-3, 10.0),
                   dynamics=DynamicsSpec(0.002, 0.002, 0.9, 1, initial=initial))
    run_case(case, mpi_tmp_path / "rod", figures=False, progress=False, model="beam")
    assert seen["initial"] == initial
    if MPI.COMM_WORLD.rank == 0:
        v = np.asarray(seen["v"])
        free = np.abs(v[1:-1]).max()
        assert (free == 0.0) if initial == "rest" else (free > 0.1 * v0), free
        assert v[-1, 2] == pytest.approx(v0, rel=1e-12)
    # a network: two cables in line (6 + 4 elements), both ends moving together along y
    x = np.linspace(0, 10.0, 11)
    pts = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    cells = np.column_stack([np.arange(10), np.arange(1, 11)])
    mesh = write_mesh(str(mpi_tmp_path / "line.msh"), pts, cells, ["a"] * 6 + ["b"] * 4,
                      {"ends": [0, 10]})
    d = case_dict(mesh, [{"group": "a", "section": "s", "pretension": 1e4},
                         {"group": "b", "section": "s", "pretension": 1e4}], ["ends"],
                  dynamics={"t_end": 0.002, "dt": 0.002, "initial": initial})
    d["anchors"][0]["motion"] = {"type": "harmonic", "amplitude": [0, 1e-3, 0],
                                 "omega": 10.0, "ramp": 0.0}
    seen = _spy_on_the_start(monkeypatch)
    run_case(parse_case(d), mpi_tmp_path / "net", figures=False, progress=False)
    assert seen["initial"] == initial
    if MPI.COMM_WORLD.rank == 0:
        v = np.asarray(seen["v"])
        ends = np.isin(np.arange(len(v)), [0, 10])
        np.testing.assert_allclose(v[ends, 1], v0, rtol=1e-12)
        want = v0 if initial == "quasi-static" else 0.0
        np.testing.assert_allclose(v[~ends], [[0, want, 0]] * int((~ends).sum()), rtol=0,
                                   atol=1e-9 * v0)
