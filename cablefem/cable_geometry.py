"""A single cable's reference geometry and the shape statics starts from.

:func:`cable_geometry` turns a description's anchors and geometry (length, horizontal
tension, sag ratio or polyline) into the stress-free stations (graded, with nodes at point
masses, point loads and dampers), checks what cannot be built (:class:`CaseError`), and
finds the elastic catenary through the anchors, with its grounded part on a seabed
(:func:`grounded_start`), which statics starts from. The model's plausibility warnings
(:mod:`cablefem.plausibility`) are added to ``model.warnings``.
"""

from __future__ import annotations

import numpy as np

from cablefem import catenary
from cablefem.dampers import damper_stations
from cablefem.errors import CaseError
from cablefem.fluid import submerged_weight
from cablefem.geometry import graded_stations, polyline_cable, straight_cable
from cablefem.plausibility import catenary_warnings, chord_frame
from cablefem.seabed import GroundedCatenary
from cablefem.water import floating_problems, water_problems

__all__ = ["cable_geometry", "grounded_start", "damper_clearance"]


def _length(case, p, q, gdir, weight) -> float:
    """The stress-free length a straight description's geometry asks for."""
    geo, sec = case.geometry, case.section
    span, rise = chord_frame(p, q, gdir)
    try:
        if geo.kind == "length":
            return float(geo.value)
        if geo.kind == "horizontal_tension":
            return catenary.length_for_horizontal_tension(span, rise, float(geo.value),
                                                          weight, sec.EA)
        return catenary.length_for_sag_ratio(span, rise, float(geo.value), weight, sec.EA)
    except ValueError as err:
        raise CaseError([(f"geometry.{geo.kind}", str(err))], case.source) from None


def cable_geometry(model):
    """The reference geometry of ``model``'s single cable and the nodal positions statics
    starts from, ``(geometry, positions)``. Sets on the model: ``damper_s`` (the dampers'
    stations), ``submerged_weight``, ``catenary_shape``, ``force_scale`` and
    ``anchor_positions``."""
    case = model.case
    sec = case.section
    a0, a1 = case.anchors
    names = (a0.name, a1.name)
    gdir = np.asarray(case.gravity.direction, dtype=float)
    extra = [pm.s for pm in case.point_masses] + [pl.s for pl in case.point_loads]
    geo = case.geometry
    if geo.kind == "polyline":
        poly = np.asarray(geo.polyline, dtype=float)
        p = np.asarray(a0.position if a0.position is not None else poly[0], dtype=float)
        q = np.asarray(a1.position if a1.position is not None else poly[-1], dtype=float)
        length = float(np.sum(np.linalg.norm(np.diff(poly, axis=0), axis=1)))
    else:
        p = np.asarray(a0.position, dtype=float)
        q = np.asarray(a1.position, dtype=float)
        length = _length(case, p, q, gdir, model.weight)
    bad = [(f"point masses/loads s={s:g}", f"must satisfy 0 < s < l = {length:g} m")
           for s in extra if not 0.0 < s < length]
    try:
        model.damper_s = damper_stations(case, length)
    except ValueError as err:
        bad += err.args[0]
    if bad:
        raise CaseError(bad, case.source)
    extra += model.damper_s
    wet = water_problems(case.anchors, case.gravity, getattr(case, "fluid", None),
                         getattr(case, "seabed", None), positions=(p, q))
    if wet:  # a description built in Python (a case file's are refused when read)
        raise CaseError(wet, case.source)
    if geo.kind == "polyline":
        g = polyline_cable(poly, case.mesh.elements, case.mesh.grading, names, tuple(extra))
    else:
        stations = graded_stations(length, case.mesh.elements, case.mesh.grading,
                                   tuple(extra), damper_clearance(model, p, q, length, gdir))
        g = straight_cable(p, (q - p) / np.linalg.norm(q - p), stations, names)
    chord = float(np.linalg.norm(q - p))
    if len(g.stations) == 2 and length > chord * (1.0 + 1e-12):
        raise CaseError([("mesh.elements", f"one element between the anchors is straight "
                          f"along their chord ({chord:g} m), shorter than the stress-free "
                          f"length l = {length:g} m: a slack element that carries nothing "
                          "(the run would fail in the dynamics); give more elements")],
                        case.source)
    # initial shape: the elastic catenary through the anchors (exact for the bare cable;
    # with a seabed it crosses, the catenary with its grounded part)
    fl = getattr(case, "fluid", None)
    model.submerged_weight = (submerged_weight(fl, sec.mass, case.gravity.g)
                              if fl is not None else model.weight)
    afloat = floating_problems(p, q, length, model.submerged_weight, sec.EA, gdir, fl)
    if afloat:
        raise CaseError(afloat, case.source)
    try:
        shape = catenary.catenary_between(p, q, length, model.weight, sec.EA, gdir)
        if getattr(case, "seabed", None) is not None:
            shape = grounded_start(model, shape, p, q, length, gdir)
        model.catenary_shape = shape
        r0 = shape.position(g.stations)
        max_tension = float(np.max(shape.tension(g.stations)))
        model.force_scale = float(max(model.weight * length, max_tension))
    except ValueError as err:
        raise CaseError([("geometry", f"no static equilibrium of the bare cable: {err}")],
                        case.source) from None
    model.anchor_positions = (p, q)
    model.warnings += catenary_warnings(f"geometry.{geo.kind}", length,
                                        float(np.linalg.norm(q - p)), max_tension, sec.EA)
    return g, r0


def grounded_start(model, shape, p, q, length, gdir):
    """The catenary with its grounded part when the free one dips below the seabed
    (:class:`cablefem.seabed.GroundedCatenary`), else ``shape`` (a warning on
    ``model.warnings`` when the grounded one cannot be found)."""
    sb, up = model.case.seabed, -np.asarray(gdir, float) / np.linalg.norm(gdir)
    s = np.linspace(0.0, length, 201)
    if np.min(shape.position(s) @ up) >= sb.z:
        return shape
    anchor_first = float(p @ up) <= float(q @ up)
    a, f = (p, q) if anchor_first else (q, p)
    try:
        return GroundedCatenary(a, f, length, model.submerged_weight, up, anchor_first,
                                model.case.section.EA)
    except ValueError as err:
        model.warnings.append(("seabed", f"statics starts from the free catenary ({err})"))
        return shape


def damper_clearance(model, p, q, length, gdir) -> dict[float, float]:
    """The least length of the elements next to each damper's station (the rod node's
    offset is applied in full on elements at least :data:`cablefem.dampers.MESH_RATIO`
    layer lengths long): 1.1 times that, from the layer length at the elastic
    catenary's tension there (an estimate before statics); none at leading order, for
    the rod, or without a catenary."""
    case = model.case
    if not model.damper_s or not model.applies_damper_offsets():
        return {}
    from cablefem.dampers import MESH_RATIO

    sec = case.section
    try:
        shape = catenary.catenary_between(p, q, length, model.weight, sec.EA, gdir)
        T = np.asarray(shape.tension(np.asarray(model.damper_s, float)), float)
    except ValueError:
        return {}
    ok = T > 0
    ell = np.where(ok, np.sqrt(sec.EI / np.where(ok, T * (1 + T / sec.EA), 1.0)), 0.0)
    return {s: 1.1 * MESH_RATIO * float(e) for s, e in zip(model.damper_s, ell) if e > 0}
