"""A user's term with a whole life, through the one door ``model.forms.add(Term(...))``
(docs/extending.md): its time law is followed in statics and dynamics, its moving mass is
the one the anchor reactions solve with, and it takes part in the modal analysis'
linearisation.

The taut weightless string of dyn_util (T = 1 N, m = 1 kg/m, stretch 1.01, 20 P1
elements): its consistent mass and a uniform added mass ``m_a a·δu`` have the same matrix up
to the factor ``m_a/m``, so the string keeps its discrete modes (sines at the nodes) and
each frequency is that of the bare string times ``sqrt(m/(m + m_a))``.

Runs serially and on 2 MPI ranks (every model is built on COMM_WORLD)."""

from __future__ import annotations

import contextlib

import numpy as np
import pytest
import ufl
from conftest import level_case
from dolfinx import fem
from dyn_util import EA, L0, M, node_value, omega_discrete
from dyn_util import L as CHORD
from mpi4py import MPI
from petsc4py import PETSc

from cablefem.cable import CableModel
from cablefem.case import parse_case
from cablefem.dynamics import integrate
from cablefem.modal import solve_modes
from cablefem.statics import solve_static
from cablefem.terms import Term

N_EL = 20


def _model(n: int = N_EL) -> CableModel:
    return CableModel(MPI.COMM_WORLD, parse_case(level_case(
        EA=EA, EI=1e-6, mass=M, g=0.0, length=L0, chord=CHORD, elements=n)))


def _constant(model, value):
    return fem.Constant(model.mesh, np.asarray(value, dtype=PETSc.ScalarType))


def _nodal(model, f) -> np.ndarray:
    return model.comm.bcast(model.gather_nodal(f), root=0)


# ----------------------------------------------------------------------------- dynamics
@pytest.mark.parametrize("law", ["set_time", "time Constant"])
def test_time_dependent_added_mass_closed_form_and_reactions(law):
    """A uniform added mass ``m_a(t) a·δu`` that switches on at ``t1`` (m_a = m after,
    0 before) through the term's own time law (``set_time``) or the forms' UFL time
    Constant. Released from rest in the first discrete mode (amplitude A at mid-span), the
    trapezoidal rule (rho_inf = 1: alpha_m = alpha_f = 1/2, whose step does not use the
    acceleration it starts from, so a mass that jumps at a step boundary restarts nothing)
    advances the modal coordinate (q, q'/omega) by the rotation 2 atan(omega dt/2) a step,
    exactly for the linear system: q_k = A cos(k th0) up to t1 = N dt, a half period
    (th0 = pi/N: q = -A, q' = 0), then q_k = -A cos((k - N) th1), th1 from
    omega1 = omega0 sqrt(m/(m + m_a)), the frequency halved in its square. A mass that
    never switched on keeps omega0: 0.6 A off within a period.

    Reactions: with its state at each output the integrator solves the equation of motion
    for the acceleration, a = -omega_h(t)^2 u_y in the mode (omega_h(t)^2 = m omega0^2/(m +
    m_a(t))), and the anchors carry the global balance sum N_y = -int (m + m_a(t)) a_y ds
    = m omega0^2 int u_y ds. A mass matrix assembled once, before t1 (the reactions of the
    base commit re-assembled it only for a term named fluid_dynamic), gives twice the
    acceleration after t1 (measured: 1.0 off) and misses the balance by 0.64 of the force
    scale m omega0^2 A L0; the anchors' sum alone would not see it (a mass proportional to
    the string's cancels from the anchor rows).

    Tolerances: the geometric nonlinearity raises the tension by EA (pi A)^2/4 = 2.5e-6 T
    at A = 1e-4, shifting the frequency by at most half that: a phase error of 2 pi 3
    1.2e-6 = 2.3e-5 rad over the three periods run (measured 2.0e-5 A), and the
    acceleration and the anchor forces by a few times 2.5e-6 of themselves with the axial
    motion the stretch drives (measured 6.0e-6, 3.6e-6); 1e-4 covers them with Newton's
    tolerance. The global balance is an identity of the discrete system (the consistent
    mass' rows sum to int m a ds; the internal forces of a translation vanish): to the LU
    solve's round-off (measured 2e-16), 1e-9 of the force scale."""
    m_a, A, half = M, 1e-4, 25  # N = 25 steps a half period of the bare string
    w0 = omega_discrete(N_EL)
    dt = 2.0 / w0 * np.tan(np.pi / (2 * half))  # 2 atan(w0 dt/2) = pi/half exactly
    t1 = half * dt
    switch = t1 - dt / 4  # the law's step: between the residuals at t1 -+ dt/2
    model = _model()
    du = model.du
    if law == "set_time":
        ma = _constant(model, 0.0)

        def set_time(t):
            ma.value = m_a if t > switch else 0.0

        term = Term("added mass", ma * ufl.inner(model.a, du) * ufl.dx, "dynamic",
                    set_time=set_time)
    else:
        ma = m_a * ufl.conditional(ufl.gt(model.forms.time, switch), 1.0, 0.0)
        term = Term("added mass", ma * ufl.inner(model.a, du) * ufl.dx, "dynamic")
    model.forms.add(term)
    assert model.forms.mass_moves  # derived: its mass follows a time law
    model.compile()
    solve_static(model)
    s = model.geometry.stations
    u0 = _nodal(model, model.u)
    shape = np.zeros_like(u0)
    shape[:, 1] = A * np.sin(np.pi * s / L0)
    model.scatter_nodal(u0 + shape, model.u)
    w1 = w0 * np.sqrt(M / (M + m_a))
    th1 = 2.0 * np.arctan(w1 * dt / 2.0)
    steps = half + int(np.ceil(3 * 2 * np.pi / th1))  # three periods after t1
    mid = N_EL // 2
    err_q = err_a = err_sum = err_balance = 0.0
    for t, forces in integrate(model, steps * dt, dt, 1.0, 1):
        k = int(round(t / dt))
        q = A * np.cos(k * np.pi / half) if k <= half else -A * np.cos((k - half) * th1)
        y = node_value(model, model.u, mid, 1)
        err_q = max(err_q, abs(y - q))
        mu = M + (m_a if t > switch else 0.0)
        wh2 = M * w0**2 / mu
        ay = node_value(model, model.a, mid, 1)
        err_a = max(err_a, abs(ay + wh2 * y) / (wh2 * A))
        uy = _nodal(model, model.u)[:, 1]
        ayy = _nodal(model, model.a)[:, 1]
        int_u = np.trapz(uy, s)  # P1 fields: the trapezoidal rule is exact
        int_a = np.trapz(ayy, s)
        scale = M * w0**2 * A * L0
        err_sum = max(err_sum, abs(np.sum(forces[:, 1]) - M * w0**2 * int_u) / scale)
        err_balance = max(err_balance, abs(np.sum(forces[:, 1]) + mu * int_a) / scale)
    assert k == steps
    assert err_q < 1e-4 * A
    assert err_a < 1e-4
    assert err_sum < 1e-4
    assert err_balance < 1e-9


# ----------------------------------------------------------------------------- statics
def test_static_term_follows_its_time_law_from_the_start():
    """A static load ``-q(t)·δu`` whose time law ``q(t) = q0 (1/2 + t)`` is added after the
    model is built (its time already set to 0): it is set to the model's time at once, so
    statics carries q(0) = q0/2 and the anchors the whole of it, sum N_z = int q_z ds =
    q0 L0/2 (the internal forces sum to zero): to Newton's tolerance, 1e-8 of it. Without
    the law called, the load stays at its Constant's value, 0."""
    model = _model()
    q0 = -0.02
    q = _constant(model, [0.0, 0.0, 0.0])

    def set_time(t):
        q.value[:] = [0.0, 0.0, q0 * (0.5 + t)]

    model.forms.add(Term("load", -ufl.inner(q, model.du) * ufl.dx, "static",
                         set_time=set_time))
    assert not model.forms.mass_moves  # a load moves no mass
    model.compile()
    res = solve_static(model)
    assert np.sum(res.anchor_forces[:, 2]) == pytest.approx(q0 * L0 / 2, rel=1e-8)


# ----------------------------------------------------------------------------- modes
@contextlib.contextmanager
def _set(pairs):
    saved = [float(c.value) for c, _ in pairs]
    for c, x in pairs:
        c.value = x
    try:
        yield
    finally:
        for (c, _), x in zip(pairs, saved):
            c.value = x


def test_user_term_takes_part_in_modal_linearisation():
    """A dynamic term with an added mass ``m_a a`` and a transverse spring ``k (u -
    u_static)`` (in y and z), both ramped in by its time law (0 at t = 0) and linearised
    at their full values (its ``linearised`` hook). The modal analysis, at t = 0, must
    enter the hook: with the consistent matrices of both terms proportional to the
    string's mass, the discrete modes stay the sines and omega_j^2 = (m omega_h,j^2 + k)/
    (m + m_a), omega_h,j the bare string's (dyn_util.omega_discrete): each transverse
    frequency in both planes, to the eigensolver's tolerance (1e-12) and round-off: 1e-9,
    as test_modal's taut string. Without the hook, the bare string's (sqrt(2) to 3x off).
    After it the term is back at its time law's values."""
    k, m_a = 25.0, 0.5
    model = _model()
    solve_static(model)
    kc, mc = _constant(model, 0.0), _constant(model, 0.0)
    d, du = model.u - model.u_static, model.du
    transverse = ufl.as_vector([0.0, d[1], d[2]])
    form = (kc * ufl.inner(transverse, du) + mc * ufl.inner(model.a, du)) * ufl.dx

    def set_time(t):  # ramped in over the first second
        r = min(t, 1.0)
        kc.value, mc.value = k * r, m_a * r

    model.forms.add(Term("foundation", form, "dynamic", set_time=set_time,
                         linearised=lambda: _set([(kc, k), (mc, m_a)])))
    model.compile()
    res = solve_modes(model, 4)
    expected = [np.sqrt((M * omega_discrete(N_EL, j) ** 2 + k) / (M + m_a))
                for j in (1, 1, 2, 2)]
    np.testing.assert_allclose(res.omegas, expected, rtol=1e-9)
    assert float(kc.value) == 0.0 and float(mc.value) == 0.0


# ----------------------------------------------------------------------------- dependence
def test_depends_on_is_the_derivative_not_the_presence():
    """``depends_on``: a form depends on a coefficient when its Gateaux derivative there is
    not identically zero. Linear in v: yes; without v: no (no derivative taken); v only in
    a conditional's test with equal branches (d/dv = 0 on both sides): no, though v is in
    the form. The dynamic Jacobian takes its v and a parts exactly where F_dynamic depends
    on them, asked once per part: the undamped string's F_dynamic depends on a (the
    inertia) and not on v, so it has no damping form."""
    from cablefem.terms import depends_on

    model = _model(4)
    u, v, du, dw = model.u, model.v, model.du, model.dw
    assert depends_on(ufl.inner(v, du) * ufl.dx, v, dw)
    assert not depends_on(ufl.inner(u, du) * ufl.dx, v, dw)
    gated = ufl.conditional(ufl.gt(v[0], 0.0), 1.0, 1.0) * du[0] * ufl.dx
    assert v in gated.coefficients() and not depends_on(gated, v, dw)
    assert model.forms.C_form is None
    assert model.forms.J_dynamic.coefficients() == model.forms.F_dynamic.coefficients()
