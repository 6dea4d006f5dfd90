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
from ufl.algorithms import expand_derivatives

from cablefem import forms

__all__ = ["AXIAL_FRACTION", "applied_offset", "axial_dampers", "damper_motion_forms",
           "damper_stations", "damper_work", "kink_offset", "layer_length", "link_work"]


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


#: a damper with a direction whose part normal to the cable, squared (the fraction of its
#: coefficient that damps the transverse motion), is below this acts along the axis
AXIAL_FRACTION = 1e-2


def axial_dampers(model) -> list[tuple[str, str]]:
    """``(key, message)`` of a single cable's dampers with a ``direction`` (nearly) along
    the cable's static tangent at their node: ``1 - (d.t)^2`` below
    :data:`AXIAL_FRACTION`; such a damper only damps the stiff axial motion (the damping
    ratios of the transverse modes are ~1e-15). Collective; every rank gets the list."""
    case = model.case
    nodes = model.damper_nodes
    if model.is_network or not nodes:
        return []
    r = model.gather_nodal(model.u_static)
    out = []
    if model.comm.rank == 0:
        x = model.geometry.points + r
        for i, (d, k) in enumerate(zip(case.dampers, nodes)):
            if d.direction is None:
                continue
            t = x[min(k + 1, len(x) - 1)] - x[max(k - 1, 0)]
            c = float(np.dot(np.asarray(d.direction, float), t / np.linalg.norm(t)))
            normal = 1.0 - c * c
            if normal < AXIAL_FRACTION:
                out.append((f"dampers[{i}].direction", f"the damper acts along the cable's "
                            f"axis: only {normal:.3g} of its coefficient (1 - (d.t)^2, t the "
                            "static tangent at its node) damps the transverse motion; give "
                            "a direction normal to the cable, or none (the normal plane)"))
    return model.comm.bcast(out, root=0)


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


def kink_offset(u_t, t0, mesh, ell):
    """Where the rod's node is against the string's corner at an interior vertex (``dS``
    restrictions of its two cells): ``r = (ℓ/2)(e₊ − e₋)``, ``e₋``, ``e₊`` the current unit
    tangents of the element before and after, written as the sum of the two elements' unit
    tangents pointing away from the vertex (``−(n·t0) g/|g|`` on each side, ``n`` the
    cell's outward normal at the vertex, ``t0`` its reference tangent and ``g`` its stretch
    vector), so it does not depend on how the cells are oriented. ``ell``: the layer length,
    a UFL scalar. The rod's bending rounds the corner over ``ℓ`` on each side, and its node
    lies inside the corner by ``(ℓ/2)|e₊ − e₋|`` (the tensioned beam's ``P ℓ/(2T)`` under a
    point load ``P``, docs/kinks.md)."""
    n = ufl.FacetNormal(mesh)
    away = []
    for side in ("+", "-"):
        g = forms.stretch_vector(u_t, t0)(side)
        away.append(-ufl.dot(n(side), t0(side)) * g / ufl.sqrt(ufl.dot(g, g)))
    return 0.5 * ell * (away[0] + away[1])


#: the offset's length at most the shorter element's over this ratio: the node's own
#: velocity keeps a weight 1 - 2 ℓ/h >= 0.2 in the damper's (a zigzag of the nodes, the
#: mesh's shortest wave, would otherwise be fed energy: at h = ℓ a damper without other
#: damping blew up; see docs/dampers.md)
MESH_RATIO = 2.5


def applied_offset(ell: float, h_min: float) -> float:
    """The part of a layer length ``ell`` the string applies as the damper's offset on
    elements whose shorter one is ``h_min`` long (NumPy; :func:`layer_length`'s cap)."""
    return min(ell, h_min / MESH_RATIO)


def layer_length(T, EA, EI, h=None):
    """The kink layer's length at an interior vertex, ``ℓ = sqrt(EI/(T (1 + T/EA)))``, from
    UFL scalars on ``dS`` (``T``, ``EA``: the means of the two elements' restrictions, the
    static state's tension); 0 where that tension is not positive (slack, or statics not
    solved yet: no correction). With ``h`` (the shorter element's length) it is capped at
    ``h /`` :data:`MESH_RATIO`."""
    ok = ufl.gt(T, 0.0)
    T_pos = ufl.conditional(ok, T, 1.0)
    ell = ufl.sqrt(EI / (T_pos * (1.0 + T_pos / EA)))
    if h is not None:
        ell = ufl.min_value(ell, h / MESH_RATIO)
    return ufl.conditional(ok, ell, 0.0)


def damper_work(mesh, dampers, tags, u_t, v_t, us_t, du_t, t0, dS, ell=None):
    """The dampers' virtual work at their vertices (``dS(tag)``, one tag per damper in
    ``tags``): ``sum (c P v_n + k P (u_n - u_s,n)) . du``; None without dampers. ``u_t``,
    ``v_t``, ``us_t``, ``du_t``: the translational parts of displacement, velocity, static
    displacement and test function.

    With ``ell`` (the string's, a UFL scalar on ``dS``: :func:`layer_length`) the damper
    acts on the motion of the rod's node, which the kink's layer places inside the string's
    corner by :func:`kink_offset` ``r``: ``u_n = u + r(u)``, ``v_n = v + r'(u)[v]`` (the
    first-order correction of the asymptotics, docs/kinks.md), while its force still acts on
    the string at the corner (the outer solution sees a point force there). Without it
    (the rod, which resolves its layer) ``u_n = u``."""
    work = None
    offsets = _offsets(mesh, u_t, v_t, us_t, t0, ell)
    for d, tag in zip(dampers, tags):
        P, Pv, Pdisp = _node_motion(mesh, d, u_t, v_t, us_t, t0, offsets)
        c = fem.Constant(mesh, PETSc.ScalarType(d.coefficient))
        f = c * Pv
        if d.stiffness > 0:
            k = fem.Constant(mesh, PETSc.ScalarType(d.stiffness))
            f = f + k * Pdisp
        term = ufl.inner(f, du_t("+")) * dS(tag)
        work = term if work is None else work + term
    return work


def _offsets(mesh, u_t, v_t, us_t, t0, ell):
    """The rod node's offsets ``(r(u), r(u_s), r'(u)[v])`` with a layer ``ell``, else
    ``(None, None, None)``."""
    if ell is None:
        return None, None, None
    r_u = kink_offset(u_t, t0, mesh, ell)
    r_s = kink_offset(us_t, t0, mesh, ell)
    return r_u, r_s, expand_derivatives(ufl.derivative(r_u, u_t, v_t))


def _node_motion(mesh, d, u_t, v_t, us_t, t0, offsets):
    """Damper ``d``'s projector ``P`` and the motion it acts on at its vertex: ``P v_n``
    and ``P (u_n - u_s,n)`` (UFL on ``dS``'s "+" side; ``offsets``: :func:`_offsets`)."""
    r_u, r_s, r_v = offsets
    direction = (None if d.direction is None else
                 fem.Constant(mesh, np.asarray(d.direction, dtype=PETSc.ScalarType)))
    P = _projector(direction, u_t, t0)
    v_n = v_t("+") if r_v is None else v_t("+") + r_v
    disp = u_t("+") - us_t("+")
    if r_u is not None:
        disp = disp + r_u - r_s
    return P, ufl.dot(P, v_n), ufl.dot(P, disp)


def damper_motion_forms(mesh, dampers, tags, u_t, v_t, us_t, du_t, t0, dS, ell=None):
    """Linear forms (in ``du_t``) whose assembled vectors hold, at each damper's node, the
    velocity ``P v_n`` and the stroke ``P (u_n - u_s,n)`` the damper acts on
    (:func:`damper_work`'s, term by term): its force on the cable is
    ``-(c P v_n + k P (u_n - u_s,n))``. ``(velocity form, stroke form)``, None without
    dampers."""
    if not dampers:
        return None
    offsets = _offsets(mesh, u_t, v_t, us_t, t0, ell)
    vel = stroke = None
    for d, tag in zip(dampers, tags):
        _, Pv, Pdisp = _node_motion(mesh, d, u_t, v_t, us_t, t0, offsets)
        tv = ufl.inner(Pv, du_t("+")) * dS(tag)
        ts = ufl.inner(Pdisp, du_t("+")) * dS(tag)
        vel = tv if vel is None else vel + tv
        stroke = ts if stroke is None else stroke + ts
    return vel, stroke


def link_work(mesh, dampers, where, h, u, v, us, du, t0):
    """A network's dampers (:class:`cablefem.description.DamperLink`): each cell where the
    cell indicator ``where[i]`` is 1 is the dashpot and spring of ``dampers[i]`` between
    its two nodes,
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
    dx = ufl.dx(domain=mesh)
    for i, d in enumerate(dampers):
        c = fem.Constant(mesh, PETSc.ScalarType(d.coefficient))
        k = fem.Constant(mesh, PETSc.ScalarType(d.stiffness))
        if d.direction is not None:  # along a fixed direction: F = c P Δv + k P Δ(u - u_s)
            # with P = n n^T and Δw = w_b - w_a = h ∂s w; its work F.Δδu = ∫ F.∂s δu dx
            n = fem.Constant(mesh, np.asarray(d.direction, dtype=PETSc.ScalarType))
            rel = c * ufl.dot(n, forms.ds_(v, t0))
            if d.stiffness > 0:
                rel = rel + k * ufl.dot(n, forms.ds_(u - us, t0))
            term = where[i] * h * rel * ufl.dot(n, forms.ds_(du, t0)) * dx
        else:
            N = c * h * ufl.dot(e, forms.ds_(v, t0))
            if d.stiffness > 0:
                N = N + k * h * (lam - lam_s)
            term = where[i] * N * ufl.dot(e, forms.ds_(du, t0)) * dx
        work = term if work is None else work + term
    return work
