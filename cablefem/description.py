"""What a model is built from, independent of the case files: the cable's gravity, stress-free
geometry, mesh, loads, point masses, damping and solver switches, gathered in
:class:`CableDescription` (a single cable or, with ``network``, a cable network).

The case schema (:mod:`cablefem.case`) reuses these classes: a :class:`cablefem.case.Case` is
a :class:`CableDescription` plus the run settings (dynamics, modal, fatigue, title).
:func:`cablefem.arguments.describe_cable` and :func:`~cablefem.arguments.describe_network`
check a description built from Python objects; :func:`cablefem.create_cable` and
:func:`cablefem.create_network` build the model from it.
Pure Python/NumPy: no dolfinx import.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from cablefem import catenary
from cablefem.anchor import Anchor
from cablefem.flow import AiryWave, Profile, VelocitySeries
from cablefem.motion import DEFAULT_RAMP_PERIODS, TimeFunction
from cablefem.properties import Section
from cablefem.turbulence import Turbulence

__all__ = ["Gravity", "Geometry", "MeshSpec", "DistributedLoad", "PointMass", "PointLoad",
           "Damper", "DamperLink", "Fluid", "Seabed", "AiryWave", "Profile", "VelocitySeries",
           "Damping", "SolverSpec", "BeamSpec", "CableSpec", "NetworkSpec", "CableDescription",
           "rayleigh_coefficients", "stress_free_length", "GEOMETRY_KINDS", "GEOMETRY_BOUNDS",
           "BEAM_BOUNDS", "DAMPING_MODELS", "OUTER_CORRECTIONS", "MAX_ELEMENTS"]

#: the ways to give the stress-free length, and the bounds of their values
GEOMETRY_KINDS = ("length", "horizontal_tension", "sag_ratio", "polyline")
GEOMETRY_BOUNDS = {"length": {"gt": 0}, "horizontal_tension": {"gt": 0},
                   "sag_ratio": {"gt": 0, "le": 10}}
GEOMETRY_UNITS = {"length": "m", "horizontal_tension": "N", "sag_ratio": "-"}
#: bounds of the reference rod's mesh options (:class:`BeamSpec`), and their units
BEAM_BOUNDS = {"layer_elements": ({"ge": 0.5, "le": 1000}, ""), "growth": ({"gt": 1, "le": 2}, ""),
               "span_elements": ({"ge": 1, "le": 1_000_000}, ""),
               "shear_stiffness": ({"gt": 0}, "N")}
DAMPING_MODELS = ("rayleigh", "rayleigh_k0", "axial", "none")
OUTER_CORRECTIONS = ("none", "hinge")
MAX_ELEMENTS = 10_000_000
NAME = re.compile(r"[A-Za-z0-9_-]+")  #: anchor names


@dataclass
class Gravity:
    """Gravitational acceleration ``g`` (m/s^2) along the unit vector ``direction``.

    Args:
        g: Gravitational acceleration (m/s^2), >= 0.
        direction: (3,) unit vector along which it acts.
    """

    g: float = 9.81
    direction: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -1.0]))

    @property
    def vector(self) -> np.ndarray:
        """``g * direction`` (m/s^2)."""
        return self.g * self.direction


@dataclass
class Geometry:
    """How the stress-free length is given: ``kind`` is 'length' | 'horizontal_tension' |
    'sag_ratio' | 'polyline'; ``value`` is l (m), H (N) or the sag ratio (-), and for a
    polyline its length l (m); ``polyline`` (n, 3) the stress-free points (m).

    Args:
        kind: 'length', 'horizontal_tension', 'sag_ratio' or 'polyline'.
        value: l (m), H (N), the sag ratio (-) or the polyline's length (m).
        polyline: (n, 3) stress-free points (m), for 'polyline'.
    """

    kind: str
    value: float | None
    polyline: np.ndarray | None = None

    @property
    def length(self) -> float | None:
        """The stress-free length l (m) if the case gives it, else None (catenary needed)."""
        return self.value if self.kind in ("length", "polyline") else None


@dataclass
class MeshSpec:
    """Number of string elements and the mid-span / end element length ratio.

    Args:
        elements: Number of string elements, >= 1.
        grading: Mid-span / end element length ratio, >= 1.
    """

    elements: int = 30
    grading: float = 1.0


@dataclass
class DistributedLoad:
    """Load per unit stress-free length ``value`` (N/m) times ``time.value(t)``.

    Args:
        value: (3,) load per unit stress-free length (N/m).
        time: Its time factor (default constant 1).
    """

    value: np.ndarray
    time: TimeFunction = field(default_factory=TimeFunction.constant)


@dataclass
class PointMass:
    """Lumped ``mass`` (kg) at stress-free arc length ``s`` (m) from the first anchor (a
    network: ``s`` is the name of a 0D group of the mesh).

    Args:
        s: Stress-free arc length (m) from the first anchor, or a network's 0D group.
        mass: The mass (kg), > 0.
    """

    s: float
    mass: float


@dataclass
class PointLoad:
    """Force ``value`` (N) times ``time.value(t)`` at stress-free arc length ``s`` (m) (a
    network: ``s`` is the name of a 0D group of the mesh).

    Args:
        s: Stress-free arc length (m) from the first anchor, or a network's 0D group.
        value: (3,) force (N).
        time: Its time factor (default constant 1).
    """

    s: float
    value: np.ndarray
    time: TimeFunction = field(default_factory=TimeFunction.constant)


@dataclass
class Damper:
    """An external damper (``docs/dampers.md``): a viscous dashpot of ``coefficient`` c
    (N s/m), with a spring of ``stiffness`` k (N/m) in parallel, from the ground to the
    cable point at stress-free ``distance`` (m) from anchor ``anchor``. It acts along the
    unit ``direction`` or, when that is None, in the plane normal to the cable at the point.
    Installed on the cable at rest: it acts in dynamics (and the modal analysis) on the
    motion from the static state, and does not change the statics.

    Args:
        anchor: Name of the anchor the distance is measured from.
        distance: Stress-free distance (m) from that anchor, inside the cable.
        coefficient: Dashpot coefficient c (N s/m), >= 0.
        stiffness: Spring stiffness k (N/m), >= 0.
        direction: (3,) unit direction, or None (the plane normal to the cable).
    """

    anchor: str
    distance: float
    coefficient: float
    stiffness: float = 0.0
    direction: np.ndarray | None = None


@dataclass
class DamperLink:
    """A damper of a network (``docs/dampers.md``): every cell of the mesh's 1D group
    ``group`` is a dashpot of ``coefficient`` c (N s/m), with a spring of ``stiffness`` k
    (N/m) in parallel, between its two nodes (cable nodes, or a cable node and an anchor),
    acting along the line between them, or along a fixed unit ``direction`` on the nodes'
    relative motion. Installed at rest, like :class:`Damper`.

    Args:
        group: The mesh's 1D group of the damper's cells.
        coefficient: Dashpot coefficient c (N s/m), >= 0.
        stiffness: Spring stiffness k (N/m), >= 0.
        direction: (3,) unit direction, or None (along each cell).
    """

    group: str
    coefficient: float
    stiffness: float = 0.0
    direction: np.ndarray | None = None


@dataclass
class Fluid:
    """The water (or air) around a single cable (``docs/fluid.md``): ``density`` (kg/m^3);
    the free ``surface`` as an elevation against gravity (m; None: everywhere immersed,
    as in air); the ``current`` velocity (m/s, 3-vector, uniform) times ``time.value(t)``
    in dynamics (a gust or turbulence history); the hydrodynamic ``diameter`` (m) and the
    Morison coefficients ``cd_normal``, ``cd_tangential``, ``ca_normal``,
    ``ca_tangential``; ``buoyancy``
    (False in air). The fluid's motion (:mod:`cablefem.flow`): the ``profile`` factor of
    the current with elevation (None: uniform), Airy ``waves`` on water of ``depth`` (m below
    the surface; None: deep water) built up over ``wave_ramp`` (s; None: 3 periods of the
    longest wave), and a uniform ``velocity`` history (dynamics only).

    Args:
        density: Fluid density (kg/m^3).
        diameter: Hydrodynamic diameter (m), or None (each cable's section's, a network).
        current: (3,) current velocity (m/s).
        surface: Elevation of the free surface against gravity (m), or None.
        cd_normal, cd_tangential: Morison drag coefficients.
        ca_normal: Normal added-mass coefficient.
        buoyancy: Whether buoyancy acts (False in air).
        time: The current's time factor.
        profile: The current's factor with elevation, or None (uniform).
        waves: Airy wave components (:class:`cablefem.flow.AiryWave`).
        depth: Water depth below the surface (m), or None (deep water).
        wave_ramp: The waves' build-up time (s), or None (3 periods of the longest wave).
        velocity: A uniform velocity history (:class:`cablefem.flow.VelocitySeries`), or None.
        ca_tangential: Tangential added-mass coefficient.
        turbulence: A turbulent wind field along the current (dynamics only), or None.
    """

    density: float
    diameter: float | None  #: None: each cable's section's (a network's)
    current: np.ndarray = field(default_factory=lambda: np.zeros(3))
    surface: float | None = None
    cd_normal: float = 1.2
    cd_tangential: float = 0.008
    ca_normal: float = 1.0
    buoyancy: bool = True
    time: TimeFunction = field(default_factory=TimeFunction.constant)
    profile: Profile | None = None
    waves: tuple = ()
    depth: float | None = None
    wave_ramp: float | None = None
    velocity: VelocitySeries | None = None
    #: tangential added-mass coefficient (MoorDyn's Cat), on the relative acceleration
    ca_tangential: float = 0.0
    #: a turbulent wind along the current (:class:`cablefem.turbulence.Turbulence`), or None
    turbulence: Turbulence | None = None

    def diameter_on(self, section) -> float:
        """The hydrodynamic diameter on a cable of ``section`` (m): ``diameter``, or (a
        network's fluid without one) the section's."""
        return float(self.diameter if self.diameter is not None else section.diameter)

    def ramp(self) -> float:
        """The waves' build-up time (s): ``wave_ramp``, or 3 periods of the longest wave."""
        if self.wave_ramp is not None:
            return float(self.wave_ramp)
        return DEFAULT_RAMP_PERIODS * max((w.period for w in self.waves), default=0.0)


@dataclass
class Seabed:
    """A flat seabed (``docs/seabed.md``) at elevation ``z`` (m, along −gravity): contact
    ``stiffness`` (N/m per m of cable), vertical ``damping`` (N s/m per m) and Coulomb
    ``friction`` (coefficient) regularised over ``friction_velocity`` (m/s).

    Args:
        z: Elevation along −gravity (m).
        stiffness: Contact stiffness (N/m per m of cable), > 0.
        damping: Vertical damping (N s/m per m), >= 0.
        friction: Coulomb friction coefficient, >= 0.
        friction_velocity: Regularisation velocity (m/s), > 0.
    """

    z: float
    stiffness: float
    damping: float = 0.0
    friction: float = 0.0
    friction_velocity: float = 0.01


@dataclass
class Damping:
    """Damping model 'none' | 'rayleigh' (current tangent) | 'rayleigh_k0' (static tangent)
    | 'axial', with resolved ``alpha`` (1/s), ``beta`` (s); ``ratios`` and ``frequencies``
    (rad/s) when given that way (:meth:`from_ratios`).

    Args:
        model: 'none', 'rayleigh', 'rayleigh_k0' or 'axial'.
        alpha: Mass-proportional coefficient (1/s), >= 0.
        beta: Stiffness-proportional coefficient (s), >= 0.
        ratios, frequencies: The ratios (-) and frequencies (rad/s) they came from, or None.
    """

    model: str = "none"
    alpha: float = 0.0
    beta: float = 0.0
    ratios: tuple | None = None
    frequencies: tuple | None = None

    def ratio_at(self, omega: float) -> float:
        """Rayleigh modal damping ratio ``alpha/(2 omega) + beta omega/2`` at omega (rad/s)."""
        return self.alpha / (2.0 * omega) + self.beta * omega / 2.0

    @classmethod
    def from_ratios(cls, ratios: tuple[float, float], frequencies: tuple[float, float],
                    model: str = "rayleigh") -> Damping:
        """Rayleigh damping with ratios ``z1, z2`` (-) at frequencies ``w1, w2`` (rad/s)."""
        zs, ws = tuple(float(z) for z in ratios), tuple(float(w) for w in frequencies)
        return cls(model, *rayleigh_coefficients(zs, ws), zs, ws)


@dataclass
class SolverSpec:
    """The model's switches: the tension-only law, the first-order outer correction
    ('none' | 'hinge'), the span's own bending (string only) and PETSc options of its
    solvers (without the options prefix).

    Args:
        tension_only: No compression (``T = EA max(strain, 0)``).
        petsc_options: Options of the model's solvers, without the prefix.
        outer_correction: 'hinge' or 'none'.
        span_bending: True, False or "auto".
        model: "string", "beam" or "auto".
        ranks: "auto" or "all" (the command line's ranks).
    """

    tension_only: bool = True
    petsc_options: dict = field(default_factory=dict)
    outer_correction: str = "hinge"
    #: the span's own EI in the string (docs/theory.md §6.1): True, False or "auto" (on
    #: where it matters, resolved by run_case; a model built directly takes it as off)
    span_bending: bool | str = False
    #: the route: "string" (+ asymptotics), "beam" (the reference rod, single straight
    #: cables) or "auto" (the string, and the rod where the string's estimate says it is
    #: outside its range: cablefem.app.automodel); ``--model`` overrides it
    model: str = "string"
    #: the command line's ranks: "auto" (as many as pay off for the size, at least
    #: cablefem.app.resources.MIN_DOFS_PER_RANK unknowns each: cablefem.app.ranks) or "all"
    ranks: str = "auto"


@dataclass
class BeamSpec:
    """Mesh grading and shear stiffness of the reference rod (:mod:`cablefem.rod`).

    Args:
        layer_elements: Elements per layer length at a clamp.
        growth: Ratio of the lengths of neighbouring elements.
        span_elements: Elements are at most l / ``span_elements`` long.
        shear_stiffness: GA (N), or None (1e5 times the largest tension).
    """

    layer_elements: float = 8.0
    growth: float = 1.1
    span_elements: int = 100
    shear_stiffness: float | None = None


@dataclass
class CableSpec:
    """A family of cables: a 1D group of the mesh, its section and pretension.

    Args:
        group: The mesh's 1D group of the cables.
        section: Name of their section.
        pretension: Their pretension (N), >= 0.
    """

    group: str
    section: str
    pretension: float


@dataclass
class NetworkSpec:
    """A cable network: the mesh file, the named sections and the cable families.

    Args:
        mesh: The gmsh file.
        sections: Section name -> :class:`cablefem.properties.Section`.
        cables: The cable families.
        kinks: The interior kinks reported: "all", "loaded" or "none".
    """

    mesh: Path
    sections: dict[str, Section]
    cables: list[CableSpec]
    #: the interior kinks reported (:func:`cablefem.kinks.network_kinks`): "all" (loaded
    #: nodes and junctions), "loaded" (point loads, masses, dampers) or "none"
    kinks: str = "all"


@dataclass(kw_only=True)
class CableDescription:
    """Everything a model is built from (:class:`cablefem.cable.CableModel`,
    :class:`cablefem.network.NetworkModel`, :class:`cablefem.rod.BeamModel`).

    A single cable has two ``anchors``, a ``section`` and a ``geometry``; a network has
    ``network`` (mesh, sections, cable families), anchors naming 0D groups of its mesh and
    ``section`` its first cable family's. ``source`` names it in error messages; ``units``
    ('SI' or 'dimensionless') only labels the outputs (:mod:`cablefem.units`).

    Args:
        section: The cross-section (a network: its first cable family's).
        anchors: The anchors.
        geometry: The stress-free geometry (single cables), or None.
        gravity: Gravity.
        mesh: The string's mesh.
        loads, point_masses, point_loads: The loads and masses.
        dampers: External dampers (a network: :class:`DamperLink`).
        fluid: The fluid around the cable, or None.
        seabed: The seabed, or None.
        damping: Structural damping.
        solver: The model's switches and PETSc options.
        beam: The reference rod's mesh.
        network: The network (mesh, sections, cable families), or None.
        source: Name in error messages.
        units: 'SI' or 'dimensionless' (labels only).
    """

    section: Section | None
    anchors: list[Anchor]
    geometry: Geometry | None = None
    gravity: Gravity = field(default_factory=Gravity)
    mesh: MeshSpec = field(default_factory=MeshSpec)
    loads: list[DistributedLoad] = field(default_factory=list)
    point_masses: list[PointMass] = field(default_factory=list)
    point_loads: list[PointLoad] = field(default_factory=list)
    dampers: list[Damper] = field(default_factory=list)
    fluid: Fluid | None = None
    seabed: Seabed | None = None
    damping: Damping = field(default_factory=Damping)
    solver: SolverSpec = field(default_factory=SolverSpec)
    beam: BeamSpec = field(default_factory=BeamSpec)
    network: NetworkSpec | None = None
    source: str = "<python>"
    units: str = "SI"


def rayleigh_coefficients(ratios: tuple[float, float],
                          frequencies: tuple[float, float]) -> tuple[float, float]:
    """Rayleigh ``alpha`` (1/s), ``beta`` (s) giving damping ratios ``z1, z2`` at circular
    frequencies ``w1 != w2`` (rad/s), from ``z(w) = alpha/(2 w) + beta w/2``:
    ``alpha = 2 w1 w2 (z1 w2 - z2 w1)/(w2^2 - w1^2)``, ``beta = 2 (z2 w2 - z1 w1)/(w2^2 - w1^2)``.

    Args:
        ratios: ``(z1, z2)`` (-).
        frequencies: ``(w1, w2)`` (rad/s), distinct.

    Returns:
        ``(alpha, beta)``.
    """
    (z1, z2), (w1, w2) = ratios, frequencies
    d = w2**2 - w1**2
    return 2.0 * w1 * w2 * (z1 * w2 - z2 * w1) / d, 2.0 * (z2 * w2 - z1 * w1) / d


def stress_free_length(desc: CableDescription) -> float:
    """Stress-free length l (m) of a single cable (the catenary's for tension/sag geometry)."""
    geo = desc.geometry
    if geo.kind in ("length", "polyline"):
        return float(geo.length)
    p, q = (np.asarray(a.position, float) for a in desc.anchors)
    up = -np.asarray(desc.gravity.direction, float)
    d = q - p
    rise = float(d @ up)
    span = float(np.linalg.norm(d - rise * up))
    w = desc.section.mass * desc.gravity.g
    if geo.kind == "horizontal_tension":
        return catenary.length_for_horizontal_tension(span, rise, geo.value, w, desc.section.EA)
    return catenary.length_for_sag_ratio(span, rise, geo.value, w, desc.section.EA)
