"""The documented keys of a case file: the single source of known keys, types, defaults,
units and meanings (:data:`CASE_KEYS`, :data:`NETWORK_KEYS`), which the parser checks against
and :func:`format_case_reference` renders for ``cablefem keys`` and the docs."""

from __future__ import annotations

import textwrap
from typing import Any, NamedTuple

from cablefem.motion import (
    DEFAULT_RAMP_PERIODS,
)

# ---------------------------------------------------------------------------------------------
# The documented keys: the single source of known keys and defaults for the parser below.

class _Required:
    def __repr__(self) -> str:
        return "required"


REQUIRED = _Required()
"""Default marker of a key that must be given."""


class KeyDoc(NamedTuple):
    """A value key: ``type``, ``default`` (``REQUIRED``, ``None`` = optional), unit, help.

    Attributes:
        type: The value's type ("number", "string", "boolean", ...).
        default: The default, ``REQUIRED``, or None (optional, no default).
        unit: The unit ("" for none).
        help: What the key means.
    """

    type: str
    default: Any
    unit: str
    help: str


class TableDoc(NamedTuple):
    """A table (``type`` "table") or array of tables: as :class:`KeyDoc` plus its ``keys``.

    Attributes:
        type: "table" or "array of tables".
        default: ``REQUIRED`` or None.
        unit: "".
        help: What the table holds.
        keys: Its keys' :class:`KeyDoc` and :class:`TableDoc`.
    """

    type: str
    default: Any
    unit: str
    help: str
    keys: dict


_TIME_DOC = TableDoc("table", None, "", "Time factor of the load; default constant 1.", {
    "type": KeyDoc("string", "constant", "", "'constant' | 'harmonic' sin(omega t + phase) | "
                   "'table' (C2 cubic spline, not-a-knot ends, through a CSV file's rows, "
                   "header time,factor)."),
    "omega": KeyDoc("number", None, "rad/s", "harmonic: circular frequency, > 0."),
    "phase": KeyDoc("number", 0.0, "rad", "harmonic: phase."),
    "file": KeyDoc("string", None, "", "table: CSV file, relative to the case file; it must "
                   "reach dynamics.t_end unless hold = true."),
    "hold": KeyDoc("boolean", False, "", "table: hold the last row's factor after the table "
                   "ends (false: a table ending before dynamics.t_end is an error)."),
})
MOTION_KEYS = {
    "harmonic": ("amplitude", "omega", "phase", "ramp"),
    "ellipse": ("omega", "axis_sin", "axis_cos", "ramp"),
    "table": ("file", "hold"),
}

CASE_KEYS: dict[str, KeyDoc | TableDoc] = {
    "title": KeyDoc("string", "", "", "Free text echoed in the outputs."),
    "units": KeyDoc("string", "SI", "", "'SI' (m, N, s, kg) | 'dimensionless' (the paper's "
                    "scaling: lengths in l, forces in w l, moments in w l^2, times in "
                    "sqrt(l/g)); names the units in logs, figures and reports."),
    "section": TableDoc("table", REQUIRED, "", "Cross-section of the cable.", {
        "EA": KeyDoc("number", REQUIRED, "N", "Axial stiffness, > 0."),
        "EI": KeyDoc("number", REQUIRED, "N m^2", "Bending stiffness, >= 0; 0 (a chain): "
                     "the string alone, no moments (single cables; docs/theory.md)."),
        "GJ": KeyDoc("number", 0.0, "N m^2", "Torsional stiffness, >= 0 (reported only)."),
        "mass": KeyDoc("number", REQUIRED, "kg/m", "Mass per stress-free length, > 0."),
        "diameter": KeyDoc("number", None, "m", "Outer diameter for stresses, > 0."),
    }),
    "gravity": TableDoc("table", None, "", "Gravity; the weight m g is applied automatically.", {
        "g": KeyDoc("number", 9.81, "m/s^2", "Gravitational acceleration, >= 0."),
        "direction": KeyDoc("3-vector", [0.0, 0.0, -1.0], "-", "Direction, non-zero, normalised."),
    }),
    "geometry": TableDoc("table", REQUIRED, "", "Give exactly one of its four keys.", {
        "length": KeyDoc("number", None, "m", "Stress-free length l, > 0."),
        "horizontal_tension": KeyDoc("number", None, "N", "Tension component normal to "
                                     "gravity, > 0 (needs g > 0, chord not along gravity)."),
        "sag_ratio": KeyDoc("number", None, "-", "Mid-span sag / chord, 0 < r <= 10 (needs "
                            "g > 0, chord not along gravity)."),
        "polyline": KeyDoc("list of 3-vectors", None, "m", "Stress-free 3D polyline, >= 2 "
                           "points, no zero-length segment; its length is l."),
    }),
    "mesh": TableDoc("table", None, "", "String mesh.", {
        "elements": KeyDoc("integer", 30, "-", "Number of elements, 1 to 10_000_000."),
        "grading": KeyDoc("number", 1.0, "-", "Largest (mid-span) / end element length, >= 1 "
                          "(symmetric geometric grading)."),
    }),
    "anchors": TableDoc("array of tables", REQUIRED, "", "Exactly two: the first at s = 0, "
                        "the second at s = l.", {
        "name": KeyDoc("string", REQUIRED, "", "Unique name, characters [A-Za-z0-9_-]."),
        "position": KeyDoc("3-vector", None, "m", "Position; required unless the geometry is "
                           "a polyline (default: its end point)."),
        "type": KeyDoc("string", "clamped", "", "'clamped' | 'pinned'."),
        "direction": KeyDoc("3-vector", None, "-", "Clamp direction into the cable (clamped "
                            "only), non-zero, normalised; default: along the chord, towards "
                            "the other anchor."),
        "motion": TableDoc("table", None, "", "Prescribed displacement from the static "
                           "position; default fixed.", {
            "type": KeyDoc("string", REQUIRED, "", "'harmonic' A sin(omega t + phase) | "
                           "'ellipse' axis_sin sin(omega t) + axis_cos (cos(omega t) - 1) | "
                           "'table' (CSV file, header time,ux,uy,uz; C2 cubic spline, "
                           "not-a-knot ends, velocity and acceleration its derivatives)."),
            "amplitude": KeyDoc("3-vector", None, "m", "harmonic: amplitude (required)."),
            "omega": KeyDoc("number or 3-vector", None, "rad/s", "harmonic/ellipse: circular "
                            "frequency, > 0 (required; a 3-vector for harmonic only)."),
            "phase": KeyDoc("number or 3-vector", 0.0, "rad", "harmonic: phase."),
            "axis_sin": KeyDoc("3-vector", [0.0, 0.0, 0.0], "m", "ellipse: sine axis."),
            "axis_cos": KeyDoc("3-vector", [0.0, 0.0, 0.0], "m", "ellipse: cosine axis (give "
                               "axis_sin and/or axis_cos)."),
            "ramp": KeyDoc("number", None, "s", "harmonic/ellipse: smooth start, the motion "
                           "times r(t/ramp), r = 10x^3 - 15x^4 + 6x^5 (0 to 1, zero slope and "
                           "curvature at both ends), >= 0; default "
                           f"{DEFAULT_RAMP_PERIODS:g} periods 2 pi/omega (lowest omega of a "
                           "moving component); 0: none, the velocity jumps at t = 0."),
            "file": KeyDoc("string", None, "", "table: CSV file, relative to the case file; it "
                           "must reach dynamics.t_end unless hold = true."),
            "hold": KeyDoc("boolean", False, "", "table: hold the last row after the table "
                           "ends (false: a table ending before dynamics.t_end is an error)."),
        }),
    }),
    "loads": TableDoc("array of tables", None, "", "Distributed loads per stress-free length "
                      "(besides the weight).", {
        "value": KeyDoc("3-vector", REQUIRED, "N/m", "Load per unit stress-free length."),
        "time": _TIME_DOC,
    }),
    "point_masses": TableDoc("array of tables", None, "", "Lumped masses.", {
        "s": KeyDoc("number", REQUIRED, "m", "Stress-free arc length from the first anchor, "
                    "0 < s < l."),
        "mass": KeyDoc("number", REQUIRED, "kg", "Mass, > 0."),
    }),
    "point_loads": TableDoc("array of tables", None, "", "Point loads.", {
        "s": KeyDoc("number", REQUIRED, "m", "Stress-free arc length from the first anchor, "
                    "0 < s < l."),
        "value": KeyDoc("3-vector", REQUIRED, "N", "Force."),
        "time": _TIME_DOC,
    }),
    "dampers": TableDoc("array of tables", None, "", "External dampers from the ground to a "
                        "point of the cable, installed on the cable at rest: they act on the "
                        "motion from the static state (dynamics, modal analysis), not in "
                        "statics (docs/dampers.md). A network's name a 1D group instead "
                        "('cablefem keys --network').", {
        "anchor": KeyDoc("string", REQUIRED, "", "Name of the anchor the distance is "
                         "measured from."),
        "distance": KeyDoc("number", REQUIRED, "m", "Stress-free arc length from that "
                           "anchor, 0 < distance < l."),
        "coefficient": KeyDoc("number", REQUIRED, "N s/m", "Dashpot coefficient c, >= 0."),
        "stiffness": KeyDoc("number", 0.0, "N/m", "Spring k in parallel with the dashpot, "
                            ">= 0."),
        "direction": KeyDoc("3-vector", None, "-", "Line of action, non-zero, normalised; "
                            "default: the plane normal to the cable at the point (the "
                            "dashpot force -c (v - (v.t) t), t the cable's current tangent)."),
    }),
    "fluid": TableDoc("table", None, "", "Water or air around the cable: Morison drag on "
                      "the relative velocity, added mass and buoyancy (docs/fluid.md).", {
        "density": KeyDoc("number", REQUIRED, "kg/m^3", "Fluid density, > 0 (sea water "
                          "1025, air 1.225)."),
        "diameter": KeyDoc("number", None, "m", "Hydrodynamic diameter D, > 0; default "
                           "section.diameter (one of them is required)."),
        "current": KeyDoc("3-vector", [0.0, 0.0, 0.0], "m/s", "Fluid velocity (current or "
                          "mean wind); times profile's factor at the elevation when a profile "
                          "is given."),
        "profile": TableDoc("table", None, "", "The current's (or mean wind's) factor against "
                            "elevation along -gravity; default uniform.", {
            "type": KeyDoc("string", REQUIRED, "", "'table' (piecewise linear through "
                           "elevation, factor; held beyond the ends) | 'power' "
                           "((z - ground)/reference)^exponent, held below 1 % of reference."),
            "elevation": KeyDoc("list of numbers", None, "m", "table: elevations, strictly "
                                "increasing, >= 2."),
            "factor": KeyDoc("list of numbers", None, "-", "table: the factors at those "
                             "elevations."),
            "reference": KeyDoc("number", None, "m", "power: reference height above ground, "
                                "> 0 (where the factor is 1)."),
            "exponent": KeyDoc("number", None, "-", "power: exponent, >= 0 (e.g. 0.12 over "
                               "the sea, 0.16-0.3 over land)."),
            "ground": KeyDoc("number", 0.0, "m", "power: elevation of the ground or sea "
                             "surface."),
        }),
        "waves": TableDoc("array of tables", None, "", "Airy (linear) wave components, summed (an "
                          "irregular sea is many); need surface. Dynamics only, built up "
                          "from rest over wave_ramp.", {
            "height": KeyDoc("number", REQUIRED, "m", "Wave height H, crest to trough, > 0."),
            "period": KeyDoc("number", REQUIRED, "s", "Period, > 0."),
            "direction": KeyDoc("3-vector", REQUIRED, "-", "Direction of travel, horizontal "
                                "(normal to gravity), normalised."),
            "phase": KeyDoc("number", 0.0, "rad", "Phase: the surface elevation is "
                            "H/2 cos(k d.x - omega t + phase)."),
        }),
        "spectrum": TableDoc("table", None, "", "An irregular long-crested sea from a wave "
                             "spectrum, added to waves as Airy components (equal frequency "
                             "bins, each component at a random frequency in its bin, random "
                             "phases; docs/fluid.md); needs surface.", {
            "type": KeyDoc("string", "jonswap", "", "'jonswap' (gamma = 1: "
                           "Pierson-Moskowitz)."),
            "hs": KeyDoc("number", REQUIRED, "m", "Significant wave height, > 0."),
            "tp": KeyDoc("number", REQUIRED, "s", "Peak period, > 0."),
            "gamma": KeyDoc("number", 3.3, "-", "Peak enhancement factor, 1 to 10."),
            "direction": KeyDoc("3-vector", REQUIRED, "-", "Direction of travel, horizontal "
                                "(normal to gravity), normalised."),
            "components": KeyDoc("integer", 60, "-", "Number of Airy components, >= 1."),
            "seed": KeyDoc("integer", 1, "-", "Seed of the random frequencies and phases "
                           "(the same sea for the same seed)."),
            "low": KeyDoc("number", 0.5, "-", "Lowest frequency, in peak frequencies, > 0."),
            "high": KeyDoc("number", 3.0, "-", "Highest frequency, in peak frequencies, > "
                           "low."),
        }),
        "depth": KeyDoc("number", None, "m", "Water depth below the surface for the waves' "
                        "dispersion and decay, > 0; default: surface - seabed.z with a "
                        "seabed, else deep water."),
        "wave_ramp": KeyDoc("number", None, "s", "Build-up time of the waves from rest, >= 0 "
                            f"(0: none); default {DEFAULT_RAMP_PERIODS:g} periods of the "
                            "longest wave."),
        "velocity": TableDoc("table", None, "", "A uniform fluid velocity history added in "
                             "dynamics (turbulent wind, a measured orbital velocity); its "
                             "derivative drives the fluid inertia.", {
            "file": KeyDoc("string", REQUIRED, "", "CSV file, header time,vx,vy,vz (s, m/s), "
                           "relative to the case file; C2 cubic spline; it must reach "
                           "dynamics.t_end unless hold = true."),
            "hold": KeyDoc("boolean", False, "", "Hold the last row after the table ends."),
        }),
        "turbulence": TableDoc("table", None, "", "A turbulent wind added in dynamics: "
                               "the fluctuation along current (mean speed U = |current|) "
                               "of a spectrum with Davenport's coherence between points of "
                               "the cable, from a seed (docs/fluid.md).", {
            "spectrum": KeyDoc("string", "kaimal", "", "'kaimal' | 'von_karman' (one-sided, "
                               "longitudinal)."),
            "intensity": KeyDoc("number", REQUIRED, "-", "Turbulence intensity sigma/U, "
                                "0 < I <= 1."),
            "length_scale": KeyDoc("number", REQUIRED, "m", "Integral length scale L of "
                                   "the spectrum, > 0."),
            "coherence_decay": KeyDoc("number", 10.0, "-", "Davenport's decay constant C: "
                                      "coherence exp(-C f distance/U), >= 0 (0: fully "
                                      "correlated)."),
            "seed": KeyDoc("integer", 1, "-", "Seed of the random phases, >= 0 (the same "
                           "field for the same seed)."),
            "spacing": KeyDoc("number", 0.0, "m", "Least distance between the stations the "
                              "field is generated at, >= 0 (0: every node); nodes between "
                              "stations are interpolated linearly."),
            "f_max": KeyDoc("number", 2.0, "Hz", "Highest frequency of the field, > 0."),
            "duration": KeyDoc("number", 600.0, "s", "Period of the field (frequency step "
                               "1/duration), > 0, >= dynamics.t_end."),
            "ramp": KeyDoc("number", None, "s", "Build-up of the field from rest, >= 0 (0: "
                           "none); default 3 length_scale/U."),
            "lateral_intensity": KeyDoc("number", 0.0, "-", "sigma_v/U of the lateral "
                                        "(horizontal, across the wind) component, 0 to 1 (0: "
                                        "none; IEC 61400-1: 0.8 intensity); kaimal only."),
            "vertical_intensity": KeyDoc("number", 0.0, "-", "sigma_w/U of the vertical "
                                         "component, 0 to 1 (0: none; IEC 61400-1: 0.5 "
                                         "intensity); kaimal only."),
            "lateral_length_scale": KeyDoc("number", None, "m", "Its length scale, > 0; "
                                           "default length_scale/3 (IEC 61400-1)."),
            "vertical_length_scale": KeyDoc("number", None, "m", "Its length scale, > 0; "
                                            "default 0.0815 length_scale (IEC 61400-1)."),
        }),
        "surface": KeyDoc("number", None, "m", "Elevation of the free surface along -gravity "
                          "(buoyancy and added mass below it only); default: everywhere "
                          "immersed."),
        "cd_normal": KeyDoc("number", 1.2, "-", "Normal drag coefficient on D, >= 0."),
        "cd_tangential": KeyDoc("number", 0.008, "-", "Tangential drag coefficient on the "
                                "area pi D per length (MoorDyn's convention), >= 0."),
        "ca_normal": KeyDoc("number", 1.0, "-", "Normal added-mass coefficient on "
                            "rho pi D^2/4, >= 0."),
        "ca_tangential": KeyDoc("number", 0.0, "-", "Tangential added-mass coefficient on "
                                "rho pi D^2/4 (MoorDyn's Cat), on the acceleration along "
                                "the cable relative to the fluid's, >= 0."),
        "buoyancy": KeyDoc("boolean", True, "", "Buoyancy rho g pi D^2/4 against gravity "
                           "below the surface (false in air)."),
        "time": _TIME_DOC,
    }),
    "seabed": TableDoc("table", None, "", "A flat seabed normal to gravity: penalty contact, "
                       "damping and friction; statics starts from the catenary with its "
                       "grounded part (a network: from its mesh; docs/seabed.md).", {
        "z": KeyDoc("number", REQUIRED, "m", "Elevation of the seabed along -gravity."),
        "stiffness": KeyDoc("number", REQUIRED, "N/m^2", "Contact stiffness per length of "
                            "cable, > 0 (the lying cable sinks in by its submerged weight / "
                            "stiffness)."),
        "damping": KeyDoc("number", 0.0, "N s/m^2", "Vertical contact damping per length, "
                          ">= 0."),
        "friction": KeyDoc("number", 0.0, "-", "Coulomb friction coefficient, >= 0 "
                           "(dynamics only)."),
        "friction_velocity": KeyDoc("number", 0.01, "m/s", "Sliding speed over which the "
                                    "friction force builds up (regularisation), > 0."),
    }),
    "damping": TableDoc("table", None, "", "Damping; default none. Give alpha/beta, or ratio "
                        "(or ratios) with frequencies, not both.", {
        "model": KeyDoc("string", "rayleigh", "", "'rayleigh' alpha M v + beta K_t(u) v, K_t "
                        "the current tangent stiffness (= beta d/dt of the internal force: "
                        "turns with the cable) | 'rayleigh_k0' the same with K0, the tangent "
                        "at the static state (not objective: damps a swinging cable "
                        "spuriously; for comparison) | 'axial' N_d = beta EA dv3/dt (beta "
                        "only) | 'none'."),
        "alpha": KeyDoc("number", 0.0, "1/s", "Mass-proportional coefficient, >= 0."),
        "beta": KeyDoc("number", 0.0, "s", "Stiffness-proportional coefficient, >= 0."),
        "ratio": KeyDoc("number", None, "-", "Damping ratio at both frequencies, 0 <= r < 1."),
        "ratios": KeyDoc("2 numbers", None, "-", "Damping ratios at the two frequencies."),
        "frequencies": KeyDoc("2 numbers", None, "rad/s", "Two distinct circular frequencies "
                              "> 0 where the ratios hold."),
    }),
    "dynamics": TableDoc("table", None, "", "Present: a dynamic run (generalised-alpha).", {
        "t_end": KeyDoc("number", REQUIRED, "s", "End time, > 0."),
        "dt": KeyDoc("number", REQUIRED, "s", "Time step, > 0, <= t_end."),
        "rho_inf": KeyDoc("number", 0.9, "-", "Spectral radius at infinite frequency, 0 to 1."),
        "output_every": KeyDoc("integer", 1, "-",
                               "Anchor rows (anchors.csv) every n-th step, >= 1."),
        "fields_every": KeyDoc("integer", 20, "-",
                               "Fields (string.xdmf, moments.xdmf) every n-th step, >= 1."),
        "checkpoint_every": KeyDoc("integer", 500, "-",
                                   "Checkpoint for 'cablefem run --restart' every n-th step, "
                                   ">= 0 (0: none)."),
        "initial": KeyDoc("string", "quasi-static", "", "Velocity at t = 0: 'quasi-static' "
                          "(the cable follows its anchors' velocity at t = 0 as a static "
                          "solution would) | 'rest' (the cable at rest, only the anchors "
                          "moving; what most FE codes start from)."),
        "statistics_start": KeyDoc("number", None, "s", "Start of the output window of the "
                                   "steady-state statistics (peak, RMS) and of the moments' "
                                   "validity summary, >= 0 and < t_end; default: the last "
                                   "third of the run. A response still building up or "
                                   "decaying in the window warns."),
    }),
    "fatigue": TableDoc("table", None, "", "Fatigue at the clamped anchors (EN 1993-1-9 style "
                        "S-N curve); present: 'cablefem run' also writes the fatigue report.", {
        "detail_category": KeyDoc("number", REQUIRED, "Pa",
                                  "Stress range at N_C cycles (detail category), > 0; in the "
                                  "unit of the run's stresses (N/m^2 for SI cases)."),
        "m1": KeyDoc("number", 3.0, "-", "S-N slope above the knee, >= 1."),
        "m2": KeyDoc("number", 5.0, "-", "S-N slope between knee and cut-off, >= 1."),
        "knee": KeyDoc("boolean", True, "", "Knee at N_knee and cut-off at N_cutoff; false: one "
                       "slope m1, no cut-off."),
        "N_C": KeyDoc("number", 2.0e6, "cycles", "Reference number of cycles, > 0."),
        "N_knee": KeyDoc("number", 5.0e6, "cycles", "Knee (constant-amplitude limit), > N_C."),
        "N_cutoff": KeyDoc("number", 1.0e8, "cycles", "Cut-off, > N_knee."),
        "area": KeyDoc("number", None, "m^2", "Effective area for the axial stress T/A, > 0 "
                       "(strands, ropes); default: solid circle of section.diameter."),
        "modulus": KeyDoc("number", None, "m^3", "Effective section modulus for the bending "
                          "stress M/W, > 0; give with area."),
        "window": KeyDoc("string", "after_startup", "", "'after_startup' from the end of the "
                         "longest anchor-motion ramp (a motion with ramp = 0 that jumps at "
                         f"t = 0: {DEFAULT_RAMP_PERIODS:g} of its periods) to the end | 'all' "
                         "the whole run | 'steady' the run's statistics window (from "
                         "dynamics.statistics_start, else the last third)."),
        "fibres": KeyDoc("integer", 36, "-", "Directions round the section scanned (with "
                         "their opposites) before the search for the worst one, >= 4."),
        "units": KeyDoc("string", "Pa", "", "Name of the stress unit in the reports."),
    }),
    "modal": TableDoc("table", None, "", "Modal analysis about the static equilibrium.", {
        "modes": KeyDoc("integer", 6, "-", "Number of modes, >= 0 (0: no modal analysis; "
                        "without a [modal] table a run computes 6)."),
    }),
    "beam": TableDoc("table", None, "", "Mesh and section of the reference rod model "
                     "('cablefem run --model beam'); the string ignores it.", {
        "layer_elements": KeyDoc("number", 8.0, "-", "Elements per layer length l_a at a "
                                 "clamped anchor (end element l_a/n; a network's: also at "
                                 "its junctions and loaded nodes), 0.5 to 1000."),
        "growth": KeyDoc("number", 1.1, "-", "Size ratio of neighbouring elements away from "
                         "a clamp, 1 < g <= 2."),
        "span_elements": KeyDoc("integer", 100, "-", "Longest element: l/n, 1 to 1_000_000."),
        "shear_stiffness": KeyDoc("number", None, "N", "GA, > 0; default 1e5 times the "
                                  "largest catenary tension or EI/l^2 (unshearable in "
                                  "effect)."),
    }),
    "solver": TableDoc("table", None, "", "Solver settings.", {
        "tension_only": KeyDoc("boolean", True, "", "No compression: T = EA max(v3, 0)."),
        "outer_correction": KeyDoc(
            "string", "hinge", "", "'hinge' (default) the first-order correction: the "
            "string pinned at a virtual hinge about one layer length along each clamp "
            "(cablefem.hinge) | 'none' pinned at the clamped anchors (the paper's leading "
            "order, for comparison); the rod ignores it."),
        "span_bending": KeyDoc(
            "boolean or 'auto'", "auto", "", "String: the span's own bending stiffness EI (a "
            "bending energy on the turning angle between neighbouring elements; the clamps' "
            "rotation stays with the boundary layer; in a network, at every node of two cable "
            "elements without an anchor or point term, the span's moment handed over at the "
            "others). 'auto': on when it would move a computed mode's frequency by more "
            "than 0.5 % (estimated from the string without it; off when no mode is "
            "computed). The rod ignores it."),
        "model": KeyDoc(
            "string", "string", "", "The route: 'string' (default) the string + "
            "asymptotics | 'beam' the reference rod (single straight cables or networks, "
            "without [seabed] or [fluid]) | 'auto' the string, then "
            "the rod on the same case where "
            "the string's estimated moment error at a clamped anchor exceeds 2 % (the rod's "
            "numbers reported, model_auto in summary.json; docs/rod.md). '--model' "
            "overrides it."),
        "ranks": KeyDoc(
            "string", "auto", "", "MPI ranks of 'cablefem run' and 'cablefem modes' started "
            "on several: 'auto' (default) a case of fewer than 20 000 unknowns (a single "
            "cable: 3 (mesh.elements + 1); a network: 3 per mesh node) runs on rank 0 alone, "
            "the others wait (a note in summary.json; docs/running.md), larger ones on "
            "every rank | 'all' every rank."),
        "petsc_options": KeyDoc(
            "table of options", {}, "",
            "PETSc options without '-' (values string/number/boolean), e.g. ts_type, "
            "snes_rtol: they go to the time integrator (prefix 'cable_'); keys starting "
            "static_, modal_ or mass_ go to statics, the eigensolver or the mass solve."),
    }),
}


def _default_text(default: Any) -> str:
    if default is REQUIRED:
        return "required"
    if default is None:
        return "optional"
    if isinstance(default, bool):
        return str(default).lower()
    return repr(default) if isinstance(default, str) else str(default)


def _network_keys() -> dict:
    """The keys of a network case: CASE_KEYS without [section], [geometry] and [mesh]
    (the mesh file gives the geometry), with [network], [[sections]] and [[cables]]; anchors
    and point masses/loads name 0D groups of the mesh."""
    c = CASE_KEYS
    section_keys = c["section"].keys
    anchors = c["anchors"]
    keys = {"title": c["title"], "units": c["units"],
            "network": TableDoc("table", REQUIRED, "", "A cable network from a mesh file.", {
                "mesh": KeyDoc("string", REQUIRED, "", "gmsh file (.msh) relative to the case "
                               "file: 1D physical groups for the cables, 0D groups for anchors "
                               "and point masses (meshes/README.md); its geometry is the "
                               "pretensioned reference."),
                "kinks": KeyDoc("string", "all", "", "Interior kinks reported (kinks.csv, "
                                "docs/kinks.md): 'all' (nodes with point loads, masses, "
                                "dampers or pinned anchors a cable passes through, and "
                                "junctions), 'loaded' (the former only) or 'none'.")}),
            "sections": TableDoc("array of tables", REQUIRED, "", "Named cross-sections.", {
                "name": KeyDoc("string", REQUIRED, "", "Section name, used by [[cables]]."),
                **section_keys}),
            "cables": TableDoc("array of tables", REQUIRED, "", "One per 1D group of the mesh.", {
                "group": KeyDoc("string", REQUIRED, "", "1D physical group name in the mesh."),
                "section": KeyDoc("string", REQUIRED, "", "Name of a [[sections]] entry."),
                "pretension": KeyDoc("number", 0.0, "N", "Tension in the mesh geometry before "
                                     "gravity and loads, >= 0: the stress-free length is the "
                                     "mesh length / (1 + pretension/EA).")}),
            "gravity": c["gravity"],
            "anchors": TableDoc("array of tables", REQUIRED, "", "One per 0D group of the mesh; "
                                "every vertex of the group is an anchor named group:k (a "
                                "clamped vertex on several cable elements: one anchor per "
                                "side, group:k+/cable, group:k-/cable, docs/kinks.md).", {
                "name": KeyDoc("string", REQUIRED, "", "0D physical group name in the mesh."),
                "type": anchors.keys["type"],
                "direction": KeyDoc("3-vector", None, "-", "Clamp direction into the cable "
                                    "(clamped only); default: along the anchor's cell. At a "
                                    "node of two cable elements (a cable running through the "
                                    "clamp) the tangent the clamp holds: +d into one side, "
                                    "-d into the other; default: each element's own "
                                    "direction. Not allowed at a node of more than two "
                                    "(each element is clamped along its own)."),
                "motion": anchors.keys["motion"]}),
            "loads": c["loads"],
            "point_masses": TableDoc("array of tables", None, "", "Lumped masses on 0D groups.", {
                "group": KeyDoc("string", REQUIRED, "", "0D physical group name in the mesh."),
                "mass": KeyDoc("number", REQUIRED, "kg", "Mass at each vertex, > 0.")}),
            "point_loads": TableDoc("array of tables", None, "", "Point loads on 0D groups.", {
                "group": KeyDoc("string", REQUIRED, "", "0D physical group name in the mesh."),
                "value": c["point_loads"].keys["value"],
                "time": c["point_loads"].keys["time"]}),
            "dampers": TableDoc("array of tables", None, "", "Dampers between two nodes of "
                                "the mesh: every cell of a 1D group that is no cable is a "
                                "dashpot (and spring) along the line between its nodes, "
                                "installed at rest (dynamics, modal analysis; not statics; "
                                "docs/dampers.md).", {
                "group": KeyDoc("string", REQUIRED, "", "1D physical group name in the mesh "
                                "(not a [[cables]] group); each cell joins two cable nodes, "
                                "or a cable node and an anchor (grounded)."),
                "coefficient": c["dampers"].keys["coefficient"],
                "stiffness": c["dampers"].keys["stiffness"],
                "direction": KeyDoc("3-vector", None, "-", "Line of action, non-zero, "
                                    "normalised: the dashpot and spring act on the two "
                                    "nodes' relative motion along it (a damper whose mesh "
                                    "cell only says where it is attached); default: along "
                                    "the line between the nodes, as it turns.")})}
    fluid = c["fluid"]
    keys["fluid"] = fluid._replace(keys={**fluid.keys, "diameter": KeyDoc(
        "number", None, "m", "Hydrodynamic diameter D of every cable, > 0; default: each "
        "cable's sections.diameter (required then for every section a cable uses).")})
    keys["seabed"] = c["seabed"]
    for name in ("damping", "dynamics", "fatigue", "modal", "beam", "solver"):
        keys[name] = c[name]
    return keys


NETWORK_KEYS: dict[str, KeyDoc | TableDoc] = _network_keys()


def format_case_reference(markdown: bool = False, network: bool = False) -> str:
    """Render :data:`CASE_KEYS` (or, with ``network``, :data:`NETWORK_KEYS`) as plain text
    (for ``--help``) or as a Markdown table.

    Args:
        markdown: A Markdown table instead of plain text.
        network: The keys of a network case.
    """
    lines = (["| key | type | default | unit | meaning |", "|---|---|---|---|---|"]
             if markdown else [])

    def walk(keys: dict, prefix: str, depth: int) -> None:
        for name, doc in keys.items():
            path = f"{prefix}.{name}" if prefix else name
            is_table = isinstance(doc, TableDoc)
            shown = (f"[[{path}]]" if doc.type == "array of tables" else f"[{path}]") \
                if is_table else path
            if markdown:
                cells = [f"`{shown}`", doc.type, _default_text(doc.default), doc.unit or "",
                         doc.help.replace("|", "\\|")]
                lines.append("| " + " | ".join(cells) + " |")
            else:
                pad = "  " * depth
                unit = f" [{doc.unit}]" if doc.unit and doc.unit != "-" else ""
                default = _default_text(doc.default)
                if doc.default is not REQUIRED and doc.default is not None:
                    default = f"default {default}"
                lines.append(f"{pad}{shown}  ({doc.type}{unit}; {default})")
                lines.extend(textwrap.wrap(doc.help, 96 - len(pad), initial_indent=pad + "    ",
                                           subsequent_indent=pad + "    "))
            if is_table:
                walk(doc.keys, path, depth + 1)

    walk(NETWORK_KEYS if network else CASE_KEYS, "", 0)
    return "\n".join(lines)
