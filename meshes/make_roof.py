"""Write a saddle-shaped cable-net roof (hyperbolic paraboloid) as a gmsh file.

Two families of cables on a square plan ``[-L/2, L/2]^2``: ``cables_x`` (sagging, they
carry the roof) and ``cables_y`` (hogging, they stabilise it) on
``z = h ((2y/L)^2 - (2x/L)^2)`` at the junctions (shared nodes), straight in between, so
that with equal pretension in both families and no gravity the mesh is in equilibrium
(the hypar's two curvatures are equal and opposite). Every cable ends at a clamped edge anchor: 0D groups
``anchors_x`` and ``anchors_y``; ``--load-node`` tags the first crossing as the 0D group ``load``. ``n`` cables per family, ``k`` elements per bay.
Nodes: about ``2 n (n + 1) k``; degrees of freedom: three per node.

    python meshes/make_roof.py --n 5 --k 4 --out meshes/roof_small.msh
"""

from __future__ import annotations

import argparse

import meshio
import numpy as np


def roof(n: int, k: int, L: float = 40.0, h: float = 2.0, load_node: bool = False):
    ticks = np.linspace(-L / 2, L / 2, n + 2)  # cable positions incl. the edges
    n_fine = (n + 1) * k + 1  # stations along a cable
    z = lambda x, y: h * ((2 * y / L) ** 2 - (2 * x / L) ** 2)  # noqa: E731
    index: dict[tuple[int, int], int] = {}
    pts: list[tuple[float, float, float]] = []

    def coord(i):  # fine station i -> position along a cable; straight between junctions
        b, r = divmod(i, k)
        if r == 0:
            return ticks[b], b, b
        return ticks[b] + (ticks[b + 1] - ticks[b]) * r / k, b, b + 1

    def node(ix, iy):  # ix, iy: integer coordinates on the fine grid (one of them on a tick)
        key = (ix, iy)
        if key not in index:
            (x, bx0, bx1), (y, by0, by1) = coord(ix), coord(iy)
            # z: the hypar at the junctions, linear in between (a cable under tension alone
            # is straight between the junctions, where the two families balance)
            if ix % k:
                w = (ix % k) / k
                zz = (1 - w) * z(ticks[bx0], y) + w * z(ticks[bx1], y)
            elif iy % k:
                w = (iy % k) / k
                zz = (1 - w) * z(x, ticks[by0]) + w * z(x, ticks[by1])
            else:
                zz = z(x, y)
            index[key] = len(pts)
            pts.append((x, y, zz))
        return index[key]

    cells, tags, anchors = [], [], {1: [], 2: []}
    for fam, tag in ((0, 1), (1, 2)):
        for j in range(1, n + 1):  # interior cable lines (the edges carry no cable)
            fixed = j * k
            ids = [node(i, fixed) if fam == 0 else node(fixed, i) for i in range(n_fine)]
            cells += [[ids[i], ids[i + 1]] for i in range(len(ids) - 1)]
            tags += [tag] * (len(ids) - 1)
            anchors[tag] += [ids[0], ids[-1]]
    verts = anchors[1] + anchors[2]
    vtags = [10] * len(anchors[1]) + [20] * len(anchors[2])
    field = {"cables_x": np.array([1, 1]), "cables_y": np.array([2, 1]),
             "anchors_x": np.array([10, 0]), "anchors_y": np.array([20, 0])}
    if load_node:  # the first crossing (first x cable, first y cable) as a point group
        verts.append(index[(k, k)])
        vtags.append(30)
        field["load"] = np.array([30, 0])
    return meshio.Mesh(np.array(pts), [("line", np.array(cells)), ("vertex", np.array(verts)[:, None])],
                       cell_data={"gmsh:physical": [np.array(tags), np.array(vtags)],
                                  "gmsh:geometrical": [np.array(tags), np.array(vtags)]},
                       field_data=field)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--n", type=int, default=5, help="cables per family")
    ap.add_argument("--k", type=int, default=4, help="elements per bay")
    ap.add_argument("--L", type=float, default=40.0, help="plan size, m")
    ap.add_argument("--h", type=float, default=2.0, help="saddle height, m")
    ap.add_argument("--load-node", action="store_true",
                    help="tag the first crossing as the 0D group 'load' (a point load there)")
    ap.add_argument("--out", default="meshes/roof_small.msh")
    a = ap.parse_args()
    m = roof(a.n, a.k, a.L, a.h, a.load_node)
    meshio.write(a.out, m, file_format="gmsh22", binary=False)
    print(f"{a.out}: {len(m.points)} nodes, {len(m.cells[0].data)} cells, "
          f"{3 * len(m.points)} dofs")
