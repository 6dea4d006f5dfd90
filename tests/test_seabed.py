"""A flat seabed ([seabed], cablefem.seabed): the grounded catenary's closed forms, the
touchdown report, a dynamic run with damping and friction, bad input (serially and under
mpirun -n 2)."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from cablefem.app.run import run_case
from cablefem.cable import CableModel
from cablefem.case import CaseError, parse_case
from cablefem.seabed import GroundedCatenary, anchor_penalty_force, touchdown
from cablefem.statics import solve_static

comm = MPI.COMM_WORLD
M, G, LINE, H_F, X_F = 50.0, 9.81, 150.0, 50.0, 120.0  # kg/m, m/s^2, m, m, m
W = M * G


def mooring(elements: int = 150, **extra) -> dict:
    """A 150 m line from an anchor on the seabed (z = 0) to a fairlead 50 m above it and
    120 m away; nearly inextensible (EA = 1e10 N: T/EA ~ 3e-6), contact stiffness 1e6
    N/m^2 (the lying line sinks in by w/k = 0.5 mm)."""
    d = {"title": "mooring", "section": {"EA": 1e10, "EI": 1e3, "mass": M},
         "gravity": {"g": G}, "geometry": {"length": LINE}, "mesh": {"elements": elements},
         "anchors": [{"name": "anchor", "position": [0.0, 0, 0], "type": "pinned"},
                     {"name": "fairlead", "position": [X_F, 0, H_F], "type": "pinned"}],
         "seabed": {"z": 0.0, "stiffness": 1e6},
         "solver": {"outer_correction": "none"}}
    d.update(extra)
    return d


def test_grounded_catenary_closed_forms():
    """The closed forms: the suspended length sqrt(h^2 + 2 h H/w) and its horizontal span
    (H/w) asinh(l_s w/H) plus the grounded length reach the fairlead, whose tension is
    H + w h (round-off of the root: 1e-12)."""
    gc = GroundedCatenary([0, 0, 0], [X_F, 0, H_F], LINE, W, [0, 0, 1], True)
    assert gc.ls == pytest.approx(math.sqrt(H_F**2 + 2 * H_F * gc.H / W), rel=1e-12)
    assert gc.grounded_length + gc.H / W * math.asinh(gc.ls * W / gc.H) == pytest.approx(
        X_F, rel=1e-12)
    np.testing.assert_allclose(gc.position(LINE), [X_F, 0, H_F], rtol=1e-12, atol=1e-9)
    assert gc.tension(LINE) == pytest.approx(gc.fairlead_tension, rel=1e-12)


def test_mooring_line_statics_against_the_closed_forms():
    """The FE line on the penalty seabed against the inextensible grounded catenary:
    horizontal and fairlead tensions within 1e-4 (the stretch T/EA = 3e-6, the penetration
    w/k = 0.5 mm against the 50 m height, the mesh's O(h^2); measured -7e-5 and -2e-5);
    the touchdown, where the penetration crosses zero, within 0.25 of an element of the
    closed form's grounded length (the mesh does not resolve the contact's edge, whose
    offset 1.048 sqrt(H/k) is 0.096 m: measured -0.16 m at 1 m elements, -0.03 m at
    0.5 m)."""
    model = CableModel(comm, parse_case(mooring()))
    st = solve_static(model)
    gc = GroundedCatenary([0, 0, 0], [X_F, 0, H_F], LINE, W, [0, 0, 1], True)
    F = st.anchor_forces[1][:3]
    assert abs(F[0]) == pytest.approx(gc.H, rel=1e-4)
    assert np.linalg.norm(F) == pytest.approx(gc.fairlead_tension, rel=1e-4)
    td = touchdown(model, st.anchor_forces)
    assert td["s"] == pytest.approx(gc.grounded_length, abs=0.25 * LINE / 150)
    # the rigid equivalent (V/w) does not depend on where the mesh puts the contact's end:
    # within 5 mm (its O(w/k) vertex depth 0.3 mm, the stretch T/EA l = 0.5 mm; measured
    # +1.3 mm)
    assert td["rigid"]["s"] == pytest.approx(gc.grounded_length, abs=5e-3)
    assert td["grounded_length"] == pytest.approx(td["s"], rel=1e-12)  # one contact run
    assert abs(td["position"][2]) < 1e-9 * LINE  # on the seabed plane


def test_rigid_touchdown_and_the_penalty_offset():
    """The penalty contact ends c sqrt(H/k) beyond the rigid seabed's touchdown (c = 1.048,
    cablefem.seabed.penalty_offset_factor; 2.9 and 0.91 m at k = 1e3 and 1e4 N/m^2 here),
    while the rigid equivalent, from the suspended length V/w, converges to the closed
    form's grounded catenary as k grows: first order in w/k (its vertex sits 0.55 w/k below
    the plane), measured -0.64 and -0.060 m, a ratio of 10.7 for 10 in k. The measured
    offset is within 3 % of c sqrt(H/k) (measured 0.5 % and 0.7 % at 1 m elements; the
    formula's small slopes, w/sqrt(kH) = 0.17 at k = 1e3, make O(slope^2) = 3 %). The anchor
    on the seabed's plane holds up that length of line: its vertical force, -1517 N at
    k = 1e3, is the first integral's -1504.5 N within 2 % (mesh: the layer sqrt(H/k) is
    2.9 elements), and it does not go away with refinement (-1512 N at 0.5 m elements)."""
    gc = GroundedCatenary([0, 0, 0], [X_F, 0, H_F], LINE, W, [0, 0, 1], True)
    err, offsets = [], []
    for k in (1e3, 1e4):
        d = mooring(150)
        d["seabed"]["stiffness"] = k
        model = CableModel(comm, parse_case(d))
        td = touchdown(model, solve_static(model).anchor_forces)
        H = td["horizontal_tension"]  # the line's own: 2.8 % above gc.H at k = 1e3
        assert td["penalty_offset"] == pytest.approx(1.04841 * math.sqrt(H / k), rel=1e-5)
        offset = td["s"] - td["rigid"]["s"]
        assert offset == pytest.approx(td["penalty_offset"], rel=0.03)
        assert td["rigid"]["grounded_length"] == pytest.approx(td["rigid"]["s"], rel=1e-12)
        err.append(td["rigid"]["s"] - gc.grounded_length)
        offsets.append(offset)
        if k == 1e3:
            a = td["anchors_on_seabed"]["anchor"]
            assert a["penalty_force"] == pytest.approx(-anchor_penalty_force(H, W, k, 0.0))
            assert a["vertical_force"] == pytest.approx(a["penalty_force"], rel=0.02)
            assert a["penalty_force"] == pytest.approx(-1.04841 * W * math.sqrt(H / k),
                                                       rel=1e-5)
    assert abs(err[1]) < abs(err[0]) / 8 and abs(err[1]) < 0.1  # order 1 in 1/k
    assert offsets[0] > 3 * offsets[1] > 2.0  # the contact's end moves by sqrt(H/k)


def test_dynamic_run_with_damping_and_friction(mpi_tmp_path):
    """The fairlead moves 1 m horizontally (a slow surge, a quarter period in 2 s): the run
    completes with contact damping and friction and reports the static touchdown (as in
    the static test, at 2 m elements), and the grounded part's tension at the anchor is H
    (measured 1.4e-3 at 2 m elements, whose contact transition is coarser; 3e-3
    allowed)."""
    d = mooring(elements=75, dynamics={"t_end": 2.0, "dt": 0.02})
    d["seabed"].update({"damping": 1e3, "friction": 0.5})
    d["anchors"][1]["motion"] = {"type": "harmonic", "amplitude": [1.0, 0, 0],
                                 "omega": 0.785}
    res = run_case(parse_case(d), mpi_tmp_path / "run", comm, figures=False,
                   progress=False, modes=0)
    assert res.summary["status"] == "completed"
    td = res.summary["static"]["touchdown"]
    gc = GroundedCatenary([0, 0, 0], [X_F, 0, H_F], LINE, W, [0, 0, 1], True)
    assert td["s"] == pytest.approx(gc.grounded_length, abs=0.25 * LINE / 75)
    assert res.summary["anchors"]["anchor"]["static_tension"] == pytest.approx(gc.H,
                                                                              rel=3e-3)


@pytest.mark.parametrize("seabed,key", [
    ({"stiffness": 0.0}, "seabed.stiffness"),
    ({"damping": -1.0}, "seabed.damping"),
    ({"friction": -0.1}, "seabed.friction"),
    ({"friction_velocity": 0.0}, "seabed.friction_velocity"),
    ({"bogus": 1}, "seabed.bogus")])
def test_bad_seabed_is_rejected_with_its_key(seabed, key):
    d = mooring()
    d["seabed"].update(seabed)
    with pytest.raises(CaseError) as err:
        parse_case(d)
    assert key in str(err.value), str(err.value)


def test_seabed_needs_z():
    d = mooring()
    d["seabed"].pop("z")
    with pytest.raises(CaseError, match="seabed.z"):
        parse_case(d)


def test_modal_damping_leaves_out_the_friction():
    """The damping ratios of a line lying on the seabed in a current: the regularised
    friction, linearised at rest, is a dashpot mu w/v0 (25 kN s/m^2 here) whose slow real
    roots crowded every oscillating mode out of the damped eigenproblem, so that every mode
    was reported overdamped. Left out (docs/seabed.md), the ratios are those of the line
    without friction, to the eigensolver's tolerance, and every mode has one."""
    from cablefem.modal import solve_modes

    def ratios(friction):
        d = mooring(elements=60, fluid={"density": 1025.0, "diameter": 0.1,
                                        "current": [0.3, 0, 0]})
        d["seabed"]["friction"] = friction
        model = CableModel(comm, parse_case(d))
        solve_static(model)
        return solve_modes(model, 4).damping_ratios
    with_friction, without = ratios(0.5), ratios(0.0)
    assert np.all(np.isfinite(with_friction)) and np.all(with_friction > 0)
    np.testing.assert_allclose(with_friction, without, rtol=1e-6)


def test_touchdown_history_follows_a_slow_surge(mpi_tmp_path):
    """The fairlead surges 3 m away from the anchor, from rest to rest over 21 s (half a
    period of 0.15 rad/s, slow against the line's own motion): touchdown.csv has a row per
    output time, the first is the static touchdown, and the last is the quasi-static
    touchdown at the displaced fairlead: the closed form's grounded length within 0.25 of
    an element as in statics (measured +0.009 m on 2 m elements; the touchdown moved by
    5.3 m). The summary's excursion is the closed forms' difference of grounded lengths
    within half an element (the contact's nodes touching and leaving make the touchdown
    jitter by a few cm on the way)."""
    A, om = 3.0, 0.15
    d = mooring(elements=75, dynamics={"t_end": np.pi / om, "dt": 0.1})
    # A (1 - cos(omega t))/2: from rest to rest, 3 m away over half a period
    d["anchors"][1]["motion"] = {"type": "ellipse", "axis_cos": [-A / 2, 0, 0],
                                 "omega": om, "ramp": 0.0}
    res = run_case(parse_case(d), mpi_tmp_path / "run", comm, figures=False,
                   progress=False, modes=0)
    h = LINE / 75
    rows = None
    if comm.rank == 0:
        with open(mpi_tmp_path / "run" / "touchdown.csv", newline="") as fh:
            rows = list(csv.DictReader(fh))
    rows = comm.bcast(rows, root=0)
    t = np.array([float(r["time"]) for r in rows])
    assert {r["line"] for r in rows} == {"cable"} and np.all(np.diff(t) > 0)  # one a time
    assert t[0] == 0.0 and t[-1] == pytest.approx(np.pi / om, rel=1e-12)
    s = np.array([float(r["s"]) for r in rows])
    assert s[0] == pytest.approx(res.summary["static"]["touchdown"]["s"], rel=1e-12)
    far = GroundedCatenary([0, 0, 0], [X_F + A, 0, H_F], LINE, W, [0, 0, 1], True)
    near = GroundedCatenary([0, 0, 0], [X_F, 0, H_F], LINE, W, [0, 0, 1], True)
    assert s[-1] == pytest.approx(far.grounded_length, abs=0.25 * h)
    td = res.summary["touchdown"]["cable"]
    assert td["excursion"] == pytest.approx(near.grounded_length - far.grounded_length,
                                            abs=0.5 * h)
    assert td["times_off_the_seabed"] == 0


# its jerk cuts the step down to 5e-5 s: 1.2 s of it (the bounce from 1.0 s on; 4 times
# off the seabed) instead of 3 s (8 times, 55 s of the suite's 11 min); the seabed's
# parallel paths are the other tests' here (the touchdown history, the dynamic runs)
@pytest.mark.single_rank
def test_a_line_bouncing_off_the_seabed_warns(mpi_tmp_path):
    """A 3 m surge started over 0.5 s (the ramp's jerk) makes the lying line bounce on the
    contact's stiffness (sqrt(k/m) dt = 141 rad/s x 0.05 s = 7: not resolved): at some
    output times no node touches and the grounded length is 0. The run says so (a
    warning naming seabed) instead of leaving a touchdown history with holes in silence;
    a surge from rest to rest does not bounce (no warning)."""
    def run(motion, name, t_end):
        d = mooring(elements=30, dynamics={"t_end": t_end, "dt": 0.05})
        d["seabed"]["damping"] = 1e3
        d["anchors"][1]["motion"] = motion
        return run_case(parse_case(d), mpi_tmp_path / name, comm, figures=False,
                        progress=False, modes=0).summary

    jerk = run({"type": "harmonic", "amplitude": [3.0, 0, 0], "omega": 0.8,
                "ramp": 0.5}, "jerk", 1.2)
    assert jerk["touchdown"]["cable"]["times_off_the_seabed"] > 0
    assert any(w["key"] == "seabed" for w in jerk["warnings"]), jerk["warnings"]
    smooth = run({"type": "ellipse", "axis_cos": [-1.0, 0, 0], "omega": 1.0, "ramp": 0.0},
                 "smooth", 3.0)
    assert smooth["touchdown"]["cable"]["times_off_the_seabed"] == 0
    assert not any(w["key"] == "seabed" for w in smooth["warnings"])


def test_mooring_demo_in_an_irregular_sea(mpi_tmp_path):
    """The mooring demo's line in a JONSWAP sea (Hs 4 m, Tp 10 s) instead of its swell,
    1.2 s of dynamics: the run completes, at about 3 Newton iterations a step. Dynamics
    with Newton's absolute tolerance raised by statics' displacement factor (|u|/h ~ 90
    here) accepted steps 5e-4 N from equilibrium and failed at t = 0.96 s (a Newton step
    from 1e-3 N to 99 N, cut six times); dynamics keeps the plain round-off floor."""
    import tomllib
    from pathlib import Path

    demo = Path(__file__).resolve().parents[1] / "demos" / "mooring.toml"
    d = tomllib.loads(demo.read_text())
    d["fluid"].pop("waves")
    d["fluid"]["spectrum"] = {"hs": 4.0, "tp": 10.0, "direction": [1.0, 0.0, 0.0]}
    d["dynamics"] = {"t_end": 1.2, "dt": 0.02}
    res = run_case(parse_case(d, base_dir=demo.parent), mpi_tmp_path / "irr", comm,
                   figures=False, progress=False, modes=0)
    dyn = res.summary["dynamics"]
    assert res.summary["status"] == "completed"
    assert dyn["newton_iterations"] <= 4 * dyn["steps"]


@pytest.mark.parametrize("z, buried", [(H_F, ["anchor"]), (100.0, ["anchor", "fairlead"]),
                                       (-50.0, []), (1e-4 * 130.0, [])])
def test_a_seabed_above_an_anchor_is_refused(z, buried):
    """A seabed between the anchors (the anchor 50 m below it) or above both (100 where
    -100 was meant) made statics 'converge' at tensions of 1e8-1e9 N (the buried part
    pushed up by k times its penetration): refused, naming seabed.z and the anchors. The
    anchors' distance is 130 m: an anchor 0.013 m below the seabed (1e-4 of it, inside
    the 1e-3 tolerance for an anchor sunk in by the penetration) is accepted."""
    d = mooring()
    d["seabed"]["z"] = z
    if not buried:
        parse_case(d)
        return
    with pytest.raises(CaseError) as err:
        parse_case(d)
    assert [k for k, _ in err.value.problems] == ["seabed.z"] * len(buried)
    for name in buried:
        assert f"anchor {name!r}" in str(err.value)


@pytest.mark.parametrize("waves", [False, True])
def test_a_free_surface_below_the_seabed_is_refused(waves):
    """A surface at -150 m over a seabed at 0 ran with no buoyancy and the waves in deep
    water, silently (an explicit negative depth was refused): refused at fluid.surface."""
    d = mooring()
    d["fluid"] = {"density": 1025.0, "diameter": 0.1, "surface": -150.0}
    if waves:
        d["fluid"]["waves"] = [{"height": 1.0, "period": 8.0, "direction": [1.0, 0, 0]}]
    with pytest.raises(CaseError) as err:
        parse_case(d)
    assert [k for k, _ in err.value.problems] == ["fluid.surface"]
    d["fluid"]["surface"] = 60.0  # above both anchors: water 60 m deep
    parse_case(d)


def test_the_mooring_demo_with_its_seabed_misplaced_exits_2(mpi_tmp_path, capsys):
    """The command line: the mooring demo with seabed.z = 100 (-100 meant) is bad input."""
    from pathlib import Path

    from cablefem.app.cli import main

    demo = Path(__file__).resolve().parents[1] / "demos" / "mooring.toml"
    case = mpi_tmp_path / "moor.toml"
    if comm.rank == 0:
        case.write_text(demo.read_text().replace("z = -100.0", "z = 100.0"))
    comm.Barrier()
    assert main(["run", str(case), "-o", str(mpi_tmp_path / "out"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "seabed.z" in err and "fluid.surface" in err


@pytest.mark.parametrize("height, warns", [(15.0, True), (14.0, False)])
def test_a_breaking_wave_warns(height, warns):
    """A wave 100 m long in deep water (T = sqrt(2 pi 100/g), lambda = g T^2/(2 pi)):
    15 m high is steeper than 1/7 (0.15) and warns on its height; 14 m (0.14) does not.
    The model's warnings, which the run lists in summary.json."""
    d = mooring(elements=20)
    d["fluid"] = {"density": 1025.0, "diameter": 0.1, "surface": 1000.0, "depth": 1e6,
                  "waves": [{"height": height, "period": math.sqrt(2 * math.pi * 100 / G),
                             "direction": [1.0, 0, 0]}]}
    model = CableModel(comm, parse_case(d))
    got = [(k, m) for k, m in model.warnings if "breaking" in m]
    assert [k for k, _ in got] == (["fluid.waves[0].height"] if warns else [])
    if warns:
        assert "H/lambda = 0.15 " in got[0][1] and "lambda = 100 m" in got[0][1]


@pytest.mark.parametrize("surface, floats", [(60.0, True), (1000.0, False)])
def test_a_cable_that_floats_to_the_surface_is_refused(surface, floats):
    """fluid.density = 1e5 kg/m^3 makes the line 7.2e3 N/m lighter than the water it
    displaces (rho g pi D^2/4 = 7.7e3 N/m against m g = 490 N/m): its catenary turned
    upwards (150 m between anchors 130 m apart) rises above a surface 10 m over the
    fairlead, where the buoyancy stops, and statics stalled (exit 1): refused at
    fluid.density when the model is built. Held 950 m below the surface it is accepted."""
    d = mooring(elements=20)
    d["fluid"] = {"density": 1e5, "diameter": 0.1, "surface": surface}
    if floats:
        with pytest.raises(CaseError) as err:
            CableModel(comm, parse_case(d))
        assert [k for k, _ in err.value.problems] == ["fluid.density"]
        assert "floats" in str(err.value)
    else:
        assert CableModel(comm, parse_case(d)).submerged_weight == pytest.approx(
            W - 1e5 * G * math.pi * 0.1**2 / 4, rel=1e-12)


def test_touchdowns_of_a_block_are_the_states_one_at_a_time():
    """``touchdown.csv``'s rows are evaluated for a block of output times at once
    (:func:`cablefem.seabed.touchdowns`): the same numbers, bit for bit, as each state
    alone, for states that touch (the static line; the line lowered by 0.5 m at the anchor,
    less towards the fairlead: more nodes on the seabed, a longer grounded length) and one
    that does not (lifted by 60 m: None), and the static state's as :func:`touchdown`
    reports it."""
    from cablefem.seabed import touchdowns

    model = CableModel(comm, parse_case(mooring(60)))
    solve_static(model)
    td = touchdown(model)
    r = model.gather_nodal(model.u)
    if comm.rank != 0:
        return
    r = r + model.geometry.points
    up = np.array([0.0, 0.0, 1.0])
    s = model.geometry.stations
    lowered = r - 0.5 * np.multiply.outer(1.0 - s / s[-1], up)
    block = np.stack([r, lowered, r + 60.0 * up, r])
    rows = touchdowns(model, block)
    assert rows == [touchdowns(model, b[None])[0] for b in block]
    assert rows[0] == td and rows[3] == td
    assert rows[2] is None
    assert rows[1]["grounded_length"] > rows[0]["grounded_length"] > 0.0


def test_seabed_dashpot_is_continuous_where_a_node_touches_down():
    """The contact's dashpot ``-c v_z`` ramps in with the contact's stiffness (``ds/dp``,
    from none at zero penetration to all of it at the smoothing depth ``b``): the residual
    is continuous where a node moving vertically crosses the seabed. Before, it acted at
    any penetration above zero, a jump of ``c v_z`` per length that Newton cycled across
    (the mooring demo at t = 26.72 s: 25 iterations between two residuals, a cut step and
    the rest of the run at a sixteenth of its step). A line laid flat at the seabed,
    sinking at 1 m/s, penetrations -1e-9 m and +1e-9 m (2e-5 of ``b``): the term's forces
    differ by that share of ``c`` times the speed times the length, not all of it."""
    from dolfinx import fem
    from dolfinx.fem import petsc as fpetsc

    c = 2.0e3
    model = CableModel(comm, parse_case(mooring(20, seabed={
        "z": 0.0, "stiffness": 1e6, "damping": c})))
    form = fem.form(model.forms.term("seabed_dynamic").form)
    X = model.V.tabulate_dof_coordinates()

    def force(p):
        u = model.u.x.array.reshape(-1, 3)
        u[:] = 0.0
        u[:, 2] = -p - X[:, 2]  # every node at elevation -p
        model.v.x.array.reshape(-1, 3)[:] = [0.0, 0.0, -1.0]
        b = fpetsc.assemble_vector(form)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        total = comm.allreduce(float(np.sum(b.array_r.reshape(-1, 3)[:, 2])), op=MPI.SUM)
        b.destroy()
        return total

    scale = c * 1.0 * LINE  # the whole dashpot's force on the line, N
    assert abs(force(1e-9) - force(-1e-9)) < 1e-3 * scale
    assert force(1.0) == pytest.approx(-scale, rel=1e-9)  # deep in: all of it
