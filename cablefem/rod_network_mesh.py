"""The network rod's mesh: the network's cells graded towards its clamps and kinks, and its
cables coloured so that cables meeting at a node carry rotations of their own.

:func:`graded_network` refines a network's geometry (:class:`cablefem.network.NetworkGeometry`,
its clamps already split into their sides) in memory: every cable cell is cut into elements
whose size follows ``h = min(h_max, min_a [ℓ_a/n + (g − 1) d_a])``, ``d_a`` the stress-free
distance along the cables from node ``a`` (a clamped anchor, a junction, a loaded node or a
damper's end: every node where the rod bends over a layer), ``ℓ_a`` its layer length at the
pretension, ``n`` = ``[beam] layer_elements``, ``g`` = ``growth`` and ``h_max`` the cable's
stress-free length over ``span_elements`` (the single rod's spec, :func:`cablefem.rod.
beam_stations`). The mesh file's nodes keep their numbers (the anchors', junctions' and
kinks' names are those of the string's run); the new nodes follow them.

:func:`cable_colours`: a *cable* is a connected set of cells of one 1D group; cables that
share a node get different colours (greedy), and the rod's unknowns at a node are its
displacement and one Cayley vector per colour, so that each cable turns on its own at a
junction (a pinned tie: the translations shared, the rotations free).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from cablefem.geometry import NetworkMesh, connected_components

__all__ = ["graded_network", "cable_colours", "layer_nodes", "cable_frames"]


def layer_nodes(model, geo) -> dict[int, float]:
    """Where the rod bends over a layer, with its length ``ℓ = sqrt(EI/(T (1 + T/EA)))`` at
    the pretension ``T`` (the smallest over the cables there): clamped anchors (and every
    side of a split clamp), junctions, nodes of point loads, point masses, pinned anchors
    on two elements and the ends of dampers' cells."""
    case = model.case
    net, cells = geo.net, np.asarray(geo.cells, np.int64)
    secs = case.network.sections
    by_group = {c.group: c for c in case.network.cables}
    cable = geo.is_cable
    nodes = set(int(k) for k in net.junctions)
    for a in case.anchors:
        for k in net.vertex_groups[a.name]:
            nodes.add(int(k))  # a clamp's layer; a pinned anchor on a cable's span: a kink
    for sides in geo.clamp_sides.values():
        nodes.update(int(s.node) for s in sides)
    for item in list(case.point_loads) + list(case.point_masses):
        nodes.update(int(k) for k in net.vertex_groups[item.s])
    nodes.update(int(k) for k in cells[~cable].ravel())
    out = {}
    for k in sorted(nodes):
        ells = []
        for e in np.nonzero(((cells[:, 0] == k) | (cells[:, 1] == k)) & cable)[0]:
            group = net.groups[int(net.cell_group[e])]
            sec, T = secs[geo.cell_section[e]], by_group[group].pretension
            if T > 0:
                ells.append(math.sqrt(sec.EI / (T * (1.0 + T / sec.EA))))
        if ells:
            out[k] = min(ells)
    return out


def cable_colours(geo) -> tuple[np.ndarray, np.ndarray, int]:
    """``(cable, colour, n_colours)``: the cable (connected cells of one 1D group) of every
    cell and its colour (-1 for a damper's cell), cables sharing a node coloured apart
    (greedy, in cable order)."""
    cells = np.asarray(geo.cells, np.int64)
    net = geo.net
    is_cable = geo.is_cable
    n = len(geo.points)
    cable = np.full(len(cells), -1, np.int64)
    count = 0
    for g in range(len(net.groups)):
        es = np.nonzero((np.asarray(net.cell_group) == g) & is_cable)[0]
        if not es.size:
            continue
        comp = connected_components(n, cells[es])
        labels = np.unique(comp[cells[es, 0]])
        remap = {int(lab): count + i for i, lab in enumerate(labels)}
        cable[es] = [remap[int(comp[cells[e, 0]])] for e in es]
        count += len(labels)
    at_node: list[set[int]] = [set() for _ in range(n)]
    for e in np.nonzero(cable >= 0)[0]:
        for k in cells[e]:
            at_node[int(k)].add(int(cable[e]))
    neighbours: list[set[int]] = [set() for _ in range(count)]
    for cs in at_node:
        for c in cs:
            neighbours[c] |= cs - {c}
    colour_of = np.full(count, -1, np.int64)
    for c in range(count):
        used = {int(colour_of[o]) for o in neighbours[c] if colour_of[o] >= 0}
        colour_of[c] = min(set(range(len(used) + 1)) - used)
    colour = np.where(cable >= 0, colour_of[np.maximum(cable, 0)], -1)
    return cable, colour, int(colour_of.max(initial=-1)) + 1


def cable_frames(geo, cable: np.ndarray, gravity_dir: np.ndarray) -> np.ndarray:
    """Each cable's stress-free frame ``(E1, E2, E3)`` per cell, (cells, 3, 3) (zero on a
    damper's cells): ``E3`` along the cable, from its end of lower node number to the other
    (a chain of cells), else along the principal axis of its nodes; ``E1`` in the plane of
    ``E3`` and gravity (the single rod's rule, :func:`cablefem.rod.rod_coefficients`)."""
    cells = np.asarray(geo.cells, np.int64)
    pts = np.asarray(geo.points, float)
    out = np.zeros((len(cells), 3, 3))
    gdir = np.asarray(gravity_dir, float)
    for c in range(int(cable.max(initial=-1)) + 1):
        es = np.nonzero(cable == c)[0]
        deg = np.bincount(cells[es].ravel(), minlength=len(pts))
        ends = np.nonzero(deg == 1)[0]
        if ends.size == 2:
            E3 = pts[ends[1]] - pts[ends[0]]
        else:
            nodes = np.unique(cells[es])
            x = pts[nodes] - pts[nodes].mean(axis=0)
            E3 = np.linalg.svd(x, full_matrices=False)[2][0]
        E3 = E3 / np.linalg.norm(E3)
        trial = gdir - (gdir @ E3) * E3
        if np.linalg.norm(trial) < 1e-6:  # a vertical cable
            trial = np.eye(3)[int(np.argmin(np.abs(E3)))]
            trial = trial - (trial @ E3) * E3
        E1 = trial / np.linalg.norm(trial)
        out[es] = np.stack([E1, np.cross(E3, E1), E3])
    return out


def graded_network(model, geo, layer_elements: float, growth: float, span_elements: float):
    """``geo`` with every cable cell cut into elements graded towards :func:`layer_nodes`
    (module docstring); a damper's cells stay whole. Returns the refined geometry and the
    layer length of each graded node."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    from cablefem.rod import beam_stations

    cells = np.asarray(geo.cells, np.int64)
    pts = np.asarray(geo.points, float)
    n = len(pts)
    cable_mask = geo.is_cable
    length = geo.cell_lengths
    layers = layer_nodes(model, geo)
    cable, _, _ = cable_colours(geo)
    cable_length = np.bincount(cable[cable_mask], weights=length[cable_mask])
    ce = cells[cable_mask]
    graph = coo_matrix((np.concatenate([length[cable_mask]] * 2),
                        (np.concatenate([ce[:, 0], ce[:, 1]]),
                         np.concatenate([ce[:, 1], ce[:, 0]]))), shape=(n, n)).tocsr()
    h_node = np.full(n, np.inf)
    if layers:
        src = np.array(sorted(layers), np.int64)
        dist = np.atleast_2d(dijkstra(graph, indices=src))
        ell = np.array([layers[int(k)] for k in src])
        h_node = np.min(ell[:, None] / layer_elements + (growth - 1.0) * dist, axis=0)
    new_pts = [pts]
    new_cells, parent = [], []
    m = n
    for e, (a, b) in enumerate(cells):
        if not cable_mask[e]:
            new_cells.append([a, b])
            parent.append(e)
            continue
        L = float(length[e])
        h_max = cable_length[cable[e]] / span_elements
        ends = {j: min(h_node[k], h_max) * layer_elements
                for j, k in enumerate((a, b)) if np.isfinite(h_node[k])}
        if L <= min(h_node[a], h_node[b], h_max):  # the size function's least value
            st = np.array([0.0, L])  # fine enough: kept whole
        elif ends:
            st = beam_stations(L, ends, layer_elements, growth, h_max)
        else:
            st = np.linspace(0.0, L, int(math.ceil(L / h_max - 1e-9)) + 1)
        inner = st[1:-1] / L
        ids = [int(a)] + list(range(m, m + inner.size)) + [int(b)]
        m += inner.size
        new_pts.append(pts[a] + inner[:, None] * (pts[b] - pts[a]))
        new_cells += [[ids[i], ids[i + 1]] for i in range(len(ids) - 1)]
        parent += [e] * (len(ids) - 1)
    parent = np.asarray(parent, np.int64)
    new_cells = np.asarray(new_cells, np.int64).reshape(-1, 2)
    points = np.concatenate(new_pts)
    net = geo.net
    rnet = NetworkMesh(points, new_cells, np.asarray(net.cell_group)[parent], net.groups,
                       net.vertex_groups, net.source)
    sides = {}
    for k, ss in geo.clamp_sides.items():  # each side's cell: its element at its node
        sides[k] = [replace(s, cell=int(np.nonzero((parent == s.cell) & np.any(
            new_cells == s.node, axis=1))[0][0])) for s in ss]
    out = replace(geo, points=points, cells=new_cells, net=rnet,
                  cell_EA=np.asarray(geo.cell_EA)[parent], cell_m=np.asarray(geo.cell_m)[parent],
                  cell_c=np.asarray(geo.cell_c)[parent],
                  cell_section=[geo.cell_section[p] for p in parent],
                  cell_damper=(np.asarray(geo.cell_damper)[parent] if len(geo.cell_damper)
                               else geo.cell_damper),
                  anchor_nodes={}, clamp_sides=sides)
    return out, layers
