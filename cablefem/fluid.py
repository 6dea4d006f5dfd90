"""Water and wind on a single cable: Morison's drag, added mass and buoyancy
(``[fluid]``, ``docs/fluid.md``).

Per unit current length, with the fluid velocity ``u_f`` and the relative velocity
``v_r = u_f − ṙ`` split along the cable's current unit tangent ``t`` into ``v_rn`` (normal)
and ``v_rt = (v_r·t) t`` (tangential)::

    drag       f_d = ½ ρ C_dn D |v_rn| v_rn + ½ ρ C_dt π D |v_rt| v_rt
    added mass f_a = −C_an ρ A (r̈ − (r̈·t) t),          A = π D²/4
    buoyancy   f_b = −ρ A g                                below the surface

(the tangential drag acts on the area ``π D`` per length, MoorDyn's convention). The
forces per current length are integrated over the current length, ``λ dx`` on the mesh.
``|x|`` is regularised, ``sqrt(x·x + δ²)`` with ``δ = DELTA_V`` (m/s), so that every force
is smooth and its Jacobian (UFL's derivative) exists at zero relative velocity: Newton
stays quadratic. The free surface switches buoyancy and added mass sharply at the
elevation of the cable's current position.

Statics sees the drag of the steady current on the cable at rest (``v = 0``) and the
buoyancy; dynamics the drag on ``u_f(t) − v`` (``u_f(t)``: the current times the fluid's
time function), added mass and buoyancy. The static drag is a static term; the dynamic one
is added as the difference ``drag(u_f(t) − v) − drag(u_f)`` so that the two together are the
drag on the relative velocity. The added mass enters the mass matrix (modal analysis,
time integrator) and the linearised drag the damping matrix of the modal analysis.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import ufl
from dolfinx import fem
from petsc4py import PETSc

from cablefem import forms

__all__ = ["DELTA_V", "add_fluid_terms", "submerged_weight"]

#: regularisation of |v| in the drag (m/s): far below any relevant relative velocity,
#: the drag at |v| = 10 DELTA_V is within 0.5 % of the exact quadratic law
DELTA_V = 1.0e-4


def _norm(x):
    return ufl.sqrt(ufl.dot(x, x) + DELTA_V**2)


def _drag(rho, k, t, vr):
    vt = ufl.dot(vr, t) * t
    vn = vr - vt
    return 0.5 * rho * (k.cdn_D * _norm(vn) * vn + k.cdt_piD * _norm(vt) * vt)


def submerged_weight(fluid, mass: float, g: float) -> float:
    """Weight per stress-free length less the buoyancy of a fully immersed cable (N/m)."""
    A = np.pi * fluid.diameter**2 / 4
    return mass * g - (fluid.density * g * A if fluid.buoyancy else 0.0)


def add_fluid_terms(model) -> None:
    """Add the fluid's terms to ``model.forms``: ``fluid_static`` (steady drag, buoyancy)
    and ``fluid_dynamic`` (the drag's change with the motion and the fluid's time function,
    added mass). ``model.fluid_factor`` (a Constant) holds the time function's value."""
    fl = model.case.fluid
    mesh, u, v, a, du, t0 = model.mesh, model.u, model.v, model.a, model.du, model.t0
    def const(x):  # Constants: a zero coefficient keeps its term (and the code is reused)
        return fem.Constant(mesh, PETSc.ScalarType(x))

    rho = const(fl.density)
    k = SimpleNamespace(cdn_D=const(fl.cd_normal * fl.diameter),
                        cdt_piD=const(fl.cd_tangential * np.pi * fl.diameter),
                        ma=const(fl.ca_normal * fl.density * np.pi * fl.diameter**2 / 4))
    uf = fem.Constant(mesh, np.asarray(fl.current, dtype=PETSc.ScalarType))
    model.fluid_factor = fem.Constant(mesh, PETSc.ScalarType(fl.time.value(0.0)))
    g = forms.stretch_vector(u, t0)
    lam = ufl.sqrt(ufl.dot(g, g))
    t = g / lam
    A = np.pi * fl.diameter**2 / 4
    wet = 1.0
    if fl.surface is not None:  # elevation along -gravity of the current position
        up = -model.gravity / ufl.sqrt(ufl.dot(model.gravity, model.gravity) + 1e-300)
        x = ufl.SpatialCoordinate(mesh) + u
        wet = ufl.conditional(ufl.lt(ufl.dot(up, x), fl.surface), 1.0, 0.0)
    static = -ufl.inner(_drag(rho, k, t, uf), du) * lam * ufl.dx
    if fl.buoyancy:
        static += ufl.inner(wet * rho * A * model.gravity, du) * lam * ufl.dx
    model.forms.add("fluid_static", static, kind="static")
    drag_change = _drag(rho, k, t, model.fluid_factor * uf - v) - _drag(rho, k, t, uf)
    an = a - ufl.dot(a, t) * t
    dynamic = (-ufl.inner(drag_change, du)
               + wet * k.ma * ufl.inner(an, du)) * lam * ufl.dx
    model.forms.add("fluid_dynamic", dynamic, kind="dynamic")
