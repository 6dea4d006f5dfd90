"""Cross-checks of the seabed, the free surface and the waves against each other and the
anchors (``[seabed]``, ``[fluid]``; docs/seabed.md, docs/fluid.md). Pure NumPy: shared by
the case parser (:mod:`cablefem.case`) and the models built in Python.

Refused (:func:`water_problems`): an anchor below the seabed by more than
:data:`BURIED_FRACTION` of the distance between the anchors (a seabed meant at ``-100`` and
given as ``100``, or between the anchors: the contact law pushes the buried part up with
``k`` times metres of penetration, tensions of 1e8 N where 4e5 N were meant); a free surface
at or below the seabed (no water: the waves' depth is not positive). Warned
(:func:`wave_warnings`): an Airy wave steeper than :data:`BREAKING_STEEPNESS` (it breaks,
linear theory does not hold).
"""

from __future__ import annotations

import math

import numpy as np

from cablefem.flow import wave_number

__all__ = ["BREAKING_STEEPNESS", "BURIED_FRACTION", "elevation", "floating_problems",
           "water_problems", "wave_warnings"]

#: an anchor may lie below the seabed by at most this fraction of the anchors' distance (an
#: anchor on the seabed sinks in by the lying cable's penetration w/k, mm against 100s of m)
BURIED_FRACTION = 1e-3
#: the steepness H/λ of the highest (breaking) regular wave in deep water, Michell's 0.142
BREAKING_STEEPNESS = 1.0 / 7.0


def elevation(point, gravity) -> float:
    """A point's elevation along −gravity (m)."""
    g = np.asarray(gravity.direction, float)
    return float(-np.asarray(point, float) @ (g / np.linalg.norm(g)))


def water_problems(anchors, gravity, fluid, seabed, positions=None) -> list[tuple[str, str]]:
    """``(key, message)`` of a seabed or a free surface that does not fit: an anchor below
    the seabed (``positions``: the anchors' points, default their ``position``; None
    entries skipped), a surface at or below the seabed. Needs gravity (None: nothing)."""
    out: list[tuple[str, str]] = []
    if seabed is None or gravity is None or seabed.z is None:
        return out
    if fluid is not None and fluid.surface is not None and fluid.surface <= seabed.z:
        out.append(("fluid.surface", f"the free surface at z = {fluid.surface:g} m is not above "
                                     f"the seabed at seabed.z = {seabed.z:g} m: no water "
                                     "(elevations along -gravity)"))
    points = [a.position for a in anchors] if positions is None else list(positions)
    given = [(i, np.asarray(p, float)) for i, p in enumerate(points) if p is not None]
    if len(given) < 2:
        return out
    pts = np.array([p for _, p in given])
    span = float(np.max(np.linalg.norm(pts[:, None] - pts[None], axis=-1)))
    tol = BURIED_FRACTION * span
    for i, p in given:
        z = elevation(p, gravity)
        if z < seabed.z - tol:
            name = getattr(anchors[i], "name", None) if i < len(anchors) else None
            out.append(("seabed.z", f"anchor {name!r} at elevation {z:g} m is "
                                    f"{seabed.z - z:g} m below the seabed at z = {seabed.z:g} "
                                    f"m (more than {BURIED_FRACTION:g} of the anchors' "
                                    f"distance, {tol:g} m): a buried anchor; elevations are "
                                    "along -gravity"))
    return out


def water_depth_of(fluid, seabed) -> float | None:
    """The waves' depth (m): ``fluid.depth``, else surface − seabed.z, else None (deep)."""
    if fluid.depth is not None:
        return float(fluid.depth)
    if seabed is not None and fluid.surface is not None and fluid.surface > seabed.z:
        return float(fluid.surface - seabed.z)
    return None


def wave_warnings(fluid, gravity, seabed) -> list[tuple[str, str]]:
    """``(key, message)`` of the waves steeper than :data:`BREAKING_STEEPNESS` (λ from the
    dispersion relation on the waves' depth)."""
    out: list[tuple[str, str]] = []
    if fluid is None or not fluid.waves or gravity is None or not gravity.g > 0:
        return out
    depth = water_depth_of(fluid, seabed)
    worst: dict[str, tuple[float, float]] = {}  # key: the steepest of its components
    for i, w in enumerate(fluid.waves):
        k = wave_number(2.0 * math.pi / w.period, gravity.g, depth)
        steep = w.height * k / (2.0 * math.pi)
        key = f"fluid.waves[{i}].height" if w.key is None else w.key
        if steep > BREAKING_STEEPNESS and steep > worst.get(key, (0.0, 0.0))[0]:
            worst[key] = (steep, 2.0 * math.pi / k)
    for key, (steep, length) in worst.items():
        out.append((key, f"a breaking wave: its steepness H/lambda = {steep:.3g} (lambda = "
                         f"{length:.4g} m) is above 1/7, where linear (Airy) theory does "
                         "not hold"))
    return out


def floating_problems(p, q, length: float, w: float, EA: float, gdir, fluid
                      ) -> list[tuple[str, str]]:
    """``(key, message)`` of a single cable lighter than the water it displaces (submerged
    weight ``w < 0``, N/m) whose catenary, turned upwards, rises above the free surface
    between its anchors ``p``, ``q``: it would float there, where its buoyancy stops (a jump
    in the load no equilibrium of the model follows; a fluid density of 1e6 kg/m^3 ran
    statics into a stall, exit 1). A buoyant line held below the surface is fine."""
    if fluid is None or fluid.surface is None or not w < 0:
        return []
    from cablefem.catenary import catenary_between

    up = -np.asarray(gdir, float) / np.linalg.norm(gdir)
    try:
        shape = catenary_between(p, q, length, -w, EA, up)  # its "gravity" points up
        top = float(np.max(shape.position(np.linspace(0.0, length, 401)) @ up))
    except ValueError:
        return []  # no catenary to judge by: statics decides
    if top <= fluid.surface:
        return []
    return [("fluid.density", f"the cable floats: its buoyancy exceeds its weight by "
                              f"{-w:.4g} N/m (fluid.density = {fluid.density:g}) and its "
                              f"catenary would rise to z = {top:.4g} m, above the free "
                              f"surface at fluid.surface = {fluid.surface:g} m, where "
                              "the buoyancy stops: no equilibrium the model can follow")]
