"""Parsers of the tables a single-cable case and a network case share: the section, the
geometry, motions and time functions, damping, dynamics, solver options and fatigue. Each takes
a :class:`~cablefem.case.reader.Reader` and returns the table's dataclass, or None after
reporting its problems to the reader."""

from __future__ import annotations

import math
import numbers
from pathlib import Path
from typing import Any

import numpy as np

from cablefem.arguments import zero_segments
from cablefem.case.keys import MOTION_KEYS
from cablefem.case.reader import Reader
from cablefem.case.schema import (
    Damping,
    DynamicsSpec,
    FatigueSpec,
    Geometry,
    rayleigh_coefficients,
)
from cablefem.description import GEOMETRY_BOUNDS, GEOMETRY_KINDS, SolverSpec
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
from cablefem.validation import is_number, is_sequence, show

_TOL = 1e-9  # relative tolerance for coincident points and parallel directions


def any_missing(*parts: Any) -> bool:
    """True if any part failed to parse (is None); safe with NumPy arrays.

    Args:
        *parts: Parsed values, None where parsing failed.
    """
    return any(p is None for p in parts)


def parse_section(r: Reader) -> Section | None:
    """``[section]`` (or one of ``[[sections]]``): the cross-section.

    Args:
        r: The table's reader (problems go to its list).

    Returns:
        The :class:`~cablefem.properties.Section`, or None (problems reported).
    """
    values = (r.number("EA", gt=0), r.number("EI", ge=0), r.number("GJ", ge=0),
              r.number("mass", gt=0))
    diameter = r.number("diameter", gt=0)
    if any_missing(*values) or (r.has("diameter") and diameter is None):
        return None
    return Section(*values, diameter=diameter)


def parse_geometry(r: Reader) -> Geometry | None:
    """``[geometry]``: exactly one of the geometry kinds.

    Args:
        r: The table's reader (problems go to its list).

    Returns:
        The :class:`~cablefem.case.schema.Geometry`, or None (problems reported).
    """
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


def _parse_polyline(r: Reader) -> np.ndarray | None:
    value, _ = r.raw("polyline")
    if not is_sequence(value) or len(value) < 2:
        r.add("polyline", f"expected a list of at least 2 points [x, y, z], got {show(value)}")
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


def parse_motion(r: Reader | None, base_dir: Path) -> Motion | None:
    """``[anchors.motion]``: a harmonic, elliptic or table motion.

    Args:
        r: The table's reader, or None (no motion).
        base_dir: Folder of the case file (for a table's CSV file).

    Returns:
        The :class:`~cablefem.motion.Motion`, or None (none given, or problems reported).
    """
    if r is None:
        return None
    kind = r.string("type", choices=tuple(MOTION_KEYS))
    if kind is None:
        return None
    what = f"a {kind} motion"
    r.only(MOTION_KEYS[kind], what)
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
        if not present or any_missing(*parts) or bad_ramp:
            return None
        ramp = default_ramp(parts[1], parts[0]) if ramp is None else ramp
        if not _finite_ramp(r, ramp):
            return None
        return HarmonicMotion(*parts, ramp=ramp)
    if not (r.has("axis_sin") or r.has("axis_cos")):
        r.problems.append((r.path, "an ellipse motion needs axis_sin and/or axis_cos"))
        present = False
    parts = (r.number("omega", gt=0), r.vector("axis_sin"), r.vector("axis_cos"))
    if not present or any_missing(*parts) or bad_ramp:
        return None
    ramp = default_ramp(parts[0]) if ramp is None else ramp
    if not _finite_ramp(r, ramp):
        return None
    return EllipseMotion(*parts, ramp=ramp)


def _finite_ramp(r: Reader, ramp: float) -> bool:
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


def parse_time(r: Reader | None, base_dir: Path) -> TimeFunction | None:
    """``[loads.time]`` (and the others): a load's time factor.

    Args:
        r: The table's reader, or None (a constant factor 1).
        base_dir: Folder of the case file (for a table's CSV file).

    Returns:
        The :class:`~cablefem.motion.TimeFunction`, or None (problems reported).
    """
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
    if not present or any_missing(omega, phase):
        return None
    return TimeFunction.harmonic(omega, phase)


def parse_damping(r: Reader | None) -> Damping | None:
    """``[damping]``: Rayleigh, stiffness-proportional or axial damping, or none.

    Args:
        r: The table's reader, or None (no damping).

    Returns:
        The :class:`~cablefem.case.schema.Damping`, or None (problems reported).
    """
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
        return Damping(model, alpha, beta) if direct and not any_missing(alpha, beta) else None
    if r.has("ratio") == r.has("ratios"):
        r.problems.append((r.path, "give exactly one of ratio and ratios"))
        return None
    if not r.require("frequencies", "damping ratios"):
        return None
    zs = (ratio, ratio) if r.has("ratio") else ratios
    if freqs is None or zs is None or any_missing(*zs):
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


def parse_dynamics(r: Reader | None) -> DynamicsSpec | None:
    """``[dynamics]``: the time integration's settings.

    Args:
        r: The table's reader, or None (no dynamics).

    Returns:
        The :class:`~cablefem.case.schema.DynamicsSpec`, or None.
    """
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
    return None if any_missing(*parts) or bad_start else DynamicsSpec(*parts, start)


def parse_solver(r: Reader) -> SolverSpec:
    """``[solver]`` of a single cable's or a network's case.

    Args:
        r: The table's reader (problems go to its list).

    Returns:
        The solver's settings.
    """
    return SolverSpec(r.boolean("tension_only"), parse_petsc_options(r),
                      r.string("outer_correction", ("none", "hinge")),
                      r.boolean_or("span_bending", "auto"),
                      r.string("model", ("string", "beam", "auto")),
                      r.string("ranks", ("auto", "all")))


def parse_petsc_options(r: Reader) -> dict:
    """``solver.petsc_options``: options without ``-`` or the ``cable_`` prefix.

    Args:
        r: The table's reader (problems go to its list).

    Returns:
        The options (empty if none given).
    """
    value, given = r.raw("petsc_options")
    if not given:
        return {}
    if not isinstance(value, dict):
        r.add("petsc_options", f"expected a table of options, got {show(value)}")
        return {}
    for name, option in value.items():
        key = f"{r.key('petsc_options')}.{name}"
        if str(name).startswith(("-", "cable_")):
            r.problems.append((key, "give the option without '-' or the 'cable_' prefix (the "
                                    "solver adds '-cable_')"))
        if not isinstance(option, (str, bool, numbers.Real)):
            r.problems.append((key, f"expected a string, number or boolean, got "
                                    f"{show(option)}"))
        elif is_number(option) and not math.isfinite(option):
            r.problems.append((key, f"must be finite, got {option!r}"))
    return dict(value)


def parse_fatigue(r: Reader | None, section: Section | None) -> FatigueSpec | None:
    """``[fatigue]``: the S-N curve, the section for stresses and the window.

    Args:
        r: The table's reader, or None (no fatigue assessment).
        section: The cable's section (its diameter for stresses), or None.

    Returns:
        The :class:`~cablefem.case.schema.FatigueSpec`, or None.
    """
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
    if any_missing(*(vals[k] for k in required)):
        return None
    return FatigueSpec(**vals)
