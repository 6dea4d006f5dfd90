"""The error estimate of the anchor moment (``error_estimate`` in anchors.csv, the per-anchor
``validity`` of summary.json, docs/theory.md §5): measured against the rod and the hinged
string, and the warnings of runs whose rows are invalid or whose estimate is too large."""

from __future__ import annotations

import copy
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from cablefem.app.compare import compare_runs
from cablefem.app.report import damping_ratio
from cablefem.app.run import run_case
from cablefem.cable import CableModel
from cablefem.case import load_case, parse_case
from cablefem.io import anchorcsv
from cablefem.modal import solve_modes
from cablefem.moments import ERROR_THRESHOLD, anchor_moments, error_estimate, resonance
from cablefem.rod import BeamModel
from cablefem.statics import solve_static

comm = MPI.COMM_WORLD
DEMOS = Path(__file__).resolve().parents[1] / "demos"


def _sagging(EI: float, corr: str) -> object:
    """A 10 %-sag cable clamped horizontally (anchor angle 0.39 rad) at eps = sqrt(EI/(w
    l^3)) = 0.03 (EI = 9e-4) or 0.08 (EI = 6.4e-3), on 160 elements."""
    data = tomllib.loads((DEMOS / "paper_inplane.toml").read_text())
    data.setdefault("solver", {})["outer_correction"] = corr
    data["mesh"]["elements"] = 160
    data["section"]["EI"] = EI
    data["anchors"][1]["position"] = [0.974, 0, 0]
    return parse_case(data, DEMOS)


def _static_moment(model) -> tuple[float, float]:
    """(moment, error_estimate) of the first anchor in the static state."""
    F = solve_static(model).anchor_forces[0]
    a = model.anchors[0]
    order = 1 if getattr(model, "hinges", None) else 0
    r = anchor_moments(F[None, :3], a.direction, a.section.EI, a.section.EA, a.section.mass,
                       np.zeros((1, 3)), a.section.mass * model.g_vec, model.length, None,
                       "exact", order)
    return float(r["moment"][0]), float(r["error_estimate"][0])


def _rod_moment(case) -> float:
    """The reference rod's static anchor moment, on each process alone (its Newton from
    the catenary does not converge for this cable when partitioned over two ranks)."""
    rod = BeamModel(MPI.COMM_SELF, case)
    return float(np.linalg.norm(solve_static(rod).anchor_forces[0][3:6]))


@pytest.mark.parametrize("EI,measured", [(9e-4, 0.056), (6.4e-3, 0.16)])
def test_estimate_brackets_the_leading_order_error_of_a_sagging_cable(EI, measured):
    """Leading order vs the rod: the static anchor moment is 5.6 % low at eps = 0.03 and
    16 % low at eps = 0.08 (measured, docs/theory.md §5); the estimate 2 h/l says 5.3 % and
    14.2 %: within a factor 1.5 both ways, and above the threshold (a warning)."""
    M_rod = _rod_moment(_sagging(EI, "none"))
    M, est = _static_moment(CableModel(comm, _sagging(EI, "none")))
    err = abs(M / M_rod - 1)
    assert err == pytest.approx(measured, rel=0.1)  # the measured error of this case
    assert est / 1.5 < err < 1.5 * est  # the factor the documentation states
    assert est > ERROR_THRESHOLD


def test_estimate_with_the_hinge_is_the_next_order():
    """With the virtual hinge at eps = 0.03 the estimate is (2 h/l)^2 = 0.32 %, below the
    threshold, and not optimistic: the moment is within it of the rod. Measured: 0.5 % with
    the first-order hinge alone, 0.08 % with its second order (theory.md §6.2), so the
    estimate now errs by a factor 4 on the safe side here (at eps = 0.08, the validation
    matrix's sag08: 3.3 % against a measured 2.8 %)."""
    M_rod = _rod_moment(_sagging(9e-4, "none"))
    M, est = _static_moment(CableModel(comm, _sagging(9e-4, "hinge")))
    err = abs(M / M_rod - 1)
    assert est < ERROR_THRESHOLD
    assert err < est


def test_case_A_near_parametric_resonance():
    """Case A is excited at twice its first frequency (a parametric resonance, damping
    ratio 0.005): its resonance factor is that of the damping (1/zeta = 200 at exact
    tuning; >= 100 with the detuning of the string's modes), so that a dynamic moment of
    the static one's size has a leading-order estimate of about 100 % (a history out of
    phase, as measured: 117 %) and a hinged one below the threshold. The hinged run's
    measured history error is 2.8 % pointwise (0.6 % in peak): its estimate, the
    hinge's next order (2h/l)^2 = 6.4e-5 and the resonant mode's span-bending frequency
    error EI m omega_1^2/(2 T^2) = 8.6e-5, both amplified, is 0.9 % there; within a factor
    4 of the measured error (an estimate of the order of magnitude, not a bound; without
    the span-bending term it was 0.4 %, a factor 7 optimistic)."""
    out = {}
    for corr in ("none", "hinge"):
        data = tomllib.loads((DEMOS / "paper_inplane.toml").read_text())
        data.setdefault("solver", {})["outer_correction"] = corr
        case = parse_case(data, DEMOS)
        m = CableModel(comm, case)
        F = solve_static(m).anchor_forces[0]
        amp, w_r = resonance(32.814, solve_modes(m, 2).omegas, damping_ratio(case))
        assert 100 < amp <= 200  # 1/zeta = 200 bounds it (damping ratio 0.005)
        assert w_r == pytest.approx(32.814 / 2, rel=0.01)  # the parametric resonance
        a = m.anchors[0]
        T = np.linalg.norm(F[:3])
        delta = np.arccos(F[:3] @ a.direction / T)
        Ms = 1.0
        est = error_estimate(delta, T, a.section.EI, a.section.EA, m.length, None,
                             1 if corr == "hinge" else 0, amp, np.array([2 * Ms]), Ms,
                             a.section.mass, w_r)[0]
        out[corr] = est
        # statics alone: 2 h/l = 0.8 % (leading order; rod: -0.07 %), below the threshold
        assert _static_moment(m)[1] < ERROR_THRESHOLD
    assert out["none"] > 0.5  # of the order of the moment itself
    assert out["hinge"] < ERROR_THRESHOLD
    assert 0.028 / 4 < out["hinge"] < 4 * 0.028


@pytest.mark.single_rank  # two runs of 6000 steps (17 s serial, 118 s on 2 ranks); the
# estimate is rank 0's from gathered forces, its parallel path tested by the other runs
def test_a_resonance_warning_names_the_span_bending(mpi_tmp_path):
    """Case A with four times its EI (eps doubled; "auto" leaves the bending off: 0.3 % at
    most) sits at its parametric resonance: many steady rows have an estimate above the
    2 % threshold, most of it the resonant mode's span-bending frequency error amplified
    (test_case_A_near_parametric_resonance), and the warning says that
    solver.span_bending puts that bending in. With it, that term is gone: the estimate
    drops (what is left, the hinge's next order amplified, may still warn, without the
    hint). Before, the warning named no remedy."""
    out = {}
    for bends in (False, True):
        data = tomllib.loads((DEMOS / "paper_inplane.toml").read_text())
        data["section"]["EI"] *= 4
        data.setdefault("solver", {})["span_bending"] = bends
        res = run_case(parse_case(data, DEMOS), mpi_tmp_path / f"sb{int(bends)}", comm,
                       figures=False, progress=False)
        out[bends] = res.summary
    warned = {b: [w["message"] for w in out[b].get("warnings", [])
                  if w["key"].startswith("anchors.")] for b in out}
    assert warned[False] and all("solver.span_bending = true" in m for m in warned[False])
    assert not any("solver.span_bending" in m for m in warned[True])
    worst = {b: max(a["validity"]["max"] for a in out[b]["anchors"].values()) for b in out}
    assert worst[False] > ERROR_THRESHOLD and worst[True] < 0.6 * worst[False]
    assert out[True]["span_bending"] is True and out[False]["span_bending"] is False


def test_the_si_stay_cable_does_not_warn(mpi_tmp_path):
    """The SI stay cable (anchor angle 0.02 rad, ell/l = 0.004): statics and a first
    second of history without modes (no resonance factor) stay below the threshold
    (2 h/l = 0.8 %; the rod: 0.07 %): no warning. (Its full 95.78 s history is case A's in
    SI units, at the same parametric resonance, and warns as case A does.)"""
    case = load_case(DEMOS / "stay_cable_si.toml")
    res = run_case(case, mpi_tmp_path / "si", comm, figures=False, progress=False, modes=0,
                   t_end=1.0)
    assert not [w for w in res.summary.get("warnings", []) if "error" in w["message"]]
    for name, a in res.summary["anchors"].items():
        if a["kind"] == "clamped":
            assert a["validity"]["max"] < ERROR_THRESHOLD
            assert a["validity"]["invalid_fraction"] == 0.0


def _thick_case(make_case):
    """EI = 0.6: the layer is 0.15 of the cable, beyond MAX_LENGTH_RATIO = 0.1 at every
    row: every row of both clamped anchors is invalid."""
    return make_case(EI=0.6, elements=8, motion={"type": "harmonic",
                                                 "amplitude": [2e-4, 0, 0], "omega": 32.814},
                     dynamics={"t_end": 0.05, "dt": 0.005})


def test_every_row_invalid_warns(mpi_tmp_path, make_case):
    """Every row invalid (the layer too long): a warning naming the anchor, the fraction
    and the reason, in summary.json (the base printed none and exited 0)."""
    res = run_case(_thick_case(make_case), mpi_tmp_path / "thick", comm, figures=False,
                   progress=False, modes=0)
    msgs = [(w["key"], w["message"]) for w in res.summary.get("warnings", [])]
    for name in ("p", "q"):
        assert any(k == f"anchors.{name}" and "EVERY row" in m and "layer too long" in m
                   for k, m in msgs), msgs
        assert res.summary["anchors"][name]["validity"]["invalid_fraction"] == 1.0


@pytest.mark.serial  # a subprocess
def test_every_row_invalid_strict_exits_non_zero(tmp_path):
    """The same on the command line: the warning on the console, exit 0 without --strict
    (the files are complete), exit 3 with it."""
    text = (DEMOS / "paper_inplane.toml").read_text()
    # the leading order (the first-order correction refuses a layer this long: exit 2)
    text = text + '\n[solver]\nouter_correction = "none"\n'
    for old, new in (("EI = 4.0e-4", "EI = 0.6"), ("elements = 30", "elements = 8"),
                     ("t_end = 30.0", "t_end = 0.05"), ("modes = 6", "modes = 1")):
        assert old in text
        text = text.replace(old, new)
    case = tmp_path / "thick.toml"
    case.write_text(text)
    for strict, code in ((False, 0), (True, 3)):
        args = [sys.executable, "-m", "cablefem", "run", str(case), "--no-figures",
                "--output", str(tmp_path / f"out{int(strict)}")] + (["--strict"] if strict
                                                                     else [])
        proc = subprocess.run(args, capture_output=True, text=True, timeout=300)
        assert proc.returncode == code, proc.stderr
        assert "anchors.p" in proc.stderr and "EVERY row" in proc.stderr, proc.stderr


def test_old_anchors_csv_without_the_column_still_reads(mpi_tmp_path, make_case):
    """A run's anchors.csv with the error_estimate column removed (a file of an older
    version) reads in fatigue's and compare's reader with the estimate NaN, and compares
    to itself."""
    case = make_case(elements=8, motion={"type": "harmonic", "amplitude": [2e-4, 0, 0],
                                         "omega": 32.814},
                     dynamics={"t_end": 0.05, "dt": 0.005})
    run_case(case, mpi_tmp_path / "new", comm, figures=False, progress=False, modes=0)
    old = mpi_tmp_path / "old"
    if comm.rank == 0:
        old.mkdir()
        for f in (mpi_tmp_path / "new").iterdir():
            if f.is_file():
                (old / f.name).write_bytes(f.read_bytes())
        lines = (old / "anchors.csv").read_text().splitlines()
        k = lines[0].split(",").index("error_estimate")
        (old / "anchors.csv").write_text("\n".join(
            ",".join(c for j, c in enumerate(ln.split(",")) if j != k) for ln in lines) + "\n")
    comm.Barrier()
    new_d = anchorcsv.read_moments(mpi_tmp_path / "new" / "anchors.csv")
    old_d = anchorcsv.read_moments(old / "anchors.csv")
    for name, d in old_d.items():
        assert np.all(np.isnan(d["error_estimate"]))
        assert np.array_equal(d["moment"], new_d[name]["moment"], equal_nan=True)
    rep = compare_runs(mpi_tmp_path / "new", old)
    assert rep is not None


def test_resuming_an_older_file_keeps_its_columns(tmp_path):
    """A run resumed on an anchors.csv of an older version (no error_estimate) appends rows
    in that file's columns: every row has the header's number of fields and reads back."""
    old_cols = [c for c in anchorcsv.columns(True) if c != "error_estimate"]
    path = tmp_path / "anchors.csv"
    row = {c: [1.0] for c in old_cols}
    row["anchor"] = ["p"]
    with anchorcsv.AnchorCSV(path, old_cols, MPI.COMM_SELF) as out:
        out.write(row)
    new_row = {**{c: [2.0] for c in anchorcsv.columns(True)}, "anchor": ["p"], "valid": [1]}
    with anchorcsv.AnchorCSV(path, anchorcsv.columns(True), MPI.COMM_SELF,
                             append=True) as out:
        out.write(new_row)
    d = anchorcsv.read(path, anchorcsv.columns(True)[2:])["p"]
    assert np.array_equal(d["time"], [1.0, 2.0])
    assert np.all(np.isnan(d["error_estimate"]))  # the older file's rows have none


def test_the_resonant_modes_own_bending_error_enters_the_estimate(mpi_tmp_path):
    """Near a resonance without the span's bending, the estimate amplifies the resonant
    mode's span-bending frequency error: the one measured on that mode
    (modes[k].span_bending_shift, cablefem.span_bending), not the taut beam's
    EI m omega^2/(2 T^2), whenever the run has it. The 10 %-sag clamped cable at
    eps = 0.01 ("auto" leaves the bending off: 0.37 % at most) with its anchor q moving in
    plane at its fourth mode's frequency (the in-plane symmetric one): the run records
    that mode's shift as the resonance's, and each row's estimate is the function's with
    it (error_estimate of the row's tension, angle and moment, to round-off), with the
    mesh's error in one signed sum, whose sign the rod's own mode confirms."""
    from test_span_bending import sagging

    d = sagging(0.01 ** 2, "clamped", "auto")
    d["modal"] = {"modes": 4}
    probe_case = copy.deepcopy(d)
    probe = run_case(parse_case(d), mpi_tmp_path / "probe", comm, figures=False,
                     progress=False, dynamics=False).summary
    w4 = probe["modes"][3]["omega"]
    d["anchors"][1]["motion"] = {"type": "harmonic", "amplitude": [0.0, 0.0, 1e-4],
                                 "omega": w4}
    d["damping"] = {"ratio": 0.01, "frequencies": [w4, 2 * w4]}
    d["dynamics"] = {"t_end": 0.2, "dt": 0.01}
    s = run_case(parse_case(d), mpi_tmp_path / "run", comm, figures=False,
                 progress=False).summary
    assert s["span_bending"] is False
    assert s["error_resonance_shift"] == pytest.approx(s["modes"][3]["span_bending_shift"],
                                                       rel=1e-12)
    assert s["error_resonance_factor"] > 10
    rows = None
    if comm.rank == 0:
        rows = anchorcsv.read(mpi_tmp_path / "run" / "anchors.csv",
                              ["Nx", "Ny", "Nz", "error_estimate"])["p"]
    rows = comm.bcast(rows, root=0)
    sec = d["section"]
    F = np.column_stack([rows["Nx"], rows["Ny"], rows["Nz"]])
    want = anchor_moments(F, np.array([1.0, 0, 0]), sec["EI"], sec["EA"], sec["mass"],
                          np.zeros((len(F), 3)), np.array([0.0, 0, -1.0]), s["length"], w4,
                          "exact", 1, s["error_resonance_factor"],
                          s["anchors"]["p"]["static_moment"], None,
                          s["error_resonance_shift"],
                          s["error_resonance_mesh"])["error_estimate"]
    # the CSV's 17 digits and the static moment's round trip: 1e-9
    np.testing.assert_allclose(rows["error_estimate"], want, rtol=1e-9)
    # the estimate amplifies the mode's signed net error, string minus rod: the mesh's
    # +0.036 % minus the bending's 0.365 % = -0.33 %; the rod's mode 4 measures -0.48 %
    # (the rest: the hinge's next order, e1 (k ell)^2/2 of theory.md §5.3, whose size the
    # estimate keeps apart). Same sign, within a factor 2; the sum of the sizes, +0.40 %,
    # had the opposite sign.
    net = s["error_resonance_frequency"]
    assert net == pytest.approx(s["error_resonance_mesh"] - s["error_resonance_shift"],
                                rel=1e-12)
    rod = run_case(parse_case(probe_case), mpi_tmp_path / "rod", comm, figures=False,
                   progress=False, dynamics=False, model="beam").summary
    measured = probe["modes"][3]["omega"] / rod["modes"][3]["omega"] - 1
    assert 0.5 < net / measured < 2, (net, measured)


@pytest.mark.parametrize("EI, warns", [(9e-4, False), (6.4e-3, True)])
def test_the_modal_table_has_its_own_validity(mpi_tmp_path, EI, warns):
    """The first six modes of the 10 %-sag cable with horizontal clamps against the rod's:
    at eps = 0.03 within 0.7 %, every mode's k ell <= 0.38 and its estimate (0.4-1.7 %)
    below the 2 % threshold: no warning; at eps = 0.08 the in-plane modes are 1 %, 10 % and
    22 % off (k ell = 0.7 to 1.4, wavelengths not long against the layers): the modes
    are flagged (valid = false beyond k ell = 0.5) and the run warns under 'modal'. On
    both, no mode's estimate is below half its measured error (the estimate's aim, as
    the anchors'). Before, the modal table said nothing."""
    data = tomllib.loads((DEMOS / "paper_inplane.toml").read_text())
    data["section"]["EI"] = EI
    data["anchors"][1]["position"] = [0.974, 0, 0]
    data["modal"] = {"modes": 6}
    case = parse_case(data, DEMOS)
    s = run_case(case, mpi_tmp_path / "s", comm, figures=False, progress=False,
                 dynamics=False).summary
    rod = run_case(case, mpi_tmp_path / "r", comm, figures=False, progress=False,
                   dynamics=False, model="beam").summary
    measured = np.array([m["omega"] / r["omega"] - 1 for m, r in zip(s["modes"],
                                                                     rod["modes"])])
    est = np.array([m["error_estimate"] for m in s["modes"]])
    assert np.all(est >= np.abs(measured) / 2), (est, measured)
    keys = [w["key"] for w in s["warnings"]]
    assert ("modal" in keys) == warns
    assert all(m["valid"] for m in s["modes"]) != warns
    assert "error_estimate" not in rod["modes"][0]  # the rod resolves its layers


def test_the_mesh_term_is_left_out_at_a_parametric_resonance(mpi_tmp_path):
    """Case A is driven at twice its first frequency: a parametric resonance, whose response
    locks its phase to the excitation, so the mesh's frequency error is recorded
    (theta^2/24 with theta = k h, k from the first mode: at least (pi/30)^2/24 = 4.6e-4 on
    its 30 elements, the in-plane mode's higher frequency adding 10 %) but not amplified
    into the estimate (docs/theory.md §5.2; measured: history error 0.84 %, estimate
    0.93 % median without it, 4.2 % with it)."""
    case = load_case(DEMOS / "paper_inplane.toml")
    s = run_case(case, mpi_tmp_path / "a", comm, figures=False, progress=False,
                 dynamics=False).summary
    assert s["error_resonance_kind"] == "parametric"
    assert s["error_resonance_mesh"] >= (np.pi / 30) ** 2 / 24


@pytest.mark.parametrize("kind, mesh, shift, names", [
    ("primary", 4.29e-3, 8.2e-4, "mesh.elements"),  # case B on 20 elements (theory.md §5.2)
    ("primary", 1.2e-4, 3.2e-4, "solver.span_bending"),  # the span's bending the larger
    ("parametric", 5.1e-4, 7.4e-5, "solver.span_bending")])  # case A: no mesh term added
def test_a_resonance_warning_names_the_larger_frequency_error(kind, mesh, shift, names):
    """The estimate amplifies the resonant mode's net frequency error, the mesh's (the
    string's mode high) minus the span's bending (low): putting the bending in removes
    only the second, and in case B (+0.43 % against -0.082 %, primary) it would raise the
    net from 0.35 % to 0.43 %. The warning names the remedy of the larger: more elements
    where the mesh's is, solver.span_bending where the bending's is (at a parametric
    resonance the mesh's is not added). Before, it named solver.span_bending always."""
    from cablefem.app.report import anchor_validity

    summary = {"span_bending": False, "error_resonance_factor": 199.0,
               "error_resonance_kind": kind, "error_resonance_mesh": mesh,
               "error_resonance_shift": shift}
    times = np.linspace(0.0, 3.0, 31)
    rows = {"valid": np.ones(31), "error_estimate": np.full(31, 0.05)}
    anchor_validity(summary, "p", times, rows, ERROR_THRESHOLD)
    (message,) = [w["message"] for w in summary["warnings"]]
    other = {"mesh.elements": "solver.span_bending", "solver.span_bending": "mesh.elements"}
    assert names in message and other[names] not in message
