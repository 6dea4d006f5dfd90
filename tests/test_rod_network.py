"""The reference rod on network meshes (``--model beam`` on a network, cablefem.rod_network):
one cable is the single rod, the 2 x 2 saddle net against an independent corotational beam
net (issue 34, 4 s: statics and 4 modes on 8 856 unknowns), the mesh's colours and grading,
serial = 2 ranks, compare on a network, the Python constructor."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI
from test_network import write_mesh

from cablefem.anchor import Anchor
from cablefem.case import load_case, parse_case
from cablefem.create import create_rod, model_from_case
from cablefem.description import Gravity
from cablefem.dynamics import integrate
from cablefem.kinks import kink_points
from cablefem.modal import solve_modes
from cablefem.properties import Section
from cablefem.rod_network import network_rod_kink_moments
from cablefem.statics import solve_static

comm = MPI.COMM_WORLD
ROOT = Path(__file__).resolve().parents[1]


def test_one_cable_network_rod_is_the_single_rod(mpi_tmp_path):
    """A network mesh of one straight cable, its nodes the single rod's graded stations
    (stretched by 1 + T0/EA onto the chord), and ``[beam]`` options that leave its cells
    whole (layer_elements 0.5, growth 2, span_elements 1: every target size exceeds the
    rod's elements), is the single rod of stress-free length chord/(1 + T0/EA): the same
    unknowns (one colour: bs = 6), strains and masses (the network's stress-free length
    per mesh length c is the stretch, and the P1 products see the same stress-free
    lengths), the same frame (E3 along the chord, E1 in the plane of gravity) and GA.
    Only the statics' paths differ (the network ramps the weight from the mesh, the single
    rod starts from its catenary): anchor forces and moments agree to Newton's tolerance
    (relative 1e-9 on residuals of about 1e4 N; 1e-7 leaves room for the conditioning of
    a rod with GA/T = 1e5)."""
    EA, EI, m, T0, D, GA = 1.0e6, 2.0, 1.0, 1.0e4, 10.0, 1.0e9
    L0 = D / (1.0 + T0 / EA)
    sec = Section(EA=EA, EI=EI, GJ=0.0, mass=m)
    anchors = [Anchor("p", np.zeros(3)), Anchor("q", np.array([D, 0.0, 0.0]))]
    rod = create_rod(comm, anchors, sec, length=L0, gravity=Gravity(9.81),
                     shear_stiffness=GA)
    st_rod = solve_static(rod)
    s = rod.geometry.stations
    pts = np.column_stack([s * D / L0, 0 * s, 0 * s])
    n = len(s)
    mesh = write_mesh(str(mpi_tmp_path / "one.msh"), pts,
                      [[i, i + 1] for i in range(n - 1)], ["c"] * (n - 1),
                      {"p": [0], "q": [n - 1]})
    case = parse_case({"title": "one", "network": {"mesh": mesh},
                       "sections": [{"name": "s", "EA": EA, "EI": EI, "mass": m}],
                       "cables": [{"group": "c", "section": "s", "pretension": T0}],
                       "gravity": {"g": 9.81}, "anchors": [{"name": "p"}, {"name": "q"}],
                       "beam": {"layer_elements": 0.5, "growth": 2.0, "span_elements": 1,
                                "shear_stiffness": GA}})
    net = model_from_case(comm, case, model="beam")
    assert net.bs == 6 and len(net.geometry.cells) == n - 1
    st_net = solve_static(net)
    F_rod, F_net = st_rod.anchor_forces, st_net.anchor_forces
    assert F_rod.shape == F_net.shape == (2, 6)
    np.testing.assert_allclose(F_net[:, :3], F_rod[:, :3], rtol=0,
                               atol=1e-7 * np.abs(F_rod[:, :3]).max())
    np.testing.assert_allclose(F_net[:, 3:], F_rod[:, 3:], rtol=0,
                               atol=1e-7 * np.abs(F_rod[:, 3:]).max())
    # a moment worth comparing: the clamp's w l ℓ/2 = 9.81 · 10 · 0.01414/2 = 0.69 N m
    assert np.linalg.norm(F_rod[0, 3:]) == pytest.approx(0.69, rel=0.02)


def _saddle(path, n=2, k=10, h=1.0, load_node=False):
    """The make_roof net (the generator run in-process on rank 0) as a file."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_roof", ROOT / "meshes/make_roof.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    if comm.rank == 0:
        import meshio

        meshio.write(str(path), mod.roof(n, k, 40.0, h, load_node), file_format="gmsh22",
                     binary=False)
    comm.Barrier()
    return str(path)


def test_colours_and_grading_of_the_saddle():
    """On the 2 x 2 saddle: 4 cables in 2 colours (each x cable meets both y cables); 2
    colours give 9 unknowns per node; the first element at every clamp and crossing is
    ℓ/layer_elements long (ℓ = sqrt(EI/(T0 (1 + T0/EA))) = 0.14139 m at the pretension),
    within the growth ratio 1.1 that the stations' rounding allows; the longest element is
    the cable's length over span_elements (40/(1.0005 · 100) m)."""
    case = load_case(ROOT / "demos/saddle_2x2.toml")
    model = model_from_case(comm, case, model="beam")
    assert model.n_colours == 2 and model.bs == 9
    assert len(set(model.cable.tolist())) == 4
    geo = model.geometry
    ell = math.sqrt(2e3 / (1e5 * (1 + 1e5 / 2e8)))
    cells = np.asarray(geo.cells)
    h = geo.cell_lengths
    for k in list(geo.net.junctions) + [a.node for a in model.anchors]:
        first = h[np.any(cells == k, axis=1)]
        assert np.all(first <= 1.1 * ell / 8.0) and np.all(first >= ell / 8.0 / 1.1)
    assert h.max() <= 40.0 / (1.0 + 1e5 / 2e8) / 100 * (1 + 1e-9)


#: the issue's corotational beam net (graded to ℓ/16, converged: refinement moves its
#: moments by 0.04-0.06 %, its frequencies by < 0.03 %)
REFERENCE = {"clamp_x": 117.71, "clamp_y": 117.72, "kink_x": 523.1, "kink_y": 447.4,
             "tension_x": 85633.0, "tension_y": 119091.0,
             "omega": [15.262, 15.841, 16.193, 17.160]}


def test_saddle_net_rod_matches_the_corotational_reference():
    """The issue's 2 x 2 saddle net (demos/saddle_2x2.toml: kinks of 0.0799 and 0.0575 rad
    at the crossings, clamp angles 0.0097 and 0.0075 rad on the string) on the default rod
    mesh (ℓ/8 at clamps and crossings). Tolerances: the reference's own convergence
    (0.06 % on moments, 0.03 % on frequencies) plus its rounding (5 digits: 0.005 %) plus
    this mesh's own error, measured by --refine 2 (moments: < 1e-5; tensions: 6e-6;
    frequencies: <= 0.009 %); tensions: the reference's rounding to 1 N (6e-6) and this
    mesh's error, 3e-5. Measured: clamps +0.014 / +0.017 %, crossings +0.017 / +0.026 %,
    tensions < 2e-6, frequencies +0.010, +0.015, +0.007, +0.008 %."""
    model = model_from_case(comm, load_case(ROOT / "demos/saddle_2x2.toml"), model="beam")
    st = solve_static(model)
    names = [a.name for a in model.anchors]
    F = st.anchor_forces
    kinks = kink_points(model)
    M_kink = network_rod_kink_moments(model, kinks)
    omegas = solve_modes(model, 4).omegas
    got = {}
    for fam in ("x", "y"):
        rows = [i for i, n in enumerate(names) if n.startswith(f"anchors_{fam}")]
        got[f"clamp_{fam}"] = np.linalg.norm(F[rows, 3:], axis=1)
        got[f"tension_{fam}"] = np.linalg.norm(F[rows, :3], axis=1)
        got[f"kink_{fam}"] = np.array([M for k, M in zip(kinks, M_kink)
                                       if k.name.endswith(f"cables_{fam}")])
        assert got[f"kink_{fam}"].size == 4
    for key in ("clamp_x", "clamp_y", "kink_x", "kink_y"):
        np.testing.assert_allclose(got[key], REFERENCE[key], rtol=6.0e-4 + 5e-5 + 1e-5)
    for key in ("tension_x", "tension_y"):
        np.testing.assert_allclose(got[key], REFERENCE[key], rtol=3e-5)
    np.testing.assert_allclose(omegas[:4], REFERENCE["omega"], rtol=3e-4 + 5e-5 + 9e-5)


def _net_history(case, c):
    model = model_from_case(c, case, model="beam")
    st = solve_static(model)
    om = solve_modes(model, 3).omegas
    kinks = network_rod_kink_moments(model, kink_points(model))
    model.u.x.array[:] = model.u_static.x.array
    hist = [f.copy() for _, f in integrate(model, 0.02, 0.005, 0.9, 2)]
    return st.anchor_forces, om, kinks, np.array(hist)


def test_network_rod_parallel_equals_serial(mpi_tmp_path):
    """A 1 x 1 saddle (one crossing, 4 clamps, 4 elements per bay) with an anchor moving:
    the partitioned rod (COMM_WORLD) and the same model alone on each rank (COMM_SELF)
    give the same static anchor forces and moments, kink moments, frequencies and a
    4-step force history to 1e-8 relative: both solve the same equations with direct
    solvers and Newton tolerances of 1e-9 (round-off amplified by the solver tolerance;
    the rod's GA/T = 1e5 costs a decade against the string's 1e-9)."""
    mesh = _saddle(mpi_tmp_path / "one.msh", n=1, k=4)
    d = {"title": "x", "network": {"mesh": mesh},
         "sections": [{"name": "s", "EA": 2e8, "EI": 2e3, "mass": 10.0}],
         "cables": [{"group": "cables_x", "section": "s", "pretension": 1e5},
                    {"group": "cables_y", "section": "s", "pretension": 1e5}],
         "gravity": {"g": 9.81},
         "anchors": [{"name": "anchors_x", "motion": {"type": "harmonic", "amplitude":
                                                       [0, 0, 0.01], "omega": 12.0}},
                     {"name": "anchors_y"}],
         "beam": {"layer_elements": 4, "growth": 1.3, "span_elements": 20}}
    case = parse_case(d)
    par = _net_history(case, comm)
    ser = _net_history(case, MPI.COMM_SELF)
    for a, b in zip(par, ser):
        scale = np.abs(b).max()
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-8 * scale)


def test_compare_a_network_string_run_with_its_rod(mpi_tmp_path):
    """``cablefem compare`` on a network: a 1 x 1 saddle (one crossing under a harmonic
    point load, 4 clamps) run as the string and as the rod for 0.3 s. Every clamp and both
    cables' kinks at the crossing are compared, with the static moment, steady-state peak
    and RMS and the history error; each static relative difference is (b − a)/a of the two
    runs' summary.json values (to round-off), and the rod's static moments differ from the
    string's by less than the string's first-order error at this ℓ/l (the issue's 5.7 % on
    a 13 m bay, ℓ = 0.14 m; here a 20 m bay: below 10 %)."""
    from cablefem.app.compare import compare_runs
    from cablefem.app.run import run_case

    mesh = _saddle(mpi_tmp_path / "one.msh", n=1, k=4, load_node=True)
    d = {"title": "x", "network": {"mesh": mesh},
         "sections": [{"name": "s", "EA": 2e8, "EI": 2e3, "mass": 10.0}],
         "cables": [{"group": "cables_x", "section": "s", "pretension": 1e5},
                    {"group": "cables_y", "section": "s", "pretension": 1e5}],
         "gravity": {"g": 9.81}, "anchors": [{"name": "anchors_x"}, {"name": "anchors_y"}],
         "point_loads": [{"group": "load", "value": [0, 0, 3000.0],
                          "time": {"type": "harmonic", "omega": 12.0}}],
         "damping": {"ratio": 0.01, "frequencies": [12.0, 17.0]},
         "dynamics": {"t_end": 0.3, "dt": 0.005, "fields_every": 1000},
         "modal": {"modes": 0},
         "beam": {"layer_elements": 4, "growth": 1.3, "span_elements": 20}}
    case = parse_case(d)
    kw = {"figures": False, "progress": False}
    a = run_case(case, mpi_tmp_path / "string", model="string", **kw).summary
    b = run_case(case, mpi_tmp_path / "rod", model="beam", **kw).summary
    res = compare_runs(mpi_tmp_path / "string", mpi_tmp_path / "rod")
    assert sorted(res["anchors"]) == sorted(a["anchors"]) and len(res["anchors"]) == 4
    assert sorted(res["kinks"]) == ["load:0/cables_x", "load:0/cables_y"]
    for table, key in (("anchors", "anchors"), ("kinks", "kinks")):
        for name, entry in res[table].items():
            ma, mb = a[key][name]["static_moment"], b[key][name]["static_moment"]
            assert entry["static_moment"]["rel_diff"] == pytest.approx((mb - ma) / ma,
                                                                       rel=1e-12)
            assert abs(entry["static_moment"]["rel_diff"]) < 0.10
            for stat in ("steady_peak", "steady_rms"):
                assert np.isfinite(entry[stat]["rel_diff"])
            assert np.isfinite(entry["history_error"]["value"])


def test_create_network_rod_is_the_case_files_rod():
    """create_network_rod builds the rod model_from_case builds from the same network
    (the saddle case's arguments): the same graded mesh and colours (functions of the
    mesh, the sections, pretensions and [beam] alone); a bad mesh option is refused by
    name."""
    from cablefem import create_network_rod
    from cablefem.description import CableSpec

    case = load_case(ROOT / "demos/saddle_2x2.toml")
    a = model_from_case(comm, case, model="beam")
    sec = case.network.sections["strand"]
    b = create_network_rod(comm, ROOT / "meshes/saddle_2x2.msh", {"strand": sec},
                           [Anchor("anchors_x", None), Anchor("anchors_y", None)],
                           cables=[CableSpec("cables_x", "strand", 1e5),
                                   CableSpec("cables_y", "strand", 1e5)],
                           gravity=Gravity(9.81), point_loads=case.point_loads,
                           damping=case.damping)
    assert b.bs == a.bs == 9
    np.testing.assert_array_equal(b.geometry.points, a.geometry.points)
    np.testing.assert_array_equal(b.colour, a.colour)
    with pytest.raises(Exception, match="layer_elements"):
        create_network_rod(comm, ROOT / "meshes/saddle_2x2.msh", {"strand": sec},
                           [Anchor("anchors_x", None), Anchor("anchors_y", None)],
                           cables=[CableSpec("cables_x", "strand", 1e5)],
                           layer_elements=0.1)


def test_a_cable_without_pretension_warns(mpi_tmp_path):
    """A cable group without pretension has no layer length to grade the rod's mesh by
    (ℓ = sqrt(EI/T0) is infinite): its elements at its clamps are the span's, and the model
    says so (key ``cables``) instead of leaving the layer silently unresolved."""
    mesh = _saddle(mpi_tmp_path / "one.msh", n=1, k=4)
    d = {"title": "x", "network": {"mesh": mesh},
         "sections": [{"name": "s", "EA": 2e8, "EI": 2e3, "mass": 10.0}],
         "cables": [{"group": "cables_x", "section": "s", "pretension": 1e5},
                    {"group": "cables_y", "section": "s", "pretension": 0.0}],
         "gravity": {"g": 9.81}, "anchors": [{"name": "anchors_x"}, {"name": "anchors_y"}],
         "beam": {"layer_elements": 4, "growth": 1.3, "span_elements": 20}}
    model = model_from_case(comm, parse_case(d), model="beam")
    assert any(k == "cables" and "cables_y" in m for k, m in model.warnings), model.warnings


def test_the_rod_solves_directly_at_every_size():
    """Above LARGE_ABOVE unknowns the string keeps its factorisation over steps; the rod
    does not: its nearly rigid shear (GA = 1e5 T) makes a stale factorisation crawl (the
    5 x 5 saddle rod: > 6 s a step with GMRES on a reused LU against 0.8 s). The rod's
    options are a direct solve with a fresh factorisation every time."""
    from cablefem.petsc_utils import LARGE_ABOVE, keeps_factorisation, linear_solver_options

    n = 10 * LARGE_ABOVE
    assert keeps_factorisation(n) and not keeps_factorisation(n, reuse=False)
    rod = linear_solver_options(n, 1, reuse=False)
    assert rod["ksp_type"] == "preonly" and "snes_lag_preconditioner" not in rod
    parallel = linear_solver_options(n, 2, reuse=False)  # a direct solve on rank 0
    assert parallel["ksp_type"] == "preonly" and parallel["pc_type"] == "python"
    assert parallel["pc_python_type"] == "cablefem.gathered_lu.GatheredLU"


def test_a_network_damper_on_the_rod(mpi_tmp_path):
    """A network's damper cell on the rod: the taut pinned cable of tests/test_dampers.py
    (T = 1e4 N, L = 10 m, 50 elements) with a grounded damper at a = 1 m, c at Krenk's
    optimum for mode 1, EI = 1e-3 N m² (ℓ = 0.32 mm). The rod and the string damp mode 1
    alike: the string's damper acts at the string's node, (ℓ/2)(1/a + 1/(L − a)) = 1.8e-4
    (relative) from the rod's (docs/dampers.md), and the string's 50 elements put its
    frequencies (π/50)²/12 = 3.3e-4 high; 5e-4 covers both. The mode across the damper's
    plane stays undamped (1e-9)."""
    from test_dampers import M, T, _tie_network

    from cablefem.network import NetworkModel

    n, a = 50, 5
    c = np.sqrt(T * M) / (np.pi * a / n)
    case = _tie_network(mpi_tmp_path / "tie.msh", True, c, 2e3, n, a, EI=1e-3)
    got = {}
    for name, model in (("string", NetworkModel(comm, case)),
                        ("rod", model_from_case(comm, case, model="beam"))):
        solve_static(model)
        res = solve_modes(model, 2)
        got[name] = (res.omegas, res.damping_ratios)
    (w_s, z_s), (w_r, z_r) = got["string"], got["rod"]
    assert z_s[1] > 0.04  # damped: 4.6 %
    assert z_r[1] == pytest.approx(z_s[1], rel=5e-4)
    np.testing.assert_allclose(w_r, w_s, rtol=5e-4)
    assert abs(z_r[0]) < 1e-9


def test_the_fan_of_stays_on_the_rod(mpi_tmp_path):
    """demos/fan.toml (six stays, clamped at the pylon head, the clamp split into its sides,
    and at the deck): the rod's statics converge by Newton alone (GA/EA = 342: its
    tolerance above the shear's round-off, ε GA per node; it stalled at 7e-4 N with EA's)
    and its anchor moments are the string's (virtual hinges) to 5e-5: the string's own
    estimate (8.5e-6) plus the rod's mesh error at ℓ/8 (< 1e-5 on the saddle), with room
    for the rod's shear (T/GA = 1e-5). Measured: 1.7e-5 at most."""
    from cablefem.app.run import run_case

    case = load_case(ROOT / "demos/fan.toml")
    rod = model_from_case(comm, case, model="beam")
    st = solve_static(rod)
    assert st.continuation_steps == 0
    M_rod = np.linalg.norm(st.anchor_forces[:, 3:], axis=1)
    names = [a.name for a in rod.anchors]
    assert len(names) == 12
    string = run_case(case, mpi_tmp_path / "string", model="string", dynamics=False,
                      figures=False, progress=False).summary["anchors"]
    np.testing.assert_allclose(M_rod, [string[n]["static_moment"] for n in names],
                               rtol=5e-5)
