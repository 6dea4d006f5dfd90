"""Parsing a case: :func:`load_case` (a TOML file) and :func:`parse_case` (a dict of the
same shape), with every problem collected before one :class:`CaseError`. The tables both kinds
of case share are parsed in :mod:`cablefem.case.tables` and :mod:`cablefem.case.environment`,
a network case in :mod:`cablefem.case.network`."""

from __future__ import annotations

import os
import re
import tomllib
from pathlib import Path

from cablefem.arguments import anchor_problems
from cablefem.case.checks import check_table_ends, table_warnings
from cablefem.case.environment import parse_fluid, parse_seabed
from cablefem.case.keys import CASE_KEYS
from cablefem.case.network import parse_network_case
from cablefem.case.reader import Reader
from cablefem.case.schema import (
    Anchor,
    BeamSpec,
    Case,
    DistributedLoad,
    Geometry,
    Gravity,
    MeshSpec,
    ModalSpec,
    PointLoad,
    PointMass,
)
from cablefem.case.tables import (
    any_missing,
    parse_damping,
    parse_dynamics,
    parse_fatigue,
    parse_geometry,
    parse_motion,
    parse_section,
    parse_solver,
    parse_time,
)
from cablefem.description import BEAM_BOUNDS, NAME, Damper
from cablefem.errors import CaseError
from cablefem.flow import flow_problems
from cablefem.validation import is_sequence, show
from cablefem.water import water_problems


def _check_anchors(anchors: list[Anchor], readers: list[Reader], geometry: Geometry | None,
                   polyline_given: bool, gravity: Gravity | None, problems: list) -> None:
    """Cross-checks that need both anchors (and the geometry and gravity): the core's
    (:func:`cablefem.description.anchor_problems`) on what the tables gave."""
    if len(readers) != 2:
        return
    for a, r in zip(anchors, readers):  # given but unreadable: reported already, or here
        if a.kind == "pinned" and a.direction is None and r.has("direction"):
            r.add("direction", "direction only applies to clamped anchors")
    problems += anchor_problems(anchors, geometry, gravity, polyline_given,
                                positions_given=tuple(r.has("position") for r in readers))


def _parse_dampers(readers: list[Reader], anchors: list, length: float | None
                   ) -> list[Damper]:
    """``[[dampers]]``: the anchor must be one of the case's, the distance inside the cable
    (against l when the case gives it directly; else when the model is built)."""
    names = [a.name for a in anchors if a is not None]
    out = []
    for r in readers:
        name = r.string("anchor")
        if name is not None and names and name not in names:
            r.add("anchor", f"must name an anchor of the case ({', '.join(names)}), got "
                  f"{name!r}")
        dist = r.number("distance", gt=0)
        if dist is not None and length is not None and dist >= length:
            r.add("distance", f"must be < l = {length:g} (m), the stress-free length")
        out.append(Damper(name, dist, r.number("coefficient", ge=0),
                          r.number("stiffness", ge=0), r.vector("direction", unit_vector=True)))
    return out


def _check_positions_on_cable(items: list, readers: list[Reader], length: float | None) -> None:
    """``s < l`` for point masses and loads, when the case gives l directly."""
    for item, r in zip(items, readers):
        if length is not None and item is not None and item.s is not None and item.s >= length:
            r.add("s", f"must be < l = {length:g} (m), the stress-free length")


def _finish(case: Case, t_end: float | None = None, dynamics: bool = True) -> Case:
    """Cross-checks of the tables against the run's time range (a problem, or warnings):
    up to ``t_end`` (the run's, e.g. ``--t-end``; default ``dynamics.t_end``), none when
    the run has no dynamics (``dynamics=False``, e.g. ``--static-only``)."""
    if case.dynamics is not None and dynamics:
        end = case.dynamics.t_end if t_end is None else float(t_end)
        problems = check_table_ends(case, end)
        if problems:
            raise CaseError(problems, case.source)
        case.warnings.extend(table_warnings(case, case.dynamics.dt, end))
    return case


def parse_case(data: dict, base_dir: str | os.PathLike = Path("."),
               source: str = "<dict>", *, t_end: float | None = None,
               dynamics: bool = True) -> Case:
    """Validate a case given as a dict of the TOML file's shape (see :data:`CASE_KEYS`).

    Args:
        data (dict): The case.
        base_dir (path-like): Folder against which relative CSV paths are resolved.
        source (str): Name of the case in error messages and in ``Case.source``.
        t_end (float, optional): The run's end (s) against which the tables' lengths are checked
            (``--t-end``); default ``dynamics.t_end``.
        dynamics (bool): False for a run without dynamics (``--static-only``, ``cablefem modes``):
            the tables' lengths are not checked.

    Raises:
        CaseError: With every problem found (unknown keys, types, ranges, missing keys,
            combinations, CSV files).
    """
    if not isinstance(data, dict):
        raise CaseError([("", f"expected a table of keys, got {show(data)}")], source)
    if "network" in data:
        return _finish(parse_network_case(data, Path(base_dir), source), t_end, dynamics)
    run = (t_end, dynamics)  # the run's (the case's own [dynamics] is parsed below)
    base_dir, problems = Path(base_dir), []
    top = Reader(data, "", CASE_KEYS, problems)

    def table(name: str) -> Reader:  # an optional table, empty when absent
        return top.table(name) or Reader({}, name, CASE_KEYS[name].keys, problems)

    title = top.string("title")
    units = top.string("units", ("SI", "dimensionless"))
    section_r, geometry_r = top.table("section"), top.table("geometry")
    section = parse_section(section_r) if section_r else None
    geometry = parse_geometry(geometry_r) if geometry_r else None
    gravity_r = table("gravity")
    g, direction = gravity_r.number("g", ge=0), gravity_r.vector("direction", unit_vector=True)
    gravity = None if g is None or direction is None else Gravity(g, direction)
    mesh_r = table("mesh")
    mesh = MeshSpec(mesh_r.integer("elements", le=10_000_000), mesh_r.number("grading", ge=1))

    anchor_rs = top.tables("anchors")
    if is_sequence(data.get("anchors")) and len(anchor_rs) != 2:
        problems.append(("anchors", f"expected exactly 2 anchors, got {len(anchor_rs)}"))
    anchors = []
    for r in anchor_rs:
        name = r.string("name")
        if name is not None and not NAME.fullmatch(name):
            r.add("name", f"must use only the characters A-Z a-z 0-9 _ -, got {name!r}")
        anchors.append(Anchor(name, r.vector("position"), r.string("type", ("clamped", "pinned")),
                              r.vector("direction", unit_vector=True),
                              parse_motion(r.table("motion"), base_dir)))
    _check_anchors(anchors, anchor_rs, geometry, geometry_r is not None and
                   geometry_r.has("polyline"), gravity, problems)

    load_rs, mass_rs, pload_rs = (top.tables(k) for k in ("loads", "point_masses", "point_loads"))
    loads = [DistributedLoad(r.vector("value"), parse_time(r.table("time"), base_dir))
             for r in load_rs]
    masses = [PointMass(r.number("s", gt=0), r.number("mass", gt=0)) for r in mass_rs]
    point_loads = [PointLoad(r.number("s", gt=0), r.vector("value"),
                             parse_time(r.table("time"), base_dir)) for r in pload_rs]
    length = geometry.length if geometry is not None else None
    _check_positions_on_cable(masses, mass_rs, length)
    _check_positions_on_cable(point_loads, pload_rs, length)

    dampers = _parse_dampers(top.tables("dampers"), anchors, length)
    fluid = parse_fluid(top.table("fluid"), section, base_dir)
    if fluid is not None:
        problems += [p for p in flow_problems(fluid, gravity)
                     if p[0] != "fluid.waves" or "surface" not in p[1]]  # reported already
    seabed = parse_seabed(top.table("seabed"))
    problems += water_problems(anchors, gravity, fluid, seabed)
    damping = parse_damping(top.table("damping"))
    dynamics = parse_dynamics(top.table("dynamics"))
    modal = ModalSpec(table("modal").integer("modes", ge=0))
    fatigue = parse_fatigue(top.table("fatigue"), section)
    beam_r = table("beam")
    beam = BeamSpec(*(beam_r.integer(k, **BEAM_BOUNDS[k][0]) if k == "span_elements"
                      else beam_r.number(k, **BEAM_BOUNDS[k][0]) for k in BEAM_BOUNDS))
    solver = parse_solver(table("solver"))
    if problems:
        raise CaseError(problems, source)
    parts = [title, section, gravity, geometry, mesh.elements, mesh.grading, damping,
             modal.modes, solver.tension_only]
    parts += [x for a in anchors for x in (a.name, a.position, a.kind)]
    parts += [x for item in loads + point_loads for x in (item.value, item.time)]
    parts += [x for item in masses for x in (item.s, item.mass)] + [p.s for p in point_loads]
    if any_missing(*parts):  # every None above must have come with a reported problem
        raise RuntimeError("cablefem internal error: a case value failed without a message")
    if any_missing(beam.layer_elements, beam.growth, beam.span_elements):
        raise RuntimeError("cablefem internal error: a case value failed without a message")
    return _finish(Case(title=title, section=section, gravity=gravity, geometry=geometry,
                        mesh=mesh, anchors=anchors, loads=loads, point_masses=masses,
                        point_loads=point_loads, dampers=dampers, fluid=fluid, seabed=seabed,
                        damping=damping,
                        dynamics=dynamics, modal=modal, solver=solver, source=source,
                        fatigue=fatigue,
                        beam=beam, units=units or "SI"), *run)


def load_case(path: str | os.PathLike, *, t_end: float | None = None,
              dynamics: bool = True) -> Case:
    """Read and validate a TOML case file; relative CSV paths are taken from its folder.

    Args:
        path: The case file.
        t_end: The run's end (s), as in :func:`parse_case`.
        dynamics: False for a run without dynamics, as in :func:`parse_case`.

    Returns:
        The validated :class:`~cablefem.case.schema.Case`.

    Raises:
        CaseError: If the file cannot be read, is not valid TOML, or has any problem (all reported).
    """
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise CaseError([("file", f"cannot read the case file: {exc.strerror or exc}")],
                        str(path)) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        where = re.search(r"line (\d+), column (\d+)", str(exc))
        key = f"line {where.group(1)}, column {where.group(2)}" if where else "TOML syntax"
        raise CaseError([(key, f"not a valid TOML file: {exc}")], str(path)) from None
    return parse_case(data, base_dir=path.parent, source=str(path), t_end=t_end,
                      dynamics=dynamics)
