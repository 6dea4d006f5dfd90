"""Supports a network's cable passes through: a clamp along the cable is split into one
clamped anchor per side (cablefem.network.split_clamps), a pin is a kink (cablefem.kinks)
(runs serially and under mpirun -n 2).

The oracle: a node held in place splits the string into spans that do not see each other
(their only coupling is the node's position, which is prescribed), so each side of a clamp
at that node is the end clamp of its span computed on its own, and a symmetric pair of
spans turns the pin's kink into the two end clamps' layers."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI
from test_network import write_mesh

from cablefem.app.fatigue import read_kinks
from cablefem.app.run import run_case
from cablefem.case import CaseError, parse_case
from cablefem.io import anchorcsv
from cablefem.network import NetworkModel

comm = MPI.COMM_WORLD
SECTION = {"name": "s", "EA": 1.0e8, "EI": 1.0e4, "mass": 10.0}
T0 = 1.0e5  # N: the mesh's pretension
DYN = {"t_end": 0.3, "dt": 0.01}  # a few steps of a harmonic vertical load
LOAD = [{"value": [0.0, 0.0, 30.0], "time": {"type": "harmonic", "omega": 6.0}}]


def spans(path, corners, n, vertex_groups):
    """A polyline through ``corners`` with ``n`` elements per segment, one cable group
    "c"; ``vertex_groups`` names corner indices."""
    pts = [np.asarray(corners[0], float)]
    for a, b in zip(corners[:-1], corners[1:]):
        for t in np.linspace(0, 1, n + 1)[1:]:
            pts.append((1 - t) * np.asarray(a, float) + t * np.asarray(b, float))
    cells = np.column_stack([np.arange(len(pts) - 1), np.arange(1, len(pts))])
    groups = {g: [n * i for i in idx] for g, idx in vertex_groups.items()}
    return write_mesh(path, np.array(pts), cells, ["c"] * len(cells), groups)


def run(path, mesh, anchors, out, correction="none", section=SECTION, dynamics=DYN):
    d = {"title": "supports", "network": {"mesh": str(mesh)}, "sections": [section],
         "cables": [{"group": "c", "section": "s", "pretension": T0}],
         "gravity": {"g": 9.81}, "anchors": anchors, "loads": LOAD, "dynamics": dynamics,
         "solver": {"outer_correction": correction}}
    res = run_case(parse_case(d), path / out, comm, figures=False, progress=False, modes=0)
    return res.summary, path / out


def moments(outdir, name):
    """The moment history of an anchor (anchors.csv) or a kink (kinks.csv), every rank."""
    data = None
    if comm.rank == 0:
        kinks = read_kinks(outdir / "kinks.csv") if (outdir / "kinks.csv").exists() else {}
        if name in kinks:
            data = kinks[name]["time"], kinks[name]["moment"]
        else:
            d = anchorcsv.read(outdir / "anchors.csv", ["time", "moment"])[name]
            data = d["time"], d["moment"]
    return comm.bcast(data, root=0)


CORNERS = [[0.0, 0.0, 0.0], [100.0, 0.0, -2.0], [160.0, 0.0, 1.8]]


@pytest.mark.parametrize("correction,direction", [("none", None),
                                                  ("none", [1.0, 0.0, -0.05]),
                                                  ("hinge", None),
                                                  ("hinge", [1.0, 0.0, -0.05])])
def test_clamp_along_the_cable_is_two_end_clamps(mpi_tmp_path, correction, direction):
    """A cable of two unequal inclined spans (100 m and 60 m, a 0.06 rad corner at the
    middle node) clamped at its ends and at the corner, under its weight and a harmonic
    vertical load: each side of the middle clamp is a clamped anchor of its own and equals
    the end clamp of its span run on its own, statically and at every output time, on the
    leading-order route and with the virtual hinges (the side's hinge and the span's take
    the same region, half the way to the far anchor). Tolerance: Newton's (1e-8 relative)
    at leading order; with the hinges the statics fixed point's (its tolerance is tied to
    Newton's; 1e-7 relative allowed). The clamp's directions: each element's mesh direction
    (default), or one tangent given (then +d into the span it points into and -d into the
    other: the moments then differ from the default's, and the oracle spans are clamped
    along +-d too). Before, the sides were kinks at leading order on both routes: with the
    hinges, their static moments were -0.38 % and -0.60 % from the spans' hinged ones. The
    error estimate is the span's too: a network anchor's layer is measured against its own
    chain of elements (before: the whole network's length, 0.35 % instead of 0.57 %)."""
    mesh = spans(str(mpi_tmp_path / "two.msh"), CORNERS, 20, {"ends": [0, 2], "mid": [1]})
    mid = {"name": "mid", **({"direction": direction} if direction else {})}
    summary, out = run(mpi_tmp_path, mesh, [{"name": "ends"}, mid], "two", correction)
    sides = sorted(n for n in summary["anchors"] if n.startswith("mid"))
    assert sides == ["mid:0+/c", "mid:0-/c"]
    rtol = 1e-8 if correction == "none" else 1e-7
    # the spans alone, each clamped at the corner along the side's clamp direction
    d = None if direction is None else np.asarray(direction) / np.linalg.norm(direction)
    for side, (a, b) in (("mid:0-/c", (1, 0)), ("mid:0+/c", (1, 2))):
        one = spans(str(mpi_tmp_path / f"span{b}.msh"), [CORNERS[a], CORNERS[b]], 20,
                    {"corner": [0], "far": [1]})
        corner = {"name": "corner"}
        if d is not None:
            corner["direction"] = (d if side.endswith("+/c") else -d).tolist()
        ref, ref_out = run(mpi_tmp_path, one, [corner, {"name": "far"}], f"span{b}",
                           correction)
        got = summary["anchors"][side]
        assert got["kind"] == "clamped" and got["clamp"] == "mid:0"
        mesh_dir = np.subtract(CORNERS[b], CORNERS[a]) / np.linalg.norm(
            np.subtract(CORNERS[b], CORNERS[a]))
        want_dir = mesh_dir if d is None else (d if side.endswith("+/c") else -d)
        assert got["direction"] == pytest.approx(want_dir, abs=1e-15)
        want = ref["anchors"]["corner:0"]
        for key in ("static_moment", "static_delta", "static_tension",
                    "static_error_estimate"):
            assert got[key] == pytest.approx(want[key], rel=rtol), key
        if correction == "hinge":
            hg, hg_ref = (s["static"]["virtual_hinges"] for s in (summary, ref))
            np.testing.assert_allclose(hg[side]["offset"], hg_ref["corner:0"]["offset"],
                                       rtol=rtol, atol=1e-12)
        t_got, m_got = moments(out, side)
        t_ref, m_ref = moments(ref_out, "corner:0")
        np.testing.assert_allclose(t_got, t_ref, rtol=0, atol=1e-12)
        np.testing.assert_allclose(m_got, m_ref, rtol=rtol)
    if direction is None and comm.rank == 0:
        check_side_segments(out, summary)


def check_side_segments(out, summary):
    """moments.xdmf at t = 0: a segment per clamped anchor, the clamp's two sides included,
    each from its node (s >= 0): at a side's start the moment is the side's layer moment
    (the field's explicit profile against the exact one: (T/EA) sin^2/2 ~ 1e-6; 1e-4
    allowed) and the curvature integrated along it is the side's angle (the trapezoids on
    the graded stations: 1 %, as for the kinks)."""
    import meshio

    with meshio.xdmf.TimeSeriesReader(out / "moments.xdmf") as reader:
        pts, cells = reader.read_points_cells()
        t, f, _ = reader.read_data(0)
    s = f["s"].ravel()
    lines = cells[0].data
    starts = np.concatenate([[0], np.nonzero(lines[1:, 0] != lines[:-1, 1])[0] + 1])
    bounds = [(lines[a, 0], lines[b - 1, 1] + 1)
              for a, b in zip(starts, list(starts[1:]) + [len(lines)])]
    assert len(bounds) == 4 and min(s) == 0.0
    at_corner = [(a, b) for a, b in bounds if np.allclose(pts[a], CORNERS[1], atol=1e-9)]
    assert len(at_corner) == 2
    layers = sorted(summary["anchors"][n]["static_moment_layer"] for n in summary["anchors"]
                    if n.startswith("mid"))
    got = sorted(np.linalg.norm(f["moment"][a]) for a, _ in at_corner)
    np.testing.assert_allclose(got, layers, rtol=1e-4)
    turns = sorted(np.linalg.norm(np.trapz(f["curvature"][a:b], s[a:b], axis=0))
                   for a, b in at_corner)
    deltas = sorted(summary["anchors"][n]["static_delta"] for n in summary["anchors"]
                    if n.startswith("mid"))
    np.testing.assert_allclose(turns, deltas, rtol=1e-2)


def test_pinned_support_is_a_kink(mpi_tmp_path):
    """A cable over a pinned support between two equal level spans: the pin is a kink of
    the cable (the reaction its concentrated force) whose angle is twice the end clamps'
    and whose moment equals theirs (by symmetry each side is the mirror image of an end
    clamp with the clamp along the bisector, and the string's curvature is the same), at
    every output time, to Newton's tolerance. Before, the pin had no moment at all."""
    mesh = spans(str(mpi_tmp_path / "pin.msh"), [[0, 0, 0], [100.0, 0, 0], [200.0, 0, 0]],
                 20, {"ends": [0, 2], "mid": [1]})
    summary, out = run(mpi_tmp_path, mesh, [{"name": "ends"},
                                            {"name": "mid", "type": "pinned"}], "pin")
    kink, end = summary["kinks"]["mid:0/c"], summary["anchors"]["ends:0"]
    assert kink["anchor"] == "mid:0"
    assert kink["static_moment"] == pytest.approx(end["static_moment"], rel=1e-8)
    assert kink["static_delta"] == pytest.approx(2 * end["static_delta"], rel=1e-8)
    t_k, m_k = moments(out, "mid:0/c")
    t_a, m_a = moments(out, "ends:0")
    np.testing.assert_allclose(t_k, t_a, rtol=0, atol=1e-12)
    np.testing.assert_allclose(m_k, m_a, rtol=1e-8)
    assert np.ptp(m_a) > 0.05 * np.max(m_a)  # the load moves it


def test_clamped_junction_of_three_cables(mpi_tmp_path):
    """Three cables clamped at one node (a T): each element's side is a clamped anchor,
    clamped along its mesh direction and named by the node it runs to; a direction (one
    cable's tangent through a clamp) is refused there, naming the key. Each arm is one
    element between two fixed nodes, so its tension stays T0 and the force it transmits
    at the hub is T0 e + q h/2 (its share of the nodal equation, h its stress-free
    length): the side's moment is the clamped layer of that force
    (cablefem.moments.anchor_moments, the end clamps' function), to round-off."""
    from cablefem.moments import anchor_moments

    pts = [[-10.0, 0, 0], [0, 0, 0], [10.0, 0, 0], [0, 0, -10.0]]
    mesh = write_mesh(str(mpi_tmp_path / "t.msh"), pts, [[0, 1], [1, 2], [1, 3]],
                      ["c"] * 3, {"hub": [1], "ends": [0, 2, 3]})

    def case(hub):
        return parse_case({"title": "t", "network": {"mesh": mesh}, "sections": [SECTION],
                           "cables": [{"group": "c", "section": "s", "pretension": T0}],
                           "gravity": {"g": 9.81}, "anchors": [hub, {"name": "ends"}],
                           "solver": {"outer_correction": "none"}})

    with pytest.raises(CaseError, match=r"anchors\[hub\]\.direction"):
        NetworkModel(comm, case({"name": "hub", "direction": [1, 0, 0]}))
    summary = run_case(case({"name": "hub"}), mpi_tmp_path / "t", comm, figures=False,
                       progress=False, modes=0).summary
    assert sorted(n for n in summary["anchors"] if n.startswith("hub")) == [
        "hub:0@0/c", "hub:0@2/c", "hub:0@3/c"]
    q = np.array([0.0, 0.0, -SECTION["mass"] * 9.81])
    h = 10.0 / (1 + T0 / SECTION["EA"])
    for name, node in (("hub:0@0/c", 0), ("hub:0@2/c", 2), ("hub:0@3/c", 3)):
        e = (np.asarray(pts[node]) - pts[1]) / 10.0
        got = summary["anchors"][name]
        assert got["clamp"] == "hub:0" and got["direction"] == pytest.approx(e, abs=1e-15)
        want = anchor_moments((T0 * e + 0.5 * h * q)[None], e, SECTION["EI"], SECTION["EA"],
                              SECTION["mass"], np.zeros((1, 3)), q, 10.0)
        assert got["static_moment"] == pytest.approx(want["moment"][0], rel=1e-9, abs=1e-9)
        assert got["static_tension"] == pytest.approx(np.linalg.norm(T0 * e + 0.5 * h * q),
                                                      rel=1e-12)
