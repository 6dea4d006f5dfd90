"""The line discretisation: mesh, spaces, node maps, point-term measures and anchors.

What the string (:class:`cablefem.cable.CableModel`), the network
(:class:`cablefem.network.NetworkModel`) and the rod (:class:`cablefem.rod.BeamModel`) all
use, whatever their physics: :class:`LineDiscretisation` holds the dolfinx mesh of a line
geometry (a :class:`cablefem.geometry.CableGeometry` or a network's), its P1 space of ``bs``
components per node and the DG0 cell space, the maps between the mesh's local vertices, dof
blocks and cells and the geometry's reference nodes and cells (the partitioner reorders
them), gather and scatter of nodal values in reference order, and the measures of point
terms at nodes (:meth:`LineDiscretisation.tag_points`, :meth:`LineDiscretisation.point_work`).
:func:`cable_anchors` and :func:`anchor_bcs` make a single cable's anchors and their
boundary conditions.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh

from cablefem.anchor import AnchorBC
from cablefem.geometry import create_line_mesh
from cablefem.jit import quiet_compiler

__all__ = ["LineDiscretisation", "cable_anchors", "anchor_bcs"]


class LineDiscretisation:
    """The mesh of ``geometry`` on ``comm`` with its spaces and node maps.

    ``bs``: components per node of the unknowns' space ``V`` (3: a string's displacement,
    6: a rod's displacement and rotation); ``W`` is the cell space (DG0) of tensions,
    strains and section fields. ``phase(what)`` is told the build's phases (for logging).
    """

    def __init__(self, comm, geometry, bs: int = 3, phase=None):
        phase = phase or (lambda what: None)
        self.comm = comm
        self.geometry = geometry
        self.bs = bs
        phase(f"mesh of {len(geometry.stations) - 1} elements")
        self.mesh = create_line_mesh(comm, geometry.points, geometry.cells)
        self.mesh.topology.create_connectivity(0, 1)
        phase("function spaces")
        with quiet_compiler():  # the elements are JIT-compiled on first use
            self.V = fem.VectorFunctionSpace(self.mesh, ("Lagrange", 1), dim=bs)
            self.W = fem.FunctionSpace(self.mesh, ("DG", 0))
        self._vertex_node = None
        self._ref_cells = None
        #: owned dof block -> node index in station order (for gathering to rank 0)
        self.owned_nodes = None
        #: the tag of every node with point terms in :attr:`dS` (:meth:`tag_points`)
        self.node_tag: dict[int, int] = {}

    # ------------------------------------------------------------------ node maps
    def locate_node(self, k: int) -> np.ndarray:
        """Local vertex indices (0 or 1 of them) of reference node ``k``."""
        return np.nonzero(self.vertex_nodes() == k)[0].astype(np.int32)

    def vertex_nodes(self) -> np.ndarray:
        """The reference node of every local vertex (owned, then ghosts), from the cells:
        each local cell's two vertices are matched to its reference cell's two nodes by
        position (distinct within a cell). Nodes at one point on different cells (a clamp
        split into its sides, :func:`cablefem.network.split_clamps`) stay apart."""
        if self._vertex_node is None:
            imap = self.mesh.topology.index_map(0)
            n = imap.size_local + imap.num_ghosts
            verts = self.mesh.topology.connectivity(1, 0).array.reshape(-1, 2)
            # a vertex's "midpoint" is its position
            xyz = dmesh.compute_midpoints(self.mesh, 0, np.arange(n, dtype=np.int32))
            self._vertex_node = self._match_ends(xyz[verts], verts, n)
        return self._vertex_node

    def dof_nodes(self, space) -> np.ndarray:
        """The reference node of every local dof block of the P1 ``space`` (owned, then
        ghosts), matched within each local cell like :meth:`vertex_nodes`."""
        imap = space.dofmap.index_map
        n = imap.size_local + imap.num_ghosts
        dofs = np.asarray(space.dofmap.list.array, np.int64).reshape(-1, 2)
        return self._match_ends(space.tabulate_dof_coordinates()[dofs], dofs, n)

    def _match_ends(self, xyz: np.ndarray, items: np.ndarray, n: int) -> np.ndarray:
        """Reference nodes of ``n`` local items (vertices or dof blocks) given per local
        cell, ``items`` (cells, 2) at positions ``xyz`` (cells, 2, 3)."""
        out = np.full(n, -1, np.int64)
        ref = self.reference_cells()
        if ref.size:
            geo = self.geometry
            ends = np.asarray(geo.cells, np.int64)[ref]
            pts = np.asarray(geo.points, float)
            to = np.stack([np.linalg.norm(xyz - pts[ends[:, j]][:, None, :], axis=2)
                           for j in (0, 1)])  # (2, cells, 2): item's distance to each end
            first = to[0] <= to[1]
            scale = max(1.0, float(np.max(np.abs(pts))))
            if np.max(np.minimum(to[0], to[1])) > 1e-8 * scale:
                raise RuntimeError("could not map the mesh's nodes to the cable's nodes")
            out[items] = np.where(first, ends[:, [0]], ends[:, [1]])
        if np.any(out < 0):
            raise RuntimeError("a local node on no local cell")
        return out

    def reference_cells(self) -> np.ndarray:
        """The reference cell (a row of ``geometry.cells``) of every local cell, owned then
        ghosts: the partitioner reorders the cells, and the mesh keeps each cell's row in
        the cells it was made from (``original_cell_index``); checked by the midpoints.
        (A k-d tree of the midpoints did this until 2026-11-27: SciPy's spatial module
        cost every run 0.1 s of imports.)"""
        if self._ref_cells is not None:
            return self._ref_cells
        geo = self.geometry
        imap = self.mesh.topology.index_map(1)
        local = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
        pts, cells = np.asarray(geo.points), np.asarray(geo.cells)
        if not local.size:
            return np.zeros(0, np.int64)
        idx = np.asarray(self.mesh.topology.original_cell_index, np.int64)[:local.size]
        mid = dmesh.compute_midpoints(self.mesh, 1, local)
        ref = 0.5 * (pts[cells[idx, 0]] + pts[cells[idx, 1]])
        if (idx.size != local.size or np.max(np.abs(mid - ref))
                > 1e-8 * max(1.0, float(np.max(np.abs(pts))))):
            raise RuntimeError("could not map mesh cells to the reference cells")
        self._ref_cells = idx
        return idx

    def vertex_tags(self, node_tags: dict[int, int]):
        """Mesh tags of dimension 0: reference node -> tag (> 0; the node's local
        vertices)."""
        lookup = np.zeros(len(self.geometry.points), np.int32)
        for k, tag in node_tags.items():
            lookup[k] = tag
        vals = lookup[self.vertex_nodes()]
        ents = np.nonzero(vals)[0].astype(np.int32)
        return dmesh.meshtags(self.mesh, 0, ents, vals[ents])

    def min_element_length(self) -> float:
        """The shortest element's mesh length (m)."""
        pts, cells = self.geometry.points, np.asarray(self.geometry.cells)
        return float(np.min(np.linalg.norm(pts[cells[:, 1]] - pts[cells[:, 0]], axis=1)))

    # ------------------------------------------------------------------ nodal gather
    def map_nodes(self) -> None:
        """Build :attr:`owned_nodes` (owned dof block -> node index in station order)."""
        self.owned_nodes = self.dof_nodes(self.V)[:self.V.dofmap.index_map.size_local]

    def gather_nodal(self, f: fem.Function, root: int = 0) -> np.ndarray | None:
        """Values of a P1 vector function of the model's space at the nodes in station
        order, (n, 3) (the displacement part for a beam), on ``root`` only
        (:meth:`gather_all` gives every component)."""
        full = self.gather_all(f, root)
        return None if full is None else full[:, :3]

    def gather_all(self, f: fem.Function, root: int = 0) -> np.ndarray | None:
        """Every component of ``f`` at the nodes in station order, (n, bs), on ``root``."""
        bs = self.bs
        n_owned = self.V.dofmap.index_map.size_local
        local = f.x.array[: bs * n_owned].reshape(-1, bs)
        if self.comm.size == 1:  # one rank: no message (a touchdown at every output step)
            out = np.full((len(self.geometry.stations), bs), np.nan)
            out[self.owned_nodes] = local
            return out
        parts = self.comm.gather((self.owned_nodes, local.copy()), root=root)
        if self.comm.rank != root:
            return None
        out = np.full((len(self.geometry.stations), bs), np.nan)
        for idx, vals in parts:
            out[idx] = vals
        return out

    def scatter_nodal(self, values: np.ndarray, f: fem.Function) -> None:
        """Set a P1 vector function from nodal values (n, bs) in station order (given on
        all ranks)."""
        n_owned = self.V.dofmap.index_map.size_local
        values = np.asarray(values)
        if values.shape[1] != self.bs:
            raise ValueError(f"nodal values have {values.shape[1]} components, the model "
                             f"{self.bs}")
        f.x.array[: self.bs * n_owned] = values[self.owned_nodes].reshape(-1)
        f.x.scatter_forward()

    # ------------------------------------------------------------------ point terms
    def tag_points(self, nodes, bending_nodes=None) -> None:
        """Vertex tags for the nodes of point terms (one tag per node: point masses, point
        loads, dampers) in :attr:`node_tag` and the interior facet measure :attr:`dS`
        (its tag :attr:`bend_tag` on the nodes ``bending_nodes()`` gives, a network's
        span bending's, called once :attr:`node_tag` is set).

        A node of two elements is reached by :attr:`dS`; one of one element (a free end)
        or of three or more (a junction) is not, as no facet of two cells lies there: its
        point terms are integrated over one adjacent element against a nodal weight
        instead (:meth:`_nodal_weights`, :meth:`point_work`)."""
        nodes = sorted(set(nodes))
        self.node_tag = {k: i + 1 for i, k in enumerate(nodes)}
        # one measure for every interior-vertex term (a form takes one subdomain_data)
        tags = dict(self.node_tag)
        self.bend_tag = len(nodes) + 1  #: the tag of a network's bending vertices in dS
        tags.update({k: self.bend_tag for k in (bending_nodes() if bending_nodes else ())})
        self.dS = ufl.Measure("dS", domain=self.mesh, subdomain_data=self.vertex_tags(tags))
        degree = np.bincount(np.asarray(self.geometry.cells).ravel(),
                             minlength=len(self.geometry.points))
        self.one_sided = [k for k in nodes if degree[k] != 2]
        if self.one_sided:
            self._nodal_weights()

    def _nodal_weights(self) -> None:
        """For every loaded node of other than two elements (:attr:`one_sided`): one of its
        elements, tagged with the node's tag in :attr:`dx_nodes`, and the weight
        :attr:`delta` = (9 - 36 t + 30 t^2)/h on it, t the position along the element from
        the node (0) to its other end (1), h the element's length. Its integral against any
        polynomial of degree two in t is the polynomial's value at the node, so against the
        product of two linear fields (a load or an acceleration times a test function) it is
        the nodal value exactly: the weight is the node's Dirac delta for these products.

        The element is chosen on the global cell list (the same on every rank): free ends
        first, then junctions, each taking an element no other node has taken."""
        geo = self.geometry
        cells, pts = np.asarray(geo.cells), np.asarray(geo.points)
        degree = np.bincount(cells.ravel(), minlength=len(pts))
        taken: dict[int, int] = {}  # reference cell -> node
        for k in sorted(self.one_sided, key=lambda k: (degree[k], k)):
            free = [int(c) for c in np.nonzero(np.any(cells == k, axis=1))[0]
                    if int(c) not in taken]
            if not free:
                raise RuntimeError(f"node {k}: every element next to it carries another "
                                   "node's point terms")
            taken[free[0]] = k
        n_owned = self.mesh.topology.index_map(1).size_local  # owned: each counted once
        local = np.arange(n_owned, dtype=np.int32)
        idx = self.reference_cells()[:n_owned]
        with quiet_compiler():
            space = fem.VectorFunctionSpace(self.mesh, ("DG", 0), dim=3)
        X, D = fem.Function(space, name="node_position"), fem.Function(space, name="node_dir")
        inv_h = fem.Function(self.W, name="node_inv_h")
        ents, vals = [], []
        for i, c in zip(local, idx):
            k = taken.get(int(c))
            if k is None:
                continue
            a, b = cells[c]
            other = pts[b] if a == k else pts[a]
            d = other - pts[k]
            h = float(np.linalg.norm(d))
            X.x.array[3 * i:3 * i + 3] = pts[k]
            D.x.array[3 * i:3 * i + 3] = d / h ** 2
            inv_h.x.array[i] = 1.0 / h
            ents.append(i)
            vals.append(self.node_tag[k])
        order = np.argsort(ents)
        tags = dmesh.meshtags(self.mesh, 1, np.asarray(ents, np.int32)[order],
                              np.asarray(vals, np.int32)[order])
        self.dx_nodes = ufl.Measure("dx", domain=self.mesh, subdomain_data=tags)
        t = ufl.dot(ufl.SpatialCoordinate(self.mesh) - X, D)
        self.delta = (9.0 - 36.0 * t + 30.0 * t ** 2) * inv_h

    def point_work(self, k: int, integrand):
        """The virtual work of a point term at reference node ``k`` (a loaded node):
        ``integrand(r)`` is the term's UFL scalar with ``r`` applied to every field in it
        (a restriction on the interior facet of a node of two elements, nothing on the
        element that carries the nodal weight of any other node)."""
        tag = self.node_tag[k]
        if k in self.one_sided:
            return integrand(lambda f: f) * self.delta * self.dx_nodes(tag)
        return integrand(lambda f: f("+")) * self.dS(tag)


# ---------------------------------------------------------------------- anchors
def cable_anchors(line: LineDiscretisation, case, positions) -> list[AnchorBC]:
    """The two anchors of a single cable (``case.anchors``) at its end nodes, ``positions``
    their positions (a clamp's default direction: along the chord, into the cable)."""
    out = []
    imap = line.V.dofmap.index_map
    for spec, pos in zip(case.anchors, positions):
        k = line.geometry.anchor_nodes[spec.name]
        verts = line.locate_node(k)
        dofs = fem.locate_dofs_topological(line.V, 0, verts)
        owned = bool(np.any(dofs < imap.size_local))
        other = positions[1] if k == 0 else positions[0]
        direction = None
        if spec.kind == "clamped":
            direction = spec.direction
            if direction is None:
                direction = (other - pos) / np.linalg.norm(other - pos)
            direction = np.asarray(direction, dtype=float)
            direction = direction / np.linalg.norm(direction)
        out.append(AnchorBC(spec.name, k, line.geometry.points[k].copy(), pos.copy(),
                            spec.kind, direction, spec.motion, dofs, owned, case.section))
    nowners = [line.comm.allreduce(int(a.owned)) for a in out]
    if any(n != 1 for n in nowners):
        raise RuntimeError(f"anchor ownership is not unique across ranks: {nowners}")
    return out


def anchor_bcs(u_bc: fem.Function, anchors) -> list:
    """Every anchor's Dirichlet condition: its dofs take ``u_bc`` (the prescribed
    displacement, written by ``set_time``)."""
    return [fem.dirichletbc(u_bc, a.dofs) for a in anchors]
