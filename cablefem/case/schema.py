"""The validated case: dataclasses that the parser fills (:class:`Case` and its parts)."""

from __future__ import annotations

from dataclasses import dataclass, field, fields, is_dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cablefem.motion import (
    Motion,
    TimeFunction,
)
from cablefem.properties import Section

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
    """Mesh grading and shear stiffness of the reference rod (:mod:`cablefem.rod`)."""

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
