"""External dampers (``[[dampers]]``) and the damping ratios of the modal analysis: against
Krenk's asymptotic formula on a taut cable, Rayleigh damping's exact ratios, the dynamics
(a free decay), and bad input (runs serially and under mpirun -n 2)."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from cablefem import Anchor, Damper, Section, create_cable
from cablefem.app.cli import main
from cablefem.cable import CableModel
from cablefem.case import CaseError, parse_case
from cablefem.dynamics import integrate
from cablefem.modal import solve_modes
from cablefem.statics import solve_static

comm = MPI.COMM_WORLD
T, M, L, EA = 1.0e4, 1.0, 10.0, 1.0e8  # N, kg/m, m, N: a taut cable, T/EA = 1e-4
LAM = 1.0 + T / EA  # stretch: stress-free lengths are current ones / LAM


def taut(a_over_l: float, eta1: float, elements: int, **damper) -> dict:
    """A taut weightless cable between pinned anchors with a damper along z at a = a/L L
    from anchor p, its coefficient giving Krenk's eta = eta1 in mode 1."""
    c = eta1 * np.sqrt(T * M) / (np.pi * a_over_l)
    d = {"title": "taut", "section": {"EA": EA, "EI": 1e-6, "mass": M},
         "gravity": {"g": 0.0}, "geometry": {"length": L / LAM},
         "mesh": {"elements": elements},
         "anchors": [{"name": "p", "position": [0.0, 0, 0], "type": "pinned"},
                     {"name": "q", "position": [L, 0, 0], "type": "pinned"}],
         "dampers": [{"anchor": "p", "distance": a_over_l * L / LAM, "coefficient": c,
                      "direction": [0.0, 0, 1], **damper}],
         "solver": {"outer_correction": "none"}}
    return d


def krenk(n: int, a_over_l: float, c: float) -> float:
    eta = n * np.pi * a_over_l * c / np.sqrt(T * M)
    return a_over_l * eta / (1 + eta**2)


def z_modes(case: dict, n: int = 6) -> list[tuple[int, float]]:
    """(mode number n, damping ratio) of the damped modes: the modes come in pairs of equal
    frequency (the two planes; the eigen-solver returns any two combinations of them), one
    damped by the damper along z, the other not (ratio 0 to round-off)."""
    model = CableModel(comm, parse_case(case))
    solve_static(model)
    res = solve_modes(model, n)
    w1 = np.pi * np.sqrt(T / (M / LAM)) / L
    numbers = np.rint(res.omegas / w1).astype(int)
    out = []
    for k in sorted(set(numbers)):
        z = np.sort(res.damping_ratios[numbers == k])
        assert z.size == 2 and abs(z[0]) < 1e-8, (k, z)
        out.append((int(k), float(z[1])))
    return out


@pytest.mark.parametrize("a_over_l,elements", [(0.01, 800), (0.02, 400), (0.05, 400)])
def test_optimal_damper_against_krenk(a_over_l, elements):
    """The damper tuned to mode 1 (eta = 1) gives zeta_1 = a/(2L) and Krenk's
    (a/L) eta/(1 + eta^2) in modes 2 and 3 (eta = 2, 3). Krenk's formula is the first term
    of an expansion in a/L: measured, the relative difference is 1.0-1.2 a/L (1.0 %, 2.1 %
    and 5.8 % at a/L = 0.01, 0.02, 0.05; the meshes put 8-20 elements between anchor and
    damper, their own error is below 1e-3 here): bounded by 1.5 a/L."""
    case = taut(a_over_l, 1.0, elements)
    c = case["dampers"][0]["coefficient"]
    got = z_modes(case)
    assert [n for n, _ in got] == [1, 2, 3]
    for n, z in got:
        err = abs(z / krenk(n, a_over_l, c) - 1)
        assert err < 1.5 * a_over_l, (n, z, krenk(n, a_over_l, c))
    assert got[0][1] == pytest.approx(a_over_l / 2, rel=1.5 * a_over_l)


def test_damper_error_shrinks_with_a_over_l_like_krenks():
    """The difference from Krenk's formula is its own error, of order a/L: halving a/L
    (0.02 -> 0.01, the elements between anchor and damper kept at 8) halves it, within
    1.6-2.4 (the next order, (a/L)^2, moves the ratio by a few percent)."""
    errs = []
    for a_over_l, elements in ((0.02, 400), (0.01, 800)):
        case = taut(a_over_l, 1.0, elements)
        n, z = z_modes(case, 2)[0]
        errs.append(abs(z / krenk(n, a_over_l, case["dampers"][0]["coefficient"]) - 1))
    assert 1.6 < errs[0] / errs[1] < 2.4, errs


@pytest.mark.parametrize("eta1", [0.1, 10.0])
def test_damper_off_optimum_against_krenk(eta1):
    """Far below and far above the optimum (eta = 0.1 and 10 in mode 1) at a/L = 0.02:
    Krenk's ratio within 1.5 a/L = 3 % (as at the optimum)."""
    case = taut(0.02, eta1, 400)
    c = case["dampers"][0]["coefficient"]
    for n, z in z_modes(case):
        assert abs(z / krenk(n, 0.02, c) - 1) < 0.03, (n, z, krenk(n, 0.02, c))


def test_rayleigh_damping_ratios_are_exact():
    """Rayleigh damping alpha M + beta K is proportional: every mode has exactly
    zeta = alpha/(2 omega) + beta omega/2 (the complex modes are the undamped ones), to the
    eigen-solver's tolerance (1e-12; 1e-8 allowed)."""
    d = taut(0.02, 1.0, 60)
    d.pop("dampers")
    d["damping"] = {"alpha": 0.3, "beta": 2e-4}
    model = CableModel(comm, parse_case(d))
    solve_static(model)
    res = solve_modes(model, 6)
    expected = 0.3 / (2 * res.omegas) + 2e-4 * res.omegas / 2
    np.testing.assert_allclose(res.damping_ratios, expected, rtol=1e-8)
    np.testing.assert_allclose(res.damped_omegas, res.omegas, rtol=1e-8)


def test_undamped_modes_have_zero_ratio():
    d = taut(0.02, 1.0, 30)
    d.pop("dampers")
    model = CableModel(comm, parse_case(d))
    solve_static(model)
    res = solve_modes(model, 4)
    assert np.all(res.damping_ratios == 0.0) and res.damped_omegas is None


@pytest.mark.single_rank  # 7250 steps of 100 elements (6 s serial, 42 s on 2 ranks); the
# damper's parallel dynamics: test_network_damper_in_dynamics_by_superposition
def test_free_decay_follows_the_modal_damping_ratio():
    """Dynamics: a cable released from its first z mode (amplitude 1e-3 L, linear range)
    decays as exp(-zeta omega t) with the PEP's zeta: the amplitude ratio over the
    5 periods after the first is exp(-2 pi zeta 5 / sqrt(1 - zeta^2)) to 3 % (the other
    modes the release also excites, and the 2 % that the plane without damper loses over
    the run by the tension's coupling of the planes; generalised-alpha's own damping at
    rho_inf = 1: none, its period error (omega dt)^2/12 = 1e-3). The release is the
    undamped mode (any combination of the two planes): only z is damped."""
    case = taut(0.02, 1.0, 100)
    case["dynamics"] = {"t_end": 1.45, "dt": 2e-4, "rho_inf": 1.0}
    model = CableModel(comm, parse_case(case))
    solve_static(model)
    res = solve_modes(model, 2)
    k = int(np.argmax(res.damping_ratios))
    zeta, w = res.damping_ratios[k], res.omegas[k]
    phi = res.shapes[k]
    model.u.x.array[:] += 1e-3 * L * phi.x.array
    node = model.geometry.node_at(model.length / 2)
    mids = []
    for t, _ in integrate(model, 1.45, 2e-4, 1.0, 1):
        nodal = model.gather_nodal(model.u)
        mids.append((t, None if nodal is None else nodal[node, 2]))
    if comm.rank == 0:
        t = np.array([x for x, _ in mids])
        z = np.array([y for _, y in mids])
        period = 2 * np.pi / w
        peaks = [np.max(np.abs(z[(t >= i * period) & (t < (i + 1) * period)]))
                 for i in range(1, 7)]  # whole periods: 7 periods take 1.40 s
        ratio = peaks[5] / peaks[0]
        expected = np.exp(-2 * np.pi * zeta * 5 / np.sqrt(1 - zeta**2))
        assert ratio == pytest.approx(expected, rel=0.03), (ratio, expected, zeta)
        assert ratio < 0.75  # it does decay (5 periods at zeta = a/2L = 1 %: 0.73)


def test_python_api_and_networks():
    """create_cable takes dampers; a bad damper names its argument."""
    anchors = [Anchor("p", [0.0, 0, 0], "pinned"), Anchor("q", [L, 0, 0], "pinned")]
    sec = Section(EA=EA, EI=1e-6, GJ=0.0, mass=M)
    model = create_cable(comm, anchors, sec, length=L / LAM, elements=40,
                         gravity=None, outer_correction="none",
                         dampers=[Damper("p", 0.2, 100.0)])
    assert "dampers" in model.forms.user
    with pytest.raises(CaseError) as err:
        create_cable(comm, anchors, sec, length=L / LAM, dampers=[Damper("x", -1.0, -2.0)])
    text = str(err.value)
    for key in ("dampers[0].anchor", "dampers[0].distance", "dampers[0].coefficient"):
        assert key in text, text


@pytest.mark.parametrize("damper,key", [
    ({"anchor": "r"}, "dampers[0].anchor"),
    ({"distance": 0.0}, "dampers[0].distance"),
    ({"distance": 20.0}, "dampers[0].distance"),
    ({"coefficient": -1.0}, "dampers[0].coefficient"),
    ({"stiffness": -1.0}, "dampers[0].stiffness"),
    ({"direction": [0.0, 0, 0]}, "dampers[0].direction"),
    ({"bogus": 1}, "dampers[0].bogus")])
def test_bad_damper_is_rejected_with_its_key(damper, key):
    d = taut(0.02, 1.0, 30)
    d["dampers"][0].update(damper)
    with pytest.raises(CaseError) as err:
        parse_case(d)
    assert key in str(err.value), str(err.value)


def _pinned_cable_toml(path, damper: str, mesh: str = "") -> None:
    """Write (rank 0) a weightless pinned 10 m cable's case file with ``damper`` (the
    [[dampers]] table's lines) and an optional [mesh] table; every rank waits for it."""
    if comm.rank == 0:
        path.write_text(f"""
[section]
EA = 1e8
EI = 1e-6
mass = 1.0
[gravity]
g = 0.0
[geometry]
length = 9.999
{mesh}
[[anchors]]
name = "p"
position = [0.0, 0.0, 0.0]
type = "pinned"
[[anchors]]
name = "q"
position = [10.0, 0.0, 0.0]
type = "pinned"
[[dampers]]
{damper}
""")
    comm.Barrier()


def test_bad_damper_exit_2(mpi_tmp_path, capsys):
    """The command line: a damper beyond the cable is an input problem (exit 2), named."""
    case = mpi_tmp_path / "bad.toml"
    _pinned_cable_toml(case, 'anchor = "q"\ndistance = 12.0\ncoefficient = 10.0')
    assert main(["run", str(case), "-o", str(mpi_tmp_path / "out"), "-q"]) == 2
    assert "dampers[0].distance" in capsys.readouterr().err


@pytest.mark.parametrize("defect,key", [
    ("missing", "dampers[0].group"), ("cable", "dampers[0].group"),
    ("dangling", "dampers[0].group"), ("negative", "dampers[0].coefficient"),
    ("stiffness", "dampers[0].stiffness"), ("direction", "dampers[0].direction")])
def test_network_damper_bad_input(mpi_tmp_path, defect, key):
    """A network's [[dampers]] entry is checked with the key named: its group must be a 1D
    group of the mesh and no [[cables]] group, each of its cells must join a cable node to
    another cable node or an anchor (a cell ending at a node of nothing would hold a node
    without mass or stiffness), coefficient and stiffness >= 0, a direction non-zero."""
    from test_network import write_mesh  # noqa: E402

    from cablefem.case import CaseError
    from cablefem.network import NetworkModel

    case = _tie_network(mpi_tmp_path / "tie.msh", True, 10.0, 0.0, n=4, a=2)
    d = {"title": "t", "network": {"mesh": str(case.network.mesh)},
         "sections": [{"name": "s", "EA": EA, "EI": 1e-6, "mass": M}],
         "cables": [{"group": "c", "section": "s", "pretension": T}],
         "anchors": [{"name": "ends", "type": "pinned"}, {"name": "ground", "type": "pinned"}],
         "dampers": [{"group": "tie", "coefficient": 10.0}]}
    if defect == "missing":
        d["dampers"][0]["group"] = "ties"
    elif defect == "cable":
        d["dampers"][0]["group"] = "c"
    elif defect == "negative":
        d["dampers"][0]["coefficient"] = -1.0
    elif defect == "stiffness":
        d["dampers"][0]["stiffness"] = -1.0
    elif defect == "direction":
        d["dampers"][0]["direction"] = [0.0, 0.0, 0.0]
    elif defect == "dangling":  # the tie's far end on no anchor
        x = np.linspace(0.0, L, 5)
        pts = np.vstack([np.column_stack([x, 0 * x, 0 * x]), [[x[2], -1.0, 0.0]]])
        cells = np.array([[0, 1], [1, 2], [2, 3], [3, 4], [2, 5]])
        d["network"]["mesh"] = write_mesh(str(mpi_tmp_path / "dangling.msh"), pts, cells,
                                          ["c"] * 4 + ["tie"], {"ends": [0, 4]})
        d["anchors"] = d["anchors"][:1]
    with pytest.raises(CaseError) as err:
        NetworkModel(comm, parse_case(d))
    assert key in str(err.value)


def _tie_network(path, grounded: bool, c: float, k: float, n: int = 50, a: int = 5,
                 slant: float = 0.0, direction=None, EI: float = 1e-6, **extra):
    """Network dampers: a taut cable along x (nodes (x_i, 0, 0), n elements, pinned ends)
    with a damper cell (group "tie") from its node a along y: to the same node of a second,
    identical cable at y = 1 m, or (``grounded``) to an anchor at y = -1 m (and ``slant``
    m along x); ``direction``: the damper's line of action (default: its cell's); ``EI``:
    the section's."""
    from test_network import case_dict, write_mesh  # noqa: E402  (tests/ is on the path)

    x = np.linspace(0.0, L, n + 1)
    pts = [np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])]
    cells = [np.column_stack([np.arange(n), np.arange(1, n + 1)])]
    ends = [0, n]
    if grounded:
        pts.append([[x[a] + slant, -1.0, 0.0]])
        tie, ground = [a, n + 1], [n + 1]
    else:
        pts.append(pts[0] + [0.0, 1.0, 0.0])
        cells.append(cells[0] + n + 1)
        ends += [n + 1, 2 * n + 1]
        tie, ground = [a, n + 1 + a], []
    groups = ["c"] * (n * len(cells)) + ["tie"]
    vgroups = {"ends": ends, **({"ground": ground} if ground else {})}
    if "point_loads" in extra:  # on the first cable's node 3 n/10
        vgroups["load"] = [3 * n // 10]
    mesh = write_mesh(str(path), np.vstack(pts), np.vstack(cells + [np.array([tie])]), groups,
                      vgroups)
    d = case_dict(mesh, [{"group": "c", "section": "s", "pretension": T}],
                  ["ends"] + (["ground"] if ground else []),
                  sections=[{"name": "s", "EA": EA, "EI": EI, "mass": M}],
                  dampers=[{"group": "tie", "coefficient": c, "stiffness": k,
                            **({"direction": direction} if direction else {})}], **extra)
    for anc in d["anchors"]:
        anc["type"] = "pinned"
    return parse_case(d)


def _by_mode_number(res, w1):
    numbers = np.rint(res.omegas / w1).astype(int)
    return {int(n): (np.sort(res.damping_ratios[numbers == n]),
                     np.sort(res.damped_omegas[numbers == n])) for n in set(numbers)}


@pytest.mark.parametrize("grounded", [False, True])
def test_network_damper_between_two_nodes(mpi_tmp_path, grounded):
    """A network's damper cell between two nodes, along the line between them. Grounded
    (cable node to an anchor, along y) it is the single cable's damper of the same c and k
    along y; between the same node of two identical parallel cables it damps their
    antisymmetric y motion as a grounded damper of 2c and 2k does (the relative velocity is
    twice each cable's) and leaves every other mode undamped. The same discrete problems:
    damping ratios and damped frequencies equal to the eigen-solver's tolerance (1e-7
    relative, 1e-9 absolute for the undamped ones), modes 1 and 2, at Krenk's optimum
    for mode 1 at a/L = 0.1."""
    from cablefem.network import NetworkModel

    n, a = 50, 5
    c_single = np.sqrt(T * M) / (np.pi * a / n)  # eta_1 = 1
    k_single = 2e3  # N/m
    share = 1.0 if grounded else 0.5
    net = NetworkModel(comm, _tie_network(mpi_tmp_path / "tie.msh", grounded,
                                          share * c_single, share * k_single, n, a))
    solve_static(net)
    from cablefem.kinks import network_kinks  # the cables kink where the damper pulls

    assert [k.name for k in network_kinks(net)] == (
        ["tie:0.0/c"] if grounded else ["tie:0.0/c", "tie:0.1/c"])
    copies = 2 if grounded else 4  # each frequency: 2 planes (x 2 cables)
    got = _by_mode_number(solve_modes(net, 2 * copies), np.pi * np.sqrt(T * LAM / M) / L)
    d = taut(a / n, 1.0, n, stiffness=k_single)
    d["dampers"][0].update(coefficient=c_single, direction=[0.0, 1.0, 0.0])
    one = CableModel(comm, parse_case(d))
    solve_static(one)
    ref = _by_mode_number(solve_modes(one, 4), np.pi * np.sqrt(T * LAM / M) / L)
    assert sorted(got) == sorted(ref) == [1, 2]
    for m in (1, 2):
        z, w = got[m]
        assert z.size == copies
        assert z[-1] > 0.01  # damped: Krenk's ~a/(2L) = 5 %
        assert z[-1] == pytest.approx(ref[m][0][-1], rel=1e-7)
        assert w[-1] == pytest.approx(ref[m][1][-1], rel=1e-7)
        np.testing.assert_allclose(z[:-1], 0.0, atol=1e-9)


def test_network_damper_along_a_given_direction(mpi_tmp_path):
    """A grounded damper cell slanted at 45 degrees in x-y (its anchor 1 m along x and 1 m
    along -y from the cable node) with direction = y acts along y only: the single cable's
    damper of the same c and k along y, to the eigen-solver's tolerance (1e-7), modes 1
    and 2 (zeta_1 = 4.63 %). Without the direction it acts along the slanted cell (half of
    c across the cable, and along it): zeta_1 = 3.64 %, more than 10 % off."""
    from cablefem.network import NetworkModel

    n, a = 50, 5
    c, k = np.sqrt(T * M) / (np.pi * a / n), 2e3
    w1 = np.pi * np.sqrt(T * LAM / M) / L

    def ratios(**kw):
        net = NetworkModel(comm, _tie_network(mpi_tmp_path / "slant.msh", True, c, k, n, a,
                                              slant=1.0, **kw))
        solve_static(net)
        return _by_mode_number(solve_modes(net, 4), w1)

    got = ratios(direction=[0.0, 1.0, 0.0])
    d = taut(a / n, 1.0, n, stiffness=k)
    d["dampers"][0].update(coefficient=c, direction=[0.0, 1.0, 0.0])
    one = CableModel(comm, parse_case(d))
    solve_static(one)
    ref = _by_mode_number(solve_modes(one, 4), w1)
    for m in (1, 2):
        assert got[m][0][-1] == pytest.approx(ref[m][0][-1], rel=1e-7)
        assert got[m][1][-1] == pytest.approx(ref[m][1][-1], rel=1e-7)
    along_cell = ratios()
    assert abs(along_cell[1][0][-1] / ref[1][0][-1] - 1) > 0.1


def _y_history(model, t_end, dt, nodes):
    """The y displacements of ``nodes`` at every step from the static state (rank 0)."""
    from cablefem.dynamics import integrate

    solve_static(model)
    out = []
    for _ in integrate(model, t_end, dt, 0.9, 1):
        u = model.gather_nodal(model.u)
        out.append(None if u is None else u[nodes, 1])
    return np.array(out) if comm.rank == 0 else None


def test_network_damper_in_dynamics_by_superposition(mpi_tmp_path):
    """Two parallel cables tied by a damper (c, k) at a/L = 0.1, a harmonic load P(t) along
    y on the first cable only. In the linear range the difference of the two cables' y
    motions is the single cable with a grounded damper of 2c and 2k under P, and their sum
    the undamped single cable under P: both against those runs, node by node and step by
    step (the tie's node and the loaded node, 0.5 s = 2.5 periods of mode 1). The
    remainder is the string's geometric nonlinearity, quadratic in P: measured 1.2 % of
    the peak at P = 20 N, 1.3e-4 at 2 N (used here), 1.3e-6 at 0.2 N; 1e-3 allowed. (Before
    Newton's tolerance stayed above the residual's round-off floor, the network's steps
    stalled and were cut, and this was 0.28 %.)"""
    from cablefem.network import NetworkModel

    n, a, p = 50, 5, 15
    c, k = np.sqrt(T * M) / (np.pi * a / n), 2e3
    time = {"type": "harmonic", "omega": 20.0}
    load = [{"group": "load", "value": [0.0, 2.0, 0.0], "time": time}]
    net = NetworkModel(comm, _tie_network(mpi_tmp_path / "tie.msh", False, c / 2, k / 2, n, a,
                                          point_loads=load))
    t_end, dt = 0.5, 0.002
    w = _y_history(net, t_end, dt, [a, p, n + 1 + a, n + 1 + p])
    refs = []
    for damped in (True, False):
        d = taut(a / n, 1.0, n, stiffness=k)
        d["dampers"][0].update(coefficient=c, direction=[0.0, 1.0, 0.0])
        if not damped:
            d["dampers"] = []
        d["point_loads"] = [{"s": p * L / n / LAM, "value": [0.0, 2.0, 0.0], "time": time}]
        refs.append(_y_history(CableModel(comm, parse_case(d)), t_end, dt, [a, p]))
    if comm.rank == 0:
        diff, total = w[:, :2] - w[:, 2:], w[:, :2] + w[:, 2:]
        for got, ref in ((diff, refs[0]), (total, refs[1])):
            assert np.max(np.abs(ref)) > 1e-4  # the motion is there
            assert np.max(np.abs(got - ref)) < 1e-3 * np.max(np.abs(ref))
        # the damper matters: the damped and undamped references differ by far more
        assert np.max(np.abs(refs[0] - refs[1])) > 0.1 * np.max(np.abs(refs[1]))


@pytest.mark.parametrize("EI, warns", [(1e-6, False), (10.0, True)])
def test_network_damper_at_the_corner_is_flagged(mpi_tmp_path, EI, warns):
    """A network's damper acts at the string's corner, not at the rod's node (l/2 inside
    it, as a single cable's damper does): the run records, per damper kink, the error
    estimate (l/2)(1/d1 + 1/d2), d1 = 1 m and d2 = 9 m the spans to the pinned ends, and
    warns, naming the kink, above 1 %: l = 0.032 m (EI = 10 N m^2) gives 1.8 %; l = 1e-5 m
    (EI = 1e-6) 6e-6, no warning. 1e-3: the spans are stress-free lengths, T/EA = 1e-4."""
    from cablefem.app.run import run_case

    case = _tie_network(mpi_tmp_path / "tie.msh", True, 500.0, 0.0, EI=EI)
    res = run_case(case, mpi_tmp_path / "out", comm, figures=False, progress=False,
                   modes=0)
    entry = res.summary["kinks"]["tie:0.0/c"]
    ell = entry["layer_length"]
    assert ell == pytest.approx(np.sqrt(EI / T), rel=1e-3)
    assert entry["damper_offset_estimate"] == pytest.approx(0.5 * ell * (1 / 1.0 + 1 / 9.0),
                                                            rel=1e-3)
    keys = [w["key"] for w in res.summary.get("warnings", [])]
    assert ("kinks.tie:0.0/c" in keys) == warns, keys


def test_the_mesh_leaves_the_damper_room_for_its_offset():
    """The rod node's offset is applied in full on elements at least 2.5 layer lengths
    long (cablefem.dampers.MESH_RATIO): a single cable's mesh keeps its nodes 1.1 x 2.5 ell
    (ell at the elastic catenary's tension, before statics) away from a damper, with a node
    at each end of that clearance. On the stay of demos/stay_damper.toml, 2000 elements of
    7.5 cm: the two elements next to the damper are at least 2.5 times the static layer
    length (ell = 0.381 m; margin 1.1: the catenary's tension is the static one to 0.1 %
    here) and at most 1.1 times that, the next ones back to the mesh's size (without the
    clearance the 7.5 cm elements would cap the offset to 8 % of its length)."""
    from dataclasses import replace
    from pathlib import Path

    from cablefem.case import load_case
    from cablefem.dampers import MESH_RATIO
    from cablefem.kinks import KinkMoments

    case = load_case(Path(__file__).resolve().parents[1] / "demos" / "stay_damper.toml")
    case = replace(case, mesh=replace(case.mesh, elements=2000))
    model = CableModel(comm, case)
    solve_static(model)
    st = np.asarray(model.geometry.stations)
    k = int(np.argmin(np.abs(st - case.dampers[0].distance)))
    ell = KinkMoments(model).measure()["layer_length"][0]
    near = np.diff(st[k - 1:k + 2])
    assert np.all(near >= MESH_RATIO * ell), (near, ell)
    assert np.all(near <= 1.1 * MESH_RATIO * ell * (1 + 1e-3))
    h = 149.74 / 2000  # about the mesh's size elsewhere (the stress-free length / 2000)
    assert np.all(np.abs(np.diff(st[k + 2:k + 6]) / h - 1) < 0.3)


@pytest.mark.parametrize("direction, warns", [([1.0, 0, 0], True), ([0.1, 0, 1.0], False)])
def test_a_damper_along_the_cable_warns(mpi_tmp_path, direction, warns):
    """A damper whose direction is the taut cable's axis x damps only the axial motion (the
    transverse modes' ratios were ~1e-15, silently): the run warns on its direction. One
    tilted by atan(0.1) from z keeps 1 - (d.t)^2 = 0.99 of its coefficient: no warning."""
    from cablefem.app.run import run_case

    case = parse_case(taut(0.05, 1.0, 40, direction=direction))
    res = run_case(case, mpi_tmp_path / "out", comm, figures=False, progress=False, modes=0)
    keys = [w["key"] for w in res.summary.get("warnings", [])]
    assert ("dampers[0].direction" in keys) == warns, keys


def test_the_warning_line_is_printed_once(mpi_tmp_path, capsys):
    """The command line's closing "1 warning(s)" line was written by every rank (twice on
    2 ranks): rank 0 writes it, as it logs the warnings themselves."""
    case = mpi_tmp_path / "axial.toml"
    _pinned_cable_toml(case, 'anchor = "q"\ndistance = 2.0\ncoefficient = 10.0\n'
                       'direction = [1.0, 0.0, 0.0]', mesh="[mesh]\nelements = 20")
    assert main(["run", str(case), "-o", str(mpi_tmp_path / "out"), "--static-only",
                 "--no-figures"]) == 0
    err = capsys.readouterr().err
    assert err.count("warning(s), listed under 'warnings'") == (1 if comm.rank == 0 else 0)


def test_summary_has_the_damped_modes_lambda(mpi_tmp_path):
    """summary.json's modes carry |lambda| of the damped system (it was only logged):
    with Rayleigh damping the complex modes are the undamped ones, so |lambda| = omega to
    the eigen-solver's tolerance (1e-8 allowed, as above); undamped: absent."""
    from cablefem.app.run import run_case

    d = taut(0.02, 1.0, 30)
    d.pop("dampers")
    d["damping"] = {"alpha": 0.3, "beta": 2e-4}
    res = run_case(parse_case(d), mpi_tmp_path / "a", comm, figures=False, progress=False,
                   modes=4)
    for entry in res.summary["modes"]:
        assert entry["lambda_abs"] == pytest.approx(entry["omega"], rel=1e-8)
    d.pop("damping")
    res = run_case(parse_case(d), mpi_tmp_path / "b", comm, figures=False, progress=False,
                   modes=4)
    assert not any("lambda_abs" in entry for entry in res.summary["modes"])


def test_damper_kink_converges_at_second_order_in_the_time_step():
    """The kink moment at a damper converges at the integrator's order when the time step
    is halved (issue 29 item 9: on demos/stay_damper.toml it had moved +9.0 %, -1.15 %,
    -3.7 % at dt = 10, 5, 2.5 ms). A taut cable (T = 1e4 N, l = 10 m, 40 elements) with
    Krenk's optimal damper at a = l/20 (its node's damping time m h/c = 4e-4 s, below every
    step here), EI giving a layer of 0.05 m (the offset applied in full, h/2.5 = 0.1 m),
    the far anchor moving across at 30 rad/s (mode 1: 31.4): the RMS difference of the kink
    moment's history over the second half (1 s), dt = 4, 2 and 1 ms, drops by 4 per halving
    (generalised-alpha's second order; measured 4.009, 4.002 with 0.5 ms too): 3.2 to 4.8
    allowed (a third of the way to first or third order, 2 or 8), and the history moves by
    1.4 % from 4 to 2 ms."""
    from cablefem.kinks import KinkMoments

    a = 0.05
    d = taut(a, 1.0, 40)
    d["section"]["EI"] = 25.0
    d["dampers"][0].pop("direction")  # the normal plane: the kink's own
    d["anchors"][1]["motion"] = {"type": "harmonic", "amplitude": [0, 0, 1e-3],
                                 "omega": 30.0}
    t_end, histories = 1.0, []
    for dt in (4e-3, 2e-3, 1e-3):
        model = CableModel(comm, parse_case(d))
        solve_static(model)
        kinks = KinkMoments(model, 30.0)
        every = int(round(4e-3 / dt))
        histories.append(np.array([(t, kinks.measure(t)["moment"][0])
                                   for t, _ in integrate(model, t_end, dt, 0.9, every)]))
    t = histories[0][:, 0]
    for h in histories[1:]:
        np.testing.assert_allclose(h[:, 0], t, atol=1e-12)
    late = t >= t_end / 2
    size = np.sqrt(np.mean(histories[-1][late, 1] ** 2))
    diffs = [np.sqrt(np.mean((histories[i][late, 1] - histories[i + 1][late, 1]) ** 2)) / size
             for i in range(2)]
    assert 3.2 < diffs[0] / diffs[1] < 4.8, diffs
    assert diffs[0] < 0.03, diffs


def test_resonance_factor_takes_the_dampers_ratio(mpi_tmp_path):
    """The error estimate's resonance factor 1/sqrt(d^2 + zeta^2) takes each mode's damping
    ratio from the damped system's modes, the damper's included: the taut cable with
    Krenk's optimum damper at a/L = 0.02 (zeta_1 = a/(2L) = 1 %) and no [damping] table,
    driven at its first frequency, has a factor of about 1/zeta_1 = 100, computed exactly
    from the modes' own ratios (round-off: 1e-9). Before, the ratio came from the
    [damping] table alone (0): the factor was 1/d, d the mode's detuning (P1 frequency
    error, 2.6e-4 here: a factor of 3890)."""
    from cablefem.app.run import run_case

    w1 = np.pi * np.sqrt(T / (M / LAM)) / L
    d = taut(0.02, 1.0, 40)
    d["dampers"][0].pop("direction")  # normal to the cable: both planes damped
    d["anchors"][1]["motion"] = {"type": "harmonic", "amplitude": [0.0, 0.0, 0.01],
                                 "omega": w1}
    d["modal"] = {"modes": 4}
    res = run_case(parse_case(d), mpi_tmp_path / "out", comm, figures=False,
                   progress=False, dynamics=False)
    modes = res.summary["modes"]
    zetas = np.array([m["damping_ratio"] for m in modes])
    assert np.all(zetas > 0.005)  # Krenk: 1 % in mode 1, 0.8 % in mode 2 (eta = 2)
    want = max(1 / np.hypot(abs(w1 / (k * m["omega"]) - 1), m["damping_ratio"])
               for m in modes for k in (1, 2))
    assert res.summary["error_resonance_factor"] == pytest.approx(want, rel=1e-9)
    assert res.summary["error_resonance_factor"] < 1 / 0.005
    # the resonant mode's mesh error (cablefem.discretisation) against the mode's own, its
    # FE frequency over the exact pi/L sqrt(T lambda/m): 2.571e-4. The mesh puts a node
    # at the damper (0.2 m instead of 0.25 m): sqrt(sum h^3/sum h) is 0.3 % longer than
    # L/40, the estimate 0.6 % above; 1 %.
    assert res.summary["error_resonance_mesh"] == pytest.approx(modes[0]["omega"] / w1 - 1,
                                                                rel=0.01)
    assert res.summary["error_resonance_kind"] == "primary"  # amplified into the estimate
