"""Cable geometry: stress-free stations, reference node positions and the dolfinx mesh.

A cable is a 1D interval mesh embedded in 3D. Its node coordinates are the stress-free
reference configuration ``X(s)``: every element's length is its stress-free length, so
``ufl.dx`` integrates over stress-free arc length (``../shared/docs/physics.md`` section 1).
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
                    extra: tuple[float, ...] | list[float] = ()) -> np.ndarray:
    """Stress-free node stations on ``[0, length]``.

    ``grading`` >= 1 is the ratio of the largest (mid-span) element to the two end elements:
    sizes follow a symmetric geometric progression. ``extra`` stations (point masses, point
    loads, polyline corners) are inserted as nodes; a graded station closer than a quarter of
    the local element size to an extra one is dropped, so that no sliver element appears.
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
    extra_arr = np.array(sorted(float(e) for e in extra if 0.0 < e < length))
    if extra_arr.size:
        h = np.diff(s)
        keep = np.ones(s.size, dtype=bool)
        for e in extra_arr:
            i = int(np.clip(np.searchsorted(s, e), 1, s.size - 1))
            for j in (i - 1, i):
                if 0 < j < s.size - 1 and abs(s[j] - e) < 0.25 * h[min(j, h.size - 1)]:
                    keep[j] = False
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
    """
    cell = ufl.Cell("interval", geometric_dimension=3)
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", cell, 1, dim=3))
    if comm.rank == 0:
        x = np.ascontiguousarray(points, dtype=np.float64)
        c = np.ascontiguousarray(cells, dtype=np.int64)
    else:
        x = np.zeros((0, 3), dtype=np.float64)
        c = np.zeros((0, 2), dtype=np.int64)
    return dmesh.create_mesh(comm, c, x, domain)
