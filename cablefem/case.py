"""Case files: a TOML description of one cable, validated into dataclasses.

Pure Python/NumPy: no dolfinx import, nothing expensive (only the CSV tables are read; the
catenary for ``horizontal_tension``/``sag_ratio`` geometry is solved elsewhere).
:func:`load_case` reads a TOML file, :func:`parse_case` a dict of the same shape (for cases
built in Python). Validation collects every problem before raising one :class:`CaseError`.
Every key, its type, default, unit and meaning is documented in :data:`CASE_KEYS`, which
:func:`format_case_reference` renders for the command line and the README. Key paths index
arrays of tables from 0: ``anchors[1].motion.omega`` is the second anchor's.
"""

from __future__ import annotations

import difflib
import math
import numbers
import operator
import os
import re
import textwrap
import tomllib
from dataclasses import dataclass, field, fields, is_dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from cablefem.motion import (
    DEFAULT_RAMP_PERIODS, EllipseMotion, HarmonicMotion, Motion, TableMotion, TimeFunction,
    default_ramp, read_factor_csv, read_motion_csv, table_resolution,
)
from cablefem.properties import Section

__all__ = [
    "CaseError", "CASE_KEYS", "KeyDoc", "TableDoc", "REQUIRED", "format_case_reference",
    "load_case", "parse_case", "rayleigh_coefficients", "Gravity", "Geometry", "MeshSpec",
    "Anchor", "DistributedLoad", "PointMass", "PointLoad", "Damping", "DynamicsSpec",
    "ModalSpec", "SolverSpec", "BeamSpec", "Case", "check_table_ends", "startup_time",
]


class CaseError(Exception):
    """One or more problems in a case file.

    Attributes
    ----------
    problems : list of (str, str)
        ``(key path, message)``, e.g. ``("anchors[1].motion.omega", "must be > 0 (rad/s)")``.
    source : str
        The case file (or ``'<dict>'``, or a CSV file for the CSV readers).

    ``str()`` gives one line per problem: ``"<source>: <key>: <message>"``.
    """

    def __init__(self, problems: list[tuple[str, str]], source: str = "<dict>") -> None:
        self.problems = list(problems)
        self.source = source
        super().__init__(str(self))

    def __str__(self) -> str:
        return "\n".join(f"{self.source}: {k}: {m}" if k else f"{self.source}: {m}"
                         for k, m in self.problems)


# ---------------------------------------------------------------------------------------------
# The documented keys: the single source of known keys and defaults for the parser below.

class _Required:
    def __repr__(self) -> str:
        return "required"


REQUIRED = _Required()
"""Default marker of a key that must be given."""


class KeyDoc(NamedTuple):
    """A value key: ``type``, ``default`` (``REQUIRED``, ``None`` = optional), unit, help."""

    type: str
    default: Any
    unit: str
    help: str


class TableDoc(NamedTuple):
    """A table (``type`` "table") or array of tables: as :class:`KeyDoc` plus its ``keys``."""

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
_MOTION_KEYS = {
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
        "EI": KeyDoc("number", REQUIRED, "N m^2", "Bending stiffness, > 0."),
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
                         "the whole run | 'steady' its last third."),
        "fibres": KeyDoc("integer", 36, "-", "Fibres around the section where stresses are "
                         "evaluated, >= 4."),
        "units": KeyDoc("string", "Pa", "", "Name of the stress unit in the reports."),
    }),
    "modal": TableDoc("table", None, "", "Modal analysis about the static equilibrium.", {
        "modes": KeyDoc("integer", 6, "-", "Number of modes, >= 1."),
    }),
    "beam": TableDoc("table", None, "", "Mesh and section of the reference rod model "
                     "('cablefem run --model beam'); the string ignores it.", {
        "layer_elements": KeyDoc("number", 8.0, "-", "Elements per layer length l_a at a "
                                 "clamped anchor (end element l_a/n), 0.5 to 1000."),
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
            "string", "none", "", "'none' the string pinned at the clamped anchors (leading "
            "order) | 'hinge' the first-order correction: pinned at a virtual hinge about "
            "one layer length along each clamp (cablefem.hinge); the rod ignores it."),
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
                               "pretensioned reference.")}),
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
                                "every vertex of the group is an anchor named group:k.", {
                "name": KeyDoc("string", REQUIRED, "", "0D physical group name in the mesh."),
                "type": anchors.keys["type"],
                "direction": KeyDoc("3-vector", None, "-", "Clamp direction into the cable "
                                    "(clamped only); default: along the anchor's cell."),
                "motion": anchors.keys["motion"]}),
            "loads": c["loads"],
            "point_masses": TableDoc("array of tables", None, "", "Lumped masses on 0D groups.", {
                "group": KeyDoc("string", REQUIRED, "", "0D physical group name in the mesh."),
                "mass": KeyDoc("number", REQUIRED, "kg", "Mass at each vertex, > 0.")}),
            "point_loads": TableDoc("array of tables", None, "", "Point loads on 0D groups.", {
                "group": KeyDoc("string", REQUIRED, "", "0D physical group name in the mesh."),
                "value": c["point_loads"].keys["value"],
                "time": c["point_loads"].keys["time"]})}
    for name in ("damping", "dynamics", "fatigue", "modal", "solver"):
        keys[name] = c[name]
    return keys


NETWORK_KEYS: dict[str, KeyDoc | TableDoc] = _network_keys()


def format_case_reference(markdown: bool = False, network: bool = False) -> str:
    """Render :data:`CASE_KEYS` (or, with ``network``, :data:`NETWORK_KEYS`) as plain text
    (for ``--help``) or as a Markdown table."""
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


# ---------------------------------------------------------------------------------------------
# The validated case.

@dataclass
class Gravity:
    """Gravitational acceleration ``g`` (m/s^2) along the unit vector ``direction``."""

    g: float
    direction: np.ndarray

    @property
    def vector(self) -> np.ndarray:
        """``g * direction`` (m/s^2)."""
        return self.g * self.direction


@dataclass
class Geometry:
    """How the stress-free length is given: ``kind`` is 'length' | 'horizontal_tension' |
    'sag_ratio' | 'polyline'; ``value`` is l (m), H (N) or the sag ratio (-), and for a
    polyline its length l (m); ``polyline`` (n, 3) the stress-free points (m)."""

    kind: str
    value: float | None
    polyline: np.ndarray | None = None

    @property
    def length(self) -> float | None:
        """The stress-free length l (m) if the case gives it, else None (catenary needed)."""
        return self.value if self.kind in ("length", "polyline") else None


@dataclass
class MeshSpec:
    """Number of string elements and the mid-span / end element length ratio."""

    elements: int
    grading: float


@dataclass
class Anchor:
    """An anchor: ``kind`` 'clamped' | 'pinned', position (m), unit clamp ``direction``
    pointing into the cable (None for pinned anchors), prescribed ``motion`` or None."""

    name: str
    position: np.ndarray | None
    kind: str
    direction: np.ndarray | None
    motion: Motion | None


@dataclass
class DistributedLoad:
    """Load per unit stress-free length ``value`` (N/m) times ``time.value(t)``."""

    value: np.ndarray
    time: TimeFunction


@dataclass
class PointMass:
    """Lumped ``mass`` (kg) at stress-free arc length ``s`` (m) from the first anchor."""

    s: float
    mass: float


@dataclass
class PointLoad:
    """Force ``value`` (N) times ``time.value(t)`` at stress-free arc length ``s`` (m)."""

    s: float
    value: np.ndarray
    time: TimeFunction


@dataclass
class Damping:
    """Damping model 'none' | 'rayleigh' (current tangent) | 'rayleigh_k0' (static tangent)
    | 'axial', with resolved ``alpha`` (1/s), ``beta`` (s); ``ratios`` and ``frequencies``
    (rad/s) when given that way."""

    model: str
    alpha: float
    beta: float
    ratios: tuple | None = None
    frequencies: tuple | None = None

    def ratio_at(self, omega: float) -> float:
        """Rayleigh modal damping ratio ``alpha/(2 omega) + beta omega/2`` at omega (rad/s)."""
        return self.alpha / (2.0 * omega) + self.beta * omega / 2.0


@dataclass
class DynamicsSpec:
    """Time integration: end time and step (s), spectral radius, output stride."""

    t_end: float
    dt: float
    rho_inf: float
    output_every: int
    fields_every: int = 20
    checkpoint_every: int = 500


@dataclass
class CableSpec:
    """A family of cables: a 1D group of the mesh, its section and pretension."""

    group: str
    section: str
    pretension: float


@dataclass
class NetworkSpec:
    """A cable network: the mesh file, the named sections and the cable families."""

    mesh: Path
    sections: dict[str, Section]
    cables: list[CableSpec]


@dataclass
class FatigueSpec:
    """S-N curve, section for stresses and window of the fatigue assessment."""

    detail_category: float
    m1: float
    m2: float
    knee: bool
    N_C: float
    N_knee: float
    N_cutoff: float
    area: float | None
    modulus: float | None
    window: str
    fibres: int
    units: str


@dataclass
class BeamSpec:
    """Mesh grading and shear stiffness of the reference rod (:mod:`cablefem.beam`)."""

    layer_elements: float = 8.0
    growth: float = 1.1
    span_elements: int = 100
    shear_stiffness: float | None = None


@dataclass
class ModalSpec:
    """Number of modes of the modal analysis."""

    modes: int


@dataclass
class SolverSpec:
    """Tension-only law switch and PETSc options (stored without the 'cable_' prefix)."""

    tension_only: bool
    petsc_options: dict
    outer_correction: str = "none"


@dataclass
class Case:
    """A validated cable case (see :data:`CASE_KEYS` for every field's meaning)."""

    title: str
    section: Section
    gravity: Gravity
    geometry: Geometry
    mesh: MeshSpec
    anchors: list[Anchor]
    loads: list[DistributedLoad]
    point_masses: list[PointMass]
    point_loads: list[PointLoad]
    damping: Damping
    dynamics: DynamicsSpec | None
    modal: ModalSpec
    solver: SolverSpec
    source: str
    fatigue: FatigueSpec | None = None
    network: NetworkSpec | None = None
    beam: BeamSpec = field(default_factory=BeamSpec)
    units: str = "SI"  #: 'SI' or 'dimensionless' (labels only: see cablefem.units)
    #: (key, message) pairs for input that is valid but suspicious; a run logs them and
    #: lists them under ``warnings`` in summary.json (``--strict`` makes them fatal)
    warnings: list = field(default_factory=list, compare=False)

    def to_dict(self) -> dict:
        """JSON-serialisable echo of the inputs (motions and time functions via describe())."""
        out = _jsonable(self)
        out.pop("warnings", None)  # reported under summary.json's own "warnings"
        return out


def _jsonable(obj: Any) -> Any:
    if hasattr(obj, "describe"):
        return obj.describe()
    if is_dataclass(obj):
        return {f.name: _jsonable(getattr(obj, f.name)) for f in fields(obj)}
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, (np.ndarray, np.generic)):
        return obj.tolist()
    return obj


def rayleigh_coefficients(ratios: tuple[float, float],
                          frequencies: tuple[float, float]) -> tuple[float, float]:
    """Rayleigh ``alpha`` (1/s), ``beta`` (s) giving damping ratios ``z1, z2`` at circular
    frequencies ``w1 != w2`` (rad/s), from ``z(w) = alpha/(2 w) + beta w/2``:
    ``alpha = 2 w1 w2 (z1 w2 - z2 w1)/(w2^2 - w1^2)``, ``beta = 2 (z2 w2 - z1 w1)/(w2^2 - w1^2)``.
    """
    (z1, z2), (w1, w2) = ratios, frequencies
    d = w2**2 - w1**2
    return 2.0 * w1 * w2 * (z1 * w2 - z2 * w1) / d, 2.0 * (z2 * w2 - z1 * w1) / d


# ---------------------------------------------------------------------------------------------
# Reading: typed getters that collect problems under key paths.

def _show(value: Any) -> str:
    """Describe a raw value for a type error, e.g. "string 'abc'"."""
    if value is None:
        return "None"
    if isinstance(value, (bool, np.bool_)):
        return f"boolean {str(bool(value)).lower()}"
    if isinstance(value, str):
        return f"string {value!r}"
    if isinstance(value, numbers.Integral):
        return f"integer {value}"
    if isinstance(value, numbers.Real):
        return f"number {value!r}"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, (list, tuple, np.ndarray)):
        return f"an array of {len(value)}"
    return type(value).__name__


def _is_number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def _is_sequence(value: Any) -> bool:
    return isinstance(value, (list, tuple)) or (isinstance(value, np.ndarray) and value.ndim == 1)


_COMPARE = {"gt": operator.gt, "ge": operator.ge, "lt": operator.lt, "le": operator.le}
_SYMBOL = {"gt": ">", "ge": ">=", "lt": "<", "le": "<="}
_UNSET = object()


def _bounds_text(**bounds: float | None) -> str:
    """E.g. '> 0 and <= 10' (floats in %g, integers as they are)."""
    return " and ".join(f"{_SYMBOL[k]} {v:g}" if isinstance(v, float) else f"{_SYMBOL[k]} {v}"
                        for k, v in bounds.items() if v is not None)


class _Reader:
    """One table of the case: unknown keys are reported on creation, getters type-check."""

    def __init__(self, data: dict, path: str, doc: dict, problems: list) -> None:
        self.data, self.path, self.doc, self.problems = data, path, doc, problems
        known = list(doc)
        lower = {k.lower(): k for k in known}
        for key in data:
            if key in doc:
                continue
            close = difflib.get_close_matches(str(key).lower(), list(lower), n=1, cutoff=0.6)
            hint = (f"; did you mean '{lower[close[0]]}'?" if close
                    else f" (known keys: {', '.join(known)})")
            problems.append((self.key(key), f"unknown key '{key}'{hint}"))

    def key(self, name: str) -> str:
        return f"{self.path}.{name}" if self.path else str(name)

    def add(self, name: str, message: str) -> None:
        self.problems.append((self.key(name), message))

    def has(self, name: str) -> bool:
        return name in self.data

    def raw(self, name: str) -> tuple[Any, bool]:
        """(value, given); a missing required key is reported and returns (None, False)."""
        if name in self.data:
            return self.data[name], True
        default = self.doc[name].default
        if default is REQUIRED:
            self.add(name, "missing required key")
            return None, False
        return default, False

    def _number(self, value: Any, key: str, unit: str, **bounds) -> float | None:
        if not _is_number(value):
            self.problems.append((key, f"expected a number, got {_show(value)}"))
            return None
        value = float(value)
        if not math.isfinite(value):
            self.problems.append((key, f"must be finite, got {value!r}"))
            return None
        if not all(_COMPARE[k](value, b) for k, b in bounds.items() if b is not None):
            unit_text = f" ({unit})" if unit and unit != "-" else ""
            self.problems.append((key, f"must be {_bounds_text(**bounds)}{unit_text}, "
                                       f"got {value!r}"))
            return None
        return value

    def number(self, name: str, **bounds) -> float | None:
        value, given = self.raw(name)
        if not given:
            return None if value is None else float(value)
        return self._number(value, self.key(name), self.doc[name].unit, **bounds)

    def integer(self, name: str, ge: int = 1, le: int | None = None) -> int | None:
        value, given = self.raw(name)
        if not given:
            return value
        if not isinstance(value, numbers.Integral) or isinstance(value, (bool, np.bool_)):
            self.add(name, f"expected an integer, got {_show(value)}")
            return None
        if value < ge or (le is not None and value > le):
            self.add(name, f"must be {_bounds_text(ge=ge, le=le)}, got {value}")
            return None
        return int(value)

    def string(self, name: str, choices: tuple[str, ...] | None = None,
               path: bool = False) -> str | None:
        """A string (one of ``choices`` if given); ``path`` also accepts os.PathLike."""
        value, given = self.raw(name)
        if not given:
            return value
        if path and isinstance(value, os.PathLike):
            value = os.fspath(value)
        if not isinstance(value, str):
            self.add(name, f"expected a string, got {_show(value)}")
            return None
        if choices is not None and value not in choices:
            close = difflib.get_close_matches(value, choices, n=1)
            hint = f"; did you mean '{close[0]}'?" if close else ""
            self.add(name, f"must be one of {', '.join(repr(c) for c in choices)}, "
                           f"got {value!r}{hint}")
            return None
        return value

    def boolean(self, name: str) -> bool | None:
        value, given = self.raw(name)
        if given and not isinstance(value, (bool, np.bool_)):
            self.add(name, f"expected a boolean (true or false), got {_show(value)}")
            return None
        return None if value is None else bool(value)

    def numbers(self, name: str, count: int, nonzero: bool = False, value: Any = _UNSET,
                key: str | None = None, **bounds) -> np.ndarray | None:
        """A list of ``count`` numbers; ``value``/``key`` override the raw value/key path."""
        given = True
        if value is _UNSET:
            value, given = self.raw(name)
        if not given:
            return None if value is None else np.array(value, dtype=float)
        key = key or self.key(name)
        if not _is_sequence(value) or len(value) != count:
            self.problems.append((key, f"expected {count} numbers, got {_show(value)}"))
            return None
        items = [self._number(v, f"{key}[{i}]", self.doc[name].unit, **bounds)
                 for i, v in enumerate(value)]
        if any(v is None for v in items):
            return None
        array = np.array(items, dtype=float)
        if nonzero and not np.any(array):
            self.problems.append((key, "must be a non-zero vector"))
            return None
        return array

    def vector(self, name: str, unit_vector: bool = False) -> np.ndarray | None:
        """A 3-vector; normalised (and checked non-zero) if ``unit_vector``."""
        array = self.numbers(name, 3, nonzero=unit_vector)
        return array / np.linalg.norm(array) if unit_vector and array is not None else array

    def number_or_vector(self, name: str, **bounds) -> float | np.ndarray | None:
        value, given = self.raw(name)
        if given and _is_sequence(value):
            return self.numbers(name, 3, value=value, **bounds)
        return self.number(name, **bounds)

    def table(self, name: str) -> _Reader | None:
        value, given = self.raw(name)
        if not given:
            return None
        if not isinstance(value, dict):
            self.add(name, f"expected a table, got {_show(value)}")
            return None
        return _Reader(value, self.key(name), self.doc[name].keys, self.problems)

    def tables(self, name: str) -> list[_Reader]:
        value, given = self.raw(name)
        if not given:
            return []
        if not _is_sequence(value) or not all(isinstance(v, dict) for v in value):
            self.add(name, f"expected an array of tables ([[{name}]]), got {_show(value)}")
            return []
        return [_Reader(v, f"{self.key(name)}[{i}]", self.doc[name].keys, self.problems)
                for i, v in enumerate(value)]

    def csv(self, name: str, reader: Any, base_dir: Path) -> Any:
        """Read the CSV named by key ``name`` (relative to ``base_dir``) with ``reader``."""
        filename = self.string(name, path=True)
        if filename is None:
            return None
        try:
            return reader(base_dir / filename, key=self.key(name))
        except CaseError as exc:
            self.problems.extend((k, f"in '{exc.source}': {m}") for k, m in exc.problems)
            return None

    def require(self, name: str, what: str) -> bool:
        """Report ``name`` missing (it is required for ``what``); True if present."""
        if name not in self.data:
            self.add(name, f"missing required key for {what}")
        return name in self.data

    def only(self, allowed: tuple[str, ...], what: str, kind_key: str = "type") -> None:
        """Report every known key but ``kind_key`` that does not apply to ``what``."""
        for name in self.data:
            if name != kind_key and name in self.doc and name not in allowed:
                keys = ", ".join(allowed) or "none"
                self.add(name, f"does not apply to {what} (its keys: {keys})")


# ---------------------------------------------------------------------------------------------
# Parsing, table by table.

_GEOMETRY_KINDS = ("length", "horizontal_tension", "sag_ratio", "polyline")
_NAME = re.compile(r"[A-Za-z0-9_-]+")
_TOL = 1e-9  # relative tolerance for coincident points and parallel directions


def _missing(*parts: Any) -> bool:
    """True if any part failed to parse (is None); safe with NumPy arrays."""
    return any(p is None for p in parts)


def _parse_section(r: _Reader) -> Section | None:
    values = (r.number("EA", gt=0), r.number("EI", gt=0), r.number("GJ", ge=0),
              r.number("mass", gt=0))
    diameter = r.number("diameter", gt=0)
    if _missing(*values) or (r.has("diameter") and diameter is None):
        return None
    return Section(*values, diameter=diameter)


def _parse_geometry(r: _Reader) -> Geometry | None:
    given = [k for k in _GEOMETRY_KINDS if r.has(k)]
    if len(given) != 1:
        got = " and ".join(given) if given else "none"
        r.problems.append((r.path, f"give exactly one of {', '.join(_GEOMETRY_KINDS)}; "
                                   f"got {got}"))
    bounds = {"length": {"gt": 0}, "horizontal_tension": {"gt": 0},
              "sag_ratio": {"gt": 0, "le": 10}}
    values = {k: r.number(k, **bounds[k]) for k in given if k != "polyline"}
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
    scale = np.maximum(1.0, np.linalg.norm(points[1:], axis=1))
    zero = np.flatnonzero(np.linalg.norm(np.diff(points, axis=0), axis=1) <= _TOL * scale) + 1
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
        return HarmonicMotion(*parts, ramp=ramp)
    if not (r.has("axis_sin") or r.has("axis_cos")):
        r.problems.append((r.path, "an ellipse motion needs axis_sin and/or axis_cos"))
        present = False
    parts = (r.number("omega", gt=0), r.vector("axis_sin"), r.vector("axis_cos"))
    if not present or _missing(*parts) or bad_ramp:
        return None
    ramp = default_ramp(parts[0]) if ramp is None else ramp
    return EllipseMotion(*parts, ramp=ramp)


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
             r.integer("fields_every"), r.integer("checkpoint_every", ge=0))
    return None if _missing(*parts) else DynamicsSpec(*parts)


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
    """Cross-checks that need both anchors (and the geometry and gravity)."""
    if len(readers) != 2:
        return
    (a, b), (ra, rb) = anchors, readers
    if a.name is not None and a.name == b.name:
        rb.add("name", f"duplicate anchor name {a.name!r} (anchors[0] has it too)")
    polyline = geometry.polyline if geometry is not None else None
    for anchor, r, end in ((a, ra, 0), (b, rb, -1)):
        if anchor.position is None and not r.has("position"):
            if polyline is not None:
                anchor.position = polyline[end].copy()
            elif not polyline_given:
                r.add("position", "missing required key (optional only with geometry.polyline)")
        if anchor.kind == "pinned" and r.has("direction"):
            r.add("direction", "direction only applies to clamped anchors")
    if a.position is None or b.position is None:
        return
    chord = b.position - a.position
    distance = float(np.linalg.norm(chord))
    scale = max(1.0, float(np.linalg.norm(a.position)), float(np.linalg.norm(b.position)))
    if distance <= _TOL * scale:
        rb.add("position", f"anchors {a.name!r} and {b.name!r} coincide (distance "
                           f"{distance:g} m)")
        return
    for anchor, sign in ((a, 1.0), (b, -1.0)):
        if anchor.kind == "clamped" and anchor.direction is None:
            anchor.direction = sign * chord / distance + 0.0  # + 0.0: no -0.0 in outputs
    if geometry is not None and geometry.kind in ("horizontal_tension", "sag_ratio") \
            and gravity is not None:
        key = f"geometry.{geometry.kind}"
        if gravity.g == 0:
            problems.append((key, "needs gravity.g > 0 (got 0)"))
        elif np.linalg.norm(np.cross(chord / distance, gravity.direction)) <= _TOL:
            problems.append((key, f"needs a chord not parallel to gravity (the chord from "
                                  f"{a.name!r} to {b.name!r} is along gravity)"))


def _check_positions_on_cable(items: list, readers: list[_Reader], length: float | None) -> None:
    """``s < l`` for point masses and loads, when the case gives l directly."""
    for item, r in zip(items, readers):
        if length is not None and item is not None and item.s is not None and item.s >= length:
            r.add("s", f"must be < l = {length:g} (m), the stress-free length")


def _tables(case: Case) -> list[tuple[str, Any]]:
    """(key path, motion or time function) of every table of the case."""
    out: list[tuple[str, Any]] = [(f"anchors[{i}].motion", a.motion)
                                  for i, a in enumerate(case.anchors)
                                  if isinstance(a.motion, TableMotion)]
    for name in ("loads", "point_loads"):
        out += [(f"{name}[{i}].time", item.time) for i, item in enumerate(getattr(case, name))
                if isinstance(item.time, TimeFunction) and item.time.kind == "table"]
    return out


def check_table_ends(case: Case, t_end: float) -> list[tuple[str, str]]:
    """Problems ``(key, message)`` of the tables (anchor motions, load factors) that end
    before ``t_end`` (s) without ``hold = true``: they would be held silently."""
    problems = []
    for key, table in _tables(case):
        last = float(table.times[-1])
        if not table.hold and last < t_end * (1 - 1e-12) - 1e-12:
            problems.append((f"{key}.file", f"the table ends at t = {last:g} s, before the "
                                            f"end of the run t = {t_end:g} s: extend it, or "
                                            f"set {key}.hold = true to hold its last row"))
    return problems


#: a table motion "starts at rest" when its displacement at t = 0 is below this fraction of
#: its largest row and its velocity below this fraction of its largest velocity at the rows
_START_FRACTION = 1e-3


def _table_warnings(case: Case, dt: float, t_end: float) -> list[tuple[str, str]]:
    """Valid but suspicious tables: what the time step cannot resolve
    (:func:`cablefem.motion.table_resolution`), a motion table that does not start at the
    static position and at rest, and a held end where the velocity jumps to 0."""
    out = []
    for key, table in _tables(case):
        motion = isinstance(table, TableMotion)
        values = table.values if motion else table.factors
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
    return out


def startup_time(case: Case) -> tuple[float, str]:
    """End of the start-up of the anchor motions (s) and why: the longest ramp of a
    harmonic or elliptic motion; a motion with ``ramp = 0`` that jumps at ``t = 0``
    (displacement or velocity not zero) counts :data:`DEFAULT_RAMP_PERIODS` of its
    periods, as long as its default ramp. 0 without such motions (tables start as given)."""
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
    return best, why


def _finish(case: Case) -> Case:
    """Cross-checks of the tables against the run's time range (a problem, or warnings)."""
    if case.dynamics is not None:
        problems = check_table_ends(case, case.dynamics.t_end)
        if problems:
            raise CaseError(problems, case.source)
        case.warnings.extend(_table_warnings(case, case.dynamics.dt, case.dynamics.t_end))
    return case


def parse_case(data: dict, base_dir: str | os.PathLike = Path("."),
               source: str = "<dict>") -> Case:
    """Validate a case given as a dict of the TOML file's shape (see :data:`CASE_KEYS`).

    Parameters
    ----------
    data : dict
        The case.
    base_dir : path-like
        Folder against which relative CSV paths are resolved.
    source : str
        Name of the case in error messages and in ``Case.source``.

    Raises
    ------
    CaseError
        With every problem found (unknown keys, types, ranges, missing keys, combinations,
        CSV files).
    """
    if not isinstance(data, dict):
        raise CaseError([("", f"expected a table of keys, got {_show(data)}")], source)
    if "network" in data:
        return _parse_network_case(data, Path(base_dir), source)
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
        if name is not None and not _NAME.fullmatch(name):
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

    damping = _parse_damping(top.table("damping"))
    dynamics = _parse_dynamics(top.table("dynamics"))
    modal = ModalSpec(table("modal").integer("modes"))
    fatigue = _parse_fatigue(top.table("fatigue"), section)
    beam_r = table("beam")
    beam = BeamSpec(beam_r.number("layer_elements", ge=0.5, le=1000),
                    beam_r.number("growth", gt=1, le=2), beam_r.integer("span_elements",
                                                                       le=1_000_000),
                    beam_r.number("shear_stiffness", gt=0))
    solver_r = table("solver")
    solver = SolverSpec(solver_r.boolean("tension_only"), _parse_petsc_options(solver_r),
                        solver_r.string("outer_correction", ("none", "hinge")))
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
    return _finish(Case(title, section, gravity, geometry, mesh, anchors, loads, masses,
                        point_loads, damping, dynamics, modal, solver, source, fatigue,
                        beam=beam, units=units or "SI"))


def _parse_network_case(data: dict, base_dir: Path, source: str) -> Case:
    """A network case (see :data:`NETWORK_KEYS`); the mesh itself is read and checked when
    the model is built (:func:`cablefem.network.read_network_mesh`)."""
    problems: list = []
    top = _Reader(data, "", NETWORK_KEYS, problems)

    def table(name: str) -> _Reader:
        return top.table(name) or _Reader({}, name, NETWORK_KEYS[name].keys, problems)

    title = top.string("title")
    units = top.string("units", ("SI", "dimensionless"))
    net_r = top.table("network")
    mesh_path = None
    if net_r is not None:
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
    damping = _parse_damping(top.table("damping"))
    dynamics = _parse_dynamics(top.table("dynamics"))
    modal = ModalSpec(table("modal").integer("modes"))
    solver_r = table("solver")
    solver = SolverSpec(solver_r.boolean("tension_only"), _parse_petsc_options(solver_r),
                        solver_r.string("outer_correction", ("none", "hinge")))
    first = sections.get(cables[0].section) if cables else None
    fatigue = _parse_fatigue(top.table("fatigue"), first)
    if problems:
        raise CaseError(problems, source)
    if _missing(title, gravity, mesh_path, first, damping, modal.modes, solver.tension_only):
        raise RuntimeError("cablefem internal error: a case value failed without a message")
    return _finish(Case(title, first, gravity, None, MeshSpec(1, 1.0), anchors, loads,
                        masses, point_loads, damping, dynamics, modal, solver, source,
                        fatigue, NetworkSpec(mesh_path, sections, cables),
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


def load_case(path: str | os.PathLike) -> Case:
    """Read and validate a TOML case file; relative CSV paths are taken from its folder.

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
    return parse_case(data, base_dir=path.parent, source=str(path))
