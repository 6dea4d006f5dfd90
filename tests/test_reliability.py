"""Reliability of the command line and of run_case: the anchor-force sign convention of
'cablefem post' and the > 90 degree check, fatigue of networks and failed steps failing the
run, the smallest meshes and more modes than degrees of freedom, the output folder's
checks and lock, the memory estimate, and signals during the build and the statics.

In-process tests run serially and under mpirun -n 2; subprocess tests are serial."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import level_case
from mpi4py import MPI

from cablefem.app.run import RunError, run_case
from cablefem.case import CaseError, load_case, parse_case

comm = MPI.COMM_WORLD
ROOT = Path(__file__).resolve().parents[1]
EA, EI, MASS, G, L, CHORD = 17857.14, 4e-4, 1.0, 1.0, 1.0, 1.0013333


def cablefem(*args, timeout=120, **kw):
    return subprocess.run([sys.executable, "-m", "cablefem", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout, **kw)


def write_toml(path: Path, text: str) -> Path:
    if comm.rank == 0:
        path.write_text(text)
    comm.Barrier()
    return path


CASE = """title = "reliability"
[section]
EA = 17857.14
EI = 4.0e-4
mass = 1.0
diameter = 0.05
[gravity]
g = 1.0
[geometry]
length = 1.0
[mesh]
elements = {elements}
[[anchors]]
name = "p"
position = [0, 0, 0]
direction = [1, 0, 0]
[[anchors]]
name = "q"
position = [1.0013333, 0, 0]
direction = [-1, 0, 0]
{extra}
"""


# ------------------------------------------------------------------ 1. post: sign convention
def _forces_csv(path: Path, sign: float, backwards_rows: int = 0) -> np.ndarray:
    """Anchor forces of the span on the anchors at 11 times: tension 25 N at an angle
    Delta(t) = 0.02 + 0.005 sin(10 t) below the clamp direction (into the span at p, back
    at q); ``sign = -1`` writes the anchor's reaction instead; the first ``backwards_rows``
    rows of p get a force pointing out of the span (angle pi - Delta)."""
    t = np.linspace(0.0, 0.1, 11)
    d = 0.02 + 0.005 * np.sin(10 * t)
    T = 25.0
    p = T * np.column_stack([np.cos(d), 0 * d, -np.sin(d)])
    q = T * np.column_stack([-np.cos(d), 0 * d, -np.sin(d)])
    p[:backwards_rows, 0] *= -1
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time", "anchor", "Nx", "Ny", "Nz"])
        for i, ti in enumerate(t):
            w.writerow([repr(ti), "p", *map(repr, sign * p[i])])
            w.writerow([repr(ti), "q", *map(repr, sign * q[i])])
    return d


def _rows(path: Path, anchor: str) -> list[dict]:
    with open(path, newline="") as fh:
        return [r for r in csv.DictReader(fh) if r["anchor"] == anchor]


@pytest.mark.serial
def test_post_reaction_convention_refused_and_sign_anchor(tmp_path):
    """Forces of the anchor on the line (the other common convention) put every angle near
    pi: 'post' refuses with exit 2 naming the convention and --sign, writing no rows; with
    --sign anchor it gives the same numbers as the span-convention file (same formulas on
    the same forces: 1e-14), the angle Delta that built the forces (1e-12: atan2 of the
    written 17-digit components), and every row valid."""
    case = write_toml(tmp_path / "c.toml", CASE.format(elements=12, extra=""))
    d = _forces_csv(tmp_path / "span.csv", +1.0)
    _forces_csv(tmp_path / "reaction.csv", -1.0)
    res = cablefem("post", tmp_path / "reaction.csv", "--case", case, "-o", tmp_path / "bad")
    assert res.returncode == 2, res.stderr
    assert "--sign anchor" in res.stderr and "force of the span on the anchor" in res.stderr
    assert "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "bad" / "anchors.csv").exists()

    assert cablefem("post", tmp_path / "span.csv", "--case", case, "-o",
                    tmp_path / "a").returncode == 0
    res = cablefem("post", tmp_path / "reaction.csv", "--case", case, "-o", tmp_path / "b",
                   "--sign", "anchor")
    assert res.returncode == 0, res.stderr
    for name in ("p", "q"):
        a, b = _rows(tmp_path / "a" / "anchors.csv", name), _rows(tmp_path / "b" /
                                                                   "anchors.csv", name)
        np.testing.assert_allclose([float(r["moment"]) for r in b],
                                   [float(r["moment"]) for r in a], rtol=1e-14)
        np.testing.assert_allclose([float(r["delta"]) for r in b], d, rtol=1e-12)
        assert all(r["valid"] == "1" for r in b)
    s = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert s["sign"] == "anchor"
    # one name for the first row's moment in 'run' and 'post' summaries
    assert "first_moment" not in s["anchors"]["p"]
    assert s["anchors"]["p"]["static_moment"] == pytest.approx(
        float(_rows(tmp_path / "b" / "anchors.csv", "p")[0]["moment"]), rel=1e-15)


@pytest.mark.serial
def test_post_some_rows_beyond_90_degrees_are_invalid(tmp_path):
    """Three of eleven rows of p pointing out of the span (angle pi - Delta > 90 deg): the
    file is accepted, exactly those rows get valid = 0, the summary counts them with the
    reason; q is untouched."""
    case = write_toml(tmp_path / "c.toml", CASE.format(elements=12, extra=""))
    _forces_csv(tmp_path / "f.csv", +1.0, backwards_rows=3)
    res = cablefem("post", tmp_path / "f.csv", "--case", case, "-o", tmp_path / "o")
    assert res.returncode == 0, res.stderr
    p = _rows(tmp_path / "o" / "anchors.csv", "p")
    assert [r["valid"] for r in p] == ["0"] * 3 + ["1"] * 8
    assert all(float(r["delta"]) > math.pi / 2 for r in p[:3])
    assert all(r["valid"] == "1" for r in _rows(tmp_path / "o" / "anchors.csv", "q"))
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["anchors"]["p"]["invalid_rows"] == {
        "force more than 90 deg from the clamp direction": 3}
    assert s["anchors"]["p"]["valid_fraction"] == pytest.approx(8 / 11, rel=1e-15)


def test_anchor_moments_angle_above_90_degrees_invalid():
    """The shared formula (run and post): a force at Delta > pi/2 from the clamp direction
    is flagged invalid with its reason; Delta < pi/2 stays valid; the angle itself is the
    one built (1e-14: atan2 of exact sines and cosines)."""
    from cablefem.moments import anchor_moments

    deltas = np.array([0.1, 1.5, 1.6, 3.0])
    N = 100.0 * np.column_stack([np.cos(deltas), np.zeros(4), np.sin(deltas)])
    res = anchor_moments(N, np.array([1.0, 0, 0]), 1.0, 1e9, 1.0, np.zeros((4, 3)),
                         np.zeros(3), 100.0)
    np.testing.assert_allclose(res["delta"], deltas, rtol=1e-14)
    assert res["valid"].tolist() == [1, 1, 0, 0]
    assert res["invalid_reason"].tolist()[2:] == [
        "force more than 90 deg from the clamp direction"] * 2
    assert res["invalid_reason"].tolist()[:2] == ["", ""]


# ------------------------------------------------------------------ 2. fatigue of a network
def test_network_run_writes_fatigue(mpi_tmp_path):
    """demos/fan.toml: run_case writes fatigue.json with a positive damage at every clamped
    anchor of the network (12 stay ends), listed in summary['fatigue'] too; 'run_fatigue'
    afterwards on the same folder reproduces it (same data, same computation: 1e-12)."""
    from cablefem.app.fatigue import run_fatigue

    text = (ROOT / "demos" / "fan.toml").read_text().replace(
        '"../meshes/fan_small.msh"', json.dumps(str(ROOT / "meshes" / "fan_small.msh")))
    case = load_case(write_toml(mpi_tmp_path / "fan.toml", text))
    # 0.02 s lie inside the motion's start-up ramp, which the default window leaves out
    case.fatigue = dataclasses.replace(case.fatigue, window="all")
    out = mpi_tmp_path / "out"
    res = run_case(case, out, modes=1, t_end=0.02, figures=False, progress=False)
    fat = res.summary["fatigue"]
    assert "error" not in fat and len(fat) == 12
    assert all(v["damage"] > 0 for v in fat.values())
    on_disk = json.loads((out / "fatigue.json").read_text())["anchors"]
    again = run_fatigue(case, out, mpi_tmp_path / "again", invalid="drop")
    for name, v in fat.items():
        assert on_disk[name]["damage"] == pytest.approx(v["damage"], rel=1e-12)
        assert again[name]["damage"] == pytest.approx(v["damage"], rel=1e-12)


def test_backwards_clamp_invalid_and_failed_fatigue_fails_the_run(mpi_tmp_path):
    """Anchor p clamped pointing out of the span (direction -x): its force is at ~180 deg
    from the clamp direction, so every row of p is invalid (> 90 deg) with a warning naming
    anchors.p; the fatigue report asked for then has no valid sample at p: the run fails
    (RunError naming fatigue, summary status 'failed') instead of ending 'completed'."""
    d = level_case(dynamics={"t_end": 0.01, "dt": 0.005},
                   motion={"type": "harmonic", "amplitude": [2e-4, 0, 0], "omega": 32.814},
                   fatigue={"detail_category": 1.0e3, "m1": 4.0, "knee": False,
                            "window": "all"},  # the 0.01 s lie inside the start-up ramp
                   modal={"modes": 1})
    d["section"]["diameter"] = 0.05
    d["anchors"][0]["direction"] = [-1.0, 0, 0]
    case = parse_case(d)
    with pytest.raises(RunError, match="fatigue"):
        run_case(case, mpi_tmp_path / "o", figures=False, progress=False)
    s = json.loads((mpi_tmp_path / "o" / "summary.json").read_text())
    assert s["status"] == "failed" and "no valid sample" in s["fatigue"]["error"]
    assert s["anchors"]["p"]["valid_fraction"] == 0.0
    assert s["anchors"]["q"]["valid_fraction"] == 1.0
    assert s["anchors"]["p"]["rows_beyond_90deg"] == 3  # t = 0, 0.005, 0.01
    assert "anchors.p" in [w["key"] for w in s["warnings"]]


# ------------------------------------------------------------------ 3. smallest meshes
def test_one_element(mpi_tmp_path):
    """mesh.elements = 1: no free node, no modes (a warning naming modal.modes), statics
    and dynamics still run. With the anchors fixed, the one element's tension is
    EA (chord/l - 1) along the chord and each anchor carries half the weight, m g l / 2
    (exact for a P1 element: 1e-9 for the 17-digit arithmetic of the assembly)."""
    case = parse_case(level_case(elements=1, dynamics={"t_end": 0.01, "dt": 0.005},
                                 motion={"type": "harmonic", "amplitude": [2e-4, 0, 0],
                                         "omega": 32.814}))
    res = run_case(case, mpi_tmp_path / "o", figures=False, progress=False)
    s = res.summary
    assert "modes" not in s
    assert [w["key"] for w in s["warnings"]] == ["modal.modes"]
    Np = np.array(s["static"]["anchor_forces"]["p"])
    assert Np[0] == pytest.approx(EA * (CHORD / L - 1), rel=1e-9)
    assert Np[2] == pytest.approx(-MASS * G * L / 2, rel=1e-9)
    assert res.times.size == 3 and np.all(np.isfinite(res.moments["p"]["moment"]))


def test_more_modes_than_free_dofs(mpi_tmp_path, make_case):
    """3 elements: 2 free nodes, 6 degrees of freedom; 8 modes asked for gives the 6 there
    are and a warning naming modal.modes (SLEPc failed on it before)."""
    case = make_case(elements=3, modal={"modes": 8})
    res = run_case(case, mpi_tmp_path / "o", dynamics=False, figures=False, progress=False)
    om = [m["omega"] for m in res.summary["modes"]]
    assert len(om) == 6 and np.all(np.diff(om) >= 0) and om[0] > 0
    keys = [w["key"] for w in res.summary["warnings"]]
    # besides, 3 elements' modes are outside the mesh's range: the modal table's own
    # validity (docs/theory.md §5.3) warns under "modal"
    assert "modal.modes" in keys and set(keys) <= {"modal.modes", "modal"}


# ------------------------------------------------------------------ 4. the output folder
def test_output_lock_collective(mpi_tmp_path):
    """The verdict reaches every rank: a file as output folder raises OutdirError on all;
    the lock is re-entrant within a process and released after the outermost holder."""
    from cablefem.io.outdir import LOCK_NAME, OutdirError, output_lock

    f = mpi_tmp_path / "afile"
    if comm.rank == 0:
        f.write_text("x")
    comm.Barrier()
    with pytest.raises(OutdirError, match="not a directory"):
        with output_lock(f):
            pass
    d = mpi_tmp_path / "d"
    with output_lock(d):
        with output_lock(d):
            pass
        if comm.rank == 0:  # still held: another open file description cannot take it
            import fcntl

            with open(d / LOCK_NAME) as fh:
                with pytest.raises(BlockingIOError):
                    fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    if comm.rank == 0:
        import fcntl

        with open(d / LOCK_NAME) as fh:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)  # released


@pytest.mark.serial
def test_output_is_a_file(tmp_path):
    case = write_toml(tmp_path / "c.toml", CASE.format(elements=12, extra=""))
    (tmp_path / "out").write_text("not a folder")
    res = cablefem("run", case, "-o", tmp_path / "out")
    assert res.returncode == 2, res.stderr
    assert res.stderr.strip() == (f"cablefem: error: output folder {tmp_path / 'out'}: not a "
                                  "directory (it is a file)")


@pytest.mark.serial
def test_read_only_output_refused_before_work():
    """A read-only output folder: exit 2 naming it, before the statics (no log line of
    theirs). Root writes anywhere, so as root the command runs as 'nobody'."""
    top = Path(tempfile.mkdtemp(prefix="cablefem-ro-"))
    try:
        os.chmod(top, 0o755)
        case = top / "c.toml"
        case.write_text(CASE.format(elements=12, extra=""))
        ro = top / "ro"
        ro.mkdir()
        os.chmod(ro, 0o555)
        kw = {}
        if os.geteuid() == 0:  # 'nobody' with a home of its own (FFCx keeps files there)
            home = top / "home"
            home.mkdir(mode=0o777)
            os.chmod(home, 0o777)
            kw = {"user": 65534, "group": 65534, "cwd": "/tmp",
                  "env": {**os.environ, "HOME": str(home), "XDG_CACHE_HOME": str(home)}}
        res = cablefem("run", case, "-o", ro, **kw)
        assert res.returncode == 2, res.stderr
        assert f"output folder {ro}: not writable" in res.stderr
        assert "statics" not in res.stderr and "Traceback" not in res.stderr
    finally:
        os.chmod(top / "ro", 0o755)
        import shutil

        shutil.rmtree(top)


def _wait_for(path: Path, what, timeout=60.0):
    t0 = time.time()
    while time.time() - t0 < timeout:
        if what(path):
            return True
        time.sleep(0.05)
    return False


@pytest.mark.serial
def test_second_run_refused_and_restart_after_kill9(tmp_path):
    """A run writing into a folder locks it: a second run there exits 2 naming the first
    one's pid, before any work. After kill -9 of the first (the kernel drops its lock),
    --restart and a new run take the folder."""
    dyn = ("[dynamics]\nt_end = 2.0\ndt = 0.001\nfields_every = 100000\n"
           "checkpoint_every = 20\n[anchors.motion]\ntype = 'harmonic'\n"
           "amplitude = [2e-4, 0, 0]\nomega = 32.814\n[modal]\nmodes = 1\n")
    case = write_toml(tmp_path / "c.toml", CASE.format(elements=20, extra=dyn))
    out = tmp_path / "out"
    first = subprocess.Popen([sys.executable, "-m", "cablefem", "run", str(case), "-o",
                              str(out), "--no-figures", "-q"], stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
    try:
        assert _wait_for(out / "checkpoint.npz", Path.is_file)
        res = cablefem("run", case, "-o", out, "--no-figures")
        assert res.returncode == 2, res.stderr
        assert res.stderr.strip() == (f"cablefem: error: output folder {out}: in use by "
                                      f"another run (pid {first.pid}); wait for it to end "
                                      "or choose another folder")
    finally:
        first.send_signal(signal.SIGKILL)
        first.wait()
    # the lock went with the killed process: --restart is not refused for it (whether the
    # files a kill -9 cut short can be continued is the restart's business, not the lock's)
    res = cablefem("run", "--restart", out, "--no-figures", "-q", "--t-end", "0.1")
    assert "in use" not in res.stderr, res.stderr
    res = cablefem("run", case, "-o", out, "--no-figures", "-q", "--t-end", "0.01")
    assert res.returncode == 0, res.stderr
    assert json.loads((out / "summary.json").read_text())["status"] == "completed"


# ------------------------------------------------------------------ 5. memory and signals
def test_memory_estimate_refuses_what_does_not_fit(monkeypatch, make_case):
    """With 1 GB available on every node, 1e6 elements (estimate 4.9 GB) are refused with
    a CaseError naming mesh.elements and the estimate; 1e4 elements (0.19 GB x 1.5) pass."""
    from cablefem.app import resources

    monkeypatch.setattr(resources, "mem_available", lambda: 1.0e9)
    with pytest.raises(CaseError) as err:
        resources.check_memory(make_case(elements=1_000_000), comm)
    assert err.value.problems[0][0] == "mesh.elements" and "GB" in str(err.value)
    est = resources.check_memory(make_case(elements=10_000), comm)
    assert est == pytest.approx(comm.size * resources.BASE_BYTES
                                + resources.BYTES_PER_ELEMENT * 10_000)


@pytest.mark.serial
def test_memory_model_bounds_measured_peak(tmp_path):
    """The estimate against the peak resident memory of a real run of 50 000 elements
    (statics, 1 mode, 2 steps): within the safety factor both ways."""
    from cablefem.app.resources import SAFETY, estimate_memory

    dyn = ("[dynamics]\nt_end = 0.0002\ndt = 0.0001\nfields_every = 1\n[modal]\nmodes = 1\n")
    case = write_toml(tmp_path / "c.toml", CASE.format(elements=50_000, extra=dyn))
    # the run's own peak: measured by a parent of its own, whose only child it is (this
    # process's RUSAGE_CHILDREN keeps the largest of every child so far: a ParaView or demo
    # test run before may have set it)
    probe = ("import resource, subprocess, sys; "
             "r = subprocess.run([sys.executable, '-m', 'cablefem', *sys.argv[1:]], "
             "capture_output=True, text=True); sys.stderr.write(r.stderr); "
             "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); "
             "sys.exit(r.returncode)")
    res = subprocess.run([sys.executable, "-c", probe, "run", str(case), "-o",
                          str(tmp_path / "o"), "--no-figures", "-q"],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    peak = float(res.stdout.split()[-1]) * 1024.0  # ru_maxrss is in kB on Linux
    est = estimate_memory(50_000, 1)
    assert est / SAFETY < peak < est * SAFETY


@pytest.mark.serial
def test_ten_million_elements_refused_at_once(tmp_path):
    """10 million elements: refused in seconds (exit 2, mesh.elements, the estimate),
    before any folder is made -- where the estimate does not fit this machine."""
    from cablefem.app.resources import SAFETY, estimate_memory, mem_available

    avail = mem_available()
    if avail is None or SAFETY * estimate_memory(10_000_000) <= avail:
        pytest.skip("this machine has the memory for 10 million elements")
    case = write_toml(tmp_path / "c.toml", CASE.format(elements=10_000_000, extra=""))
    t0 = time.time()
    res = cablefem("run", case, "-o", tmp_path / "o", timeout=30)
    assert res.returncode == 2, res.stderr
    assert "mesh.elements" in res.stderr and "GB" in res.stderr
    assert time.time() - t0 < 20 and not (tmp_path / "o").exists()


def _interrupt_at(tmp_path, marker: str, elements: int):
    """Start a run, send SIGINT when its log shows ``marker``; (exit code, seconds from
    the signal to the exit, stderr)."""
    case = write_toml(tmp_path / "c.toml", CASE.format(elements=elements,
                                                      extra="[modal]\nmodes = 1\n"))
    proc = subprocess.Popen([sys.executable, "-m", "cablefem", "run", str(case), "-o",
                             str(tmp_path / "o"), "--static-only", "--no-figures"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    lines = []
    try:
        for line in proc.stderr:
            lines.append(line)
            if marker in line:
                break
        assert marker in "".join(lines), "".join(lines)
        proc.send_signal(signal.SIGINT)
        t0 = time.time()
        rest = proc.stderr.read()
        proc.wait(timeout=60)
        return proc.returncode, time.time() - t0, "".join(lines) + rest
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.serial
@pytest.mark.parametrize("marker", ["build: function spaces", "statics: "])
def test_sigint_during_build_and_statics(tmp_path, marker):
    """A real SIGINT to a real run of 200 000 elements, sent when the log shows the build
    (its function spaces) or the statics starting: exit 130 within a few seconds (the
    C call in progress finishes first: about a second at this size), one line, no
    traceback."""
    code, dt, err = _interrupt_at(tmp_path, marker, 200_000)
    assert code == 130, err
    assert dt < 5.0, (dt, err)
    print(f"stopped {dt:.2f} s after SIGINT")
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith("cablefem: stopped by SIGINT")


def test_small_problem_note():
    """The note on too many ranks for too few degrees of freedom: none on one rank or with
    enough dofs per rank, one below the threshold."""
    from cablefem.app.resources import MIN_DOFS_PER_RANK, note_small_problem

    class Two:
        size = 2

    assert note_small_problem(100, MPI.COMM_SELF) is None
    assert note_small_problem(2 * MIN_DOFS_PER_RANK, Two()) is None
    assert "per rank" in note_small_problem(2 * MIN_DOFS_PER_RANK - 1, Two())


def test_small_problem_note_in_summary(mpi_tmp_path, make_case):
    """run_case lists the note in summary['notes'] when run on more ranks than pay off
    (12 elements: 39 degrees of freedom)."""
    from cablefem.app.resources import MIN_DOFS_PER_RANK

    res = run_case(make_case(elements=12), mpi_tmp_path / "o", modes=1, dynamics=False,
                   figures=False, progress=False)
    dofs = res.summary["degrees_of_freedom"]
    assert dofs == 39
    assert ("notes" in res.summary) == (comm.size > 1 and dofs < MIN_DOFS_PER_RANK * comm.size)
