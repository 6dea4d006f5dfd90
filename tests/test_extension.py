"""User terms through the one extension point, ``model.forms.add(name, form, kind)``
(docs/extending.md): every Jacobian is derived again, so a user's dashpot damps at its
closed-form ratio with Newton converging quadratically, a user's static load or spring gives
the equilibrium of the case-file input or of the closed form (also through the bilateral
twin statics uses from a slack guess), and the rod goes through the same object.

Runs serially and on 2 MPI ranks (every model is built on COMM_WORLD)."""

from __future__ import annotations

import contextlib
import logging

import numpy as np
import pytest
import ufl
from conftest import level_case
from dolfinx import fem
from dolfinx.fem import petsc as fpetsc
from dyn_util import node_value, omega_discrete
from mpi4py import MPI
from petsc4py import PETSc

from cablefem.cable import CableModel
from cablefem.case import parse_case
from cablefem.dynamics import DynamicsStats, integrate
from cablefem.rod import BeamModel, p1_product, split
from cablefem.statics import solve_static

# the taut weightless string of dyn_util: T = EA (L/l0 - 1) = 1 at stretch 1.01
EA, L0, CHORD, M = 100.0, 1.0, 1.01, 1.0
T = EA * (CHORD / L0 - 1.0)


def _taut(n: int, **extra) -> dict:
    return level_case(EA=EA, EI=1e-6, mass=M, g=0.0, length=L0, chord=CHORD, elements=n,
                      **extra)


def _constant(model, value):
    return fem.Constant(model.mesh, np.asarray(value, dtype=PETSc.ScalarType))


def _peaks(ts: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Values of the interior maxima of a sampled signal, each from the parabola through
    its three samples."""
    out = []
    for k in range(1, ys.size - 1):
        if ys[k] > ys[k - 1] and ys[k] >= ys[k + 1]:
            y0, y1, y2 = ys[k - 1: k + 2]
            out.append(y1 - (y0 - y2) ** 2 / (8.0 * (y0 - 2.0 * y1 + y2)))
    return np.array(out)


@contextlib.contextmanager
def _statics_log():
    """The messages statics logs meanwhile (a handler on its own logger: the package's
    logger may not propagate to pytest's, once the command-line set-up has run)."""
    logger = logging.getLogger("cablefem.statics")
    messages: list[str] = []
    handler = logging.Handler(logging.INFO)
    handler.emit = lambda record: messages.append(record.getMessage())
    level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    try:
        yield messages
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)


# ----------------------------------------------------------------------------- 1. dashpot
def test_user_dashpot_damps_at_its_ratio_with_newton_at_full_speed():
    """A distributed dashpot ``-c v`` per unit length added as a dynamic term: the consistent
    P1 dashpot matrix is (c/m) M, so the first discrete mode decays on its own with
    zeta = c/(2 m omega_h) (omega_h the exact discrete frequency). Released from that mode at
    rest, the maxima of the mid-span deflection are one damped period apart, and the log
    decrement over N periods, d = ln(y_0/y_N)/N, gives zeta = d/sqrt(4 pi^2 + d^2) exactly.

    Time integration: rho_inf = 1 (no numerical dissipation) is the trapezoidal rule, whose
    step factor z = (1 + lam dt/2)/(1 - lam dt/2) for lam = omega (-zeta + i sqrt(1 -
    zeta^2)) gives the discrete ratio zeta_dt = -Re(log z)/|log z| = zeta (1 - (omega
    dt)^2/6 + O((omega dt)^4)): 2.6e-3 below zeta at 50 steps per period. The measured ratio
    must equal zeta_dt to the sampling error: the vertex of the parabola through three
    samples misses a maximum by at most max|y_ttt| dt^3/(9 sqrt 3) (the quadratic
    interpolation error), with |y_ttt| <= (1.5 omega^4 dt + 3 zeta omega^3) |y| over the
    three samples (within 1.5 dt of the maximum): 4.3e-5 of the peak at omega dt = 2 pi/50;
    two peaks over N = 4 periods (d = 0.31) give 6.8e-5 of zeta;
    bound 1e-4 with the nonlinear frequency shift (A/l)^2 EA/T = 1e-6 and Newton's
    tolerance. And zeta to that plus (omega dt)^2/6.

    Newton: the residual is linear in v and the Jacobian has the dashpot's shift_v part, so
    each step converges in 2 iterations (1 to the tolerance, 1 to see it); a Jacobian
    without it (a term added to F_dynamic without re-deriving J_dynamic, the base commit)
    contracts only by (c/m) dt/2 per iteration and takes 4 at these numbers."""
    n, zeta, per_period, periods = 20, 0.05, 50, 4
    w = omega_discrete(n)
    dt = 2.0 * np.pi / w / per_period
    model = CableModel(MPI.COMM_WORLD, parse_case(_taut(n)))
    c = _constant(model, 2.0 * zeta * M * w)
    model.forms.add("dashpot", c * ufl.inner(model.v, model.du) * ufl.dx, kind="dynamic")
    model.compile()
    solve_static(model)
    s = model.geometry.stations
    shape = np.zeros((s.size, 3))
    shape[:, 1] = 1e-4 * np.sin(np.pi * s / L0)
    u0 = model.comm.bcast(model.gather_nodal(model.u), root=0)
    model.scatter_nodal(u0 + shape, model.u)
    stats = DynamicsStats()
    ts, ys = [], []
    for t, _ in integrate(model, (periods + 1.5) * 2.0 * np.pi / w, dt, 1.0, 1, stats):
        ts.append(t)
        ys.append(node_value(model, model.u, n // 2, 1))
    peaks = _peaks(np.array(ts), np.array(ys))
    assert peaks.size == periods + 1  # the maxima at 1, 2, ... 5 periods
    d = np.log(peaks[0] / peaks[-1]) / periods
    measured = d / np.sqrt(4.0 * np.pi**2 + d**2)
    lam = w * (-zeta + 1j * np.sqrt(1.0 - zeta**2))
    log_z = np.log((1.0 + lam * dt / 2.0) / (1.0 - lam * dt / 2.0))
    zeta_dt = -log_z.real / abs(log_z)
    assert measured == pytest.approx(zeta_dt, rel=1e-4)
    assert measured == pytest.approx(zeta, rel=(w * dt) ** 2 / 6.0 + 1e-4)
    assert stats.newton_iterations / stats.steps <= 3.0, (
        f"{stats.newton_iterations} Newton iterations in {stats.steps} steps")


# ----------------------------------------------------------------------------- Jacobians
def _field(model, scale: float, k: float):
    """A smooth function of the model's space (the same on every rank, ghosts included)."""
    f = fem.Function(model.V)
    bs = model.bs
    f.interpolate(lambda x: np.array([scale * np.sin(k * (i + 1) * x[0] + i)
                                      for i in range(bs)]))
    return f


def _residual(model) -> np.ndarray:
    b = fpetsc.assemble_vector(model.f_dynamic)
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    out = b.array.copy()
    b.destroy()
    return out


def _apply(model, form, d) -> np.ndarray:
    A = fpetsc.assemble_matrix(form)
    A.assemble()
    y = A.createVecLeft()
    A.mult(d.vector, y)
    out = y.array.copy()
    A.destroy()
    y.destroy()
    return out


def _rel(a: np.ndarray, b: np.ndarray, comm) -> float:
    num = comm.allreduce(float(np.sum((a - b) ** 2)))
    den = comm.allreduce(float(np.sum(b**2)))
    return float(np.sqrt(num / den))


def _check_derivatives(model, amplitude: float) -> None:
    """The compiled dynamic Jacobian with shifts (0, 0), (S, 0), (0, S) applied to a field d
    gives dF/du d, dF/du d + S dF/dv d, dF/du d + S dF/da d, and the mass form dF/da d: each
    must match the central difference of the compiled residual in that unknown, to 1e-6.

    In u the step is 1e-4 of the field: truncation O(1e-8) relative, round-off 1e-16 |F| /
    (1e-4 |dF/du d|) below 1e-9. The residual is affine in v and a (inertia, dashpots, added
    masses), where the difference is exact for any step: step 1e3, round-off 1e-16 |F| /
    (1e3 |dF/dv d|) ~ 1e-10 on the rod. S = 1e4 lifts the v and a parts far above the
    round-off of the u part they are separated from (|dF/du d| / |dF/dv d| reaches 1e10 on
    the rod: 1e-16 1e10 / S = 1e-10)."""
    d = _field(model, amplitude, 3.0)
    for w, kv, ka in ((model.v, 1.3, 2.1), (model.a, 0.7, 5.0)):
        w.x.array[:] = _field(model, amplitude * ka, kv).x.array
    fd = {}
    for w, eps in ((model.u, 1e-4), (model.v, 1e3), (model.a, 1e3)):
        base = w.x.array.copy()
        w.x.array[:] = base + eps * d.x.array
        plus = _residual(model)
        w.x.array[:] = base - eps * d.x.array
        minus = _residual(model)
        w.x.array[:] = base
        fd[w.name] = (plus - minus) / (2.0 * eps)
    S = 1e4
    jac = {}
    for sv, sa in ((0.0, 0.0), (S, 0.0), (0.0, S)):
        model.shift_v.value, model.shift_a.value = sv, sa
        jac[sv, sa] = _apply(model, model.j_dynamic, d)
    comm = model.comm
    assert _rel(jac[0.0, 0.0], fd[model.u.name], comm) < 1e-6
    assert _rel((jac[S, 0.0] - jac[0.0, 0.0]) / S, fd[model.v.name], comm) < 1e-6
    assert _rel((jac[0.0, S] - jac[0.0, 0.0]) / S, fd[model.a.name], comm) < 1e-6
    assert _rel(_apply(model, model.m_form, d), fd[model.a.name], comm) < 1e-6


def test_string_jacobians_derive_user_dashpot_and_added_mass():
    """A dashpot c v and an added mass m_a a (dynamic terms) on a taut string near its
    static state: J_dynamic's u, v and a parts and the mass form are the derivatives of
    F_dynamic (_check_derivatives), the added mass in the mass form included."""
    model = CableModel(MPI.COMM_WORLD, parse_case(_taut(12)))
    solve_static(model)
    du, dx = model.du, ufl.dx
    model.forms.add("dashpot", _constant(model, 0.3) * ufl.inner(model.v, du) * dx,
                    kind="dynamic")
    model.forms.add("added mass", _constant(model, 0.4) * ufl.inner(model.a, du) * dx,
                    kind="dynamic")
    model.compile()
    model.u.x.array[:] += _field(model, 1e-3, 5.0).x.array  # off equilibrium, still taut
    _check_derivatives(model, 1e-3)


def _rod_case(**extra) -> dict:
    """A weightless rod clamped along its chord, 0.1 % stretched (T = 10 N)."""
    d = {"title": "rod", "section": {"EA": 1e4, "EI": 1e-3, "GJ": 1e-3, "mass": 1.0},
         "gravity": {"g": 0.0}, "geometry": {"length": 1.0},
         "beam": {"span_elements": 20, "layer_elements": 4.0},
         "anchors": [{"name": "p", "position": [0, 0, 0], "direction": [1.0, 0, 0]},
                     {"name": "q", "position": [1.001, 0, 0], "direction": [-1.0, 0, 0]}]}
    d.update(extra)
    return d


def test_rod_jacobians_derive_user_dashpot_and_added_mass():
    """The rod through the same object: a dashpot on its centre line's velocity and an
    added mass on the rotations' acceleration (dynamic terms, UFL on the split unknowns,
    integrated with the rod's one-point rule, exact for P1 products by p1_product): J_dynamic
    and the mass form are the derivatives of F_dynamic (_check_derivatives). A cell integral
    of more points is refused (FFCx 0.5 cannot compile the Jacobian mixing the rules)."""
    model = BeamModel(MPI.COMM_WORLD, parse_case(_rod_case()))
    solve_static(model)
    (vu, _), (_, aq) = split(model.v), split(model.a)
    duu, dqq = split(model.du)
    t0, mesh, dx = model.t0, model.mesh, model.forms.dx
    with pytest.raises(ValueError, match="one point"):
        model.forms.add("dashpot", ufl.inner(vu, duu) * ufl.dx, kind="dynamic")
    model.forms.add("dashpot", _constant(model, 0.3) * p1_product(vu, duu, t0, mesh) * dx,
                    kind="dynamic")
    model.forms.add("rotary added mass",
                    _constant(model, 0.2) * p1_product(aq, dqq, t0, mesh) * dx, kind="dynamic")
    model.compile()
    model.u.x.array[:] += _field(model, 1e-4, 5.0).x.array
    _check_derivatives(model, 1e-4)


# ----------------------------------------------------------------------------- 2. statics
@pytest.mark.single_rank  # the rod's case (26 s on 2 ranks); a user term's parallel
# assembly: test_static_spring_and_load_closed_form_through_the_bilateral_twin
@pytest.mark.parametrize("kind", ["string", "rod"])
def test_static_load_term_equals_case_load(kind):
    """A distributed load q added as the static term -q.du dx gives the equilibrium of the
    same load in the case file ([[loads]]), to Newton's tolerance (residual 1e-10 of the
    force scale: forces within 1e-8 of the tension, displacements within 1e-8 of the
    deflection); the rod's as well."""
    q = [0.0, 0.3, -0.2]
    if kind == "string":
        def make(loads):
            return CableModel(MPI.COMM_WORLD, parse_case(level_case(elements=20, **loads)))
    else:
        def make(loads):
            return BeamModel(MPI.COMM_WORLD, parse_case(_rod_case(**loads)))
    ref = make({"loads": [{"value": q}]})
    r_ref = solve_static(ref)
    user = make({})
    du_t = split(user.du)[0] if kind == "rod" else user.du
    user.forms.add("load", -ufl.inner(_constant(user, q), du_t) * ufl.dx, kind="static")
    user.compile()
    r_user = solve_static(user)
    scale = np.max(np.abs(r_ref.anchor_forces[:, :3]))
    np.testing.assert_allclose(r_user.anchor_forces, r_ref.anchor_forces, rtol=0,
                               atol=1e-8 * scale)
    a = user.comm.bcast(user.gather_nodal(user.u), root=0)
    b = ref.comm.bcast(ref.gather_nodal(ref.u), root=0)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-8 * np.max(np.abs(b)))


def test_static_spring_and_load_closed_form_through_the_bilateral_twin():
    """A transverse spring to ground k (in y and z) and a load q in y, both static user
    terms, on the taut weightless string: small deflections obey -(T/lam) w'' + k w = q in
    the stress-free coordinate s (lam = L/l0 the stretch, T = 1), so w = (q/k)(1 -
    cosh(b (s - l0/2))/cosh(b l0/2)) with b^2 = k lam/T. Statics starts from a slack guess
    (the stress-free line, u = 0: no element in tension, the tension-only tangent singular),
    so it solves with compression allowed first, i.e. through the bilateral twin, which must
    hold the user terms (its residual vanishes at the solution, as the taut string's
    tension-only one does, to Newton's tolerance).

    Tolerance: the P1 discretisation's nodal error, from its truncation error k h^2 w''/12
    and the maximum principle, is at most (b h)^2/12 (q/k) (1.3e-3 of q/k at b = 5, 40
    elements); the geometric nonlinearity (the tension grows by EA w'^2/2 ~ 1e-5 T) adds
    1e-4 of q/k at most."""
    n, k, qy = 40, 25.0, 2.5e-3
    lam = CHORD / L0
    model = CableModel(MPI.COMM_WORLD, parse_case(_taut(n)))
    u, du, dx = model.u, model.du, ufl.dx
    kk = _constant(model, k)
    model.forms.add("spring", kk * (u[1] * du[1] + u[2] * du[2]) * dx, kind="static")
    model.forms.add("load", -_constant(model, qy) * du[1] * dx, kind="static")
    model.compile()
    model.initial_guess = lambda: np.zeros((n + 1, 3))  # the stress-free line: slack
    with _statics_log() as messages:
        solve_static(model)
    assert any("compression allowed" in m for m in messages)  # the bilateral path taken
    s = model.geometry.stations
    b = np.sqrt(k * lam / T)
    w = qy / k * (1.0 - np.cosh(b * (s - L0 / 2)) / np.cosh(b * L0 / 2))
    got = model.comm.bcast(model.gather_nodal(model.u), root=0)
    h = L0 / n
    np.testing.assert_allclose(got[:, 1], w, rtol=0, atol=((b * h) ** 2 / 12 + 1e-4) * qy / k)
    np.testing.assert_allclose(got[:, 2], 0.0, atol=1e-12)
    # the bilateral residual holds the user terms: it vanishes at the solution (free rows)
    for form in (model.f_static_bilateral, model.f_static):
        r = fpetsc.assemble_vector(form)
        r.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fpetsc.set_bc(r, model.bcs, scale=0.0)
        assert r.norm() < 1e-9 * qy
        r.destroy()
    assert model.f_static_bilateral is not model.f_static  # a twin of its own


# ----------------------------------------------------------------------------- misuse
def test_misuse_is_refused():
    """A static term cannot depend on v (statics has none), a name is taken once, and the
    derived forms cannot be replaced: the way to change them is a term."""
    model = CableModel(MPI.COMM_WORLD, parse_case(_taut(4)))
    term = ufl.inner(model.v, model.du) * ufl.dx
    with pytest.raises(ValueError, match="kind='dynamic'"):
        model.forms.add("dashpot", term, kind="static")
    model.forms.add("dashpot", term, kind="dynamic")
    with pytest.raises(ValueError, match="taken"):
        model.forms.add("dashpot", term, kind="dynamic")
    with pytest.raises(ValueError, match="kind must be"):
        model.forms.add("other", term, kind="damping")
    with pytest.raises(ValueError, match="test function"):
        model.forms.add("energy", ufl.inner(model.v, model.v) * ufl.dx, kind="dynamic")
    with pytest.raises(AttributeError, match="forms.add"):
        model.F_dynamic = model.F_dynamic + term
    with pytest.raises(AttributeError, match="forms.add"):
        model.j_dynamic = None


@pytest.mark.parametrize("kind", ["static", "dynamic"])
def test_a_term_not_linear_in_du_or_a_is_refused_at_add(kind):
    """inner(du, du)*dx was accepted by add and failed in compile() ("too many values to
    unpack"); a dynamic term quadratic in a was accepted silently: both are refused at add,
    naming the term. A term linear in a (an added mass) is accepted."""
    model = CableModel(MPI.COMM_WORLD, parse_case(_taut(4)))
    du, a = model.du, model.a
    with pytest.raises(ValueError, match="'square'.*not linear in the test function"):
        model.forms.add("square", ufl.inner(du, du) * ufl.dx, kind=kind)
    with pytest.raises(ValueError, match="'root'.*not linear in the test function"):
        model.forms.add("root", ufl.sqrt(ufl.inner(du, du) + 1.0) * ufl.dx, kind=kind)
    assert model.forms.user == {}
    if kind == "dynamic":
        with pytest.raises(ValueError, match="'drag_a'.*not linear in the acceleration"):
            model.forms.add("drag_a", ufl.dot(a, a) * du[1] * ufl.dx, kind=kind)
        model.forms.add("added_mass", _constant(model, 0.5) * ufl.inner(a, du) * ufl.dx,
                        kind=kind)
        model.compile()


@pytest.mark.parametrize("from_static", [True, False])
def test_a_spring_from_the_static_state_leaves_it_at_rest(from_static):
    """docs/extending.md: a spring k (u - u_static) added as a dynamic term leaves the
    static state an equilibrium of the dynamics (the taut string at rest stays there to
    round-off, 0.2 s); the spring k u, on the displacement from the stress-free reference,
    pulls the statically stretched string (u_x up to CHORD - L0 = 0.01) back and it moves
    (measured 3.6e-6 m at k = 25 N/m^2: far above round-off)."""
    model = CableModel(MPI.COMM_WORLD, parse_case(_taut(8)))
    disp = model.u - model.u_static if from_static else model.u
    model.forms.add("spring", _constant(model, 25.0) * ufl.inner(disp, model.du) * ufl.dx,
                    kind="dynamic")
    model.compile()
    solve_static(model)
    us = model.comm.bcast(model.gather_nodal(model.u), root=0)
    for _ in integrate(model, 0.2, 0.01, 1.0):
        pass
    moved = np.max(np.abs(model.comm.bcast(model.gather_nodal(model.u), root=0) - us))
    if from_static:
        assert moved <= 1e-12 * (CHORD - L0)
    else:
        assert moved > 1e-7
