"""Water and wind on a cable or a network: Morison's drag, added mass, fluid inertia and
buoyancy (``[fluid]``, ``docs/fluid.md``).

The fluid's velocity is ``u_f = f_t(t) f_z(z) U + u_w(x, t) + u_s(t) + u_t(X, t)``: the
current ``U`` times the profile's factor at the elevation of the cable's current position (a
UFL expression, :func:`_profile_factor`) and the time function, plus the waves, the uniform
velocity history and the turbulence (along the current, optionally across it) at the
nodes' reference positions (:mod:`cablefem.turbulence`; :class:`FluidMotion`, from
:mod:`cablefem.flow`). Per unit current length, with the relative velocity
``v_r = u_f − ṙ`` split along the cable's current unit tangent ``t`` into ``v_rn`` (normal)
and ``v_rt = (v_r·t) t`` (tangential)::

    drag       f_d = ½ ρ C_dn D |v_rn| v_rn + ½ ρ C_dt π D |v_rt| v_rt
    added mass f_a = −C_an ρ A (r̈ − (r̈·t) t) − C_at ρ A ((r̈ − u̇_f)·t) t,  A = π D²/4
    inertia    f_i = (1 + C_an) ρ A (u̇_f − (u̇_f·t) t)
    buoyancy   f_b = −ρ A g

all below the free surface only (the elevation of the current position against the
surface's). ``|x|`` is regularised, ``sqrt(x·x + δ²)`` with ``δ = DELTA_V`` (m/s), so that
every force is smooth and its Jacobian (UFL's derivative) exists at zero relative velocity:
Newton stays quadratic. The waves are P1 functions evaluated at the nodes' positions of the
last converged step (once per step, by the dynamic term's time law, which the model's
``set_time`` calls): their dependence on the position is lagged by a step and not in the
Jacobian.

Statics sees the drag of the steady current on the cable at rest (scaled by the load
factor: the load continuation ramps it) and the buoyancy; dynamics adds the difference
``drag(u_f − v) − drag(f_z U)``, the added mass and the inertia. The modal analysis
linearises about the cable at rest in the steady current (:func:`steady_flow`, the dynamic
term's ``linearised``).
"""

from __future__ import annotations

import contextlib
from types import SimpleNamespace

import numpy as np
import ufl
from dolfinx import fem
from petsc4py import PETSc

from cablefem import forms
from cablefem.flow import POWER_FLOOR, WaveField
from cablefem.jit import mixed_rules
from cablefem.terms import Term
from cablefem.turbulence import TurbulentField, wind_frame
from cablefem.water import water_depth_of

__all__ = ["DELTA_V", "QUADRATURE_DEGREE", "medium_dx", "add_fluid_terms", "submerged_weight",
           "water_depth", "FluidMotion", "steady_flow"]

#: regularisation of |v| in the drag (m/s): far below any relevant relative velocity,
#: the drag at |v| = 10 DELTA_V is within 0.5 % of the exact quadratic law
DELTA_V = 1.0e-4
#: the Gauss rule of the fluid's terms, its degree: 5, 3 points (None: UFL's estimate, 12
#: for the drag, 7 points, shared with every term without a rule of its own): docs/fluid.md,
#: "Quadrature"
QUADRATURE_DEGREE: int | None = 5


def medium_dx(degree: int | None):
    """The cell measure of a term of the medium, integrated with the Gauss rule of
    ``degree`` (None, or an FFCx that cannot compile kernels of several rules
    (:func:`cablefem.jit.mixed_rules`): UFL's estimate, shared with every term without a
    rule of its own)."""
    if degree is None or not mixed_rules():
        return ufl.dx
    return ufl.dx(metadata={"quadrature_degree": degree})


def _norm(x):
    return ufl.sqrt(ufl.dot(x, x) + DELTA_V**2)


def _drag(rho, k, t, vr):
    vt = ufl.dot(vr, t) * t
    vn = vr - vt
    return 0.5 * rho * (k.cdn_D * _norm(vn) * vn + k.cdt_piD * _norm(vt) * vt)


def submerged_weight(fluid, mass: float, g: float, diameter: float | None = None) -> float:
    """Weight per stress-free length less the buoyancy of a fully immersed cable (N/m) of
    ``diameter`` (default the fluid's)."""
    A = np.pi * (fluid.diameter if diameter is None else diameter)**2 / 4
    return mass * g - (fluid.density * g * A if fluid.buoyancy else 0.0)


def _profile_factor(profile, z, const):
    """UFL: the profile's factor at elevation ``z`` (:class:`cablefem.flow.Profile`);
    ``const(x)``: a Constant of value x."""
    if profile is None:
        return 1.0
    if profile.kind == "power":
        height = ufl.max_value(z - profile.ground, POWER_FLOOR * profile.reference)
        # the exponent a Constant: FFCx 0.5 writes a power of a literal exponent out at
        # each use (three components of the current, their derivatives), of a Constant once
        return (height / profile.reference) ** const(profile.exponent)
    f = float(profile.factors[0])
    for z0, z1, slope in profile.segments():
        f = f + float(slope) * (ufl.min_value(ufl.max_value(z, float(z0)), float(z1))
                                - float(z0))
    return f


def water_depth(model) -> float | None:
    """The waves' water depth (m): ``fluid.depth``, else the surface above the seabed, else
    None (deep water)."""
    return water_depth_of(model.case.fluid, getattr(model.case, "seabed", None))


class FluidMotion:
    """The unsteady part of the fluid's velocity and acceleration at the nodes: the waves
    (P1 vector functions, evaluated at the nodes' positions of the last converged state),
    the turbulence (P1 functions at the nodes' reference positions) and the uniform
    velocity history (Constants). :meth:`update` sets them for time t."""

    def __init__(self, model) -> None:
        fl = model.case.fluid
        self.model, self.fluid = model, fl
        mesh = model.mesh
        self.up = -np.asarray(model.case.gravity.direction, dtype=float)
        self.up /= np.linalg.norm(self.up)
        self.depth = water_depth(model)
        self.ramp = fl.ramp()
        self.g = float(model.case.gravity.g)
        self.wave_v = self.wave_a = None
        if fl.waves:
            self.wave_v = fem.Function(model.V, name="wave_velocity")
            self.wave_a = fem.Function(model.V, name="wave_acceleration")
            self.X = model.V.tabulate_dof_coordinates()
            self.waves = WaveField(fl.waves, self.up, fl.surface, self.depth, self.g,
                                   self.ramp)
        self.turb_v = self.turb_a = None
        if fl.turbulence is not None:
            self._init_turbulence(model)
        zero = np.zeros(3, dtype=PETSc.ScalarType)
        self.series_v = fem.Constant(mesh, zero)
        self.series_a = fem.Constant(mesh, zero.copy())

    def _init_turbulence(self, model) -> None:
        """The turbulent field (:class:`cablefem.turbulence.TurbulentField`) at the stations
        chosen among every rank's nodes (the same field on every rank), and the P1
        functions of its fluctuation along the mean wind at this rank's nodes."""
        fl = self.fluid
        X = model.V.tabulate_dof_coordinates()
        points = np.concatenate(model.mesh.comm.allgather(X))
        speed = float(np.linalg.norm(fl.current))
        self.frame = wind_frame(fl.current, self.up, fl.turbulence,
                                str(getattr(model.case, "source", "<dict>")))
        self.turbulence = TurbulentField(fl.turbulence, points, speed,
                                         str(getattr(model.case, "source", "<dict>")))
        self.turb_idx, self.turb_w = self.turbulence.weights(X)
        self.turb_v = fem.Function(model.V, name="turbulence_velocity")
        self.turb_a = fem.Function(model.V, name="turbulence_acceleration")

    @staticmethod
    def _unsteady(series, wave, turb):
        out = series if wave is None else wave + series
        return out if turb is None else out + turb

    def velocity(self):
        """UFL: the unsteady velocity (waves, turbulence and history)."""
        return self._unsteady(self.series_v, self.wave_v, self.turb_v)

    def acceleration(self):
        """UFL: the fluid's acceleration (waves, turbulence and history)."""
        return self._unsteady(self.series_a, self.wave_a, self.turb_a)

    def update(self, t: float) -> None:
        fl = self.fluid
        if fl.velocity is not None:
            self.series_v.value[:] = fl.velocity.velocity(t)
            self.series_a.value[:] = fl.velocity.acceleration(t)
        if self.wave_v is not None:
            bs = self.model.bs
            x = self.X + self.model.u.x.array.reshape(-1, bs)[:, :3]
            vel, acc = self.waves.at(x, t)
            self.wave_v.x.array.reshape(-1, bs)[:, :3] = vel
            self.wave_a.x.array.reshape(-1, bs)[:, :3] = acc
        if self.turb_v is not None:
            bs = self.model.bs
            u, du = self.turbulence.at(t)
            w, i = self.turb_w, self.turb_idx
            for f, x in ((self.turb_v, u), (self.turb_a, du)):
                nodal = np.einsum("mk,mkc->mc", w, x[i])  # (nodes, components)
                f.x.array.reshape(-1, bs)[:, :3] = nodal @ self.frame


@contextlib.contextmanager
def steady_flow(factor, motion: FluidMotion):
    """Within the block the fluid is its steady current (time factor 1, no waves or
    velocity history): the modal analysis linearises about the cable at rest in it (the
    ``fluid_dynamic`` term's ``linearised``). ``factor``: the time function's Constant."""
    parts = [factor, motion.series_v, motion.series_a]
    saved = [np.array(c.value, copy=True) for c in parts]
    funcs = [f for f in (motion.wave_v, motion.wave_a, motion.turb_v, motion.turb_a)
             if f is not None]
    saved_f = [f.x.array.copy() for f in funcs]
    factor.value = 1.0
    for c in parts[1:]:
        c.value[:] = 0.0
    for f in funcs:
        f.x.array[:] = 0.0
    try:
        yield
    finally:
        for c, x in zip(parts, saved):
            c.value = x
        for f, x in zip(funcs, saved_f):
            f.x.array[:] = x


def add_fluid_terms(model) -> None:
    """Add the fluid's terms to ``model.forms``, both forces of the medium (``medium``):
    ``fluid_static`` (steady drag, buoyancy) and ``fluid_dynamic`` (the drag's change with
    the motion, the fluid's time function, waves and velocity history; added mass and
    fluid inertia). The dynamic term's time law sets the time function's value (a
    Constant) and the unsteady flow (:class:`FluidMotion`) whenever the model's time is
    set; it linearises about the steady current (:func:`steady_flow`); its added mass
    turns with the cable (``moves_mass``, derived: it depends on ``u``)."""
    fl = model.case.fluid
    mesh, u, v, a, du, t0 = model.mesh, model.u, model.v, model.a, model.du, model.t0

    def const(x):  # Constants: a zero coefficient keeps its term (and the code is reused)
        return fem.Constant(mesh, PETSc.ScalarType(x))

    dx = medium_dx(QUADRATURE_DEGREE)
    rho = const(fl.density)
    # the diameter of each cable's section (a network's DG0 field: zero on a damper's
    # cells, which the fluid does not see; a single cable's: a Constant)
    D = model.section_field("fluid_diameter", fl.diameter_on)
    A = (np.pi / 4) * D**2
    k = SimpleNamespace(cdn_D=const(fl.cd_normal) * D,
                        cdt_piD=const(fl.cd_tangential * np.pi) * D,
                        ma=const(fl.ca_normal * fl.density) * A,
                        mi=const((1.0 + fl.ca_normal) * fl.density) * A,
                        mt=const(fl.ca_tangential * fl.density) * A)
    factor = fem.Constant(mesh, PETSc.ScalarType(fl.time.value(0.0)))
    motion = FluidMotion(model)
    g = forms.stretch_vector(u, t0)
    lam = ufl.sqrt(ufl.dot(g, g))
    t = g / lam
    up = fem.Constant(mesh, np.asarray(motion.up, dtype=PETSc.ScalarType))
    z = ufl.dot(up, ufl.SpatialCoordinate(mesh) + u)  # elevation of the current position
    uf = fem.Constant(mesh, np.asarray(fl.current, dtype=PETSc.ScalarType)) \
        * _profile_factor(fl.profile, z, const)
    wet = 1.0
    if fl.surface is not None:
        wet = ufl.conditional(ufl.lt(z, fl.surface), 1.0, 0.0)
    # the current's drag is an extra load of statics: the load continuation ramps it
    static = -wet * model.load_factor * ufl.inner(_drag(rho, k, t, uf), du) * lam * dx
    if fl.buoyancy:  # ramped with the weight where statics ramps it (a network)
        ramp = model.load_factor if model.ramp_weight else 1.0
        static += ramp * ufl.inner(wet * rho * A * model.gravity, du) * lam * dx
    model.forms.add(Term("fluid_static", static, "static", medium=True, slow_jacobian=True))
    u_fluid = factor * uf + motion.velocity()
    drag_change = _drag(rho, k, t, u_fluid - v) - _drag(rho, k, t, uf)
    an = a - ufl.dot(a, t) * t
    af = motion.acceleration()
    afn = af - ufl.dot(af, t) * t
    at = ufl.dot(a - af, t) * t  # along the cable, relative to the fluid
    dynamic = wet * (-ufl.inner(drag_change, du) + k.ma * ufl.inner(an, du)
                     - k.mi * ufl.inner(afn, du) + k.mt * ufl.inner(at, du)) * lam * dx

    def set_time(time: float) -> None:
        factor.value = fl.time.value(time)
        motion.update(time)  # waves at the nodes' positions of the last converged state

    model.forms.add(Term("fluid_dynamic", dynamic, "dynamic", set_time=set_time,
                         linearised=lambda: steady_flow(factor, motion), medium=True,
                         slow_jacobian=True))
