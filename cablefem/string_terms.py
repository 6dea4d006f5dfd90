"""The string's physics as terms of :class:`cablefem.forms.CableForms`.

Functions of a model (:class:`cablefem.cable.CableModel` or a network) that build its
section coefficients (:func:`string_coefficients`, :func:`hinge_law_fields`) and its terms:
the string's internal work, weight and inertia (:func:`build_string_forms`); what the string
and the rod share, extra loads, point masses, damping and the dampers (:func:`add_model_terms`);
a single cable's span bending and end moments (:func:`add_span_bending`); the dampers at
their nodes with the kink layer's offset (:func:`string_damper_work`).
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from petsc4py import PETSc
from ufl.algorithms import expand_derivatives

from cablefem import bending_forms, forms
from cablefem.dampers import damper_work, layer_length
from cablefem.fluid import add_fluid_terms
from cablefem.jit import quiet_compiler
from cablefem.seabed import add_seabed_terms
from cablefem.span_bending import is_on

__all__ = ["string_coefficients", "hinge_law_fields", "build_string_forms", "add_model_terms",
           "add_span_bending", "away_from_kinks", "axial_damping_work", "string_damper_work",
           "kink_layer"]


def string_coefficients(model) -> None:
    """Section coefficients of the forms: EA, m and c (stress-free length per mesh
    length, 1 for a single cable whose mesh is stress-free)."""
    sec = model.case.section
    model.m = fem.Constant(model.mesh, PETSc.ScalarType(sec.mass))
    if model.has_hinges():  # the hinges change the first elements: cell fields
        model.c = fem.Function(model.W, name="c")
        model.c.x.array[:] = 1.0
        model.EA = fem.Function(model.W, name="EA")
        model.EA.x.array[:] = sec.EA
    else:
        model.EA = fem.Constant(model.mesh, PETSc.ScalarType(sec.EA))
        model.c = fem.Constant(model.mesh, PETSc.ScalarType(1.0))


def hinge_law_fields(model) -> None:
    """The cell fields of the virtual hinges' layer law (:mod:`cablefem.hinge`,
    :func:`cablefem.forms.layer_law_tension`) in ``model.law``, set to the elastic law
    of every cell; ``cos``: the cosine of the anchor angle in each cell of a hinge's
    region (``turn_dir``: the clamp direction, signed by the cell's orientation; zero
    elsewhere)."""
    from types import SimpleNamespace

    from cablefem.hinge import DCOS

    law = SimpleNamespace()
    for name in ("a", "b", "ka", "kb", "tf", "tc", "cos_ref", "tref", "qT", "qC"):
        setattr(law, name, fem.Function(model.W, name=f"law_{name}"))
        setattr(model, f"law_{name}" if name != "cos_ref" else "cos_ref",
                getattr(law, name))
    law.a.x.array[:] = model.c.x.array
    EA = model.EA.x.array
    # a network's damper cells have no section (EA = 0) and no law: a finite placeholder
    # there (c/0 = inf warned on the console; 0 made the law's 1/ka, weighted by the
    # cell's zero indicator, a NaN)
    law.ka.x.array[:] = np.divide(model.c.x.array, EA, out=np.ones_like(EA), where=EA > 0)
    law.kb.x.array[:] = law.ka.x.array
    law.dcos = DCOS
    with quiet_compiler():  # the element is JIT-compiled on first use
        space = fem.VectorFunctionSpace(model.mesh, ("DG", 0), dim=3)
    model.turn_dir = fem.Function(space, name="turn_dir")
    law.dir = model.turn_dir
    g = forms.stretch_vector(model.u, model.t0)
    law.cos = ufl.dot(model.turn_dir, g) / ufl.sqrt(ufl.dot(g, g))
    model.law = law


def build_string_forms(model) -> None:
    """Build the string's terms of the residual in ``model.forms`` (a
    :class:`cablefem.forms.CableForms`; users add theirs with ``model.forms.add``)."""
    u, v, a, du, t0, cc = model.u, model.v, model.a, model.du, model.t0, model.c
    T = T2 = g = None
    if model.law is not None:  # virtual hinges: their regions' law and offset
        T = forms.layer_law_tension(u, t0, model.law, model.tension_only)
        T2 = forms.layer_law_tension(u, t0, model.law, False)
        g = forms.layer_stretch_vector(u, t0, model.law, T2)  # the force's direction
    add_model_terms(
        model,
        F_int=forms.internal_work(u, du, t0, model.EA, model.tension_only, c=cc, T=T,
                                  g=g),
        F_weight=forms.load_work(model.m * model.gravity, du, c=cc),
        F_inertia=forms.inertia_work(model.m, a, du, c=cc),
        du_t=du, a_t=a, dx=ufl.dx,
        # the same with compression allowed: statics uses it to get off a guess on
        # which every element is slack (zero tangent stiffness under tension only)
        bilateral=forms.internal_work(u, du, t0, model.EA, False, c=cc, T=T2, g=g))
    model.forms.outputs = {
        "tension": T if T is not None else forms.tension(u, t0, model.EA,
                                                          model.tension_only, cc),
        "strain": forms.axial_strain(u, t0, cc)}
    if getattr(model.case, "fluid", None) is not None:  # water or wind (Morison)
        add_fluid_terms(model)
    if getattr(model.case, "seabed", None) is not None:
        add_seabed_terms(model, model.submerged_weight)
    strain = forms.strain_energy_density(u, t0, model.EA, model.tension_only, cc) * ufl.dx
    if is_on(model.case.solver.span_bending):
        strain = strain + model.add_span_bending()
    model.forms.energies = (
        0.5 * ufl.inner(v, v) * cc * model.m * ufl.dx, strain,
        -ufl.inner(cc * model.m * model.gravity, u) * ufl.dx)


def add_span_bending(model):
    """``solver.span_bending``: the span's own EI (``docs/theory.md`` §6.1) as the terms
    ``span_bending`` (a bending energy on the turning angle at every interior vertex)
    and ``end_moments`` (at each clamped anchor the moment ``EI κ_s`` of the outer
    curvature, handed over by the layer; the clamp's rotation stays with the layer).
    Returns the bending energy (a form)."""
    model.EI = fem.Constant(model.mesh, PETSc.ScalarType(model.case.section.EI))
    # the curvature per stress-free length of the *outer* string: the mesh's (a single
    # cable's mesh is stress-free), not the hinge region's c < 1, which holds the
    # layer's removed length (theory.md §6.1; with c the region was 1/(1 - sigma_h/K)
    # too stiff in bending). Not at a kink (a point load, point mass or damper: the
    # nodes tagged in dS): its turn belongs to the kink's own layer (cablefem.kinks),
    # as a clamp's to the clamp's; the span's moment is handed over on both sides.
    kinks = sorted(set(model.line.node_tag.values()))
    model.forms.add("span_bending", bending_forms.span_bending_work(
        model.u, model.du, model.t0, model.EI, model.mesh, model.dS, c=1.0, skip=kinks),
        kind="static")
    T = model.forms.outputs["tension"]
    q = -(model.m * model.gravity + sum((f for f, _ in model.loads), 0.0 * model.gravity))
    clamped = [(i + 1, anc) for i, anc in enumerate(model.anchors) if anc.kind == "clamped"]
    work = []
    if clamped:
        ds = ufl.Measure("ds", domain=model.mesh, subdomain_data=model.line.vertex_tags(
            {anc.node: tag for tag, anc in clamped}))
        work += [bending_forms.end_moment_work(
            model.u, model.du, model.t0, model.EI, T, q,
            fem.Constant(model.mesh, np.asarray(anc.direction, dtype=PETSc.ScalarType)),
            ds(tag)) for tag, anc in clamped]
    if kinks:
        density = bending_forms.end_moment_density(model.u, model.du, model.t0, model.EI, T, q,
                                           away_from_kinks(model))
        work += [density(side) * model.dS(tag) for tag in kinks for side in ("+", "-")]
    if work:
        model.forms.add("end_moments", sum(work[1:], work[0]), kind="static")
    return bending_forms.span_bending_form(model.u, model.t0, model.EI, model.mesh, model.dS,
                                           c=1.0, skip=kinks)


def away_from_kinks(model):
    """A cell field (DG0, 3): on each element next to a kink node (a node tagged in
    ``model.dS``), the unit direction from that node into the element (the side's
    'clamp direction' of the span's moment handed over there); zero elsewhere. An
    element between two kink nodes takes the second's (such kinks' layers overlap:
    their rows are invalid, cablefem.kinks)."""
    geo = model.geometry
    pts, cells = np.asarray(geo.points), np.asarray(geo.cells)
    with quiet_compiler():
        space = fem.VectorFunctionSpace(model.mesh, ("DG", 0), dim=3)
    away = fem.Function(space, name="away_from_kink")
    for i, c in enumerate(model.line.reference_cells()):  # owned and ghost cells alike
        a, b = cells[c]
        for k, other in ((a, b), (b, a)):
            if int(k) in model.line.node_tag:
                d = pts[other] - pts[k]
                away.x.array[3 * i:3 * i + 3] = d / np.linalg.norm(d)
    return away


def axial_damping_work(model):
    """The "axial" damping model's virtual work (strain-rate damping along the axis)."""
    return forms.axial_damping_work(model.u, model.v, model.du, model.t0, model.EA,
                                     model.beta, c=model.c)


def add_model_terms(model, F_int, F_weight, F_inertia, du_t, a_t, dx, bilateral=None,
                    u_t=None, v_t=None, us_t=None, axial_damping=axial_damping_work) -> None:
    """What the string and the rod share: the extra loads (ramped by statics through
    ``load_factor``), point masses and damping; creates ``model.forms`` with the model's
    terms.

    ``F_int``, ``F_weight``, ``F_inertia``: the model's internal work, own weight and
    distributed inertia; ``du_t``, ``a_t``: the translational parts of the test function
    and the acceleration; ``dx``: the cell measure of distributed loads; ``bilateral``:
    the internal work with compression allowed (default ``F_int``); ``u_t``, ``v_t``,
    ``us_t``: the translational parts of displacement, velocity and static displacement
    (default: the fields themselves, a string's); ``axial_damping(model)``: the "axial"
    damping model's work."""
    u, v, a, dw = model.u, model.v, model.a, model.dw
    case, cc = model.case, model.c
    point_work = model.line.point_work
    extra = [forms.load_work(q, du_t, dx=dx, c=cc) for q, _ in model.loads]
    extra += [point_work(k, lambda r, pm=pm: pm.mass * ufl.inner(model.gravity, r(du_t)))
              for pm in case.point_masses for k in sorted(set(model.item_nodes(pm)))]
    extra += [point_work(k, lambda r, q=q: ufl.inner(q, r(du_t)))
              for q, pl in model.point_loads for k in sorted(set(model.item_nodes(pl)))]
    F_ext = F_weight
    if model.ramp_weight:  # networks: statics ramps the weight too (from the pretension)
        F_ext = model.load_factor * sum(extra, F_weight)
    elif extra:
        F_ext = F_weight + model.load_factor * sum(extra[1:], extra[0])

    for pm in case.point_masses:
        for k in sorted(set(model.item_nodes(pm))):
            F_inertia = F_inertia + point_work(
                k, lambda r, pm=pm: pm.mass * ufl.inner(r(a_t), r(du_t)))

    damp = case.damping
    # Constants, not floats: one compiled form serves every value (FFCx caches by code)
    model.alpha = fem.Constant(model.mesh, PETSc.ScalarType(damp.alpha))
    model.beta = fem.Constant(model.mesh, PETSc.ScalarType(damp.beta))
    F_damp = None
    if damp.model in ("rayleigh", "rayleigh_k0") and (damp.alpha > 0 or damp.beta > 0):
        F_damp = model.alpha * ufl.replace(F_inertia, {a: v})
        if damp.beta > 0 and damp.model == "rayleigh":
            # beta K_t(u) v = beta d/dt f_int(u): the current tangent, which turns with
            # the cable (its Jacobian in u, a second derivative of F_int, is derived)
            # (derivatives applied now: v must appear explicitly, or the Jacobian's
            # derivative in v does not see through the nested Gateaux derivative)
            F_damp = F_damp + model.beta * expand_derivatives(ufl.derivative(F_int, u, v))
        elif damp.beta > 0:  # rayleigh_k0: the tangent at the static state
            K0 = ufl.derivative(ufl.replace(F_int, {u: model.u_static}), model.u_static, dw)
            F_damp = F_damp + model.beta * ufl.action(K0, v)
    elif damp.model == "axial" and damp.beta > 0:
        F_damp = axial_damping(model)

    model.forms = forms.CableForms(u, v, a, model.du, dw, model.shift_v, model.shift_a,
                                   model.W.element.interpolation_points())
    model.forms.set_model_terms(F_int, F_ext, F_inertia, F_damp, bilateral)
    if case.dampers:  # dynamic terms on the motion from the static state
        parts = (u, v, model.u_static) if u_t is None else (u_t, v_t, us_t)
        model.forms.add("dampers", model.damper_work(*parts, du_t), kind="dynamic")


def string_damper_work(model, u_t, v_t, us_t, du_t):
    """The dampers' virtual work (:func:`cablefem.dampers.damper_work`: each at its
    node, from the ground)."""
    return damper_work(model.mesh, model.case.dampers,
                       [model.line.node_tag[k] for k in model.damper_nodes],
                       u_t, v_t, us_t, du_t, model.t0, model.dS, ell=kink_layer(model, us_t))


def kink_layer(model, us_t):
    """The kink layer's length at a damper's node from the static state (UFL on
    ``model.dS``, :func:`cablefem.dampers.layer_length`), or None at leading order
    (``solver.outer_correction = "none"``) and for a model that resolves its layers
    (``kink_offsets`` false: the rod)."""
    if not model.applies_damper_offsets():
        return None
    T = forms.tension(us_t, model.t0, model.EA, c=model.c)

    def mean(f):
        return 0.5 * (f("+") + f("-"))
    EA = mean(model.EA) if isinstance(model.EA, fem.Function) else model.EA
    EI = fem.Constant(model.mesh, PETSc.ScalarType(model.case.section.EI))
    h = ufl.CellVolume(model.mesh)  # the elements' stress-free lengths (the mesh's)
    return layer_length(mean(T), EA, EI, ufl.min_value(h("+"), h("-")))
