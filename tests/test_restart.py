"""A long run never loses what it computed: a run stopped by a signal, or killed (SIGKILL)
at any instant -- checkpoint, field writes and XDMF rewrites included -- leaves files that
say what happened, and ``cablefem run --restart`` then ends with the files of the
uninterrupted run: the same ``anchors.csv`` (here exactly: the same operations are repeated
from the checkpoint, at which the uninterrupted run restarts its integrator as well), the
same field frames, the same file names and the whole run's solver counters.

The kills at exact points use the ``CABLEFEM_KILL_AT=<point>:<n>`` hook (cablefem.io.faults);
one kill comes from outside, at whatever instant the run is in."""

from __future__ import annotations

import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest
from conftest import read_series

pytestmark = pytest.mark.serial  # subprocesses, signals and mpirun: not under mpirun

# a tiny cable (8 elements): 60 steps, fields every 4 steps, a checkpoint every 10; its
# anchor moves a little out of the plane, so that psi0 swings about pi ("down"), where
# anchors.csv's branch of each anchor's first row keeps it continuous (a resumed run must
# take that branch from the rows it reads back)
CASE = """
[section]
EA = 17857.14
EI = 4.0e-4
mass = 1.0
[gravity]
g = 1.0
[geometry]
length = 1.0
[mesh]
elements = 8
[[anchors]]
name = "p"
position = [0, 0, 0]
[[anchors]]
name = "q"
position = [1.0013333, 0, 0]
[anchors.motion]
type = "harmonic"
amplitude = [2e-4, 2e-5, 0]
omega = 32.814
[damping]
ratio = 0.005
frequencies = [16.407, 32.814]
[dynamics]
t_end = 0.3
dt = 0.005
fields_every = 4
checkpoint_every = 10
[modal]
modes = 2
"""
DT, FIELDS, CHECK = 0.005, 4, 10
LONG = 1.0  # --t-end of the runs stopped from outside, at an instant we do not choose
COUNTERS = ("steps", "rejected_steps", "newton_iterations", "linear_iterations", "outputs")


def cablefem(*args, env=None):
    return subprocess.run([sys.executable, "-m", "cablefem", *map(str, args)],
                          capture_output=True, text=True, timeout=600,
                          env={**os.environ, **(env or {})})


def rows(path: Path) -> np.ndarray:
    with open(path, newline="") as fh:
        return np.array([[float(r[k]) if r[k] else np.nan
                          for k in ("time", "Nx", "Ny", "Nz", "moment", "psi0")]
                         for r in csv.DictReader(fh)])


series = read_series  # every frame of an XDMF series (conftest)


def files(out: Path) -> list[str]:
    return sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file())


def assert_same_run(out: Path, ref: Path) -> None:
    """``out`` (resumed) holds what the uninterrupted run ``ref`` wrote."""
    a, b = rows(out / "anchors.csv"), rows(ref / "anchors.csv")
    assert a.shape == b.shape
    # the resumed run repeats the uninterrupted one's operations from the checkpoint (both
    # re-estimate the acceleration there): equal to round-off
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)
    for name in ("string.xdmf", "moments.xdmf"):
        fa, fb = series(out / name), series(ref / name)
        assert [t for t, _ in fa] == [t for t, _ in fb], name  # every frame, same times
        for (_, da), (_, db) in zip(fa, fb):
            assert da.keys() == db.keys()
            for key in da:
                np.testing.assert_allclose(da[key], db[key], rtol=1e-12, atol=1e-15)
    # the same files: no extra series, no left-over temporary or discarded part
    assert files(out) == files(ref)
    sa = json.loads((out / "summary.json").read_text())
    sb = json.loads((ref / "summary.json").read_text())
    assert sa["status"] == sb["status"] == "completed"
    # the counters of the whole run, not of its last part
    assert {k: sa["dynamics"][k] for k in COUNTERS} == {k: sb["dynamics"][k] for k in COUNTERS}


def assert_left_running(out: Path) -> dict:
    """What a killed run leaves: summary.json says 'running' and names the checkpoint that
    is on disk."""
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "running"
    with np.load(out / "checkpoint.npz") as z:
        ck = {"time": float(z["time"]), "step": int(z["step"])}
    assert s["checkpoint"] == ck
    return ck


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    path = tmp_path_factory.mktemp("case") / "case.toml"
    path.write_text(CASE)
    return path


@pytest.fixture(scope="module")
def reference(case):
    out = case.parent / "ref"
    res = cablefem("run", case, "--output", out, "--no-figures", "-q")
    assert res.returncode == 0, res.stderr
    return out


@pytest.fixture(scope="module")
def reference_long(case):
    out = case.parent / "ref_long"
    res = cablefem("run", case, "--output", out, "--no-figures", "-q", "--t-end", LONG)
    assert res.returncode == 0, res.stderr
    return out


# (kill point, n-th time it is reached) and the step of the checkpoint left on disk, from
# the case's strides: frames at steps 0, 4, 8, ...; checkpoints at steps 10, 20, ...;
# XDMF writes: 2 whole at the start (string, moments), then 2 appends at every checkpoint.
# A kill in the checkpoint's own writing: test_killed_twice
KILLS = [("step:25", 20),  # between checkpoints
         ("frame-string:5", 10),  # in the middle of the string's frame at step 16
         ("frame-moments:7", 20),  # in the middle of the moments' frame at step 24
         # string.xdmf at the 2nd checkpoint: its new frames appended, its closing lines
         # not (the restart reads its whole frames and writes it whole)
         ("xml:5", 10)]


@pytest.mark.parametrize("point,ck_step", KILLS)
def test_kill_at_any_point_then_restart(case, reference, tmp_path, point, ck_step):
    out = tmp_path / "out"
    res = cablefem("run", case, "--output", out, "--no-figures", "-q",
                   env={"CABLEFEM_KILL_AT": point})
    assert res.returncode == -signal.SIGKILL, res.stderr
    ck = assert_left_running(out)
    assert ck["step"] == ck_step
    res = cablefem("run", "--restart", out, "--no-figures", "-q")
    assert res.returncode == 0, res.stderr
    assert_same_run(out, reference)


def test_killed_twice(case, reference, tmp_path):
    """Killed while writing its 2nd checkpoint (temporary file written, not renamed: the
    1st one stays), then the resumed run killed again (in a field write, before its first
    checkpoint): it resumes from the same checkpoint and ends as the uninterrupted run."""
    out = tmp_path / "out"
    res = cablefem("run", case, "--output", out, "--no-figures", "-q",
                   env={"CABLEFEM_KILL_AT": "checkpoint:2"})
    assert res.returncode == -signal.SIGKILL
    res = cablefem("run", "--restart", out, "--no-figures", "-q",
                   env={"CABLEFEM_KILL_AT": "frame-string:2"})
    assert res.returncode == -signal.SIGKILL
    assert assert_left_running(out)["step"] == CHECK
    res = cablefem("run", "--restart", out, "--no-figures", "-q")
    assert res.returncode == 0, res.stderr
    assert_same_run(out, reference)


def _start_and_wait(case, out, checkpoints=2):
    """A run of --t-end LONG, once its ``checkpoints``-th checkpoint is listed."""
    proc = subprocess.Popen([sys.executable, "-m", "cablefem", "run", str(case), "--output",
                             str(out), "--no-figures", "-q", "--t-end", str(LONG)],
                            stderr=subprocess.PIPE, text=True)
    t0 = time.time()
    while True:
        assert proc.poll() is None, "the run ended before it could be stopped"
        assert time.time() - t0 < 120, "no checkpoint written"
        try:
            ck = json.loads((out / "summary.json").read_text()).get("checkpoint")
            if ck and ck["step"] >= checkpoints * CHECK:
                return proc
        except (OSError, ValueError):
            pass
        time.sleep(0.005)


def test_kill_from_outside_then_restart(case, reference_long, tmp_path):
    out = tmp_path / "out"
    proc = _start_and_wait(case, out)
    proc.kill()  # SIGKILL, wherever the run is
    proc.communicate(timeout=60)
    assert proc.returncode == -signal.SIGKILL
    assert assert_left_running(out)["step"] >= 2 * CHECK
    res = cablefem("run", "--restart", out, "--no-figures", "-q")
    assert res.returncode == 0, res.stderr
    assert_same_run(out, reference_long)


@pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_interrupt_and_restart_reproduces(case, reference_long, tmp_path, sig, code):
    out = tmp_path / "out"
    proc = _start_and_wait(case, out)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == code, err
    assert "--restart" in err and "Traceback" not in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    # every file is valid as it stands: complete CSV rows, every frame listed readable
    part = rows(out / "anchors.csv")
    assert part.shape[0] >= 2 and np.all(np.isfinite(part[:, :4]))
    assert len(series(out / "string.xdmf")) >= 2 and len(series(out / "moments.xdmf")) >= 2
    res = cablefem("run", "--restart", out, "--no-figures", "-q")
    assert res.returncode == 0, res.stderr
    # the same file names (no separate file of the resumed part), every frame, the
    # counters of the whole run
    assert_same_run(out, reference_long)


def test_restart_refusals(case, reference, tmp_path):
    """No checkpoint, a changed case file, a completed run: exit 2 with one line."""
    res = cablefem("run", "--restart", tmp_path)  # an empty folder
    assert res.returncode == 2 and "no checkpoint" in res.stderr
    out = tmp_path / "out"
    res = cablefem("run", case, "--output", out, "--no-figures", "-q",
                   env={"CABLEFEM_KILL_AT": "step:15"})
    assert res.returncode == -signal.SIGKILL
    changed = tmp_path / "case.toml"
    changed.write_text(CASE.replace("t_end = 0.3", "t_end = 0.4"))
    res = cablefem("run", changed, "--restart", out, "-q")
    assert res.returncode == 2 and "has changed since the checkpoint" in res.stderr
    before = (reference / "anchors.csv").read_text()
    for extra in ([], ["--t-end", "0.6"]):
        res = cablefem("run", "--restart", reference, "-q", *extra)
        assert res.returncode == 2 and "complete" in res.stderr, res.stderr
        assert len(res.stderr.strip().splitlines()) == 1
    assert (reference / "anchors.csv").read_text() == before  # nothing re-run


def test_output_times_on_the_grid_and_displacements(case, reference):
    """Output times are step x dt without accumulated round-off (written as the shortest
    decimal: 0.06, not 0.060000000000000005). One displacement convention: string.xdmf's
    mesh is the stress-free reference (straight, of the cable's length l = 1 along the
    chord) and 'displacement' takes it to the current shape; 'dynamic_displacement' is from
    the static state, in both files: moments.xdmf's mesh (the static shape) plus it is the
    string's current position at the anchors."""
    from cablefem.case import load_case

    text = (reference / "anchors.csv").read_text().splitlines()[1:]
    times = sorted({line.split(",")[0] for line in text}, key=float)
    grid = [repr(float(Decimal(repr(DT)) * k)) for k in range(len(times))]
    assert times == grid
    s, m = series(reference / "string.xdmf"), series(reference / "moments.xdmf")
    assert [repr(t) for t, _ in s] == [repr(t) for t, _ in m] == grid[::FIELDS]

    import meshio

    with meshio.xdmf.TimeSeriesReader(reference / "string.xdmf") as r:
        X = r.read_points_cells()[0]
    with meshio.xdmf.TimeSeriesReader(reference / "moments.xdmf") as r:
        P0 = r.read_points_cells()[0]
    p, q = (np.asarray(a.position, float) for a in load_case(case).anchors)
    chord = (q - p) / np.linalg.norm(q - p)
    np.testing.assert_allclose(X, np.linspace(0, 1.0, len(X))[:, None] * chord, atol=1e-15)
    static = s[0][1]["displacement"]  # t = 0 is the static state
    # the string's end nodes are at the virtual hinges, h along each clamp direction from
    # the anchor plus the second order (the default correction, docs/theory.md §6, §6.2)
    hinges = json.loads((reference / "summary.json").read_text())["static"]["virtual_hinges"]
    ends = [p + np.asarray(hinges["p"]["offset"]), q + np.asarray(hinges["q"]["offset"])]
    np.testing.assert_allclose(X[[0, -1]] + static[[0, -1]], ends, atol=1e-15)
    tol = 1e-12 * np.linalg.norm(q)  # positions summed from parts: round-off
    for (t, d), (_, dm) in zip(s, m):
        np.testing.assert_allclose(d["dynamic_displacement"], d["displacement"] - static,
                                   atol=tol)
        np.testing.assert_allclose(d["dynamic_displacement"][0], 0.0, atol=tol)  # p fixed
        np.testing.assert_allclose(P0[[0, -1]] + dm["dynamic_displacement"][[0, -1]],
                                   X[[0, -1]] + d["displacement"][[0, -1]], atol=tol)
        assert "displacement" not in dm  # the moments' mesh is the static shape
    assert np.max(np.abs(s[-1][1]["dynamic_displacement"][-1])) > 1e-5  # q has moved


def test_new_run_replaces_the_folder(case, reference, tmp_path):
    """A new run into a used folder leaves exactly the files of a run into an empty one
    (no stale frame, checkpoint or series of the earlier run); the series live in a
    subfolder, so the top level does not grow with the number of frames."""
    used = tmp_path / "used"
    shutil.copytree(reference, used)
    res = cablefem("run", case, "--output", used, "--no-figures", "-q", "--t-end", "0.1")
    assert res.returncode == 0, res.stderr
    fresh = tmp_path / "fresh"
    res = cablefem("run", case, "--output", fresh, "--no-figures", "-q", "--t-end", "0.1")
    assert res.returncode == 0, res.stderr
    assert files(used) == files(fresh)
    assert len(series(used / "string.xdmf")) == 1 + round(0.1 / DT) // FIELDS
    top = lambda d: sorted(p.name for p in d.iterdir())  # noqa: E731
    assert top(fresh) == top(reference)  # 20 steps or 60: the same top-level files


@pytest.mark.skipif(shutil.which("mpirun") is None, reason="no mpirun")
def test_two_ranks_killed_then_restarted(case, reference, tmp_path):
    """On 2 MPI ranks: one rank killed in a field write, the restart on 2 ranks ends with
    the serial run's files (the partitioned solve agrees with the serial one to round-off
    of the direct solver: 1e-9, as in test_network)."""
    out = tmp_path / "out"
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    cmd = ["mpirun", "-n", "2", sys.executable, "-m", "cablefem", "run"]
    res = subprocess.run(cmd + [str(case), "--output", str(out), "--no-figures", "-q"],
                         env={**env, "CABLEFEM_KILL_AT": "frame-string:5"},
                         capture_output=True, text=True, timeout=600)
    assert res.returncode != 0
    assert assert_left_running(out)["step"] == CHECK
    res = subprocess.run(cmd + ["--restart", str(out), "--no-figures", "-q"], env=env,
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    a, b = rows(out / "anchors.csv"), rows(reference / "anchors.csv")
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9 * 25.0)  # 25 N: the tension
    fa, fb = series(out / "string.xdmf"), series(reference / "string.xdmf")
    assert [t for t, _ in fa] == [t for t, _ in fb]
    for (_, da), (_, db) in zip(fa, fb):
        for key in db:  # nodes and cells in the mesh's order whatever the partition
            np.testing.assert_allclose(da[key], db[key], rtol=1e-9,
                                       atol=1e-9 * np.max(np.abs(db[key])))
    assert files(out) == files(reference)


SEABED_CASE = """
[section]
EA = 1e10
EI = 1e3
mass = 50.0
[gravity]
g = 9.81
[geometry]
length = 150.0
[mesh]
elements = 30
[[anchors]]
name = "anchor"
position = [0, 0, 0]
type = "pinned"
[[anchors]]
name = "fairlead"
position = [120.0, 0, 50.0]
type = "pinned"
[anchors.motion]
type = "ellipse"
axis_cos = [-1.0, 0, 0]
omega = 1.0
ramp = 0.0
[seabed]
z = 0.0
stiffness = 1e6
damping = 1e3
[solver]
outer_correction = "none"
[dynamics]
t_end = 3.0
dt = 0.05
checkpoint_every = 10
"""


def test_touchdown_history_survives_a_kill(tmp_path):
    """A line on the seabed killed between checkpoints and restarted: touchdown.csv holds
    the uninterrupted run's rows (the rows after the checkpoint dropped and written again:
    equal to round-off), one per output time, and the summary's touchdown range is the
    whole run's."""
    case = tmp_path / "seabed.toml"
    case.write_text(SEABED_CASE)
    ref, out = tmp_path / "ref", tmp_path / "out"
    assert cablefem("run", case, "--output", ref, "--no-figures", "-q").returncode == 0
    res = cablefem("run", case, "--output", out, "--no-figures", "-q",
                   env={"CABLEFEM_KILL_AT": "step:25"})
    assert res.returncode == -signal.SIGKILL, res.stderr
    res = cablefem("run", "--restart", out, "--no-figures", "-q")
    assert res.returncode == 0, res.stderr

    def table(path):
        with open(path / "touchdown.csv", newline="") as fh:
            return np.array([[float(r[k]) for k in ("time", "s", "x", "z", "grounded_length")]
                             for r in csv.DictReader(fh)])

    a, b = table(out), table(ref)
    assert a.shape == b.shape == (61, 5)
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)
    sa = json.loads((out / "summary.json").read_text())["touchdown"]
    sb = json.loads((ref / "summary.json").read_text())["touchdown"]
    assert sa["cable"] == pytest.approx(sb["cable"], rel=1e-12)
    assert sa["cable"]["excursion"] > 1.0  # the 2 m surge moves the touchdown
    assert sa["cable"]["times_off_the_seabed"] == 0
