"""What the solvers read of a model: :class:`LineModel`, a :class:`typing.Protocol`.

The string (:class:`cablefem.cable.CableModel`), the network
(:class:`cablefem.network.NetworkModel`) and the rod (:class:`cablefem.rod.BeamModel`)
satisfy it; a model of one's own that does can be handed to :class:`cablefem.StaticProblem`,
:class:`cablefem.ModalProblem`, :class:`cablefem.DynamicProblem` and
:class:`cablefem.AnchorReactions`. The capabilities (:data:`CAPABILITIES`) have declared
defaults, class attributes of :class:`cablefem.cable.CableModel`: a solver reads them as
attributes, it never probes for them.

This module imports no dolfinx (the annotations are strings).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

__all__ = ["LineModel", "CAPABILITIES", "Builders"]

#: the capabilities a model declares, with the string's defaults: the solvers branch on
#: them (a network, a rod, the virtual hinges, the string alone, dampers, pre-solves)
CAPABILITIES: dict[str, Any] = {
    "bs": 3, "is_beam": False, "is_network": False, "string_alone": False, "hinges": None,
    "law": None, "static_stages": None, "static_options": {}, "ramp_weight": False,
    "damper_s": (), "damper_nodes": (), "kink_gaps": (), "kink_offsets": True,
    "node_terms": (), "corner_kinks": frozenset(), "junction_gaps": (),
    "junction_offsets": {},
}


@dataclass(frozen=True)
class Builders:
    """What a model is built from, each a function of the model being built, called in
    this order by :class:`cablefem.cable.CableModel`: ``geometry(model)`` -> (reference
    geometry, nodal positions statics starts from); ``coefficients(model)`` sets the
    section's coefficients (``EA``, ``m``, ``c``, ...); ``anchors(model)`` -> the
    :class:`cablefem.anchor.AnchorBC` list; ``bcs(model)`` -> their Dirichlet conditions.
    The string's are ``cablefem.cable.STRING``; a network (``cablefem.network.NETWORK``)
    and the rod (``cablefem.rod.ROD``) provide their own."""

    geometry: Callable[[Any], tuple]
    coefficients: Callable[[Any], None]
    anchors: Callable[[Any], list]
    bcs: Callable[[Any], list]


@runtime_checkable
class LineModel(Protocol):
    """A discretised line model as statics, modes, dynamics, reactions and the output
    read it. Data attributes first, then capabilities, then the methods."""

    # -- the discretisation (cablefem.line) and the unknowns
    comm: Any  #: MPI communicator
    prefix: str  #: PETSc options prefix of every solver of the model
    case: Any  #: the description it was built from
    geometry: Any  #: reference geometry (points, cells, stations, anchor_nodes, node_at)
    line: Any  #: the :class:`cablefem.line.LineDiscretisation`
    length: float  #: stress-free length, m
    mesh: Any
    V: Any  #: P1 space of ``bs`` components per node
    W: Any  #: DG0 cell space
    u: Any
    v: Any
    a: Any
    u_static: Any
    u_bc: Any  #: the anchors' prescribed displacement (written by set_time)
    du: Any
    dw: Any
    t0: Any  #: the reference tangent (UFL)
    bcs: list  #: Dirichlet conditions of the anchors
    anchors: list  #: :class:`cablefem.anchor.AnchorBC` in anchors.csv order
    dS: Any  #: interior facet measure with the point terms' nodes tagged
    # -- the physics' coefficients and terms
    forms: Any  #: :class:`cablefem.forms.CableForms` (``model.forms.add`` adds a term)
    m: Any
    c: Any
    EA: Any
    g_vec: Any  #: gravity vector, m/s^2 (NumPy)
    gravity: Any  #: gravity vector (a Constant)
    loads: list  #: (Constant, load) of the distributed loads
    point_loads: list
    load_factor: Any  #: the extra loads' factor statics ramps (a Constant)
    shift_v: Any  #: the time integrator's shifts (Constants)
    shift_a: Any
    tension_only: bool
    force_scale: float  #: N, the scale of Newton's absolute tolerance
    weight: float  #: N/m
    warnings: list  #: (key, message) of implausible derived quantities
    # -- capabilities (declared defaults: CAPABILITIES)
    bs: int
    is_beam: bool
    is_network: bool
    string_alone: bool
    hinges: Any  #: :class:`cablefem.hinge.VirtualHinges` or None
    law: Any
    static_stages: Callable[[], Iterator[str]] | None
    static_options: dict
    ramp_weight: bool
    damper_s: tuple
    damper_nodes: tuple
    kink_gaps: tuple
    kink_offsets: bool
    node_terms: tuple  #: terms assembled outside UFL (cablefem.junctions)
    corner_kinks: frozenset  #: the kinks the network's corner term corrects
    junction_gaps: tuple  #: (kink, why) of those it leaves out
    junction_offsets: dict  #: the kinks' offsets at the static state
    builders: Builders  #: what the model was built from

    # -- compiled forms (read-only, derived from the terms)
    f_static: Any
    j_static: Any
    f_static_bilateral: Any
    j_static_bilateral: Any
    f_dynamic: Any
    j_dynamic: Any
    m_form: Any

    def set_time(self, t: float) -> None: ...
    def invalidate_time(self) -> None: ...
    def compile(self) -> None: ...
    def initial_guess(self) -> Any: ...
    def residual_floor(self, displaced: bool = False) -> float: ...
    def gather_nodal(self, f, root: int = 0) -> Any: ...
    def gather_all(self, f, root: int = 0) -> Any: ...
    def scatter_nodal(self, values, f) -> None: ...
    def min_element_length(self) -> float: ...
    def slack_elements(self) -> int: ...
    def tension_field(self, name: str = "tension") -> Any: ...
    def cable_cells(self) -> Any: ...
    def output_fields(self) -> list: ...
    def displacement_part(self, f, name: str) -> Any: ...
    def anchor_span(self, name: str) -> float: ...
    def anchor_junction_offset(self, name: str) -> float: ...
    def applies_damper_offsets(self) -> bool: ...
    def section_field(self, name: str, value) -> Any: ...
    def bending_vertices(self) -> tuple: ...
    def translational(self, f) -> Any: ...
    def translational_inner(self, a, b) -> tuple: ...
    def energies(self) -> dict: ...
    def dimensionless_groups(self) -> dict: ...
