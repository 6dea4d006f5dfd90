"""Cable networks: many cables, junctions and anchors from a tagged mesh file.

:class:`NetworkModel` is a :class:`cablefem.cable.CableModel` whose geometry, sections and
anchors come from a gmsh file (:func:`cablefem.geometry.read_network_mesh`, tag convention
in ``meshes/README.md``). The mesh is the *pretensioned* geometry: each cable family's
stress-free length is its mesh length divided by ``1 + T0/EA`` (``T0`` its pretension), so
that with the anchors at their mesh positions and no gravity the mesh is in equilibrium;
statics then ramps gravity and the loads from there (load continuation if Newton fails).
Section properties are cell-wise (DG0) coefficients of the same UFL forms as a single cable.

A clamp that a cable runs through (or where several cables are clamped at one node) holds
each element's tangent: the node is split into one node per cable element, all at the
clamp's position (:func:`split_clamps`), and each becomes a clamped anchor of its own, its
*side*, that ends its chain of elements. The split is exact: a clamp prescribes the node's
position, so the sides do not see each other through it, and each side gets what an end
clamp gets (its anchors.csv rows, its layer, its virtual hinge).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from cablefem import bending_forms, junctions
from cablefem.anchor import AnchorBC
from cablefem.cable import CableModel, string_bcs
from cablefem.contract import Builders
from cablefem.errors import CaseError
from cablefem.fluid import submerged_weight
from cablefem.geometry import MeshError, NetworkMesh, connected_components, read_network_mesh
from cablefem.jit import quiet_compiler
from cablefem.plausibility import pretension_warnings
from cablefem.span_bending import is_on
from cablefem.water import water_problems

__all__ = ["NetworkModel", "NetworkGeometry", "ClampSide", "split_clamps", "NETWORK",
           "network_geometry", "network_coefficients", "network_anchors"]

log = logging.getLogger(__name__)


@dataclass
class ClampSide:
    """One side of a clamp a network's cable runs through: a clamped anchor of its own."""

    clamp: str  #: the clamp's anchor name, ``<group>:<i>``
    name: str  #: the side's name: ``<clamp>+/<cable group>``, ``-/`` or ``@<node>/``
    node: int  #: its node (the clamp's own node for the first side, a copy for the others)
    cell: int  #: its cable element
    direction: np.ndarray  #: unit clamp direction into its element


def _side_sign_direction(e0: np.ndarray, e1: np.ndarray) -> np.ndarray:
    """The tangent a through-clamp's sides are signed by when it has no ``direction``: the
    mesh's tangent through the node, ``e1 - e0`` (the unit mesh directions of its two
    elements away from the node), oriented so that the first of x, y, z along which it
    has a component (above 1e-6) is positive (mesh independent)."""
    d = e1 - e0
    n = np.linalg.norm(d)
    d = d / n if n > 1e-12 else e1
    for comp in d:
        if abs(comp) > 1e-6:
            return d if comp > 0 else -d
    return d


def split_clamps(net: NetworkMesh, anchors, is_cable: np.ndarray, source=None
                 ) -> tuple[NetworkMesh, dict[int, list[ClampSide]]]:
    """Split every clamped node on more than one cable element into one node per element.

    ``anchors``: the case's anchor groups (:class:`cablefem.anchor.Anchor`); ``is_cable``:
    which cells are a cable's (a damper's cells stay on the clamp's own node). Returns the
    network with the copies appended to its points (at the clamp's position) and its cells
    re-pointed, and, per clamp node, its sides. At a node of two elements the sides are
    ``+`` and ``-``: ``+`` the element the clamp's ``direction`` points into (then clamped
    along ``+d`` and ``-d``), or by default the one the mesh's tangent through the node
    points into, oriented towards +x, else +y, +z (each then clamped along its own mesh
    direction); at more than two, ``@<other node>`` and each its mesh direction (a
    ``direction`` there is refused: :class:`CaseError`)."""
    points = [np.asarray(net.points, float)]
    cells = np.array(net.cells, np.int64, copy=True)
    n = len(net.points)
    sides: dict[int, list[ClampSide]] = {}
    for spec in anchors:
        if spec.kind != "clamped" or spec.name not in net.vertex_groups:
            continue
        for i, k in enumerate(net.vertex_groups[spec.name]):
            k = int(k)
            es = [int(e) for e in np.nonzero(((net.cells[:, 0] == k) | (net.cells[:, 1] == k))
                                             & is_cable)[0]]
            if len(es) < 2:
                continue
            clamp = f"{spec.name}:{i}"
            other = [int(net.cells[e][net.cells[e] != k][0]) for e in es]
            mesh_dir = [(net.points[o] - net.points[k])
                        / np.linalg.norm(net.points[o] - net.points[k]) for o in other]
            if len(es) == 2:
                d = (None if spec.direction is None else
                     np.asarray(spec.direction, float) / np.linalg.norm(spec.direction))
                sign = d if d is not None else _side_sign_direction(*mesh_dir)
                plus = int(np.argmax([np.dot(sign, m) for m in mesh_dir]))
                tags = ["+" if j == plus else "-" for j in range(2)]
                dirs = ([d if j == plus else -d for j in range(2)] if d is not None
                        else mesh_dir)
            else:
                if spec.direction is not None:
                    raise CaseError([(f"anchors[{spec.name}].direction",
                                      f"anchor {clamp} at node {k} is on {len(es)} cable "
                                      "elements: a direction is the tangent of one cable "
                                      "running through a clamp (two elements); leave it out "
                                      "and each element is clamped along its mesh direction")],
                                    source)
                tags = [f"@{o}" for o in other]
                dirs = mesh_dir
            out = []
            for j, (e, tag, dj) in enumerate(zip(es, tags, dirs)):
                node = k
                if j:  # a copy of the node for every element but the first
                    node = n
                    n += 1
                    points.append(np.asarray(net.points[k], float)[None, :])
                    cells[e][cells[e] == k] = node
                group = net.groups[int(net.cell_group[e])]
                out.append(ClampSide(clamp, f"{clamp}{tag}/{group}", node, e,
                                     np.asarray(dj, float) / np.linalg.norm(dj)))
            sides[k] = out
    if not sides:
        return net, sides
    split = NetworkMesh(np.concatenate(points), cells, net.cell_group, net.groups,
                        net.vertex_groups, net.source)
    return split, sides


@dataclass
class NetworkGeometry:
    """Reference geometry of a network (identical on every rank)."""

    points: np.ndarray
    cells: np.ndarray
    length: float  #: total stress-free length, m
    net: NetworkMesh
    cell_EA: np.ndarray
    cell_m: np.ndarray
    cell_c: np.ndarray  #: stress-free length / mesh length per cell
    cell_section: list[str | None]  #: the section of each cell (None: a damper's cell)
    anchor_nodes: dict[str, int] = field(default_factory=dict)
    #: the [[dampers]] entry of each cell (-1: a cable's cell)
    cell_damper: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    #: the sides of every clamp a cable runs through, by the clamp's node (split_clamps)
    clamp_sides: dict = field(default_factory=dict)

    @property
    def is_cable(self) -> np.ndarray:
        """Which cells are a cable's (a damper's are not)."""
        if not len(self.cell_damper):
            return np.ones(len(self.cells), dtype=bool)
        return np.asarray(self.cell_damper) < 0

    @property
    def cell_lengths(self) -> np.ndarray:
        """The stress-free length of every cell, ``cell_c`` times its mesh length, m."""
        return self.lengths_of(slice(None))

    def lengths_of(self, which) -> np.ndarray:
        """:attr:`cell_lengths` of the cells ``which`` (indices, a mask or a slice) alone."""
        cells = np.asarray(self.cells, np.int64)[which]
        return np.asarray(self.cell_c, float)[which] * np.linalg.norm(
            self.points[cells[:, 1]] - self.points[cells[:, 0]], axis=1)

    @property
    def stations(self) -> np.ndarray:  # node numbering, for gathers
        return np.arange(len(self.points), dtype=float)


def network_geometry(model):
    """A network's reference geometry (its mesh, the clamps split into their sides) and
    the positions statics starts from (the mesh); checks the mesh against the case
    (:class:`CaseError` naming the keys) and warns of implausible pretensions. Sets
    ``model.submerged_weight`` and ``model.force_scale``."""
    case = model.case
    spec = case.network
    try:
        net = read_network_mesh(spec.mesh)
    except MeshError as err:
        raise CaseError(err.problems, case.source) from None
    problems = [(f"sections.{name}.EI", "must be > 0 in a network (its kinks and clamps "
                 "need bending stiffness; EI = 0, the string alone, is for single "
                 "cables)") for name, sec in spec.sections.items() if not sec.EI > 0]
    by_group = {c.group: c for c in spec.cables}
    links = {d.group: i for i, d in enumerate(case.dampers)}
    for g in net.groups:
        if g not in by_group and g not in links:
            problems.append(("cables", f"the mesh's 1D group {g!r} has no [[cables]] "
                                       "(or [[dampers]]) entry"))
    for g in by_group:
        if g not in net.groups:
            problems.append(("cables", f"group {g!r} is not a 1D group of the mesh "
                                       f"(its groups: {net.groups})"))
    for g, i in links.items():
        if g not in net.groups:
            problems.append((f"dampers[{i}].group", f"{g!r} is not a 1D group of the "
                                                    f"mesh (its groups: {net.groups})"))
    for a in case.anchors:
        if a.name not in net.vertex_groups:
            problems.append(("anchors", f"group {a.name!r} is not a 0D group of the mesh "
                                        f"(its groups: {sorted(net.vertex_groups)})"))
    for item in list(case.point_masses) + list(case.point_loads):
        if item.s not in net.vertex_groups:
            problems.append(("point_masses/point_loads", f"group {item.s!r} is not a 0D "
                                                         "group of the mesh"))
    anchored = np.zeros(len(net.points), dtype=bool)
    for a in case.anchors:
        if a.name in net.vertex_groups:
            anchored[net.vertex_groups[a.name]] = True
    cell_damper = np.array([links.get(net.groups[g], -1) for g in net.cell_group],
                           np.int64).reshape(-1)
    on_cable = np.zeros(len(net.points), dtype=bool)
    on_cable[net.cells[cell_damper < 0].ravel()] = True
    for e in np.nonzero(cell_damper >= 0)[0]:
        a, b = (int(k) for k in net.cells[e])
        i = int(cell_damper[e])
        lost = [k for k in (a, b) if not (on_cable[k] or anchored[k])]
        if lost or not (on_cable[a] or on_cable[b]):
            k = lost[0] if lost else a
            problems.append((f"dampers[{i}].group", (
                f"a cell of {case.dampers[i].group!r} ends at node {k} at "
                f"{net.points[k].tolist()}, " + ("on no cable and no anchor" if lost
                                                 else "and joins no cable") +
                ": a damper joins two cable nodes, or a cable node and an anchor "
                "(one cell each)")))
            break
    # the dampers carry nothing in statics: a part held only through them is free
    comp = connected_components(len(net.points), net.cells[cell_damper < 0])
    free = sorted(set(comp.tolist()) - set(comp[anchored].tolist()))
    if free:
        k = int(np.nonzero(comp == free[0])[0][0])
        problems.append(("anchors", f"{len(free)} part(s) of the network are held by no "
                                    f"anchor (disconnected cables), e.g. the one with node "
                                    f"{k} at {net.points[k].tolist()}"))
    held = [(a, net.points[k]) for a in case.anchors if a.name in net.vertex_groups
            for k in net.vertex_groups[a.name]]
    problems += water_problems([a for a, _ in held], case.gravity, None,
                               getattr(case, "seabed", None), [p for _, p in held])
    if problems:
        raise CaseError(problems, case.source)
    net, sides = split_clamps(net, case.anchors, cell_damper < 0, case.source)
    secs = spec.sections
    model.warnings += pretension_warnings(spec.cables, secs)
    cable = cell_damper < 0
    cell_section = [by_group[net.groups[g]].section if net.groups[g] in by_group else None
                    for g in net.cell_group]
    # a damper's cell: no axial stiffness, no mass, stress-free at its mesh length
    EA = np.array([secs[n].EA if n is not None else 0.0 for n in cell_section])
    m = np.array([secs[n].mass if n is not None else 0.0 for n in cell_section])
    T0 = np.array([by_group[net.groups[g]].pretension if net.groups[g] in by_group
                   else 0.0 for g in net.cell_group])
    c = np.ones(len(EA))
    c[cable] = 1.0 / (1.0 + T0[cable] / EA[cable])
    h = np.linalg.norm(net.points[net.cells[:, 1]] - net.points[net.cells[:, 0]], axis=1)
    length = float(np.sum((c * h)[cable]))
    geo = NetworkGeometry(net.points, net.cells, length, net, EA, m, c, cell_section,
                          cell_damper=cell_damper, clamp_sides=sides)
    # the seabed's contact law is smoothed over a fraction of the lightest cable's
    # penetration (cablefem.seabed): the least submerged weight of the sections used
    fl, g = getattr(case, "fluid", None), case.gravity.g
    used = [secs[n] for n in sorted({n for n in cell_section if n is not None})]
    w = [submerged_weight(fl, sec.mass, g, fl.diameter_on(sec)) if fl is not None
         else sec.mass * g for sec in used]
    model.submerged_weight = float(min([x for x in w if x > 0], default=max(w)))
    model.force_scale = float(max(np.max(T0, initial=0.0),
                                 np.max(m, initial=0.0) * case.gravity.g * length, 1e-300))
    log.info("network %s: %d nodes, %d cells, %d cable groups, %d junctions, %d anchor "
             "groups, stress-free length %.6g m", spec.mesh.name, len(net.points),
             len(net.cells), len(net.groups), len(net.junctions), len(case.anchors),
             length)
    return geo, net.points.copy()


def network_coefficients(model) -> None:
    """The cell fields EA, m and c of every cell's section (a damper's cells: none)."""
    geo = model.geometry
    idx = model.cell_index = model.line.reference_cells()
    model.EA, model.m, model.c = (fem.Function(model.W, name=n) for n in ("EA", "m", "c"))
    for f, arr in ((model.EA, geo.cell_EA), (model.m, geo.cell_m), (model.c, geo.cell_c)):
        f.x.array[:] = arr[idx].astype(PETSc.ScalarType)


def network_anchors(model) -> list[AnchorBC]:
    """An anchor per node of every anchor group (a clamp a cable runs through: one per
    side, ``clamp`` naming the clamp), in the order of the case's groups."""
    geo = model.geometry
    net = geo.net
    secs = model.case.network.sections
    out = []
    imap = model.V.dofmap.index_map

    def held(name, node, kind, direction, spec, cell):
        geo.anchor_nodes[name] = node
        dofs = fem.locate_dofs_topological(model.V, 0, model.line.locate_node(node))
        owned = bool(np.any(dofs < imap.size_local))
        section = secs[geo.cell_section[cell]] if cell is not None else None
        X = net.points[node].copy()
        return AnchorBC(name, node, X, X.copy(), kind, direction, spec.motion, dofs,
                        owned, section)

    for spec in model.case.anchors:
        for i, k in enumerate(net.vertex_groups[spec.name]):
            k = int(k)
            name = f"{spec.name}:{i}"
            if k in geo.clamp_sides:  # a clamp a cable runs through: one per side
                for side in geo.clamp_sides[k]:
                    out.append(held(side.name, side.node, "clamped", side.direction,
                                    spec, side.cell))
                    out[-1].clamp = name
                continue
            at = np.nonzero(((net.cells[:, 0] == k) | (net.cells[:, 1] == k))
                            & geo.is_cable)[0]  # its cables' cells
            direction = None
            if spec.kind == "clamped":
                if at.size == 0:  # only dampers end there
                    raise CaseError([(f"anchors[{spec.name}].type", f"anchor {name} at "
                                      f"node {k} holds no cable element, nothing to "
                                      "clamp: make it 'pinned'")], model.case.source)
                direction = spec.direction
                if direction is None:
                    other = net.cells[at[0]][net.cells[at[0]] != k][0]
                    d = net.points[other] - net.points[k]
                    direction = d / np.linalg.norm(d)
                direction = np.asarray(direction, float) / np.linalg.norm(direction)
            out.append(held(name, k, spec.kind, direction, spec,
                            int(at[0]) if at.size else None))
    owners = model.comm.allreduce(np.array([int(a.owned) for a in out]))
    if np.any(owners != 1):
        raise RuntimeError("anchor ownership is not unique across ranks")
    return out


#: what a network is built from (:class:`cablefem.contract.Builders`): its mesh and
#: sections, the string's boundary conditions
NETWORK = Builders(geometry=network_geometry, coefficients=network_coefficients,
                   anchors=network_anchors, bcs=string_bcs)


class NetworkModel(CableModel):
    """A cable network, ready to be solved (same API as :class:`CableModel`)."""

    ramp_weight = True
    is_network = True
    builders = NETWORK
    _at_node = None  # the cable cells at every node (cable_cells_at), made on first use

    def section_field(self, name: str, value):
        """A cell field (DG0) of ``value(section)`` of each cell's cable section, 0 on a
        damper's cells (which carry no section)."""
        secs = self.case.network.sections
        per_cell = np.array([0.0 if n is None else float(value(secs[n]))
                             for n in self.geometry.cell_section])
        f = fem.Function(self.W, name=name)
        f.x.array[:] = per_cell[self.cell_index].astype(PETSc.ScalarType)
        return f

    def compile(self) -> None:
        """Build the kinks' corner term (:func:`cablefem.junctions.junction_terms`), then
        compile the forms."""
        from cablefem.junctions import junction_terms

        self.node_terms = junction_terms(self)
        super().compile()

    #: the corner term on every kink whose nodes are on this rank, and the local cells of
    #: its two elements (cablefem.junctions): the tension field's values there
    corner_report = None

    def tension_field(self, name: str = "tension") -> fem.Function:
        """The cells' tensions; a corrected kink's two elements carry the tension of the
        string run to its corner (:mod:`cablefem.junctions`), not the chord to the node."""
        f = super().tension_field(name)
        junctions.set_corner_cells(self, f, lambda term: term.element_tensions(self.u.x.array))
        return f

    def strain_field(self, name: str = "strain") -> fem.Function:
        """The cells' strains, ``T/EA`` on a corrected kink's elements (as
        :meth:`tension_field`)."""
        f = super().strain_field(name)
        junctions.set_corner_cells(
            self, f, lambda term: term.element_tensions(self.u.x.array) / term.EA[:, None])
        return f

    def cable_cells(self) -> np.ndarray:
        n_owned = self.mesh.topology.index_map(1).size_local
        return self.geometry.is_cable[self.cell_index[:n_owned]]

    def applies_damper_offsets(self) -> bool:
        """A network's dampers act at the string's node: their cells do not reach the two
        cable elements at their ends (the run estimates what that costs, docs/dampers.md)."""
        return False

    def damper_work(self, u_t, v_t, us_t, du_t):
        """The dampers' virtual work: each cell of a damper's group a dashpot (and spring)
        between its nodes (:func:`cablefem.dampers.link_work`), marked by a cell indicator
        per damper (not a tagged measure: a form holds one set of cell tags, and the
        virtual hinges' law has its own)."""
        from cablefem.dampers import link_work

        which = np.asarray(self.geometry.cell_damper)[self.cell_index]
        where = []
        for i in range(len(self.case.dampers)):
            chi = fem.Function(self.W, name=f"damper{i}_cells")
            chi.x.array[:] = (which == i).astype(PETSc.ScalarType)
            where.append(chi)
        h = fem.Function(self.W, name="damper_length")  # each cell's mesh length
        pts, cells = self.geometry.points, self.geometry.cells
        ref = cells[self.cell_index]
        h.x.array[:] = np.linalg.norm(pts[ref[:, 1]] - pts[ref[:, 0]], axis=1)
        return link_work(self.mesh, self.case.dampers, where, h, u_t, v_t, us_t, du_t, self.t0)

    def bending_nodes(self) -> list[int]:
        """With ``solver.span_bending``: the nodes of :meth:`bending_vertices` (tagged in
        :attr:`dS`)."""
        if not is_on(self.case.solver.span_bending):
            return []
        return self.bending_vertices()[0][:, 1].tolist()

    def bending_vertices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Where the span-bending term acts, whether it is on or not: every node of two
        cable elements (of one group or two) that holds no anchor, point load, point mass
        or damper end, as (node before, node, node after), (n, 3); the mean ``EI`` of the
        two elements and their mean stress-free length ``hbar`` (the pretension's, the
        outer string's) at each."""
        geo = self.geometry
        cells = np.asarray(geo.cells, np.int64)
        at = self.cable_cells_at()
        stops = ({int(k) for k in geo.anchor_nodes.values()} | set(self.line.node_tag)
                 | {int(k) for k in cells[~geo.is_cable].ravel()})
        secs = self.case.network.sections
        length = geo.cell_lengths
        rows, EI, hbar = [], [], []
        for k, es in enumerate(at):
            if len(es) != 2 or k in stops:
                continue
            e0, e1 = es
            rows.append((int(cells[e0][cells[e0] != k][0]), k,
                         int(cells[e1][cells[e1] != k][0])))
            EI.append(0.5 * (secs[geo.cell_section[e0]].EI + secs[geo.cell_section[e1]].EI))
            hbar.append(0.5 * (length[e0] + length[e1]))
        return (np.asarray(rows, np.int64).reshape(-1, 3), np.asarray(EI, float),
                np.asarray(hbar, float))

    def add_span_bending(self):
        """``solver.span_bending`` on a network (docs/theory.md §6.1): the bending energy
        at every node of :meth:`bending_nodes`; at every other node of a cable (a clamped
        anchor, a kink, a junction; not a free end or a pinned end) the span's moment
        ``EI κ_s`` is handed over on each of its elements, as at a single cable's clamps
        and kinks. The hand-over is constant along an element (P1: its tension, tangent
        and rotation are), so it is integrated over the element against ``1/h``, which
        also reaches a junction's elements (no interior facet joins three cells); an
        element with hand-overs at both ends gets none (the two cancel: its curvature,
        hence its moment, is the same at both). The energy's lengths are the outer
        string's, the pretension's stress-free length per mesh length ``c0`` (also in a
        hinge's region). Returns the bending energy (a form)."""
        geo = self.geometry
        cells = np.asarray(geo.cells, np.int64)
        cable = geo.is_cable
        n = len(geo.points)
        degree = np.array([len(es) for es in self.cable_cells_at()])
        clamped = {int(a.node) for a in self.anchors if a.kind == "clamped"}
        hand = (degree >= 2) | np.isin(np.arange(n), sorted(clamped))
        hand[self.bending_nodes()] = False
        self.EI = self.section_field("EI", lambda sec: sec.EI)
        c0 = fem.Function(self.W, name="c_outer")
        c0.x.array[:] = np.asarray(geo.cell_c, float)[self.cell_index]
        energy = (bending_forms.span_bending_energy(self.u, self.t0, self.EI, self.mesh, c0)
                  * self.dS(self.line.bend_tag))
        self.forms.add("span_bending", ufl.derivative(energy, self.u, self.du),
                       kind="static")
        # each cable element's sum of the unit vectors away from its hand-over ends (zero
        # on the others: sign(0) = 0 in the hand-over)
        with quiet_compiler():
            space = fem.VectorFunctionSpace(self.mesh, ("DG", 0), dim=3)
        away = fem.Function(space, name="away_from_handover")
        ends = cells[self.cell_index]
        d = geo.points[ends[:, 1]] - geo.points[ends[:, 0]]
        d = d / np.linalg.norm(d, axis=1)[:, None]
        w = (hand[ends[:, 0]].astype(float) - hand[ends[:, 1]]) * cable[self.cell_index]
        away.x.array[:] = (w[:, None] * d).ravel()
        if self.comm.allreduce(int(np.count_nonzero(w)), op=MPI.SUM):
            T = self.forms.outputs["tension"]
            q = -(self.m * self.gravity + sum((f for f, _ in self.loads), 0.0 * self.gravity))
            J = ufl.Jacobian(self.mesh)
            h = ufl.sqrt(ufl.dot(J[:, 0], J[:, 0]))
            density = bending_forms.end_moment_density(self.u, self.du, self.t0, self.EI, T, q,
                                                       away)
            self.forms.add("end_moments", density / h * ufl.dx, kind="static")
        return energy

    def cable_cells_at(self) -> list[list[int]]:
        """The cable cells (not the dampers') at every node, in cell order (cached)."""
        if self._at_node is None:
            geo = self.geometry
            cells = np.asarray(geo.cells, np.int64)
            self._at_node = [[] for _ in range(len(geo.points))]
            for e in np.nonzero(geo.is_cable)[0]:
                for n in cells[e]:
                    self._at_node[int(n)].append(int(e))
        return self._at_node

    def chain(self, k: int) -> tuple[list[int], int]:
        """The chain of cable elements from node ``k`` (the end of one cable element)
        through nodes of two cable elements that hold no anchor, up to a junction, a free
        end or an anchor: its cells, in order from ``k``, and the node it ends at."""
        geo = self.geometry
        at, cells = self.cable_cells_at(), np.asarray(geo.cells, np.int64)
        anchored = {int(n) for n in geo.anchor_nodes.values()}
        chain, node, prev = [], int(k), -1
        while True:
            e = [c for c in at[node] if c != prev][0]
            chain.append(e)
            node = int(cells[e][cells[e] != node][0])
            prev = e
            if len(at[node]) != 2 or node in anchored:
                return chain, node

    def anchor_span(self, name: str) -> float:
        """The stress-free length of clamped anchor ``name``'s chain of elements
        (:meth:`chain`): the span its layer's validity and error estimate are measured
        against (a single cable's is its length), m."""
        chain, _ = self.chain(self.geometry.anchor_nodes[name])
        return float(np.sum(self.geometry.lengths_of(chain)))

    def anchor_junction_offset(self, name: str) -> float:
        """What the string leaves of the rod's node offsets at the far end of clamped
        anchor ``name``'s chain (:meth:`chain`), m: at every kink there the part of
        ``|o| = ℓ_r sin(Δ/2)`` its corner does not apply, ``(1 − applied) |o|``, plus
        ``applied |o| Δ²/4``, the small-angle form's own error (docs/theory.md §6.3);
        from the static state (:func:`cablefem.junctions.junction_state`). A normal shift
        of the chain's far end by that much turns the anchor's angle by it over the span
        (:func:`cablefem.moments.error_estimate`)."""
        _, far = self.chain(self.geometry.anchor_nodes[name])
        return float(sum(so * ((1.0 - ap) + ap * d * d / 4.0)
                         for _, so, ap, d in self.junction_offsets.get(int(far), ())))

    def item_nodes(self, item) -> list[int]:
        return [int(k) for k in self.geometry.net.vertex_groups[item.s]]
