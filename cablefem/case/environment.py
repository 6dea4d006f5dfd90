"""Parsers of a case's environment: the water (``[fluid]`` with its profile, waves and
spectrum) and the seabed (``[seabed]``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cablefem.case.reader import Reader
from cablefem.case.tables import any_missing, parse_time
from cablefem.description import AiryWave, Fluid, Profile, Seabed, VelocitySeries
from cablefem.flow import jonswap_waves, read_velocity_csv
from cablefem.motion import TimeFunction
from cablefem.turbulence import SPECTRA, Turbulence


def parse_seabed(r: Reader | None) -> Seabed | None:
    """``[seabed]``: the seabed's elevation, stiffness, damping and friction.

    Args:
        r: The table's reader, or None (no seabed).

    Returns:
        The :class:`~cablefem.description.Seabed`, or None.
    """
    return None if r is None else Seabed(
        r.number("z"), r.number("stiffness", gt=0), r.number("damping", ge=0),
        r.number("friction", ge=0), r.number("friction_velocity", gt=0))


def parse_fluid(r: Reader | None, section, base_dir: Path) -> Fluid | None:
    """``[fluid]``: the diameter defaults to the section's (``section`` None, a network's:
    to each cable's section's, checked by the caller; the diameter stays None).

    Args:
        r: The table's reader, or None (no fluid).
        section: The cable's section, or None (a network).
        base_dir: Folder of the case file (for a velocity table's CSV file).

    Returns:
        The :class:`~cablefem.description.Fluid`, or None.
    """
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
                 parse_time(r.table("time"), base_dir) or TimeFunction.constant(),
                 _parse_profile(r.table("profile")), tuple(w for w in waves if w is not None),
                 r.number("depth", gt=0), r.number("wave_ramp", ge=0), velocity,
                 r.number("ca_tangential", ge=0),
                 _parse_turbulence(r.table("turbulence"), current, r))


def _parse_turbulence(r: Reader | None, current, fluid: Reader) -> Turbulence | None:
    """``[fluid.turbulence]``: a turbulent wind along the current
    (:class:`cablefem.turbulence.Turbulence`); it needs a nonzero ``fluid.current``."""
    if r is None:
        return None
    kind = r.string("spectrum", SPECTRA)
    values = (r.number("intensity", gt=0, le=1), r.number("length_scale", gt=0),
              r.number("coherence_decay", ge=0), r.integer("seed", ge=0),
              r.number("spacing", ge=0), r.number("f_max", gt=0), r.number("duration", gt=0),
              r.number("ramp", ge=0), r.number("lateral_intensity", ge=0, le=1),
              r.number("vertical_intensity", ge=0, le=1),
              r.number("lateral_length_scale", gt=0), r.number("vertical_length_scale", gt=0))
    if current is not None and not np.linalg.norm(current) > 0:
        fluid.add("current", "turbulence needs the mean wind: a nonzero fluid.current")
        return None
    for key, value in (("lateral_intensity", values[8]), ("vertical_intensity", values[9])):
        if kind == "von_karman" and value:
            r.add(key, "the transverse components are generated with the Kaimal spectrum "
                  "only: spectrum = 'kaimal'")
            return None
    if any_missing(kind, *values[:7], *values[8:10]) or current is None:
        return None
    if values[5] * values[6] > 1.0e5:
        r.add("f_max", f"f_max x duration = {values[5] * values[6]:.4g} frequencies, above "
              "1e5: lower f_max or duration")
        return None
    return Turbulence(kind, *values)


def _parse_profile(r: Reader | None) -> Profile | None:
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
        return None if any_missing(ref, exp, ground) else Profile("power", reference=ref,
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


def _parse_spectrum(r: Reader) -> list:
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
    if any_missing(hs, tp, gamma, direction, n, seed, low, high):
        return []
    return jonswap_waves(hs, tp, direction, gamma, n, seed, low, high)


def _parse_wave(r: Reader) -> AiryWave | None:
    """``[[fluid.waves]]``: an Airy component with a horizontal direction (checked against
    gravity in the model, which knows it)."""
    height, period = r.number("height", gt=0), r.number("period", gt=0)
    direction, phase = r.vector("direction", unit_vector=True), r.number("phase")
    if any_missing(height, period, direction, phase):
        return None
    return AiryWave(height, period, direction, phase)
