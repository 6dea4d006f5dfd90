"""Parsing a case, table by table: :func:`load_case` (a TOML file) and :func:`parse_case` (a
dict of the same shape), with every problem collected before one :class:`CaseError`."""

from __future__ import annotations

import math
import numbers
import os
import re
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from cablefem.case.checks import _table_warnings, check_table_ends
from cablefem.case.keys import _MOTION_KEYS, CASE_KEYS, NETWORK_KEYS
from cablefem.case.reader import _is_number, _is_sequence, _Reader, _show
from cablefem.case.schema import (
    Anchor,
    BeamSpec,
    CableSpec,
    Case,
    Damping,
    DistributedLoad,
    DynamicsSpec,
    FatigueSpec,
    Geometry,
    Gravity,
    MeshSpec,
    ModalSpec,
    NetworkSpec,
    PointLoad,
    PointMass,
    SolverSpec,
    rayleigh_coefficients,
)
from cablefem.describe import anchor_problems, zero_segments
from cablefem.description import (
    BEAM_BOUNDS,
    GEOMETRY_BOUNDS,
    GEOMETRY_KINDS,
    NAME,
    AiryWave,
    Damper,
    DamperLink,
    Fluid,
    Profile,
    Seabed,
    VelocitySeries,
)
from cablefem.errors import CaseError
from cablefem.flow import flow_problems, jonswap_waves, read_velocity_csv
from cablefem.motion import (
    EllipseMotion,
    HarmonicMotion,
    Motion,
    TableMotion,
    TimeFunction,
    default_ramp,
    read_factor_csv,
    read_motion_csv,
)
from cablefem.properties import Section
from cablefem.water import water_problems

# ---------------------------------------------------------------------------------------------
# Parsing, table by table.

_TOL = 1e-9  # relative tolerance for coincident points and parallel directions


def _missing(*parts: Any) -> bool:
    """True if any part failed to parse (is None); safe with NumPy arrays."""
    return any(p is None for p in parts)


def _parse_section(r: _Reader) -> Section | None:
    values = (r.number("EA", gt=0), r.number("EI", ge=0), r.number("GJ", ge=0),
              r.number("mass", gt=0))
    diameter = r.number("diameter", gt=0)
    if _missing(*values) or (r.has("diameter") and diameter is None):
        return None
    return Section(*values, diameter=diameter)


def _parse_geometry(r: _Reader) -> Geometry | None:
    given = [k for k in GEOMETRY_KINDS if r.has(k)]
    if len(given) != 1:
        got = " and ".join(given) if given else "none"
        r.problems.append((r.path, f"give exactly one of {', '.join(GEOMETRY_KINDS)}; "
                                   f"got {got}"))
    values = {k: r.number(k, **GEOMETRY_BOUNDS[k]) for k in given if k != "polyline"}
    points = _parse_polyline(r) if "polyline" in given else None
    if len(given) != 1:
        return None
    kind = given[0]
    if kind == "polyline":
        if points is None:
            return None
        length = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))
        return Geometry("polyline", length, points)
    return None if values[kind] is None else Geometry(kind, values[kind])


def _parse_polyline(r: _Reader) -> np.ndarray | None:
    value, _ = r.raw("polyline")
    if not _is_sequence(value) or len(value) < 2:
        r.add("polyline", f"expected a list of at least 2 points [x, y, z], got {_show(value)}")
        return None
    key = r.key("polyline")
    points = [r.numbers("polyline", 3, value=p, key=f"{key}[{i}]") for i, p in enumerate(value)]
    if any(p is None for p in points):
        return None
    points = np.array(points)
    zero = zero_segments(points)
    for i in zero:
        r.problems.append((f"{key}[{i}]", f"zero-length segment: point {i} coincides with "
                                          f"point {i - 1}"))
    return None if zero.size else points


def _parse_motion(r: _Reader | None, base_dir: Path) -> Motion | None:
    if r is None:
        return None
    kind = r.string("type", choices=tuple(_MOTION_KEYS))
    if kind is None:
        return None
    what = f"a {kind} motion"
    r.only(_MOTION_KEYS[kind], what)
    if kind == "table":
        hold = r.boolean("hold")
        table = r.csv("file", read_motion_csv, base_dir) if r.require("file", what) else None
        return None if table is None or hold is None else TableMotion(
            table.times, table.values, table.source, hold)
    present = r.require("omega", what)
    ramp = r.number("ramp", ge=0)  # None: not given (the default below) or bad (reported)
    bad_ramp = r.has("ramp") and ramp is None
    if kind == "harmonic":
        present = r.require("amplitude", what) and present
        parts = (r.vector("amplitude"), r.number_or_vector("omega", gt=0),
                 r.number_or_vector("phase"))
        if not present or _missing(*parts) or bad_ramp:
            return None
        ramp = default_ramp(parts[1], parts[0]) if ramp is None else ramp
        if not _finite_ramp(r, ramp):
            return None
        return HarmonicMotion(*parts, ramp=ramp)
    if not (r.has("axis_sin") or r.has("axis_cos")):
        r.problems.append((r.path, "an ellipse motion needs axis_sin and/or axis_cos"))
        present = False
    parts = (r.number("omega", gt=0), r.vector("axis_sin"), r.vector("axis_cos"))
    if not present or _missing(*parts) or bad_ramp:
        return None
    ramp = default_ramp(parts[0]) if ramp is None else ramp
    if not _finite_ramp(r, ramp):
        return None
    return EllipseMotion(*parts, ramp=ramp)


def _finite_ramp(r: _Reader, ramp: float) -> bool:
    """A ramp (given, or the default of a few periods) that is a number of seconds; else
    the problem goes to ``omega`` (a frequency so small that its periods overflow) or
    ``ramp``."""
    if math.isfinite(ramp):
        return True
    key = "ramp" if r.has("ramp") else "omega"
    r.problems.append((f"{r.path}.{key}", "too small a circular frequency: the default ramp "
                       "of a few periods is not a finite time; give a larger omega or a ramp"
                       if key == "omega" else "must be finite"))
    return False


def _parse_time(r: _Reader | None, base_dir: Path) -> TimeFunction | None:
    if r is None:
        return TimeFunction.constant()
    kind = r.string("type", choices=("constant", "harmonic", "table"))
    if kind is None:
        return None
    what = f"a {kind} time function"
    r.only({"constant": (), "harmonic": ("omega", "phase"), "table": ("file", "hold")}[kind],
           what)
    if kind == "constant":
        return TimeFunction.constant()
    if kind == "table":
        hold = r.boolean("hold")
        table = r.csv("file", read_factor_csv, base_dir) if r.require("file", what) else None
        return None if table is None or hold is None else TimeFunction.table(
            table.times, table.factors, table.source, hold)
    present = r.require("omega", what)
    omega, phase = r.number("omega", gt=0), r.number("phase")
    return TimeFunction.harmonic(omega, phase) if present and not _missing(omega, phase) else None


def _parse_damping(r: _Reader | None) -> Damping | None:
    if r is None:
        return Damping("none", 0.0, 0.0)
    model = r.string("model", choices=("rayleigh", "rayleigh_k0", "axial", "none"))
    alpha, beta = r.number("alpha", ge=0), r.number("beta", ge=0)
    ratio = r.number("ratio", ge=0, lt=1)
    ratios = r.numbers("ratios", 2, ge=0, lt=1)
    freqs = r.numbers("frequencies", 2, gt=0)
    direct = [k for k in ("alpha", "beta") if r.has(k)]
    modal = [k for k in ("ratio", "ratios", "frequencies") if r.has(k)]
    if model is None:
        return None
    if model == "none":
        r.only((), "model 'none'", "model")
        return Damping("none", 0.0, 0.0)
    if model == "axial":
        r.only(("beta",), "axial damping", "model")
        return Damping("axial", 0.0, beta) if r.require("beta", "axial damping") and \
            beta is not None else None
    if direct and modal:
        r.problems.append((r.path, f"give either alpha/beta or ratio(s) with frequencies, not "
                                   f"both (got {', '.join(direct + modal)})"))
        return None
    if not modal:
        if not direct:
            r.problems.append((r.path, "give alpha and/or beta, or ratio (or ratios) with "
                                       "frequencies"))
        return Damping(model, alpha, beta) if direct and not _missing(alpha, beta) else None
    if r.has("ratio") == r.has("ratios"):
        r.problems.append((r.path, "give exactly one of ratio and ratios"))
        return None
    if not r.require("frequencies", "damping ratios"):
        return None
    zs = (ratio, ratio) if r.has("ratio") else ratios
    if freqs is None or zs is None or _missing(*zs):
        return None
    if abs(freqs[1] - freqs[0]) <= _TOL * max(freqs):
        r.add("frequencies", f"must be two distinct frequencies, got {freqs.tolist()}")
        return None
    zs, freqs = tuple(float(z) for z in zs), tuple(float(w) for w in freqs)
    a, b = rayleigh_coefficients(zs, freqs)
    if a < 0 or b < 0:
        r.problems.append((r.path, f"the ratios {list(zs)} at {list(freqs)} rad/s give a "
                                   f"negative coefficient (alpha = {a:g} 1/s, beta = {b:g} s)"))
        return None
    return Damping(model, a, b, zs, freqs)


def _parse_dynamics(r: _Reader | None) -> DynamicsSpec | None:
    if r is None:
        return None
    t_end, dt = r.number("t_end", gt=0), r.number("dt", gt=0)
    if t_end is not None and dt is not None and dt > t_end:
        r.add("dt", f"must be <= t_end = {t_end!r} (s), got {dt!r}")
        return None
    parts = (t_end, dt, r.number("rho_inf", ge=0, le=1), r.integer("output_every"),
             r.integer("fields_every"), r.integer("checkpoint_every", ge=0),
             r.string("initial", choices=("quasi-static", "rest")))
    start, bad_start = r.number("statistics_start", ge=0), False
    if start is not None and t_end is not None and start >= t_end:
        r.add("statistics_start", f"must be < t_end = {t_end!r} (s), got {start!r}")
        bad_start = True
    if r.has("statistics_start") and start is None:
        bad_start = True
    return None if _missing(*parts) or bad_start else DynamicsSpec(*parts, start)


def _parse_petsc_options(r: _Reader) -> dict:
    value, given = r.raw("petsc_options")
    if not given:
        return {}
    if not isinstance(value, dict):
        r.add("petsc_options", f"expected a table of options, got {_show(value)}")
        return {}
    for name, option in value.items():
        key = f"{r.key('petsc_options')}.{name}"
        if str(name).startswith(("-", "cable_")):
            r.problems.append((key, "give the option without '-' or the 'cable_' prefix (the "
                                    "solver adds '-cable_')"))
        if not isinstance(option, (str, bool, numbers.Real)):
            r.problems.append((key, f"expected a string, number or boolean, got "
                                    f"{_show(option)}"))
        elif _is_number(option) and not math.isfinite(option):
            r.problems.append((key, f"must be finite, got {option!r}"))
    return dict(value)


def _check_anchors(anchors: list[Anchor], readers: list[_Reader], geometry: Geometry | None,
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


def _parse_dampers(readers: list[_Reader], anchors: list, length: float | None
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


def _parse_seabed(r: _Reader | None) -> Seabed | None:
    return None if r is None else Seabed(
        r.number("z"), r.number("stiffness", gt=0), r.number("damping", ge=0),
        r.number("friction", ge=0), r.number("friction_velocity", gt=0))


def _parse_fluid(r: _Reader | None, section, base_dir: Path) -> Fluid | None:
    """``[fluid]``: the diameter defaults to the section's (``section`` None, a network's:
    to each cable's section's, checked by the caller; the diameter stays None)."""
    if r is None:
        return None
    D = r.number("diameter", gt=0)
    if D is None:
        D = getattr(section, "diameter", None) if section is not None else None
        if D is None and section is not None:
            r.add("diameter", "required: give fluid.diameter or section.diameter")
    current = r.vector("current")
    surface = r.number("surface")
    waves = [_parse_wave(w) for w in r.tables("waves")]
    if waves and surface is None and not r.has("surface"):
        r.add("waves", "waves need the free surface: give fluid.surface")
    spectrum = r.table("spectrum")
    if spectrum is not None:
        waves += _parse_spectrum(spectrum)
        if surface is None and not r.has("surface"):
            r.add("spectrum", "waves need the free surface: give fluid.surface")
    velocity = r.table("velocity")
    if velocity is not None:
        hold = velocity.boolean("hold")
        velocity = (velocity.csv("file", read_velocity_csv, base_dir)
                    if velocity.require("file", "a velocity history") else None)
        if velocity is not None and hold:
            velocity = VelocitySeries(velocity.times, velocity.values, velocity.source, True)
    return Fluid(r.number("density", gt=0), D,
                 np.zeros(3) if current is None else current, surface,
                 r.number("cd_normal", ge=0), r.number("cd_tangential", ge=0),
                 r.number("ca_normal", ge=0), r.boolean("buoyancy"),
                 _parse_time(r.table("time"), base_dir) or TimeFunction.constant(),
                 _parse_profile(r.table("profile")), tuple(w for w in waves if w is not None),
                 r.number("depth", gt=0), r.number("wave_ramp", ge=0), velocity,
                 r.number("ca_tangential", ge=0))


def _parse_profile(r: _Reader | None) -> Profile | None:
    """``[fluid.profile]``: a table of factors against elevation, or a power law."""
    if r is None:
        return None
    kind = r.string("type", choices=("table", "power"))
    if kind is None:
        return None
    r.only({"table": ("elevation", "factor"),
            "power": ("reference", "exponent", "ground")}[kind], f"a {kind} profile")
    if kind == "power":
        ref, exp, ground = (r.number("reference", gt=0), r.number("exponent", ge=0),
                            r.number("ground"))
        return None if _missing(ref, exp, ground) else Profile("power", reference=ref,
                                                                exponent=exp, ground=ground)
    present = r.require("elevation", "a table profile") & r.require("factor", "a table profile")
    z, f = r.number_list("elevation"), r.number_list("factor")
    if not present or z is None or f is None:
        return None
    if z.size != f.size:
        r.add("factor", f"expected as many factors as elevations ({z.size}), got {f.size}")
        return None
    if np.any(np.diff(z) <= 0):
        r.add("elevation", "must be strictly increasing")
        return None
    return Profile("table", elevations=z, factors=f)


def _parse_spectrum(r: _Reader) -> list:
    """``[fluid.spectrum]``: an irregular sea of a JONSWAP spectrum, as Airy components
    (:func:`cablefem.flow.jonswap_waves`)."""
    r.string("type", ("jonswap",))
    hs, tp = r.number("hs", gt=0), r.number("tp", gt=0)
    gamma = r.number("gamma", ge=1, le=10)
    direction = r.vector("direction", unit_vector=True)
    n, seed = r.integer("components"), r.integer("seed", ge=0)
    low, high = r.number("low", gt=0), r.number("high", gt=0)
    if None not in (low, high) and low >= high:
        r.add("high", f"must be above low = {low:g}")
        return []
    if _missing(hs, tp, gamma, direction, n, seed, low, high):
        return []
    return jonswap_waves(hs, tp, direction, gamma, n, seed, low, high)


def _parse_wave(r: _Reader) -> AiryWave | None:
    """``[[fluid.waves]]``: an Airy component with a horizontal direction (checked against
    gravity in the model, which knows it)."""
    height, period = r.number("height", gt=0), r.number("period", gt=0)
    direction, phase = r.vector("direction", unit_vector=True), r.number("phase")
    if _missing(height, period, direction, phase):
        return None
    return AiryWave(height, period, direction, phase)


def _check_positions_on_cable(items: list, readers: list[_Reader], length: float | None) -> None:
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
        case.warnings.extend(_table_warnings(case, case.dynamics.dt, end))
    return case


def parse_case(data: dict, base_dir: str | os.PathLike = Path("."),
               source: str = "<dict>", *, t_end: float | None = None,
               dynamics: bool = True) -> Case:
    """Validate a case given as a dict of the TOML file's shape (see :data:`CASE_KEYS`).

    Parameters
    ----------
    data : dict
        The case.
    base_dir : path-like
        Folder against which relative CSV paths are resolved.
    source : str
        Name of the case in error messages and in ``Case.source``.
    t_end : float, optional
        The run's end (s) against which the tables' lengths are checked (``--t-end``);
        default ``dynamics.t_end``.
    dynamics : bool
        False for a run without dynamics (``--static-only``, ``cablefem modes``): the
        tables' lengths are not checked.

    Raises
    ------
    CaseError
        With every problem found (unknown keys, types, ranges, missing keys, combinations,
        CSV files).
    """
    if not isinstance(data, dict):
        raise CaseError([("", f"expected a table of keys, got {_show(data)}")], source)
    if "network" in data:
        return _finish(_parse_network_case(data, Path(base_dir), source), t_end, dynamics)
    run = (t_end, dynamics)  # the run's (the case's own [dynamics] is parsed below)
    base_dir, problems = Path(base_dir), []
    top = _Reader(data, "", CASE_KEYS, problems)

    def table(name: str) -> _Reader:  # an optional table, empty when absent
        return top.table(name) or _Reader({}, name, CASE_KEYS[name].keys, problems)

    title = top.string("title")
    units = top.string("units", ("SI", "dimensionless"))
    section_r, geometry_r = top.table("section"), top.table("geometry")
    section = _parse_section(section_r) if section_r else None
    geometry = _parse_geometry(geometry_r) if geometry_r else None
    gravity_r = table("gravity")
    g, direction = gravity_r.number("g", ge=0), gravity_r.vector("direction", unit_vector=True)
    gravity = None if g is None or direction is None else Gravity(g, direction)
    mesh_r = table("mesh")
    mesh = MeshSpec(mesh_r.integer("elements", le=10_000_000), mesh_r.number("grading", ge=1))

    anchor_rs = top.tables("anchors")
    if _is_sequence(data.get("anchors")) and len(anchor_rs) != 2:
        problems.append(("anchors", f"expected exactly 2 anchors, got {len(anchor_rs)}"))
    anchors = []
    for r in anchor_rs:
        name = r.string("name")
        if name is not None and not NAME.fullmatch(name):
            r.add("name", f"must use only the characters A-Z a-z 0-9 _ -, got {name!r}")
        anchors.append(Anchor(name, r.vector("position"), r.string("type", ("clamped", "pinned")),
                              r.vector("direction", unit_vector=True),
                              _parse_motion(r.table("motion"), base_dir)))
    _check_anchors(anchors, anchor_rs, geometry, geometry_r is not None and
                   geometry_r.has("polyline"), gravity, problems)

    load_rs, mass_rs, pload_rs = (top.tables(k) for k in ("loads", "point_masses", "point_loads"))
    loads = [DistributedLoad(r.vector("value"), _parse_time(r.table("time"), base_dir))
             for r in load_rs]
    masses = [PointMass(r.number("s", gt=0), r.number("mass", gt=0)) for r in mass_rs]
    point_loads = [PointLoad(r.number("s", gt=0), r.vector("value"),
                             _parse_time(r.table("time"), base_dir)) for r in pload_rs]
    length = geometry.length if geometry is not None else None
    _check_positions_on_cable(masses, mass_rs, length)
    _check_positions_on_cable(point_loads, pload_rs, length)

    dampers = _parse_dampers(top.tables("dampers"), anchors, length)
    fluid = _parse_fluid(top.table("fluid"), section, base_dir)
    if fluid is not None:
        problems += [p for p in flow_problems(fluid, gravity)
                     if p[0] != "fluid.waves" or "surface" not in p[1]]  # reported already
    seabed = _parse_seabed(top.table("seabed"))
    problems += water_problems(anchors, gravity, fluid, seabed)
    damping = _parse_damping(top.table("damping"))
    dynamics = _parse_dynamics(top.table("dynamics"))
    modal = ModalSpec(table("modal").integer("modes", ge=0))
    fatigue = _parse_fatigue(top.table("fatigue"), section)
    beam_r = table("beam")
    beam = BeamSpec(*(beam_r.integer(k, **BEAM_BOUNDS[k][0]) if k == "span_elements"
                      else beam_r.number(k, **BEAM_BOUNDS[k][0]) for k in BEAM_BOUNDS))
    solver_r = table("solver")
    solver = SolverSpec(solver_r.boolean("tension_only"), _parse_petsc_options(solver_r),
                        solver_r.string("outer_correction", ("none", "hinge")),
                        solver_r.boolean_or("span_bending", "auto"),
                        solver_r.string("model", ("string", "beam", "auto")))
    if problems:
        raise CaseError(problems, source)
    parts = [title, section, gravity, geometry, mesh.elements, mesh.grading, damping,
             modal.modes, solver.tension_only]
    parts += [x for a in anchors for x in (a.name, a.position, a.kind)]
    parts += [x for item in loads + point_loads for x in (item.value, item.time)]
    parts += [x for item in masses for x in (item.s, item.mass)] + [p.s for p in point_loads]
    if _missing(*parts):  # every None above must have come with a reported problem
        raise RuntimeError("cablefem internal error: a case value failed without a message")
    if _missing(beam.layer_elements, beam.growth, beam.span_elements):
        raise RuntimeError("cablefem internal error: a case value failed without a message")
    return _finish(Case(title=title, section=section, gravity=gravity, geometry=geometry,
                        mesh=mesh, anchors=anchors, loads=loads, point_masses=masses,
                        point_loads=point_loads, dampers=dampers, fluid=fluid, seabed=seabed,
                        damping=damping,
                        dynamics=dynamics, modal=modal, solver=solver, source=source,
                        fatigue=fatigue,
                        beam=beam, units=units or "SI"), *run)


def _parse_network_case(data: dict, base_dir: Path, source: str) -> Case:
    """A network case (see :data:`NETWORK_KEYS`); the mesh itself is read and checked when
    the model is built (:func:`cablefem.geometry.read_network_mesh`)."""
    problems: list = []
    top = _Reader(data, "", NETWORK_KEYS, problems)

    def table(name: str) -> _Reader:
        return top.table(name) or _Reader({}, name, NETWORK_KEYS[name].keys, problems)

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
        name, sec = r.string("name"), _parse_section(r)
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
                              _parse_motion(r.table("motion"), base_dir)))
    loads = [DistributedLoad(r.vector("value"), _parse_time(r.table("time"), base_dir))
             for r in top.tables("loads")]
    masses = [PointMass(r.string("group"), r.number("mass", gt=0))
              for r in top.tables("point_masses")]
    point_loads = [PointLoad(r.string("group"), r.vector("value"),
                             _parse_time(r.table("time"), base_dir))
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
    damping = _parse_damping(top.table("damping"))
    dynamics = _parse_dynamics(top.table("dynamics"))
    modal = ModalSpec(table("modal").integer("modes", ge=0))
    solver_r = table("solver")
    solver = SolverSpec(solver_r.boolean("tension_only"), _parse_petsc_options(solver_r),
                        solver_r.string("outer_correction", ("none", "hinge")),
                        solver_r.boolean_or("span_bending", "auto"),
                        solver_r.string("model", ("string", "beam", "auto")))
    first = sections.get(cables[0].section) if cables else None
    fatigue = _parse_fatigue(top.table("fatigue"), first)
    fluid_r = top.table("fluid")
    fluid = _parse_fluid(fluid_r, None, base_dir)
    if fluid is not None:
        if fluid.diameter is None:  # each cable's section's
            bare = sorted({c.section for c in cables if c.section in sections
                           and sections[c.section].diameter is None})
            if bare:
                fluid_r.add("diameter", "required: give fluid.diameter, or a diameter to "
                            f"the sections {bare} (sections.diameter)")
        problems += [p for p in flow_problems(fluid, gravity)
                     if p[0] != "fluid.waves" or "surface" not in p[1]]  # reported already
    seabed = _parse_seabed(top.table("seabed"))
    problems += water_problems([], gravity, fluid, seabed)  # the anchors: in the model
    if problems:
        raise CaseError(problems, source)
    if _missing(title, gravity, mesh_path, first, damping, modal.modes, solver.tension_only):
        raise RuntimeError("cablefem internal error: a case value failed without a message")
    return (Case(title=title, section=first, gravity=gravity, geometry=None,
                        mesh=MeshSpec(1, 1.0), anchors=anchors, loads=loads,
                        point_masses=masses, point_loads=point_loads, damping=damping,
                        dynamics=dynamics, modal=modal, solver=solver, source=source,
                        dampers=links, fatigue=fatigue, fluid=fluid, seabed=seabed,
                        network=NetworkSpec(mesh_path, sections, cables, net_kinks),
                        units=units or "SI"))


def _parse_fatigue(r: _Reader | None, section: Section | None) -> FatigueSpec | None:
    if r is None:
        return None
    vals = dict(detail_category=r.number("detail_category", gt=0), m1=r.number("m1", ge=1),
                m2=r.number("m2", ge=1), knee=r.boolean("knee"), N_C=r.number("N_C", gt=0),
                N_knee=r.number("N_knee", gt=0), N_cutoff=r.number("N_cutoff", gt=0),
                area=r.number("area", gt=0), modulus=r.number("modulus", gt=0),
                window=r.string("window", ("after_startup", "all", "steady")),
                fibres=r.integer("fibres", ge=4), units=r.string("units"))
    if None not in (vals["N_C"], vals["N_knee"], vals["N_cutoff"]) and vals["knee"] and not (
            vals["N_C"] < vals["N_knee"] < vals["N_cutoff"]):
        r.add("N_knee", "must satisfy N_C < N_knee < N_cutoff, got "
                        f"{vals['N_C']:g}, {vals['N_knee']:g}, {vals['N_cutoff']:g}")
        return None
    if (vals["area"] is None) != (vals["modulus"] is None):
        r.add("modulus" if vals["modulus"] is None else "area",
              "give both area and modulus (an effective section), or neither")
        return None
    if vals["area"] is None and section is not None and section.diameter is None:
        r.add("area", "stresses need a section: give section.diameter (solid circle) or "
                      "fatigue.area and fatigue.modulus")
        return None
    required = [k for k in vals if k not in ("area", "modulus")]
    if _missing(*(vals[k] for k in required)):
        return None
    return FatigueSpec(**vals)


def load_case(path: str | os.PathLike, *, t_end: float | None = None,
              dynamics: bool = True) -> Case:
    """Read and validate a TOML case file; relative CSV paths are taken from its folder.
    ``t_end``, ``dynamics``: the run's, as in :func:`parse_case`.

    Raises
    ------
    CaseError
        If the file cannot be read, is not valid TOML, or has any problem (all reported).
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
