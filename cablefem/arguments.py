"""Checking descriptions built in Python: :func:`describe_cable` and
:func:`describe_network` turn the arguments of :func:`cablefem.create_cable` and
:func:`cablefem.create_network` into a :class:`cablefem.description.CableDescription`, every
problem under its argument's name in one :class:`cablefem.errors.CaseError`.
:func:`anchor_problems` and :func:`zero_segments` are the cross-checks the case parser
(:mod:`cablefem.case`) shares. Pure Python/NumPy: no dolfinx import.
"""

from __future__ import annotations

import numbers
import os
from pathlib import Path
from typing import Any

import numpy as np

from cablefem.anchor import ANCHOR_KINDS, Anchor
from cablefem.description import (
    DAMPING_MODELS,
    GEOMETRY_BOUNDS,
    GEOMETRY_KINDS,
    GEOMETRY_UNITS,
    MAX_ELEMENTS,
    NAME,
    OUTER_CORRECTIONS,
    BeamSpec,
    CableDescription,
    CableSpec,
    Damper,
    Damping,
    DistributedLoad,
    Fluid,
    Geometry,
    Gravity,
    MeshSpec,
    NetworkSpec,
    PointLoad,
    PointMass,
    SolverSpec,
)
from cablefem.errors import CaseError
from cablefem.flow import flow_problems
from cablefem.motion import TimeFunction
from cablefem.properties import Section
from cablefem.validation import is_sequence, number_problem, show, vector_problem

__all__ = ["describe_cable", "describe_network", "anchor_problems", "zero_segments"]

_TOL = 1e-9  # relative tolerance for coincident points and parallel directions


# ---------------------------------------------------------------------------------------------
# Checks shared with the case parser.

def zero_segments(points: np.ndarray) -> np.ndarray:
    """Indices ``i`` of the polyline points that coincide with point ``i - 1``.

    Args:
        points: (n, 3) polyline points.
    """
    scale = np.maximum(1.0, np.linalg.norm(points[1:], axis=1))
    return np.flatnonzero(np.linalg.norm(np.diff(points, axis=0), axis=1) <= _TOL * scale) + 1


def anchor_problems(anchors: list[Anchor], geometry: Geometry | None, gravity: Gravity | None,
                    polyline_given: bool = False, positions_given: tuple = (False, False),
                    key: str = "anchors") -> list[tuple[str, str]]:
    """Cross-checks of a single cable's two anchors (with the geometry and gravity); fills in
    what they leave out: a polyline's end as the position, the chord as a clamp's direction.
    ``polyline_given``: a polyline was given (if it is None, it could not be read);
    ``positions_given[i]``: anchor i's position was given (if it is None, it could not be
    read): both reported already, not reported as missing.

    Args:
        anchors: The two anchors (completed in place).
        geometry: The stress-free geometry, or None.
        gravity: Gravity, or None.
        polyline_given: See above.
        positions_given: See above.
        key: The key path of the anchors in the messages.

    Returns:
        ``(key, message)`` of every problem.
    """
    problems: list[tuple[str, str]] = []
    if len(anchors) != 2:
        return problems
    a, b = anchors
    if a.name is not None and a.name == b.name:
        problems.append((f"{key}[1].name", f"duplicate anchor name {a.name!r} ({key}[0] has "
                                           "it too)"))
    polyline = geometry.polyline if geometry is not None else None
    for i, (anchor, end) in enumerate(((a, 0), (b, -1))):
        if anchor.position is None and not positions_given[i]:
            if polyline is not None:
                anchor.position = polyline[end].copy()
            elif not polyline_given:
                problems.append((f"{key}[{i}].position", "missing required key (optional only "
                                                         "with geometry.polyline)"))
        if anchor.kind == "pinned" and anchor.direction is not None:
            problems.append((f"{key}[{i}].direction", "direction only applies to clamped "
                                                      "anchors"))
    if a.position is None or b.position is None:
        return problems
    chord = b.position - a.position
    distance = float(np.linalg.norm(chord))
    scale = max(1.0, float(np.linalg.norm(a.position)), float(np.linalg.norm(b.position)))
    if distance <= _TOL * scale:
        problems.append((f"{key}[1].position", f"anchors {a.name!r} and {b.name!r} coincide "
                                               f"(distance {distance:g} m)"))
        return problems
    for anchor, sign in ((a, 1.0), (b, -1.0)):
        if anchor.kind == "clamped" and anchor.direction is None:
            anchor.direction = sign * chord / distance + 0.0  # + 0.0: no -0.0 in outputs
    if geometry is not None and geometry.kind in ("horizontal_tension", "sag_ratio") \
            and gravity is not None:
        name = f"geometry.{geometry.kind}"
        if gravity.g == 0:
            problems.append((name, "needs gravity.g > 0 (got 0)"))
        elif np.linalg.norm(np.cross(chord / distance, gravity.direction)) <= _TOL:
            problems.append((name, f"needs a chord not parallel to gravity (the chord from "
                                   f"{a.name!r} to {b.name!r} is along gravity)"))
    return problems


def _check(problems: list, key: str, problem: str | None) -> bool:
    if problem is not None:
        problems.append((key, problem))
    return problem is None


def _vector(problems: list, key: str, value: Any, unit_vector: bool = False) -> np.ndarray | None:
    if not _check(problems, key, vector_problem(value, 3, nonzero=unit_vector)):
        return None
    v = np.asarray(value, dtype=float)
    return v / np.linalg.norm(v) if unit_vector else v


def _anchors(problems: list, anchors: Any, network: bool) -> list[Anchor]:
    """Type and value checks of the anchors (copies: the caller's objects stay as given)."""
    out = []
    if not is_sequence(anchors) and not isinstance(anchors, tuple):
        problems.append(("anchors", f"expected a list of Anchor, got {show(anchors)}"))
        return out
    if not network and len(anchors) != 2:
        problems.append(("anchors", f"expected exactly 2 anchors, got {len(anchors)}"))
    for i, a in enumerate(anchors):
        key = f"anchors[{i}]"
        if not isinstance(a, Anchor):
            problems.append((key, f"expected an Anchor, got {show(a)}"))
            continue
        ok = isinstance(a.name, str) and NAME.fullmatch(a.name) is not None
        _check(problems, f"{key}.name", None if ok else
               f"must be a string of the characters A-Z a-z 0-9 _ -, got {a.name!r}")
        _check(problems, f"{key}.kind", None if a.kind in ANCHOR_KINDS else
               f"must be one of {', '.join(map(repr, ANCHOR_KINDS))}, got {a.kind!r}")
        position = direction = None
        if a.position is not None:
            if network:
                problems.append((f"{key}.position", "a network's anchors are its mesh's nodes: "
                                                    "give no position"))
            else:
                position = _vector(problems, f"{key}.position", a.position)
        if a.direction is not None:
            direction = _vector(problems, f"{key}.direction", a.direction, unit_vector=True)
        ok = a.motion is None or all(callable(getattr(a.motion, m, None))
                                     for m in ("displacement", "velocity", "acceleration"))
        _check(problems, f"{key}.motion", None if ok else
               f"expected a motion (cablefem.motion) or None, got {show(a.motion)}")
        out.append(Anchor(a.name, position, a.kind, direction, a.motion))
    return out


def _items(problems: list, key: str, items: Any, cls: type, network: bool) -> list:
    """Loads, point masses or point loads: type and value checks (copies)."""
    if not isinstance(items, (list, tuple)):
        problems.append((key, f"expected a list of {cls.__name__}, got {show(items)}"))
        return []
    out = []
    for i, item in enumerate(items):
        k = f"{key}[{i}]"
        if not isinstance(item, cls):
            problems.append((k, f"expected a {cls.__name__}, got {show(item)}"))
            continue
        new = cls(**vars(item))
        if hasattr(item, "s"):
            if network:
                _check(problems, f"{k}.s", None if isinstance(item.s, str) else
                       f"expected the name of a 0D group of the mesh, got {show(item.s)}")
            else:
                _check(problems, f"{k}.s", number_problem(item.s, "m", gt=0))
        if hasattr(item, "mass"):
            _check(problems, f"{k}.mass", number_problem(item.mass, "kg", gt=0))
        if hasattr(item, "value"):
            new.value = _vector(problems, f"{k}.value", item.value)
        if hasattr(item, "time") and not isinstance(item.time, TimeFunction):
            problems.append((f"{k}.time", f"expected a TimeFunction, got {show(item.time)}"))
        out.append(new)
    return out


def _common(problems: list, *, gravity, elements, grading, loads, point_masses, point_loads,
            damping, tension_only, outer_correction, petsc_options, network: bool,
            span_bending: bool | str = False) -> dict:
    """The parts a single cable and a network share, checked."""
    if not isinstance(gravity, Gravity):
        problems.append(("gravity", f"expected a Gravity, got {show(gravity)}"))
    else:
        ok = _check(problems, "gravity.g", number_problem(gravity.g, "m/s^2", ge=0))
        d = _vector(problems, "gravity.direction", gravity.direction, unit_vector=True)
        gravity = Gravity(float(gravity.g), d) if ok and d is not None else None
    ok = isinstance(elements, numbers.Integral) and not isinstance(elements, (bool, np.bool_))
    if not ok:
        problems.append(("elements", f"expected an integer, got {show(elements)}"))
    elif not 1 <= elements <= MAX_ELEMENTS:
        problems.append(("elements", f"must be >= 1 and <= {MAX_ELEMENTS}, got {elements}"))
    else:
        elements = int(elements)
    _check(problems, "grading", number_problem(grading, "", ge=1))
    if damping is None:
        damping = Damping()
    elif not isinstance(damping, Damping):
        problems.append(("damping", f"expected a Damping, got {show(damping)}"))
    else:
        _check(problems, "damping.model", None if damping.model in DAMPING_MODELS else
               f"must be one of {', '.join(map(repr, DAMPING_MODELS))}, got {damping.model!r}")
        _check(problems, "damping.alpha", number_problem(damping.alpha, "1/s", ge=0))
        _check(problems, "damping.beta", number_problem(damping.beta, "s", ge=0))
    _check(problems, "tension_only", None if isinstance(tension_only, bool) else
           f"expected a boolean, got {show(tension_only)}")
    _check(problems, "outer_correction", None if outer_correction in OUTER_CORRECTIONS else
           f"must be one of {', '.join(map(repr, OUTER_CORRECTIONS))}, got {outer_correction!r}")
    _check(problems, "span_bending", None if isinstance(span_bending, bool)
           or span_bending == "auto" else
           f"expected a boolean or 'auto', got {show(span_bending)}")
    if not isinstance(petsc_options, dict):
        problems.append(("petsc_options", f"expected a dict, got {show(petsc_options)}"))
        petsc_options = {}
    return dict(gravity=gravity, mesh=MeshSpec(elements, float(grading) if isinstance(
        grading, (int, float)) else grading),
        loads=_items(problems, "loads", loads, DistributedLoad, network),
        point_masses=_items(problems, "point_masses", point_masses, PointMass, network),
        point_loads=_items(problems, "point_loads", point_loads, PointLoad, network),
        damping=damping, solver=SolverSpec(tension_only, dict(petsc_options),
                                           outer_correction, span_bending))


def describe_cable(anchors: list[Anchor], section: Section, *, length: float | None = None,
                   horizontal_tension: float | None = None, sag_ratio: float | None = None,
                   polyline: Any = None, elements: int = 30, grading: float = 1.0,
                   gravity: Gravity | None = None, loads=(), point_masses=(), point_loads=(),
                   damping: Damping | None = None, tension_only: bool = True,
                   outer_correction: str = "hinge", span_bending: bool | str = False,
                   petsc_options: dict | None = None, beam: BeamSpec | None = None,
                   units: str = "SI", source: str = "<python>", dampers=(),
                   fluid: Fluid | None = None) -> CableDescription:
    """A checked description of a single cable (the arguments of
    :func:`cablefem.create_cable`, which see).

    Args:
        anchors, section: As for :func:`cablefem.create_cable`.
        length, horizontal_tension, sag_ratio, polyline: As for :func:`cablefem.create_cable`.
        elements, grading, gravity, loads, point_masses, point_loads, damping: Likewise.
        tension_only, outer_correction, span_bending, petsc_options, units: Likewise.
        dampers, fluid: Likewise.
        beam: The reference rod's mesh (:func:`cablefem.create_rod`), or None.
        source: Name of the cable in the messages.

    Returns:
        The checked :class:`cablefem.description.CableDescription`.

    Raises:
        CaseError: With every problem, each under its argument's name (``sag_ratio``,
            ``anchors[1].kind``).
    """
    problems: list[tuple[str, str]] = []
    if not isinstance(section, Section):
        problems.append(("section", f"expected a Section, got {show(section)}"))
    given = {k: v for k, v in (("length", length), ("horizontal_tension", horizontal_tension),
                               ("sag_ratio", sag_ratio), ("polyline", polyline))
             if v is not None}
    geometry = None
    if len(given) != 1:
        got = " and ".join(given) if given else "none"
        problems.append(("length", f"give exactly one of {', '.join(GEOMETRY_KINDS)}; got "
                                   f"{got}"))
    elif "polyline" in given:
        points = np.asarray(polyline, dtype=float) if is_sequence(polyline) or isinstance(
            polyline, np.ndarray) else None
        if points is None or points.ndim != 2 or points.shape[1] != 3 or len(points) < 2 \
                or not np.all(np.isfinite(points)):
            problems.append(("polyline", f"expected at least 2 finite points [x, y, z], got "
                                         f"{show(polyline)}"))
        else:
            problems += [(f"polyline[{i}]", f"zero-length segment: point {i} coincides with "
                                            f"point {i - 1}") for i in zero_segments(points)]
            length_p = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))
            geometry = Geometry("polyline", length_p, points)
    else:
        kind, value = next(iter(given.items()))
        if _check(problems, kind, number_problem(value, GEOMETRY_UNITS[kind],
                                                 **GEOMETRY_BOUNDS[kind])):
            geometry = Geometry(kind, float(value))
    parts = _common(problems, gravity=Gravity() if gravity is None else gravity,
                    elements=elements, grading=grading, loads=loads,
                    point_masses=point_masses, point_loads=point_loads, damping=damping,
                    tension_only=tension_only, outer_correction=outer_correction,
                    petsc_options={} if petsc_options is None else petsc_options,
                    network=False, span_bending=span_bending)
    anchor_list = _anchors(problems, anchors, network=False)
    if not problems:
        problems += anchor_problems(anchor_list, geometry, parts["gravity"])
        problems = [(k.replace("geometry.", ""), m) for k, m in problems]
    if geometry is not None and geometry.length is not None and not problems:
        for name in ("point_masses", "point_loads"):
            for i, item in enumerate(parts[name]):
                if item.s >= geometry.length:
                    problems.append((f"{name}[{i}].s", f"must be < l = {geometry.length:g} "
                                                       "(m), the stress-free length"))
    if beam is not None and not isinstance(beam, BeamSpec):
        problems.append(("beam", f"expected a BeamSpec, got {show(beam)}"))
    damper_list = _dampers(problems, dampers, anchor_list)
    if fluid is not None and not isinstance(fluid, Fluid):
        problems.append(("fluid", f"expected a Fluid, got {show(fluid)}"))
    elif fluid is not None:
        for name, unit, bounds in (("density", "kg/m^3", {"gt": 0}), ("diameter", "m",
                                                                      {"gt": 0}),
                                   ("cd_normal", "", {"ge": 0}),
                                   ("cd_tangential", "", {"ge": 0}),
                                   ("ca_normal", "", {"ge": 0}),
                                   ("ca_tangential", "", {"ge": 0})):
            _check(problems, f"fluid.{name}", number_problem(getattr(fluid, name), unit,
                                                             **bounds))
        problems += flow_problems(fluid, parts.get("gravity"))
    if problems:
        raise CaseError(problems, source)
    return CableDescription(section=section, anchors=anchor_list, geometry=geometry,
                            beam=beam or BeamSpec(), source=source, units=units,
                            dampers=damper_list, fluid=fluid, **parts)


def _dampers(problems: list, dampers, anchors: list) -> list[Damper]:
    """Check ``dampers`` (a sequence of :class:`Damper`, copied by :func:`_items`) against
    the anchors' names and the bounds of their values."""
    names = [getattr(a, "name", None) for a in anchors]
    out = _items(problems, "dampers", dampers, Damper, network=False)
    given = [d for d in dampers if isinstance(d, Damper)] if out else []
    for i, (d, new) in enumerate(zip(given, out)):
        key = f"dampers[{i}]"
        if d.anchor not in names:
            problems.append((f"{key}.anchor", f"must name an anchor ({', '.join(map(str, names))}"
                             f"), got {show(d.anchor)}"))
        for name, unit, bounds in (("distance", "m", {"gt": 0}),
                                   ("coefficient", "N s/m", {"ge": 0}),
                                   ("stiffness", "N/m", {"ge": 0})):
            _check(problems, f"{key}.{name}", number_problem(getattr(d, name), unit, **bounds))
        if d.direction is not None:
            new.direction = _vector(problems, f"{key}.direction", d.direction,
                                    unit_vector=True)
    return out


def describe_network(mesh_file: str | os.PathLike, sections: dict[str, Section],
                     anchors: list[Anchor], *, cables: list[CableSpec],
                     gravity: Gravity | None = None, loads=(), point_masses=(),
                     point_loads=(), damping: Damping | None = None, tension_only: bool = True,
                     outer_correction: str = "hinge", span_bending: bool | str = False,
                     petsc_options: dict | None = None, units: str = "SI",
                     source: str = "<python>", beam: BeamSpec | None = None
                     ) -> CableDescription:
    """A checked description of a cable network (the arguments of
    :func:`cablefem.create_network`, which see); the mesh itself is read by the model.

    Args:
        mesh_file: The gmsh ``.msh`` file.
        sections: Section name -> :class:`cablefem.properties.Section`.
        anchors: :class:`cablefem.anchor.Anchor` named by 0D groups of the mesh.
        cables: :class:`cablefem.description.CableSpec` of every cable group.
        gravity, loads, point_masses, point_loads, damping: As for
            :func:`cablefem.create_network`.
        tension_only, outer_correction, span_bending, petsc_options, units: As for
            :func:`cablefem.create_network`.
        source: Name of the network in the messages.
        beam: The reference rod's mesh (:func:`cablefem.create_network_rod`), or None.

    Returns:
        The checked :class:`cablefem.description.CableDescription`.

    Raises:
        CaseError: Every problem, each under its argument's name.
    """
    problems: list[tuple[str, str]] = []
    mesh = Path(mesh_file) if isinstance(mesh_file, (str, os.PathLike)) else None
    if mesh is None:
        problems.append(("mesh_file", f"expected a path, got {show(mesh_file)}"))
    elif not mesh.is_file():
        problems.append(("mesh_file", f"no such file: {mesh}"))
    if not isinstance(sections, dict) or not sections or not all(
            isinstance(s, Section) for s in sections.values()):
        problems.append(("sections", "expected a non-empty dict of name -> Section"))
        sections = {}
    if not isinstance(cables, (list, tuple)) or not cables:
        problems.append(("cables", "expected a non-empty list of CableSpec"))
        cables = []
    for i, c in enumerate(cables):
        if not isinstance(c, CableSpec):
            problems.append((f"cables[{i}]", f"expected a CableSpec, got {show(c)}"))
            continue
        if sections and c.section not in sections:
            problems.append((f"cables[{i}].section", f"unknown section {c.section!r}; known: "
                                                     f"{sorted(sections)}"))
        _check(problems, f"cables[{i}].pretension", number_problem(c.pretension, "N", ge=0))
    parts = _common(problems, gravity=Gravity() if gravity is None else gravity, elements=1,
                    grading=1.0, loads=loads, point_masses=point_masses,
                    point_loads=point_loads, damping=damping, tension_only=tension_only,
                    outer_correction=outer_correction,
                    petsc_options={} if petsc_options is None else petsc_options,
                    network=True, span_bending=span_bending)
    anchor_list = _anchors(problems, anchors, network=True)
    if beam is not None and not isinstance(beam, BeamSpec):
        problems.append(("beam", f"expected a BeamSpec, got {show(beam)}"))
    names = [a.name for a in anchor_list]
    problems += [(f"anchors[{i}].name", f"duplicate anchor group {n!r}")
                 for i, n in enumerate(names) if n in names[:i]]
    if problems:
        raise CaseError(problems, source)
    first = sections[cables[0].section]
    return CableDescription(section=first, anchors=anchor_list,
                            network=NetworkSpec(mesh, dict(sections), list(cables)),
                            beam=beam or BeamSpec(), source=source, units=units, **parts)
