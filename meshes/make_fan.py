"""Write a fan of stay cables from a pylon head to a deck as a gmsh file.

``n`` stays on each side of a pylon of height ``H``: stay ``i`` runs from the pylon head
(anchor heights spaced by ``dz`` below ``H``) to the deck at ``x = +-(i + 1) d``. Each stay
is its own 1D group ``stay_01 ...`` (so that each can get its own section) and has ``k``
elements; 0D groups ``pylon`` (the upper anchors, which move with the pylon head) and
``deck`` (fixed).

    python meshes/make_fan.py --n 4 --k 20 --out meshes/fan_small.msh
"""

from __future__ import annotations

import argparse

import meshio
import numpy as np


def fan(n: int, k: int, H: float = 60.0, d: float = 15.0, dz: float = 1.5, b: float = 1.0):
    pts, cells, tags, field = [], [], [], {}
    pylon, deck = [], []
    tag = 0
    for side in (-1.0, 1.0):
        for i in range(n):
            tag += 1
            top = np.array([side * 0.5 * b, 0.0, H - i * dz])  # pylon of width b
            bottom = np.array([side * (i + 1) * d, 0.0, 0.0])
            start = len(pts)
            for t in np.linspace(0.0, 1.0, k + 1):
                pts.append(top + t * (bottom - top))
            cells += [[start + j, start + j + 1] for j in range(k)]
            tags += [tag] * k
            field[f"stay_{tag:02d}"] = np.array([tag, 1])
            pylon.append(start)
            deck.append(start + k)
    field["pylon"] = np.array([100, 0])
    field["deck"] = np.array([200, 0])
    verts = np.array(pylon + deck)[:, None]
    vtags = np.array([100] * len(pylon) + [200] * len(deck))
    return meshio.Mesh(np.array(pts), [("line", np.array(cells)), ("vertex", verts)],
                       cell_data={"gmsh:physical": [np.array(tags), vtags],
                                  "gmsh:geometrical": [np.array(tags), vtags]},
                       field_data=field)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--n", type=int, default=4, help="stays per side")
    ap.add_argument("--k", type=int, default=20, help="elements per stay")
    ap.add_argument("--out", default="meshes/fan_small.msh")
    a = ap.parse_args()
    m = fan(a.n, a.k)
    meshio.write(a.out, m, file_format="gmsh22", binary=False)
    print(f"{a.out}: {len(m.points)} nodes, {len(m.cells[0].data)} cells, "
          f"{3 * len(m.points)} dofs")
