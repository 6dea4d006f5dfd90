"""Cable networks: closed forms on small networks, parallel = serial, XDMF read back, and
bad meshes rejected with the key named (runs serially and under mpirun -n 2)."""

from __future__ import annotations

import json

import meshio
import numpy as np
import pytest
from mpi4py import MPI

from cablefem.app.run import run_case
from cablefem.cable import CableModel
from cablefem.case import CaseError, parse_case
from cablefem.dynamics import integrate
from cablefem.modal import solve_modes
from cablefem.network import NetworkModel
from cablefem.statics import solve_static

comm = MPI.COMM_WORLD


def write_mesh(path, points, cells, cell_groups, vertex_groups):
    """A gmsh file with named groups (rank 0 writes, everyone waits)."""
    if comm.rank == 0:
        names1 = sorted(set(cell_groups))
        tag1 = {n: i + 1 for i, n in enumerate(names1)}
        names0 = list(vertex_groups)
        tag0 = {n: 100 + i for i, n in enumerate(names0)}
        verts = [k for n in names0 for k in vertex_groups[n]]
        vtags = [tag0[n] for n in names0 for _ in vertex_groups[n]]
        field = {n: np.array([tag1[n], 1]) for n in names1}
        field.update({n: np.array([tag0[n], 0]) for n in names0})
        tags = [np.array([tag1[g] for g in cell_groups]), np.array(vtags)]
        m = meshio.Mesh(np.asarray(points, float),
                        [("line", np.asarray(cells)), ("vertex", np.array(verts)[:, None])],
                        cell_data={"gmsh:physical": tags, "gmsh:geometrical": tags},
                        field_data=field)
        meshio.write(path, m, file_format="gmsh22", binary=False)
    comm.Barrier()
    return path


def case_dict(mesh, cables, anchors, sections=None, g=0.0, **extra):
    d = {"title": "net", "network": {"mesh": str(mesh)},
         "sections": sections or [{"name": "s", "EA": 1.0e6, "EI": 1.0, "mass": 2.0}],
         "cables": cables, "gravity": {"g": g},
         "anchors": [{"name": a} for a in anchors],
         # the leading order, whose closed forms these tests check (the hinges at a
         # network's clamps: tests/test_hinge_network.py)
         "solver": {"outer_correction": "none"}}
    d.update(extra)
    return d


def test_cables_in_series_closed_form(mpi_tmp_path):
    """Two cable families in series on a straight line (L = 10 m, 12 + 8 elements), EA1 =
    1e6 N and EA2 = 4e6 N, pretensions 1e4 and 3e4 N (so the mesh is not in equilibrium at
    the junction): with no gravity the tension is uniform and equals
    T = (L - l1 - l2) / (l1/EA1 + l2/EA2) with l_i = L_i / (1 + T0_i/EA_i), exactly for
    P1 elements (uniform strain per family); to Newton's tolerance 1e-10."""
    x = np.linspace(0, 10.0, 21)
    pts = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    cells = np.column_stack([np.arange(20), np.arange(1, 21)])
    groups = ["a"] * 12 + ["b"] * 8
    mesh = write_mesh(str(mpi_tmp_path / "series.msh"), pts, cells, groups,
                      {"ends": [0, 20]})
    d = case_dict(mesh, [{"group": "a", "section": "s1", "pretension": 1e4},
                         {"group": "b", "section": "s2", "pretension": 3e4}], ["ends"],
                  sections=[{"name": "s1", "EA": 1e6, "EI": 1.0, "mass": 2.0},
                            {"name": "s2", "EA": 4e6, "EI": 1.0, "mass": 2.0}])
    model = NetworkModel(comm, parse_case(d))
    st = solve_static(model)
    l1, l2 = 6.0 / (1 + 1e4 / 1e6), 4.0 / (1 + 3e4 / 4e6)
    T = (10.0 - l1 - l2) / (l1 / 1e6 + l2 / 4e6)
    assert st.max_tension == pytest.approx(T, rel=1e-10)
    assert st.min_tension == pytest.approx(T, rel=1e-10)
    np.testing.assert_allclose(st.anchor_forces[0], [T, 0, 0], rtol=1e-10)
    assert st.anchor_forces[1] == pytest.approx([-T, 0, 0], rel=1e-10)


def fan_mesh(path, k=10):
    """Three straight stays from a pylon head (x = 0) to the deck, different lengths."""
    pts, cells, groups, top, bottom = [], [], [], [], []
    for i, (xd, zt) in enumerate([(15.0, 60.0), (30.0, 58.5), (45.0, 57.0)]):
        start = len(pts)
        for t in np.linspace(0, 1, k + 1):
            pts.append([0.5 + t * (xd - 0.5), 0.0, zt * (1 - t)])
        cells += [[start + j, start + j + 1] for j in range(k)]
        groups += [f"stay{i}"] * k
        top.append(start)
        bottom.append(start + k)
    return write_mesh(path, pts, cells, groups, {"pylon": top, "deck": bottom})


def fan_case(mesh, **extra):
    return case_dict(mesh, [{"group": f"stay{i}", "section": "s", "pretension": 2e6}
                            for i in range(3)], ["pylon", "deck"],
                     sections=[{"name": "s", "EA": 9e8, "EI": 2e4, "mass": 37.0}], **extra)


def test_weightless_fan_frequencies(mpi_tmp_path):
    """Without gravity each stay is a taut string between fixed anchors with T = T0 exactly
    (its mesh is its equilibrium): the lowest frequencies are the stays' first transverse
    modes pi sqrt(T/m_c)/L (m_c = m/lambda per current length), each twice (two planes),
    up to the consistent-mass error (pi/k)^2/24 = 4.1e-3 for k = 10 elements."""
    mesh = fan_mesh(str(mpi_tmp_path / "fan.msh"))
    model = NetworkModel(comm, parse_case(fan_case(mesh)))
    solve_static(model)
    om = solve_modes(model, 6).omegas
    lam = 1 + 2e6 / 9e8
    expected = []
    for xd, zt in [(15.0, 60.0), (30.0, 58.5), (45.0, 57.0)]:
        L = np.hypot(xd - 0.5, zt)
        expected += [np.pi * np.sqrt(2e6 / (37.0 / lam)) / L] * 2
    expected = np.sort(expected)
    np.testing.assert_allclose(om, expected * (1 + (np.pi / 10) ** 2 / 24), rtol=3e-4)


def test_network_parallel_equals_serial_and_xdmf(mpi_tmp_path):
    """A fan with gravity and an elliptic pylon motion: anchor forces and moments of the
    partitioned run equal the serial ones to 1e-9 relative (same equations, direct solvers,
    Newton tolerance); string.xdmf holds the nodes and the field steps written."""
    mesh = fan_mesh(str(mpi_tmp_path / "fan.msh"))
    d = fan_case(mesh, g=9.81, dynamics={"t_end": 0.2, "dt": 0.005, "fields_every": 10})
    d["anchors"][0]["motion"] = {"type": "ellipse", "omega": 6.0,
                                 "axis_sin": [0.02, 0, 0], "axis_cos": [0, 0.01, 0],
                                 "ramp": 0.0}  # moving from t = 0 (0.2 s run)
    case = parse_case(d)
    hist = []
    for c in (comm, MPI.COMM_SELF):
        model = NetworkModel(c, case)
        st = solve_static(model)
        hist.append([st.anchor_forces] + [f.copy() for _, f in integrate(model, 0.2, 0.005,
                                                                            0.9, 10)])
    np.testing.assert_allclose(np.array(hist[0]), np.array(hist[1]), rtol=0,
                               atol=1e-9 * 2e6)
    out = mpi_tmp_path / "fanrun"
    res = run_case(case, out, comm, figures=False, progress=False)
    assert res.summary["status"] == "completed"
    assert len(res.forces) == 6 and all(n.split(":")[0] in ("pylon", "deck")
                                        for n in res.forces)
    if comm.rank == 0:
        from cablefem.geometry import read_network_mesh

        net = read_network_mesh(mesh)
        with meshio.xdmf.TimeSeriesReader(out / "string.xdmf") as reader:
            points, cells = reader.read_points_cells()
            assert reader.num_steps == 1 + 40 // 10  # t = 0 and every 10 steps of 40
            t0, first, cell_data = reader.read_data(0)
            assert first["displacement"].shape == (33, 3)  # 3 stays x 11 nodes
            assert cell_data["tension"][0].shape == (30,)  # 3 stays x 10 cells
            # gathered in the mesh's input order: nodes and cells of the partitioned run
            # at the reference geometry (the network's own points, in file order)
            np.testing.assert_array_equal(points, net.points)
            np.testing.assert_array_equal(cells[0].data, net.cells)
            _, last, _ = reader.read_data(reader.num_steps - 1)
            # the fixed deck anchors' nodes do not move, the moving pylon's do
            assert np.all(last["displacement"][net.vertex_groups["deck"]] == 0.0)
            assert np.all(np.abs(last["displacement"][net.vertex_groups["pylon"]]).max(
                axis=1) > 1e-4)
        s = json.loads((out / "summary.json").read_text())
        assert s["anchors"]["pylon:0"]["section"] == "s"
        assert np.isfinite(s["anchors"]["pylon:0"]["static_moment"])


@pytest.mark.parametrize("defect,key", [
    ("duplicate", "duplicate node"), ("zero", "zero-length"), ("floating", "held by no anchor"),
    ("offcable", "on no cable"), ("nogroup", "has no [[cables]]")])
def test_bad_meshes_rejected(mpi_tmp_path, defect, key):
    """Bad meshes end in a CaseError naming network.mesh (or the table) and the defect."""
    pts = [[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]
    cells = [[0, 1], [1, 2], [2, 3]]
    groups = ["a", "a", "a"]
    vg = {"ends": [0, 3]}
    if defect == "duplicate":
        pts.append([1, 0, 0])
        cells[1] = [4, 2]
    elif defect == "zero":
        pts[2] = [1, 0, 0]
    elif defect == "floating":
        pts += [[0, 1, 0], [1, 1, 0]]
        cells.append([4, 5])
        groups.append("a")
    elif defect == "offcable":
        pts.append([5, 5, 5])
        vg["stray"] = [4]
    elif defect == "nogroup":
        groups[2] = "b"
    mesh = write_mesh(str(mpi_tmp_path / f"{defect}.msh"), pts, cells, groups, vg)
    d = case_dict(mesh, [{"group": "a", "section": "s", "pretension": 1e3}], ["ends"])
    with pytest.raises(CaseError) as err:
        NetworkModel(comm, parse_case(d))
    assert key in str(err.value)


def test_point_load_on_vertex_group(mpi_tmp_path):
    """A weightless cable (L = 10 m, 10 elements, EA = 1e6 N, pretension 1e4 N) with a point
    load P = 2e3 N down at its middle vertex (a 0D group): both halves stay straight, so the
    P1 solution is exact: with half-chord s = sqrt((L/2)^2 + d^2), T = EA (s / (c L/2) - 1)
    and 2 T d / s = P (c = 1/(1 + T0/EA)); d from a scalar root, to Newton's tolerance."""
    from scipy.optimize import brentq

    x = np.linspace(0, 10.0, 11)
    pts = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    cells = np.column_stack([np.arange(10), np.arange(1, 11)])
    mesh = write_mesh(str(mpi_tmp_path / "load.msh"), pts, cells, ["a"] * 10,
                      {"ends": [0, 10], "mid": [5]})
    d = case_dict(mesh, [{"group": "a", "section": "s", "pretension": 1e4}], ["ends"],
                  point_loads=[{"group": "mid", "value": [0, 0, -2e3]}])
    model = NetworkModel(comm, parse_case(d))
    st = solve_static(model)
    c, P, EA = 1 / (1 + 1e4 / 1e6), 2e3, 1e6

    def residual(dd):
        s = np.hypot(5.0, dd)
        return 2 * EA * (s / (c * 5.0) - 1) * dd / s - P

    dd = brentq(residual, 1e-9, 5.0, xtol=1e-15)
    s = np.hypot(5.0, dd)
    T = EA * (s / (c * 5.0) - 1)
    np.testing.assert_allclose(st.anchor_forces[0], [T * 5.0 / s, 0, -T * dd / s], rtol=1e-9)
    u = model.gather_nodal(model.u)
    if comm.rank == 0:
        assert u[5, 2] == pytest.approx(-dd, rel=1e-9)


def cross_mesh(path, n: int = 10):
    """Two cables of 10 m crossing at their middles (groups "a" along x, "b" along y, 2n
    elements each, sharing the middle node: a junction of four elements), anchored at the
    four ends ("ends"); the junction is the 0D group "hub"."""
    x = np.linspace(0, 10.0, 2 * n + 1)
    pa = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    pb = np.delete(np.column_stack([np.full_like(x, 5.0), x - 5.0, np.zeros_like(x)]), n,
                   axis=0)
    ia = np.arange(2 * n + 1)
    ib = np.concatenate([2 * n + 1 + np.arange(n), [n], 3 * n + 1 + np.arange(n)])
    cells = np.vstack([np.column_stack([ia[:-1], ia[1:]]),
                       np.column_stack([ib[:-1], ib[1:]])])
    return write_mesh(path, np.vstack([pa, pb]), cells, ["a"] * (2 * n) + ["b"] * (2 * n),
                      {"ends": [0, 2 * n, int(ib[0]), int(ib[-1])], "hub": [n]})


def cross_case(mesh, mass: float = 1.0, **extra) -> dict:
    return case_dict(mesh, [{"group": "a", "section": "s", "pretension": 1e4},
                            {"group": "b", "section": "s", "pretension": 1e4}], ["ends"],
                     sections=[{"name": "s", "EA": 1e6, "EI": 1.0, "mass": mass}], **extra)


def test_point_load_at_a_junction(mpi_tmp_path):
    """A point load P = 4 kN down on the junction of two crossing cables (four elements
    meet there: no interior facet of two cells, which the point terms were integrated on,
    so the load was silently left out): by symmetry each anchor is pulled down by P/4,
    and the junction sinks as a single cable of the same length under P/2 at its middle
    (the closed form of test_point_load_on_vertex_group), to Newton's tolerance."""
    from scipy.optimize import brentq

    mesh = cross_mesh(str(mpi_tmp_path / "cross.msh"))
    model = NetworkModel(comm, parse_case(cross_case(
        mesh, point_loads=[{"group": "hub", "value": [0.0, 0.0, -4e3]}])))
    st = solve_static(model)
    np.testing.assert_allclose(st.anchor_forces[:, 2], [-1e3] * 4, rtol=1e-9)  # pulled down
    c, P, EA = 1 / (1 + 1e4 / 1e6), 2e3, 1e6
    dd = brentq(lambda dd: 2 * EA * (np.hypot(5.0, dd) / (c * 5.0) - 1) * dd
                / np.hypot(5.0, dd) - P, 1e-9, 5.0, xtol=1e-15)
    u = model.gather_nodal(model.u)
    if comm.rank == 0:
        assert u[10, 2] == pytest.approx(-dd, rel=1e-9)


def test_point_mass_at_a_junction(mpi_tmp_path):
    """A point mass M = 10 kg on the junction of two crossing taut cables of nearly no mass
    (1e-3 kg/m): the vertical mode is the mass on four taut halves, ω = sqrt(8 T/(L M)),
    T = 1e4 N, L = 10 m (28.28 rad/s); the cables' 0.02 kg lower it by about
    (m L/3)/(2 M) = 3e-4 relative; 1e-3 allowed. The mass was left out at such a node (the
    mode was then the cables' own, 3000 rad/s)."""
    mesh = cross_mesh(str(mpi_tmp_path / "cross.msh"))
    model = NetworkModel(comm, parse_case(cross_case(
        mesh, mass=1e-3, point_masses=[{"group": "hub", "mass": 10.0}])))
    solve_static(model)
    om = solve_modes(model, 1).omegas
    assert om[0] == pytest.approx(np.sqrt(8 * 1e4 / (10.0 * 10.0)), rel=1e-3)


def test_point_mass_at_a_free_end(mpi_tmp_path):
    """A 10 m cable of nearly no mass (1e-3 kg/m) hanging from one anchor with M = 10 kg at
    its free end (a node of one element, which no interior facet reaches either): the
    anchor carries (M + m L) g, and the first mode is the pendulum, w = sqrt(g/L) with L the
    hanging length (the mesh is stress-free at the pretension M g, so L = 10 m to the
    cable's own weight, 5e-6 relative); the cable's 0.01 kg shifts it by about (m L/3)/M =
    3e-4 relative: 1e-3 allowed."""
    n, g, M, m = 10, 9.81, 10.0, 1e-3
    z = np.linspace(0.0, -10.0, n + 1)
    pts = np.column_stack([np.zeros_like(z), np.zeros_like(z), z])
    cells = np.column_stack([np.arange(n), np.arange(1, n + 1)])
    mesh = write_mesh(str(mpi_tmp_path / "hang.msh"), pts, cells, ["c"] * n,
                      {"top": [0], "tip": [n]})
    d = case_dict(mesh, [{"group": "c", "section": "s", "pretension": M * g}], ["top"],
                  sections=[{"name": "s", "EA": 1e6, "EI": 1.0, "mass": m}], g=g,
                  point_masses=[{"group": "tip", "mass": M}])
    model = NetworkModel(comm, parse_case(d))
    st = solve_static(model)
    np.testing.assert_allclose(st.anchor_forces[0], [0.0, 0.0, -(M + m * 10.0) * g],
                               rtol=1e-6, atol=1e-9)  # Newton's tolerance
    om = solve_modes(model, 1).omegas
    assert om[0] == pytest.approx(np.sqrt(g / 10.0), rel=1e-3)


def test_a_slack_network_from_a_rough_mesh(mpi_tmp_path):
    """A chain of 12 m hanging between anchors 10 m apart, meshed as a stress-free U (1 m
    down, 10 m across, 1 m up; 24 elements of 0.5 m, pretension 0): the unloaded mesh has
    no stiffness to start the load continuation from (it stalled at load factor 0 before);
    statics relaxes to the equilibrium instead, which is the single cable's of the same
    elements (from its catenary) to Newton's tolerance (1e-8 of the anchor force)."""
    pts = ([[0.0, 0.0, -0.5 * i] for i in range(3)] + [[0.5 * i, 0.0, -1.0]
                                                        for i in range(1, 20)]
           + [[10.0, 0.0, -1.0 + 0.5 * i] for i in range(3)])
    cells = np.column_stack([np.arange(24), np.arange(1, 25)])
    mesh = write_mesh(str(mpi_tmp_path / "u.msh"), pts, cells, ["c"] * 24,
                      {"ends": [0, 24]})
    sec = {"name": "s", "EA": 1.0e7, "EI": 1.0, "mass": 5.0}
    net = NetworkModel(comm, parse_case(case_dict(
        mesh, [{"group": "c", "section": "s", "pretension": 0.0}], ["ends"],
        sections=[sec], g=9.81)))
    single = CableModel(comm, parse_case({
        "title": "chain", "section": {k: v for k, v in sec.items() if k != "name"},
        "gravity": {"g": 9.81}, "geometry": {"length": 12.0}, "mesh": {"elements": 24},
        "anchors": [{"name": "p", "position": [0.0, 0, 0]},
                    {"name": "q", "position": [10.0, 0, 0]}],
        "solver": {"outer_correction": "none"}}))
    F = [solve_static(m).anchor_forces[:, :3] for m in (single, net)]
    np.testing.assert_allclose(F[1], F[0], rtol=0, atol=1e-8 * np.abs(F[0]).max())


def test_junctions_are_the_nodes_of_three_cells_or_of_two_groups():
    """``NetworkMesh.junctions`` against its definition, node by node: a node where three
    or more cells meet, or where cells of two different groups meet (in line too); not
    a free end, a node inside one group's chain, or a node of no cell."""
    from cablefem.geometry import NetworkMesh

    rng = np.random.default_rng(3)
    n = 60
    cells = np.array([(i, i + 1) for i in range(n - 2)]  # a chain through 0..n-2
                     + [(int(a), int(b)) for a, b in rng.integers(12, n - 1, (25, 2)) if a != b])
    groups = rng.integers(0, 3, len(cells))
    groups[:10] = 1  # a stretch of one group, then groups that change in line
    net = NetworkMesh(np.zeros((n, 3)), cells, groups, ["a", "b", "c"], {})
    expected = [k for k in range(n)
                if np.count_nonzero(cells == k) >= 3
                or len({int(g) for g, c in zip(groups, cells) if k in c}) >= 2]
    # an end, nodes inside one group's chain, a node of no cell
    assert not {0, 5, n - 1} & set(expected) and len(expected) > 10
    assert net.junctions.tolist() == expected
    assert net.junctions.dtype == np.int64
