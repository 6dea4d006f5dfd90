"""The virtual hinge (cablefem.hinge) at the clamped anchors of networks and polylines: a
one-cable network equals the single cable, the fan runs with it on any partition, and a
clamped anchor on a junction is refused naming the key.

Runs serially and on 2 MPI ranks (every model is built on COMM_WORLD)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI
from test_network import write_mesh  # noqa: E402  (tests/ is on the path)

from cablefem.cable import CableModel
from cablefem.case import parse_case
from cablefem.modal import solve_modes
from cablefem.moments import anchor_moments
from cablefem.network import NetworkModel
from cablefem.statics import solve_static

comm = MPI.COMM_WORLD
DEMOS = Path(__file__).resolve().parents[1] / "demos"

EA, EI, MASS, T0, G = 1.0e6, 1.0, 2.0, 1.0e4, 9.81
SPAN, N = 10.0, 40


def _moments(model, res):
    out = []
    for i, anc in enumerate(model.anchors):
        F = res.anchor_forces[i]
        out.append(anchor_moments(F[None, :3], anc.direction, anc.section.EI, anc.section.EA,
                                  anc.section.mass, np.zeros((1, 3)),
                                  anc.section.mass * model.g_vec, model.length, None,
                                  "exact")["moment"][0])
    return np.array(out)


def _state(model, n_modes=3):
    res = solve_static(model)
    return _moments(model, res), solve_modes(model, n_modes).omegas, res


def _points(bend: float):
    """Mesh points of one cable from x = 0 to SPAN, its middle node lifted by ``bend``."""
    x = np.linspace(0.0, SPAN, N + 1)
    z = bend * (1.0 - np.abs(2.0 * x / SPAN - 1.0))
    return np.column_stack([x, np.zeros_like(x), z])


def _network(path, corr, bend=0.0):
    pts = _points(bend)
    cells = np.column_stack([np.arange(N), np.arange(1, N + 1)])
    mesh = write_mesh(str(path / "one.msh"), pts, cells, ["c"] * N, {"ends": [0, N]})
    d = {"title": "one", "network": {"mesh": mesh},
         "sections": [{"name": "s", "EA": EA, "EI": EI, "mass": MASS}],
         "cables": [{"group": "c", "section": "s", "pretension": T0}],
         "gravity": {"g": G}, "anchors": [{"name": "ends"}],
         "solver": {"outer_correction": corr}}
    return NetworkModel(comm, parse_case(d))


def _single(corr, bend=0.0):
    """The same cable as :func:`_network`: the polyline through the network's stress-free
    corners (mesh points scaled by 1/(1 + T0/EA) about the first anchor) in N equal
    elements (the network's), anchors at the mesh's ends, clamped along the first
    elements."""
    pts = _points(bend)
    free = pts / (1.0 + T0 / EA)
    d0 = (pts[1] - pts[0]) / np.linalg.norm(pts[1] - pts[0])
    d1 = (pts[-2] - pts[-1]) / np.linalg.norm(pts[-2] - pts[-1])
    d = {"title": "one", "section": {"EA": EA, "EI": EI, "mass": MASS},
         "gravity": {"g": G}, "geometry": {"polyline": free[[0, N // 2, N]].tolist()},
         "mesh": {"elements": N},
         "anchors": [{"name": "p", "position": pts[0].tolist(), "type": "clamped",
                      "direction": d0.tolist()},
                     {"name": "q", "position": pts[-1].tolist(), "type": "clamped",
                      "direction": d1.tolist()}],
         "solver": {"outer_correction": corr}}
    return CableModel(comm, parse_case(d))


@pytest.mark.parametrize("bend", [0.0, 0.5])
def test_one_cable_network_with_hinges_equals_the_single_cable(mpi_tmp_path, bend):
    """A network of one cable (mesh file) and the polyline cable with the same stress-free
    elements and anchors are the same equations: the same static anchor moments and first
    frequencies with the hinges, to round-off (measured 1e-14; 1e-11 leaves room for the
    fixed point's stopping point, far below the O(ell/l) = 1e-3 the hinge moves them: a
    wrong region, a lost pretension coefficient or a hinge on the wrong node shows). The
    hinges are on: they raise the first frequency by about 2 h / l (the span turns about
    the hinges, h ~ ell = sqrt(EI/T0) = 0.01 m, l = 10 m: 2e-3; the sag and the layer's
    stretch change it by some per cent of that, so between 1.5e-3 and 2.5e-3, on the straight
    cable; the kinked one, whose first mode stretches it, only by more than 1e-3)."""
    M_net, w_net, _ = _state(_network(mpi_tmp_path, "hinge", bend))
    M_one, w_one, _ = _state(_single("hinge", bend))
    np.testing.assert_allclose(M_net, M_one, rtol=1e-11)
    np.testing.assert_allclose(w_net, w_one, rtol=1e-11)
    M_lead, w_lead, _ = _state(_network(mpi_tmp_path, "none", bend))
    if bend == 0.0:
        assert 1.5e-3 < w_net[0] / w_lead[0] - 1 < 2.5e-3
    else:
        assert w_net[0] / w_lead[0] - 1 > 1e-3
