"""UFL forms of the 3D extensible string (``docs/theory.md`` §2).

Nothing else lives here: no meshes, no solvers. Every function takes UFL objects and returns
UFL expressions or forms, so that users can add terms (drag, buoyancy, ...) to the residual
that :class:`cablefem.cable.CableModel` exposes.

Kinematics on a 1D mesh embedded in 3D, with ``s`` the arc length of the mesh (the
reference configuration). A single cable's mesh is its stress-free geometry; a network's
mesh is its pretensioned geometry, each cell of stress-free length ``c`` times its mesh
length (``c = 1/(1 + T0/EA)`` for a pretension ``T0``); every function below takes ``c``
(default 1), strains are measured against the stress-free length and masses and
distributed loads are per stress-free length (so they carry a factor ``c`` per mesh length).
With ``c = 1``:

* reference tangent ``t0 = J[:, 0] / |J[:, 0]|`` (``J`` the cell Jacobian),
* ``∂s u = grad(u) t0``, ``∂s r = t0 + ∂s u``, stretch ``λ = |∂s r|``, strain ``v3 = λ − 1``,
* tension ``T = EA v3`` (``EA max(v3, 0)`` for a tension-only cable, the default),
* internal force ``N = T ∂s r / λ``.

Weak form (paper Eq. 16 in weak form), for all admissible ``δu``::

    ∫ m ü·δu ds + ∫ N·∂s δu ds + damping − ∫ f·δu ds − Σ P_i·δu(s_i) = 0
"""

from __future__ import annotations

import ufl

__all__ = ["reference_tangent", "ds_", "stretch_vector", "stretch", "axial_strain",
           "tension", "internal_force", "internal_work", "inertia_work", "load_work",
           "strain_rate", "axial_damping_work", "strain_energy_density"]


def reference_tangent(mesh) -> ufl.core.expr.Expr:
    """Unit tangent of the stress-free reference configuration, ``t0 = dX/ds``."""
    J = ufl.Jacobian(mesh)
    return J[:, 0] / ufl.sqrt(ufl.dot(J[:, 0], J[:, 0]))


def ds_(w, t0):
    """Derivative with respect to stress-free arc length: ``∂s w = grad(w) t0``."""
    return ufl.grad(w) * t0


def stretch_vector(u, t0):
    """``∂s r = t0 + ∂s u``, the current tangent scaled by the stretch."""
    return t0 + ds_(u, t0)


def stretch(u, t0):
    """``λ = |∂s r|``."""
    g = stretch_vector(u, t0)
    return ufl.sqrt(ufl.dot(g, g))


def axial_strain(u, t0, c=1.0):
    """Axial (engineering) strain against the stress-free length, ``v3 = λ/c − 1``."""
    return stretch(u, t0) / c - 1.0


def tension(u, t0, EA, tension_only: bool = True, c=1.0):
    """Tension ``T = EA v3``; a tension-only cable carries no compression (``T >= 0``)."""
    v3 = axial_strain(u, t0, c)
    if tension_only:
        return ufl.conditional(ufl.gt(v3, 0.0), EA * v3, 0.0)
    return EA * v3


def internal_force(u, t0, EA, tension_only: bool = True, c=1.0):
    """Internal force vector ``N = T ∂s r / λ``."""
    g = stretch_vector(u, t0)
    return tension(u, t0, EA, tension_only, c) * g / ufl.sqrt(ufl.dot(g, g))


def internal_work(u, du, t0, EA, tension_only: bool = True, dx=ufl.dx, c=1.0):
    """Internal virtual work ``∫ N · ∂s δu ds`` (``∂s`` along the mesh: the stress-free
    measure ``c ds`` and derivative ``∂s / c`` cancel)."""
    return ufl.inner(internal_force(u, t0, EA, tension_only, c), ds_(du, t0)) * dx


def inertia_work(m, a, du, dx=ufl.dx, c=1.0):
    """Virtual work of the inertia forces ``∫ m ü · δu c ds`` (consistent mass)."""
    return c * m * ufl.inner(a, du) * dx


def load_work(f, du, dx=ufl.dx, c=1.0):
    """Virtual work of a distributed load ``∫ f · δu c ds`` (``f`` per stress-free length)."""
    return c * ufl.inner(f, du) * dx


def strain_rate(u, v, t0, c=1.0):
    """Rate of axial strain ``dv3/dt = (∂s r · ∂s v) / (c λ)``."""
    g = stretch_vector(u, t0)
    return ufl.dot(g, ds_(v, t0)) / ufl.sqrt(ufl.dot(g, g)) / c


def axial_damping_work(u, v, du, t0, EA, beta, dx=ufl.dx, c=1.0):
    """Axial strain-rate damping ``N_d = β EA (dv3/dt) ∂s r / λ`` (model "axial").

    This damps axial stretching only: taut transverse modes stay undamped (docs/theory.md
    §2), which is why it is not the default.
    """
    g = stretch_vector(u, t0)
    nd = beta * EA * strain_rate(u, v, t0, c) * g / ufl.sqrt(ufl.dot(g, g))
    return ufl.inner(nd, ds_(du, t0)) * dx


def strain_energy_density(u, t0, EA, tension_only: bool = True, c=1.0):
    """Strain energy per mesh length, ``c EA v3² / 2`` (tension part only if
    tension-only)."""
    v3 = axial_strain(u, t0, c)
    if tension_only:
        return ufl.conditional(ufl.gt(v3, 0.0), 0.5 * c * EA * v3 * v3, 0.0)
    return 0.5 * c * EA * v3 * v3
