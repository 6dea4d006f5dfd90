"""Cable geometry: stress-free stations, reference node positions and the dolfinx mesh.

A cable is a 1D interval mesh embedded in 3D. Its node coordinates are the stress-free
reference configuration ``X(s)``: every element's length is its stress-free length, so
``ufl.dx`` integrates over stress-free arc length (``docs/theory.md`` §1).
For a cable given by two anchors and a length (or a tension, or a sag) the reference is the
straight segment of that length along the chord; for a polyline it is the polyline itself. A
string has no bending stiffness, so the reference shape only matters through its
arc-length parametrisation: statics moves the anchors to their positions and the catenary
gives the initial guess.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import ufl
from dolfinx import mesh as dmesh
from mpi4py import MPI

from cablefem.errors import MeshError

__all__ = ["CableGeometry", "graded_stations", "straight_cable", "polyline_cable",
           "create_line_mesh"]


@dataclass
class CableGeometry:
    """Reference geometry of one cable (identical on every rank)."""

    stations: np.ndarray  #: stress-free arc length of each node from the first anchor, m
    points: np.ndarray  #: reference (stress-free) node positions X, shape (n+1, 3), m
    length: float  #: stress-free length l, m
    anchor_nodes: dict[str, int] = field(default_factory=dict)  #: anchor name -> node

    @property
    def cells(self) -> np.ndarray:
        n = len(self.stations) - 1
        return np.column_stack([np.arange(n), np.arange(1, n + 1)]).astype(np.int64)

    def node_at(self, s: float) -> int:
        """Index of the node at stress-free arc length ``s`` (the nearest one)."""
        return int(np.argmin(np.abs(self.stations - s)))


def graded_stations(length: float, elements: int, grading: float = 1.0,
                    extra: tuple[float, ...] | list[float] = (),
                    clearance: dict[float, float] | None = None) -> np.ndarray:
    """Stress-free node stations on ``[0, length]``.

    ``grading`` >= 1 is the ratio of the largest (mid-span) element to the two end elements:
    sizes follow a symmetric geometric progression. ``extra`` stations (point masses, point
    loads, polyline corners) are inserted as nodes; a graded station closer than a quarter of
    the local element size to an extra one is dropped, so that no sliver element appears.
    ``clearance``: for some extra stations (a damper's), the least length of the elements
    next to them: the graded stations closer than that are dropped too (never an anchor's).
    """
    if elements < 1:
        raise ValueError(f"mesh.elements must be >= 1, got {elements}")
    if grading < 1.0:
        raise ValueError(f"mesh.grading must be >= 1, got {grading}")
    n = elements
    if grading == 1.0 or n < 3:
        sizes = np.ones(n)
    else:
        half = (n + 1) // 2
        q = grading ** (1.0 / max(half - 1, 1))
        left = q ** np.arange(half)
        sizes = np.concatenate([left, left[::-1][n % 2:]])
    s = np.concatenate([[0.0], np.cumsum(sizes)])
    s *= length / s[-1]
    s[-1] = length
    h = np.diff(s)
    extra = [float(e) for e in extra if 0.0 < e < length]
    # a clearance: the graded nodes inside it go, and a node stands at each of its ends
    # (if clear of the other extra stations and of the cable's ends by a quarter element)
    inside = [(e, w) for e, w in (clearance or {}).items() if w > 0.0 and 0.0 < e < length]
    for e, w in inside:
        for b in (e - w, e + w):
            j = int(np.clip(np.searchsorted(s, b), 1, s.size - 1))
            if (0.25 * h[j - 1] < b < length - 0.25 * h[j - 1]
                    and all(abs(b - x) >= 0.25 * h[j - 1] for x in extra)):
                extra.append(b)
    extra_arr = np.array(sorted(extra))
    if extra_arr.size:
        keep = np.ones(s.size, dtype=bool)
        for e in extra_arr:
            i = int(np.clip(np.searchsorted(s, e), 1, s.size - 1))
            for j in (i - 1, i):
                if 0 < j < s.size - 1 and abs(s[j] - e) < 0.25 * h[min(j, h.size - 1)]:
                    keep[j] = False
        for e, w in inside:
            keep[1:-1] &= np.abs(s[1:-1] - e) >= w
        s = np.unique(np.concatenate([s[keep], extra_arr]))
    return s


def straight_cable(start: np.ndarray, direction: np.ndarray, stations: np.ndarray,
                   anchor_names: tuple[str, str]) -> CableGeometry:
    """Straight stress-free reference from ``start`` along unit ``direction``."""
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    pts = np.asarray(start, dtype=float)[None, :] + stations[:, None] * d[None, :]
    return CableGeometry(stations=stations, points=pts, length=float(stations[-1]),
                         anchor_nodes={anchor_names[0]: 0,
                                       anchor_names[1]: len(stations) - 1})


def polyline_length(polyline: np.ndarray) -> np.ndarray:
    """Cumulative arc length at the vertices of a polyline."""
    seg = np.linalg.norm(np.diff(polyline, axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(seg)])


def polyline_cable(polyline: np.ndarray, elements: int, grading: float,
                   anchor_names: tuple[str, str], extra: tuple[float, ...] = ()) -> CableGeometry:
    """Stress-free reference along a 3D polyline; its corners become nodes."""
    poly = np.asarray(polyline, dtype=float)
    cum = polyline_length(poly)
    corners = tuple(cum[1:-1])
    stations = graded_stations(float(cum[-1]), elements, grading, tuple(extra) + corners)
    pts = np.column_stack([np.interp(stations, cum, poly[:, k]) for k in range(3)])
    return CableGeometry(stations=stations, points=pts, length=float(cum[-1]),
                         anchor_nodes={anchor_names[0]: 0,
                                       anchor_names[1]: len(stations) - 1})


def create_line_mesh(comm: MPI.Comm, points: np.ndarray, cells: np.ndarray) -> dmesh.Mesh:
    """A dolfinx mesh of interval cells embedded in 3D, partitioned over ``comm``.

    Rank 0 passes all cells and points, the other ranks empty arrays (dolfinx 0.5.2).

    The coordinate element is declared with the point spacing FFCx 0.5 gives it anyway
    ("equispaced"; the same element at degree 1): FFCx sets it on the mesh's element in
    place when it compiles a form, which changed the signature (the cache key) of every form
    made on the mesh afterwards, so that each run whose forms came from the cache compiled
    the next form again under a new key (tests/test_jit.py).
    """
    cell = ufl.Cell("interval", geometric_dimension=3)
    domain = ufl.Mesh(ufl.VectorElement(
        ufl.FiniteElement("Lagrange", cell, 1, variant="equispaced"), dim=3))
    if comm.rank == 0:
        x = np.ascontiguousarray(points, dtype=np.float64)
        c = np.ascontiguousarray(cells, dtype=np.int64)
    else:
        x = np.zeros((0, 3), dtype=np.float64)
        c = np.zeros((0, 2), dtype=np.int64)
    return dmesh.create_mesh(comm, c, x, domain)


# ---------------------------------------------------------------------------- networks
@dataclass
class NetworkMesh:
    """A cable network read from a mesh file (identical on every rank).

    Tag convention (gmsh physical groups, ``meshes/README.md``): every line cell belongs to
    a 1D physical group naming its cable family (mapped to a section by the case's
    ``[[cables]]``); anchors and point masses are 0D physical groups (one or more vertices
    each). Nodes shared by cells of a cable or of several cables are junctions.
    """

    points: np.ndarray  #: (n, 3) node positions, m (the reference: pretensioned geometry)
    cells: np.ndarray  #: (c, 2) node indices of the line cells
    cell_group: np.ndarray  #: (c,) index into ``groups``
    groups: list[str]  #: names of the 1D groups
    vertex_groups: dict[str, np.ndarray]  #: 0D group name -> node indices
    source: str = ""

    @property
    def junctions(self) -> np.ndarray:
        """Nodes where three or more cells meet, or two cells of different groups."""
        n = len(self.points)
        nodes = np.asarray(self.cells, np.int64).ravel()
        deg = np.bincount(nodes, minlength=n)
        groups = np.repeat(np.asarray(self.cell_group, np.int64), 2)
        low = np.full(n, np.iinfo(np.int64).max)  # the least and the largest group at
        high = np.full(n, -1, np.int64)  # each node: two groups where they differ
        np.minimum.at(low, nodes, groups)
        np.maximum.at(high, nodes, groups)
        return np.flatnonzero((deg >= 3) | ((deg > 0) & (low != high))).astype(np.int64)


def read_network_mesh(path) -> NetworkMesh:
    """Read a gmsh file (``.msh``, via meshio) and check it: every line cell in a named 1D
    group, no zero-length cell, no duplicate node, no 0D group without a vertex. Raises
    :class:`MeshError` with every problem found."""
    import meshio

    path = str(path)
    try:
        mesh = meshio.read(path)
    except Exception as err:  # noqa: BLE001 - any reader failure is a bad file
        raise MeshError([("network.mesh", f"cannot read the mesh: {err}")], path) from None
    problems: list[tuple[str, str]] = []
    pts = np.asarray(mesh.points, dtype=float)
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    names_by_tag = {(int(v[1]), int(v[0])): str(k) for k, v in mesh.field_data.items()}
    phys = mesh.cell_data.get("gmsh:physical")
    if phys is None:
        raise MeshError([("network.mesh", "no gmsh physical groups: tag the cables (1D) and "
                                          "anchors (0D), see meshes/README.md")], path)
    lines, line_tags, vgroups = [], [], {}
    for block, tags in zip(mesh.cells, phys):
        if block.type == "line":
            lines.append(block.data)
            line_tags.append(tags)
        elif block.type == "vertex":
            for node, tag in zip(block.data[:, 0], tags):
                name = names_by_tag.get((0, int(tag)), f"point_{int(tag)}")
                vgroups.setdefault(name, []).append(int(node))
        else:
            problems.append(("network.mesh", f"cell type {block.type!r} is not a cable "
                                             "(only line and vertex cells)"))
    if not lines:
        raise MeshError([("network.mesh", "no line cells")], path)
    cells = np.concatenate(lines).astype(np.int64)
    tags = np.concatenate(line_tags)
    groups = sorted({names_by_tag.get((1, int(t)), f"line_{int(t)}") for t in tags})
    gidx = {g: i for i, g in enumerate(groups)}
    cell_group = np.array([gidx[names_by_tag.get((1, int(t)), f"line_{int(t)}")]
                           for t in tags])
    unnamed = [g for g in groups if g.startswith("line_")]
    if unnamed:
        problems.append(("network.mesh", f"1D physical groups without a name: {unnamed}"))
    scale = max(1.0, float(np.max(np.abs(pts))))
    lengths = np.linalg.norm(pts[cells[:, 1]] - pts[cells[:, 0]], axis=1)
    bad = np.nonzero(lengths <= 1e-12 * scale)[0]
    if bad.size:
        problems.append(("network.mesh", f"{bad.size} zero-length cell(s), e.g. cell "
                                         f"{int(bad[0])} between nodes {cells[bad[0]].tolist()}"))
    used = np.unique(cells)
    from scipy.spatial import cKDTree

    pairs = cKDTree(pts[used]).query_pairs(1e-9 * scale)
    if pairs:
        i, j = next(iter(pairs))
        problems.append(("network.mesh", f"{len(pairs)} duplicate node(s), e.g. nodes "
                                         f"{int(used[i])} and {int(used[j])} at "
                                         f"{pts[used[i]].tolist()}: merge them (junctions "
                                         "must share one node)"))
    vg = {}
    for name, nodes in vgroups.items():
        nodes = np.unique(nodes)
        off = np.setdiff1d(nodes, used)
        if off.size:
            problems.append((f"network.mesh[{name}]", f"{off.size} vertex(es) on no cable, "
                                                      f"e.g. node {int(off[0])}"))
        vg[name] = nodes
    if problems:
        raise MeshError(problems, path)
    # keep only the nodes that cables use, renumbered
    renum = -np.ones(len(pts), dtype=np.int64)
    renum[used] = np.arange(used.size)
    return NetworkMesh(pts[used], renum[cells], cell_group, groups,
                       {k: renum[v] for k, v in vg.items()}, path)


def connected_components(n_nodes: int, cells: np.ndarray) -> np.ndarray:
    """Component label of every node (scipy's graph routines)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components as cc

    a = coo_matrix((np.ones(len(cells)), (cells[:, 0], cells[:, 1])), shape=(n_nodes, n_nodes))
    return cc(a, directed=False)[1]
