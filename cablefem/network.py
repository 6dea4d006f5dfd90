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
from dolfinx import fem
from dolfinx import mesh as dmesh
from petsc4py import PETSc

from cablefem.cable import MAX_PLAUSIBLE_STRAIN, AnchorBC, CableModel
from cablefem.errors import CaseError
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
    cell_section: list[str]
    anchor_nodes: dict[str, int] = field(default_factory=dict)

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
        for g in net.groups:
            if g not in by_group:
                problems.append(("cables", f"the mesh's cable group {g!r} has no [[cables]] "
                                           "entry"))
        for g in by_group:
            if g not in net.groups:
                problems.append(("cables", f"group {g!r} is not a 1D group of the mesh "
                                           f"(its groups: {net.groups})"))
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
        comp = connected_components(len(net.points), net.cells)
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
        cell_section = [by_group[net.groups[g]].section for g in net.cell_group]
        EA = np.array([secs[n].EA for n in cell_section])
        m = np.array([secs[n].mass for n in cell_section])
        T0 = np.array([by_group[net.groups[g]].pretension for g in net.cell_group])
        c = 1.0 / (1.0 + T0 / EA)
        h = np.linalg.norm(net.points[net.cells[:, 1]] - net.points[net.cells[:, 0]], axis=1)
        length = float(np.sum(c * h))
        geo = NetworkGeometry(net.points, net.cells, length, net, EA, m, c, cell_section)
        self.force_scale = float(max(np.max(T0, initial=0.0),
                                     np.max(m) * case.gravity.g * length, 1e-300))
        log.info("network %s: %d nodes, %d cells, %d cable groups, %d junctions, %d anchor "
                 "groups, stress-free length %.6g m", spec.mesh.name, len(net.points),
                 len(net.cells), len(net.groups), len(net.junctions), len(case.anchors),
                 length)
        return geo, net.points.copy()

    def _coefficients(self) -> None:
        geo = self.geometry
        cells = np.arange(self.mesh.topology.index_map(1).size_local
                          + self.mesh.topology.index_map(1).num_ghosts, dtype=np.int32)
        mid = dmesh.compute_midpoints(self.mesh, 1, cells)
        from scipy.spatial import cKDTree

        ref_mid = 0.5 * (geo.points[geo.cells[:, 0]] + geo.points[geo.cells[:, 1]])
        dist, idx = cKDTree(ref_mid).query(mid)
        if dist.size and dist.max() > 1e-8 * max(1.0, float(np.max(np.abs(geo.points)))):
            raise RuntimeError("could not map mesh cells to network cells")
        self._cell_index = idx
        self.EA, self.m, self.c = (fem.Function(self.W, name=n) for n in ("EA", "m", "c"))
        for f, arr in ((self.EA, geo.cell_EA), (self.m, geo.cell_m), (self.c, geo.cell_c)):
            f.x.array[:] = arr[idx].astype(PETSc.ScalarType)

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
                at = np.nonzero((net.cells[:, 0] == k) | (net.cells[:, 1] == k))[0]
                direction = None
                if spec.kind == "clamped":
                    direction = spec.direction
                    if direction is None:
                        if at.size != 1:
                            raise CaseError([(f"anchors[{spec.name}]", f"anchor {name} at node "
                                              f"{k} is on {at.size} cells: give its direction")],
                                            self.case.source)
                        other = net.cells[at[0]][net.cells[at[0]] != k][0]
                        d = net.points[other] - net.points[k]
                        direction = d / np.linalg.norm(d)
                    direction = np.asarray(direction, float) / np.linalg.norm(direction)
                verts = self._locate_node(k)
                dofs = fem.locate_dofs_topological(self.V, 0, verts)
                owned = bool(np.any(dofs < imap.size_local))
                section = secs[geo.cell_section[at[0]]] if at.size else None
                out.append(AnchorBC(name, k, net.points[k].copy(), net.points[k].copy(),
                                    spec.kind, direction, spec.motion, dofs, owned, section))
        owners = self.comm.allreduce(np.array([int(a.owned) for a in out]))
        if np.any(owners != 1):
            raise RuntimeError("anchor ownership is not unique across ranks")
        return out

    def _item_nodes(self, item) -> list[int]:
        return [int(k) for k in self.geometry.net.vertex_groups[item.s]]
