"""External dampers (``[[dampers]]``, ``docs/dampers.md``): from the ground to a point of a
single cable (:func:`damper_work`), or a network's dampers between two nodes
(:func:`link_work`).

A damper is a viscous dashpot of coefficient ``c`` with a spring ``k`` in parallel, from the
ground to the cable node at a stress-free distance from one anchor. It is installed on the
cable at rest, so it acts on the motion from the static state::

    f = -c P v - k P (u - u_static)

with ``P = d d^T`` for a given direction ``d``, or, by default, the projector on the plane
normal to the cable at the node, ``P = I - (e+ e+^T + e- e-^T)/2`` with ``e±`` the current
unit tangents of the two elements that meet there (the cable turns at a damper; the mean
keeps the projector independent of the elements' orientation). It enters the dynamic
residual as ``+(c P v + k P (u - u_static)) . du`` at the node: a dynamic term of
:class:`cablefem.forms.CableForms`, whose Jacobians (in ``u`` through ``P``, and in ``v``)
UFL derives. Statics does not see it.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from petsc4py import PETSc

from cablefem import forms

__all__ = ["damper_stations", "damper_work", "link_work"]


def damper_stations(description, length: float) -> list[float]:
    """Stress-free arc length from the first anchor of every damper of a single cable of
    stress-free ``length``; raises ValueError (key, message) pairs for a damper outside."""
    names = [a.name for a in description.anchors]
    out, problems = [], []
    for i, d in enumerate(description.dampers):
        s = d.distance if names.index(d.anchor) == 0 else length - d.distance
        if not 0.0 < s < length:
            problems.append((f"dampers[{i}].distance", f"must be < l = {length:g} m, the "
                             "stress-free length"))
        out.append(float(s))
    if problems:
        raise ValueError(problems)
    return out


def _projector(d, u_t, t0):
    """``d d^T`` for a direction, else the mean normal-plane projector at an interior
    vertex (restrictions of the two cells)."""
    if d is not None:
        return ufl.outer(d, d)
    e = []
    for side in ("+", "-"):
        g = forms.stretch_vector(u_t, t0)(side)
        e.append(g / ufl.sqrt(ufl.dot(g, g)))
    return ufl.Identity(3) - 0.5 * (ufl.outer(e[0], e[0]) + ufl.outer(e[1], e[1]))


def damper_work(mesh, dampers, tags, u_t, v_t, us_t, du_t, t0, dS):
    """The dampers' virtual work at their vertices (``dS(tag)``, one tag per damper in
    ``tags``): ``sum (c P v + k P (u - u_s)) . du``; None without dampers. ``u_t``, ``v_t``,
    ``us_t``, ``du_t``: the translational parts of displacement, velocity, static
    displacement and test function."""
    work = None
    for d, tag in zip(dampers, tags):
        direction = (None if d.direction is None else
                     fem.Constant(mesh, np.asarray(d.direction, dtype=PETSc.ScalarType)))
        P = _projector(direction, u_t, t0)
        c = fem.Constant(mesh, PETSc.ScalarType(d.coefficient))
        f = c * ufl.dot(P, v_t("+"))
        if d.stiffness > 0:
            k = fem.Constant(mesh, PETSc.ScalarType(d.stiffness))
            f = f + k * ufl.dot(P, u_t("+") - us_t("+"))
        term = ufl.inner(f, du_t("+")) * dS(tag)
        work = term if work is None else work + term
    return work


def link_work(mesh, dampers, dx, h, u, v, us, du, t0):
    """A network's dampers (:class:`cablefem.description.DamperLink`): each cell of the
    measure ``dx(i + 1)`` is the dashpot and spring of ``dampers[i]`` between its two nodes,
    along the line between them, installed at rest. With ``h`` the cell's mesh length, ``g``
    the stretch vector (the chord over ``h``, exact for P1) and ``λ = |g|``, the damper's
    extension from the static state is ``h (λ − λ_s)``, its rate ``h ∂λ/∂t = h e·∂s v``
    (``e = g/λ``), so its force ``N = c h e·∂s v + k h (λ − λ_s)`` does the virtual work
    ``N e·(δu_b − δu_a) = ∫ N e·∂s δu dx`` over the cell; None without dampers. With a
    ``direction`` n the damper acts on the nodes' relative motion along n instead,
    ``F = n (c n·Δv + k n·Δ(u − u_s))`` (``Δ``: node b less node a), linear. Jacobians
    (in ``u`` through ``e``, and in ``v``) are derived by UFL."""
    g = forms.stretch_vector(u, t0)
    lam = ufl.sqrt(ufl.dot(g, g))
    e = g / lam
    lam_s = forms.stretch(us, t0)
    work = None
    for i, d in enumerate(dampers):
        c = fem.Constant(mesh, PETSc.ScalarType(d.coefficient))
        k = fem.Constant(mesh, PETSc.ScalarType(d.stiffness))
        if d.direction is not None:  # along a fixed direction: F = c P Δv + k P Δ(u - u_s)
            # with P = n n^T and Δw = w_b - w_a = h ∂s w; its work F.Δδu = ∫ F.∂s δu dx
            n = fem.Constant(mesh, np.asarray(d.direction, dtype=PETSc.ScalarType))
            rel = c * ufl.dot(n, forms.ds_(v, t0))
            if d.stiffness > 0:
                rel = rel + k * ufl.dot(n, forms.ds_(u - us, t0))
            term = h * rel * ufl.dot(n, forms.ds_(du, t0)) * dx(i + 1)
        else:
            N = c * h * ufl.dot(e, forms.ds_(v, t0))
            if d.stiffness > 0:
                N = N + k * h * (lam - lam_s)
            term = N * ufl.dot(e, forms.ds_(du, t0)) * dx(i + 1)
        work = term if work is None else work + term
    return work
