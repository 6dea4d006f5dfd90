"""Parsing a network case (``[network]``, ``[[sections]]``, ``[[cables]]``, anchor groups,
...; see :data:`cablefem.case.keys.NETWORK_KEYS`)."""

from __future__ import annotations

from pathlib import Path

from cablefem.case.environment import parse_fluid, parse_seabed
from cablefem.case.keys import NETWORK_KEYS
from cablefem.case.reader import Reader
from cablefem.case.schema import (
    Anchor,
    CableSpec,
    Case,
    DistributedLoad,
    Gravity,
    MeshSpec,
    ModalSpec,
    NetworkSpec,
    PointLoad,
    PointMass,
)
from cablefem.case.tables import (
    any_missing,
    parse_damping,
    parse_dynamics,
    parse_fatigue,
    parse_motion,
    parse_section,
    parse_solver,
    parse_time,
)
from cablefem.description import BEAM_BOUNDS, BeamSpec, DamperLink
from cablefem.errors import CaseError
from cablefem.flow import flow_problems
from cablefem.water import water_problems


def parse_network_case(data: dict, base_dir: Path, source: str) -> Case:
    """A network case (see :data:`NETWORK_KEYS`); the mesh itself is read and checked when
    the model is built (:func:`cablefem.geometry.read_network_mesh`).

    Args:
        data: The case, as a dict of the TOML file's shape.
        base_dir: Folder of the case file (the mesh and CSV files are relative to it).
        source: Name of the case in the messages.

    Returns:
        The :class:`~cablefem.case.schema.Case` (its ``network`` set), not yet checked
        against the run's time range.

    Raises:
        CaseError: With every problem found.
    """
    problems: list = []
    top = Reader(data, "", NETWORK_KEYS, problems)

    def table(name: str) -> Reader:
        return top.table(name) or Reader({}, name, NETWORK_KEYS[name].keys, problems)

    title = top.string("title")
    units = top.string("units", ("SI", "dimensionless"))
    net_r = top.table("network")
    mesh_path, net_kinks = None, "all"
    if net_r is not None:
        net_kinks = net_r.string("kinks", ("all", "loaded", "none")) or "all"
        name = net_r.string("mesh")
        if name is not None:
            mesh_path = base_dir / name
            if not mesh_path.is_file():
                net_r.add("mesh", f"no such file: {mesh_path}")
                mesh_path = None
    sections = {}
    for r in top.tables("sections"):
        name, sec = r.string("name"), parse_section(r)
        if name in sections:
            r.add("name", f"duplicate section name {name!r}")
        elif name is not None and sec is not None:
            sections[name] = sec
    cables = []
    for r in top.tables("cables"):
        group, sec_name = r.string("group"), r.string("section")
        pre = r.number("pretension", ge=0)
        if sec_name is not None and sec_name not in sections and not problems:
            r.add("section", f"unknown section {sec_name!r}; known: {sorted(sections)}")
        if None not in (group, sec_name, pre):
            cables.append(CableSpec(group, sec_name, pre))
    gravity_r = table("gravity")
    g, direction = gravity_r.number("g", ge=0), gravity_r.vector("direction", unit_vector=True)
    gravity = None if g is None or direction is None else Gravity(g, direction)
    anchors = []
    names = set()
    for r in top.tables("anchors"):
        name = r.string("name")
        if name in names:
            r.add("name", f"duplicate anchor group {name!r}")
        names.add(name)
        kind = r.string("type", ("clamped", "pinned"))
        if kind == "pinned" and r.has("direction"):
            r.add("direction", "direction only applies to clamped anchors")
        anchors.append(Anchor(name, None, kind, r.vector("direction", unit_vector=True),
                              parse_motion(r.table("motion"), base_dir)))
    loads = [DistributedLoad(r.vector("value"), parse_time(r.table("time"), base_dir))
             for r in top.tables("loads")]
    masses = [PointMass(r.string("group"), r.number("mass", gt=0))
              for r in top.tables("point_masses")]
    point_loads = [PointLoad(r.string("group"), r.vector("value"),
                             parse_time(r.table("time"), base_dir))
                   for r in top.tables("point_loads")]
    links = []
    for r in top.tables("dampers"):
        group = r.string("group")
        if group is not None and group in {c.group for c in cables}:
            r.add("group", f"{group!r} is a [[cables]] group: a damper's group holds its own "
                           "cells")
        elif group is not None and group in {d.group for d in links}:
            r.add("group", f"duplicate damper group {group!r}")
        links.append(DamperLink(group, r.number("coefficient", ge=0),
                                r.number("stiffness", ge=0),
                                r.vector("direction", unit_vector=True)))
    damping = parse_damping(top.table("damping"))
    dynamics = parse_dynamics(top.table("dynamics"))
    modal = ModalSpec(table("modal").integer("modes", ge=0))
    beam_r = table("beam")
    beam = BeamSpec(*(beam_r.integer(k, **BEAM_BOUNDS[k][0]) if k == "span_elements"
                      else beam_r.number(k, **BEAM_BOUNDS[k][0]) for k in BEAM_BOUNDS))
    solver = parse_solver(table("solver"))
    first = sections.get(cables[0].section) if cables else None
    fatigue = parse_fatigue(top.table("fatigue"), first)
    fluid_r = top.table("fluid")
    fluid = parse_fluid(fluid_r, None, base_dir)
    if fluid is not None:
        if fluid.diameter is None:  # each cable's section's
            bare = sorted({c.section for c in cables if c.section in sections
                           and sections[c.section].diameter is None})
            if bare:
                fluid_r.add("diameter", "required: give fluid.diameter, or a diameter to "
                            f"the sections {bare} (sections.diameter)")
        problems += [p for p in flow_problems(fluid, gravity)
                     if p[0] != "fluid.waves" or "surface" not in p[1]]  # reported already
    seabed = parse_seabed(top.table("seabed"))
    problems += water_problems([], gravity, fluid, seabed)  # the anchors: in the model
    if problems:
        raise CaseError(problems, source)
    if any_missing(title, gravity, mesh_path, first, damping, modal.modes, solver.tension_only,
                   beam.layer_elements, beam.growth, beam.span_elements):
        raise RuntimeError("cablefem internal error: a case value failed without a message")
    return (Case(title=title, section=first, gravity=gravity, geometry=None,
                        mesh=MeshSpec(1, 1.0), anchors=anchors, loads=loads,
                        point_masses=masses, point_loads=point_loads, damping=damping,
                        dynamics=dynamics, modal=modal, solver=solver, source=source,
                        dampers=links, fatigue=fatigue, fluid=fluid, seabed=seabed,
                        network=NetworkSpec(mesh_path, sections, cables, net_kinks), beam=beam,
                        units=units or "SI"))
