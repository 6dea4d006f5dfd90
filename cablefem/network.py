"""Cable networks: many cables, junctions and anchors from a tagged mesh file.

:class:`NetworkModel` is a :class:`cablefem.cable.CableModel` whose geometry, sections and
anchors come from a gmsh file (:func:`cablefem.geometry.read_network_mesh`, tag convention
in ``meshes/README.md``). The mesh is the *pretensioned* geometry: each cable family's
stress-free length is its mesh length divided by ``1 + T0/EA`` (``T0`` its pretension), so
that with the anchors at their mesh positions and no gravity the mesh is in equilibrium;
statics then ramps gravity and the loads from there (load continuation if Newton fails).
Section properties are cell-wise (DG0) coefficients of the same UFL forms as a single cable.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from petsc4py import PETSc

from cablefem.anchor import CLAMPED_THROUGH
from cablefem.cable import MAX_PLAUSIBLE_STRAIN, AnchorBC, CableModel
from cablefem.errors import CaseError
from cablefem.fluid import submerged_weight
from cablefem.geometry import MeshError, NetworkMesh, connected_components, read_network_mesh

__all__ = ["NetworkModel", "NetworkGeometry"]

log = logging.getLogger(__name__)


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

    @property
    def is_cable(self) -> np.ndarray:
        """Which cells are a cable's (a damper's are not)."""
        if not len(self.cell_damper):
            return np.ones(len(self.cells), dtype=bool)
        return np.asarray(self.cell_damper) < 0

    @property
    def stations(self) -> np.ndarray:  # node numbering, for gathers
        return np.arange(len(self.points), dtype=float)


class NetworkModel(CableModel):
    """A cable network, ready to be solved (same API as :class:`CableModel`)."""

    ramp_weight = True
    is_network = True

    def _build_geometry(self):
        case = self.case
        spec = case.network
        try:
            net = read_network_mesh(spec.mesh)
        except MeshError as err:
            raise CaseError(err.problems, case.source) from None
        problems = []
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
        if problems:
            raise CaseError(problems, case.source)
        secs = spec.sections
        for i, c in enumerate(spec.cables):
            strain = c.pretension / secs[c.section].EA
            if strain > MAX_PLAUSIBLE_STRAIN:
                self.warnings.append((f"cables[{i}].pretension", (
                    f"pretension / EA is a strain of {100 * strain:.3g} %, above the "
                    f"{100 * MAX_PLAUSIBLE_STRAIN:g} % that any cable material stays linear "
                    "to: check the value and the section")))
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
                              cell_damper=cell_damper)
        # the seabed's contact law is smoothed over a fraction of the lightest cable's
        # penetration (cablefem.seabed): the least submerged weight of the sections used
        fl, g = getattr(case, "fluid", None), case.gravity.g
        used = [secs[n] for n in sorted({n for n in cell_section if n is not None})]
        w = [submerged_weight(fl, sec.mass, g, fl.diameter_on(sec)) if fl is not None
             else sec.mass * g for sec in used]
        self.submerged_weight = float(min([x for x in w if x > 0], default=max(w)))
        self.force_scale = float(max(np.max(T0, initial=0.0),
                                     np.max(m, initial=0.0) * case.gravity.g * length, 1e-300))
        log.info("network %s: %d nodes, %d cells, %d cable groups, %d junctions, %d anchor "
                 "groups, stress-free length %.6g m", spec.mesh.name, len(net.points),
                 len(net.cells), len(net.groups), len(net.junctions), len(case.anchors),
                 length)
        return geo, net.points.copy()

    def _coefficients(self) -> None:
        geo = self.geometry
        idx = self._cell_index = self._reference_cells()
        self.EA, self.m, self.c = (fem.Function(self.W, name=n) for n in ("EA", "m", "c"))
        for f, arr in ((self.EA, geo.cell_EA), (self.m, geo.cell_m), (self.c, geo.cell_c)):
            f.x.array[:] = arr[idx].astype(PETSc.ScalarType)

    def section_field(self, name: str, value):
        """A cell field (DG0) of ``value(section)`` of each cell's cable section, 0 on a
        damper's cells (which carry no section)."""
        secs = self.case.network.sections
        per_cell = np.array([0.0 if n is None else float(value(secs[n]))
                             for n in self.geometry.cell_section])
        f = fem.Function(self.W, name=name)
        f.x.array[:] = per_cell[self._cell_index].astype(PETSc.ScalarType)
        return f

    def cable_cells(self) -> np.ndarray:
        n_owned = self.mesh.topology.index_map(1).size_local
        return self.geometry.is_cable[self._cell_index[:n_owned]]

    def _damper_work(self, u_t, v_t, us_t, du_t):
        """The dampers' virtual work: each cell of a damper's group a dashpot (and spring)
        between its nodes (:func:`cablefem.dampers.link_work`), on the owned cells."""
        from cablefem.dampers import link_work

        n_owned = self.mesh.topology.index_map(1).size_local
        which = np.asarray(self.geometry.cell_damper)[self._cell_index[:n_owned]]
        ents = np.nonzero(which >= 0)[0].astype(np.int32)
        tags = dmesh.meshtags(self.mesh, 1, ents, (which[ents] + 1).astype(np.int32))
        h = fem.Function(self.W, name="damper_length")  # each cell's mesh length
        pts, cells = self.geometry.points, self.geometry.cells
        ref = cells[self._cell_index]
        h.x.array[:] = np.linalg.norm(pts[ref[:, 1]] - pts[ref[:, 0]], axis=1)
        dx = ufl.Measure("dx", domain=self.mesh, subdomain_data=tags)
        return link_work(self.mesh, self.case.dampers, dx, h, u_t, v_t, us_t, du_t, self.t0)

    def _build_anchors(self) -> list[AnchorBC]:
        geo = self.geometry
        net = geo.net
        secs = self.case.network.sections
        out = []
        imap = self.V.dofmap.index_map
        for spec in self.case.anchors:
            for i, k in enumerate(net.vertex_groups[spec.name]):
                k = int(k)
                name = f"{spec.name}:{i}"
                geo.anchor_nodes[name] = k
                at = np.nonzero(((net.cells[:, 0] == k) | (net.cells[:, 1] == k))
                                & geo.is_cable)[0]  # its cables' cells
                direction, kind = None, spec.kind
                if spec.kind == "clamped" and at.size > 1:
                    # a clamp the cable runs through, or several cables clamped at one
                    # node: each element's side is a layer of its own (cablefem.kinks)
                    kind = CLAMPED_THROUGH
                    if spec.direction is not None:
                        if at.size != 2:
                            raise CaseError([(f"anchors[{spec.name}].direction",
                                              f"anchor {name} at node {k} is on {at.size} "
                                              "cable elements: a direction is the tangent "
                                              "of one cable running through a clamp (two "
                                              "elements); leave it out and each element is "
                                              "clamped along its mesh direction")],
                                            self.case.source)
                        direction = (np.asarray(spec.direction, float)
                                     / np.linalg.norm(spec.direction))
                elif spec.kind == "clamped":
                    if at.size == 0:  # only dampers end there
                        raise CaseError([(f"anchors[{spec.name}].type", f"anchor {name} at "
                                          f"node {k} holds no cable element, nothing to "
                                          "clamp: make it 'pinned'")], self.case.source)
                    direction = spec.direction
                    if direction is None:
                        other = net.cells[at[0]][net.cells[at[0]] != k][0]
                        d = net.points[other] - net.points[k]
                        direction = d / np.linalg.norm(d)
                    direction = np.asarray(direction, float) / np.linalg.norm(direction)
                verts = self._locate_node(k)
                dofs = fem.locate_dofs_topological(self.V, 0, verts)
                owned = bool(np.any(dofs < imap.size_local))
                section = secs[geo.cell_section[at[0]]] if at.size else None
                out.append(AnchorBC(name, k, net.points[k].copy(), net.points[k].copy(),
                                    kind, direction, spec.motion, dofs, owned, section))
        owners = self.comm.allreduce(np.array([int(a.owned) for a in out]))
        if np.any(owners != 1):
            raise RuntimeError("anchor ownership is not unique across ranks")
        return out

    def _item_nodes(self, item) -> list[int]:
        return [int(k) for k in self.geometry.net.vertex_groups[item.s]]
