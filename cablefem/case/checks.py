"""Checks of a case against its run: tables that end before ``t_end``, tables too coarse
for the time step, and the start-up time (the end of the longest ramp)."""

from __future__ import annotations

from typing import Any

import numpy as np

from cablefem.case.schema import (
    Case,
)
from cablefem.motion import (
    DEFAULT_RAMP_PERIODS,
    EllipseMotion,
    HarmonicMotion,
    TableMotion,
    TimeFunction,
    default_ramp,
)
from cablefem.timetables import table_resolution

# ---------------------------------------------------------------------------------------------
# Parsing, table by table.


def _tables(case: Case) -> list[tuple[str, Any]]:
    """(key path, motion or time function) of every table of the case."""
    out: list[tuple[str, Any]] = [(f"anchors[{i}].motion", a.motion)
                                  for i, a in enumerate(case.anchors)
                                  if isinstance(a.motion, TableMotion)]
    for name in ("loads", "point_loads"):
        out += [(f"{name}[{i}].time", item.time) for i, item in enumerate(getattr(case, name))
                if isinstance(item.time, TimeFunction) and item.time.kind == "table"]
    fluid = getattr(case, "fluid", None)
    if fluid is not None:
        if fluid.time.kind == "table":
            out.append(("fluid.time", fluid.time))
        if fluid.velocity is not None:
            out.append(("fluid.velocity", fluid.velocity))
    return out


def check_table_ends(case: Case, t_end: float) -> list[tuple[str, str]]:
    """Problems ``(key, message)`` of the tables (anchor motions, load factors) that end
    before ``t_end`` (s) without ``hold = true``: they would be held silently.

    Args:
        case: The case.
        t_end: The run's end (s).
    """
    problems = []
    for key, table in _tables(case):
        last = float(table.times[-1])
        if not table.hold and last < t_end * (1 - 1e-12) - 1e-12:
            problems.append((f"{key}.file", f"the table ends at t = {last:g} s, before the "
                                            f"end of the run t = {t_end:g} s: extend it, or "
                                            f"set {key}.hold = true to hold its last row"))
    turbulence = getattr(getattr(case, "fluid", None), "turbulence", None)
    if turbulence is not None and turbulence.duration < t_end * (1 - 1e-12) - 1e-12:
        problems.append(("fluid.turbulence.duration", f"the field's period {turbulence.duration:g}"
                         f" s is shorter than the run t = {t_end:g} s: it would repeat"))
    return problems


#: a table motion "starts at rest" when its displacement at t = 0 is below this fraction of
#: its largest row and its velocity below this fraction of its largest velocity at the rows
_START_FRACTION = 1e-3


def table_warnings(case: Case, dt: float, t_end: float) -> list[tuple[str, str]]:
    """Valid but suspicious tables: what the time step cannot resolve
    (:func:`cablefem.timetables.table_resolution`), a motion table that does not start at the
    static position and at rest, and a held end where the velocity jumps to 0.

    Args:
        case: The case.
        dt: The time step (s).
        t_end: The run's end (s).

    Returns:
        ``(key, message)`` of every warning.
    """
    out = []
    for key, table in _tables(case):
        motion = isinstance(table, TableMotion)
        values = table.values if hasattr(table, "values") else table.factors
        out += [(f"{key}.file", m) for m in table_resolution(table.times, values, dt)]
        if not motion:
            continue
        scale_u = float(np.max(np.linalg.norm(values, axis=1)))
        scale_v = max(float(np.linalg.norm(table.velocity(float(t)))) for t in table.times)
        u0 = table.displacement(0.0)
        v0 = table.velocity(0.0)
        if np.linalg.norm(u0) > _START_FRACTION * scale_u:
            out.append((f"{key}.file", f"the anchor's displacement at t = 0 is "
                                       f"{np.round(u0, 12).tolist()} m, not 0 (the static "
                                       f"position): it jumps there at the first step"))
        if np.linalg.norm(v0) > _START_FRACTION * scale_v:
            out.append((f"{key}.file", f"the anchor's velocity at t = 0 is "
                                       f"{np.round(v0, 12).tolist()} m/s, not 0: the run "
                                       f"starts with a velocity jump (start the table at "
                                       f"rest)"))
        for edge, name in ((float(table.times[0]), "starts"), (float(table.times[-1]), "ends")):
            inside = 0.0 < edge < t_end
            v = table.velocity(edge)  # the spline's (held only strictly outside)
            if inside and np.linalg.norm(v) > _START_FRACTION * scale_v:
                out.append((f"{key}.file", f"the table {name} at t = {edge:g} s with a velocity "
                                           f"{np.round(v, 12).tolist()} m/s and is held "
                                           f"constant beyond: the velocity jumps to 0 there"))
    turbulence = getattr(getattr(case, "fluid", None), "turbulence", None)
    if turbulence is not None and turbulence.f_max * dt > 0.1:
        out.append(("fluid.turbulence.f_max", f"the time step {dt:g} s samples the field's "
                    f"highest frequency {turbulence.f_max:g} Hz with fewer than 10 steps a "
                    f"period: its drag is filtered by the integrator above {0.1 / dt:.3g} Hz"))
    return out


def startup_time(case: Case) -> tuple[float, str]:
    """End of the start-up of the anchor motions, waves and turbulence (s) and why: the
    longest ramp of a harmonic or elliptic motion; a motion with ``ramp = 0`` that jumps at
    ``t = 0`` (displacement or velocity not zero) counts :data:`DEFAULT_RAMP_PERIODS` of its
    periods, as long as its default ramp; the waves' and the turbulence's build-up. 0
    without such motions (tables start as given).

    Args:
        case: The case.

    Returns:
        ``(time, reason)``.
    """
    best, why = 0.0, "no anchor motion with a ramp or a jump at t = 0"
    for i, a in enumerate(case.anchors):
        m = a.motion
        if not isinstance(m, (HarmonicMotion, EllipseMotion)):
            continue
        if m.ramp > 0:
            t, reason = m.ramp, f"the end of the ramp anchors[{i}].motion.ramp = {m.ramp:g} s"
        elif np.any(m.displacement(0.0) != 0) or np.any(m.velocity(0.0) != 0):
            t = (default_ramp(m.omega, m.amplitude) if isinstance(m, HarmonicMotion)
                 else default_ramp(m.omega))
            reason = (f"anchors[{i}].motion jumps at t = 0 (ramp = 0): "
                      f"{DEFAULT_RAMP_PERIODS:g} of its periods, {t:g} s")
        else:
            continue
        if t > best:
            best, why = t, reason
    fluid = getattr(case, "fluid", None)
    if fluid is not None and fluid.waves and fluid.ramp() > best:
        best, why = fluid.ramp(), f"the waves' build-up fluid.wave_ramp = {fluid.ramp():g} s"
    turbulence = getattr(fluid, "turbulence", None)
    if turbulence is not None:
        t = turbulence.ramp_time(float(np.linalg.norm(fluid.current)))
        if t > best:
            best, why = t, f"the turbulence's build-up fluid.turbulence.ramp = {t:g} s"
    return best, why
