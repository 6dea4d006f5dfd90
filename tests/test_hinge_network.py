"""The virtual hinge (cablefem.hinge) at the clamped anchors of networks and polylines: a
one-cable network equals the single cable, the fan runs with it on any partition, and a
clamped anchor on a junction is refused naming the key.

Runs serially and on 2 MPI ranks (every model is built on COMM_WORLD)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from dyn_util import resume_round_trip
from mpi4py import MPI
from test_network import write_mesh  # noqa: E402  (tests/ is on the path)

from cablefem.cable import CableModel
from cablefem.case import CaseError, load_case, parse_case
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


def _fan(correction: str):
    case = load_case(DEMOS / "fan.toml")
    return dataclasses.replace(case, solver=dataclasses.replace(
        case.solver, outer_correction=correction))


def _fan_run(comm, correction: str):
    from cablefem.dynamics import integrate

    m = NetworkModel(comm, _fan(correction))
    M, w, _ = _state(m, 4)
    m.u.x.array[:] = m.u_static.x.array
    hist = np.array([f.copy() for _, f in integrate(m, 0.1, 0.005, 0.9, 10)])
    return M, w, hist, m


def test_fan_with_hinges_is_partition_independent_and_first_order():
    """demos/fan.toml (12 clamped stay ends, the pylon moving): statics, modes and 20 steps
    of dynamics with the hinges on this communicator equal those on one rank (the
    partition only reorders sums: Newton's 1e-10 of the force scale, 1e-9 after 20 steps).
    The hinges raise the first frequencies by about 2 h / l of the longest stays (h ~ ell
    = sqrt(EI/T) = 0.09 m, l ~ 80 m: 2.2e-3 measured; bounds 1e-3 and 4e-3), and move the
    static anchor moments by less than ell / l ~ 1e-3 (taut stays: the anchor force is set
    by the weight and the stretch, which the hinge changes only at O(ell T / EA); measured
    1.5e-5)."""
    M, w, hist, m = _fan_run(MPI.COMM_WORLD, "hinge")
    assert len(m.hinges.items) == 12
    assert all(n == 1 for n in m.hinges.regions().values())
    M1, w1, hist1, _ = _fan_run(MPI.COMM_SELF, "hinge")
    np.testing.assert_allclose(M, M1, rtol=1e-9)
    np.testing.assert_allclose(w, w1, rtol=1e-9)
    np.testing.assert_allclose(hist, hist1, rtol=0, atol=1e-9 * np.abs(hist1).max())
    M0, w0, _, _ = _fan_run(MPI.COMM_WORLD, "none")
    assert np.all((1e-3 < w / w0 - 1) & (w / w0 - 1 < 4e-3))
    assert np.all(np.abs(M / M0 - 1) < 1e-3)
    assert np.all(np.isfinite(hist))


def test_network_hinges_resume_from_a_checkpoint_exactly(mpi_tmp_path):
    """The fan resumed from its checkpoint at step 10 of 20 gives the uninterrupted anchor
    forces (the layers' laws are set again from the static state): round-off of the 2.5e6 N
    forces."""
    full, resumed, ck = resume_round_trip(
        lambda: NetworkModel(MPI.COMM_WORLD, _fan("hinge")), mpi_tmp_path, 0.1, 0.005, 20)
    np.testing.assert_allclose(resumed, full, rtol=0, atol=1e-12 * np.abs(full).max())


def test_network_hinge_refusals_name_the_key(mpi_tmp_path):
    """A clamped anchor whose chain to a junction is too short for the layer (0.01 m to
    the junction, sigma_h ~ ell = sqrt(EI/T) ~ 0.01 m > 0.25 x 0.01 m) is refused as an
    input error naming solver.outer_correction; without the hinge it is accepted. A clamped
    junction (below) is split into its sides, each an anchor with its own hinge."""
    # a T: arms from the junction J (node 1) to anchors at nodes 0 (0.01 m away), 2 and 3
    pts = [[-0.01, 0, 0], [0, 0, 0], [10, 0, 0], [0, 0, -10]]

    def case(anchors, corr, directions=None):
        mesh = write_mesh(str(mpi_tmp_path / "t.msh"), pts, [[0, 1], [1, 2], [1, 3]],
                          ["c"] * 3, anchors)
        d = {"title": "t", "network": {"mesh": mesh},
             "sections": [{"name": "s", "EA": EA, "EI": EI, "mass": MASS}],
             "cables": [{"group": "c", "section": "s", "pretension": T0}],
             "gravity": {"g": 0.0},
             "anchors": [{"name": n, "type": "clamped", **({"direction": directions[n]}
                                                           if directions and n in directions
                                                           else {})} for n in anchors],
             "solver": {"outer_correction": corr}}
        return parse_case(d)

    too_short = ({"p": [0], "q": [2], "r": [3]}, None)
    for groups, dirs in (too_short,):
        m = NetworkModel(comm, case(groups, "none", dirs))
        solve_static(m)
        with pytest.raises(CaseError) as err:
            solve_static(NetworkModel(comm, case(groups, "hinge", dirs)))
        assert "solver.outer_correction" in str(err.value), str(err.value)
    # the junction itself clamped: a direction (one cable's tangent through a clamp) is
    # refused for three elements, naming the key; without one each element is clamped
    # along its mesh direction, a side of its own (cablefem.kinks), with no hinge
    on_junction = {"p": [1], "q": [2], "r": [3]}
    with pytest.raises(CaseError) as err:
        NetworkModel(comm, case(on_junction, "hinge", {"p": [1, 0, 0]}))
    assert "anchors[p].direction" in str(err.value), str(err.value)
    m = NetworkModel(comm, case(on_junction, "none"))
    solve_static(m)
    assert [(a.name, a.kind, a.clamp) for a in m.anchors] == [
        ("p:0@0/c", "clamped", "p:0"), ("p:0@2/c", "clamped", "p:0"),
        ("p:0@3/c", "clamped", "p:0"), ("q:0", "clamped", None), ("r:0", "clamped", None)]
    # with the hinges every side has one (cablefem.network.split_clamps): the side on the
    # 0.01 m arm to a free end is too short for its layer and is refused, naming the key
    with pytest.raises(CaseError) as err:
        solve_static(NetworkModel(comm, case(on_junction, "hinge")))
    assert "solver.outer_correction" in str(err.value) and "p:0@0/c" in str(err.value)


@pytest.mark.parametrize("direction", ["chord", "segment"])
def test_polyline_cable_end_anchors_take_hinges(direction):
    """A 3D polyline cable (three segments out of plane, 11.33 m stress-free, 11.5 m between
    the anchors: taut, tension 1.5e4 N) clamped at its ends, along the chord or along the end
    segments of the stress-free polyline: both ends get a hinge, the anchor node sits at the
    anchor + h c (round-off), the build on this communicator equals the one-rank build
    (Newton's 1e-10 of the force scale), and the first frequency rises by about 2 h / L
    (the span turns about the hinges; h ~ ell = sqrt(EI/T) ~ 8e-3 m, L = 11.5 m: 1.4e-3;
    between 1e-3 and 4e-3)."""
    from cablefem import Anchor, Section, create_cable

    poly = np.array([[0, 0, 0], [3, 1, 0.5], [7, -1, 0.3], [10.5, 0, 0]], float)
    B = np.array([11.5, 0, 0])
    dirs = {"chord": (None, None),
            "segment": (poly[1] - poly[0], (poly[2] - poly[3]))}[direction]
    anchors = [Anchor("p", poly[0], "clamped", dirs[0]), Anchor("q", B, "clamped", dirs[1])]
    sec = Section(EA, EI, 0.02, MASS)

    def build(comm, corr):
        return create_cable(comm, anchors, sec, polyline=poly, elements=60,
                            outer_correction=corr)

    m = build(comm, "hinge")
    res = solve_static(m)
    assert len(m.hinges.items) == 2
    for name, hg in m.hinges.report().items():
        assert hg["elements"] >= 1 and hg["h"] > 0
        anc = next(a for a in m.anchors if a.name == name)
        if anc.owned:
            assert np.allclose(m.u_bc.x.array[anc.flat_dofs].reshape(-1, 3),
                               anc.displacement(0.0) + hg["offset"], atol=1e-14)
    res1 = solve_static(build(MPI.COMM_SELF, "hinge"))
    F1 = np.asarray(res1.anchor_forces)
    np.testing.assert_allclose(res.anchor_forces, F1, rtol=0, atol=1e-9 * np.abs(F1).max())
    w = solve_modes(m, 1).omegas[0]
    m0 = build(comm, "none")
    solve_static(m0)
    w0 = solve_modes(m0, 1).omegas[0]
    assert 1e-3 < w / w0 - 1 < 4e-3
