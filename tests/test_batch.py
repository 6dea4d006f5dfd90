"""`cablefem batch`: load-case set files and their runs (docs/loadsets.md).

The cases are a tiny clamped string (20 elements) whose anchor q moves harmonically for a few
periods, with a [fatigue] table whose window is the statistics window (dynamics.
statistics_start): a run takes about a second.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
from mpi4py import MPI

from cablefem.app.batch import run_batch
from cablefem.app.cli import main
from cablefem.case import CaseError
from cablefem.case.loadset import case_dict, load_loadset

BASE = """title = "batch test"
[section]
EA = 17857.14
EI = 4e-4
mass = 1.0
[gravity]
g = 1.0
[geometry]
length = 1.0
[mesh]
elements = 20
[solver]
outer_correction = "none"
petsc_options = {}
[[anchors]]
name = "p"
position = [0.0, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
[[anchors]]
name = "q"
position = [1.0013333, 0.0, 0.0]
direction = [-1.0, 0.0, 0.0]
[anchors.motion]
type = "harmonic"
amplitude = [0.0, 0.0, 2e-3]
omega = 3.0
ramp = 2.0
[dynamics]
t_end = 6.0
dt = 0.05
statistics_start = 3.0
checkpoint_every = 20
[fatigue]
detail_category = 0.02
area = 1.0
modulus = 1.0
window = "steady"
"""

SET = """base = "base.toml"
design_life = 50
total_hours = 8766
[[cases]]
name = "low"
hours = 3000
[[cases]]
name = "mid"
probability = 0.25
[cases.overrides]
"anchors.q.motion.amplitude" = [0.0, 0.0, 3e-3]
[[cases]]
name = "high"
hours = 1000
[cases.overrides]
"anchors.q.motion.amplitude" = [0.0, 0.0, 4e-3]
"dynamics.t_end" = 7.0
"""
HOURS = {"low": 3000.0, "mid": 0.25 * 8766, "high": 1000.0}
LIFE = 50.0


def write_set(folder: Path, text: str = SET) -> Path:
    if MPI.COMM_WORLD.rank == 0:
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "base.toml").write_text(BASE)
        (folder / "set.toml").write_text(text)
    MPI.COMM_WORLD.Barrier()
    return folder / "set.toml"


def numbers(design: dict) -> dict:
    """design.json without what differs between two runs of the same set (wall times)."""
    d = json.loads(json.dumps(design))
    for c in d["cases"]:
        c.pop("wall_time")
    d.pop("loadset", None)
    return d


def test_design_damage_is_the_weighted_sum_of_the_cases(mpi_tmp_path):
    """Every location's design damage equals the sum over the cases of the damage in
    fatigue.json over its window duration times the case's hours over the design life,
    recomputed here from each case folder (the same floating-point sum: round-off only)."""
    out = mpi_tmp_path / "out"
    res = run_batch(load_loadset(write_set(mpi_tmp_path)), out, MPI.COMM_WORLD, figures=False)
    design = res.design
    assert design["complete"] and not res.failed
    assert json.loads((out / "design.json").read_text())["fatigue"] == design["fatigue"]
    for loc in ("p", "q"):
        parts = []
        for name, hours in HOURS.items():
            rep = json.loads((out / name / "seed0" / "fatigue.json").read_text())["anchors"]
            assert rep[loc]["duration"] > 0 and rep[loc]["damage"] > 0
            parts.append(rep[loc]["damage"] / rep[loc]["duration"] * hours * 3600 * LIFE)
        # the same terms summed exactly (fsum) on both sides: 1e-14 is round-off
        assert math.isclose(design["fatigue"][loc]["damage"], math.fsum(parts), rel_tol=1e-14)
        shares = [c["damage"][loc] for c in design["cases"]]
        assert math.isclose(math.fsum(shares), design["fatigue"][loc]["damage"],
                            rel_tol=1e-14)
    # the override reached the run: its window ends at the overridden t_end
    assert design["cases"][2]["window"] == [3.0, 7.0]
    if MPI.COMM_WORLD.rank == 0:
        assert (out / "design_damage.png").is_file()


@pytest.mark.parametrize("ranks_per_case", [1, MPI.COMM_WORLD.size])
def test_world_and_one_rank_give_the_same_design(mpi_tmp_path, ranks_per_case):
    """The set on every rank of the world (groups of ranks_per_case) and on one rank (each
    rank alone, COMM_SELF) give the same design.json numbers (groups of one rank solve the
    same equations in the same order: equal; a case split over 2 ranks: its solves'
    round-off, 1e-9 relative)."""
    comm = MPI.COMM_WORLD
    ls = load_loadset(write_set(mpi_tmp_path))
    world = run_batch(ls, mpi_tmp_path / "world", comm, ranks_per_case=ranks_per_case,
                      figures=False).design
    alone = run_batch(ls, mpi_tmp_path / f"self{comm.rank}", MPI.COMM_SELF,
                      figures=False).design
    a, b = numbers(world), numbers(alone)
    for loc in a["fatigue"]:
        assert b["fatigue"][loc]["damage"] == pytest.approx(a["fatigue"][loc]["damage"],
                                                            rel=1e-9)
        assert b["extremes"][loc]["max_moment"] == pytest.approx(
            a["extremes"][loc]["max_moment"], rel=1e-9)
    assert [(c["name"], c["status"]) for c in a["cases"]] == [
        (c["name"], c["status"]) for c in b["cases"]]
    if ranks_per_case == 1:
        assert a["fatigue"] == b["fatigue"]


@pytest.mark.parametrize("edit, key", [
    (("design_life = 50", "design_lif = 50"), "design_lif"),
    (('"dynamics.t_end" = 7.0', '"fluid.current" = [1.0, 0.0, 0.0]'),
     "cases[2].overrides.fluid.current"),
    (('"dynamics.t_end" = 7.0', '"anchors.r.motion.omega" = 2.0'),
     "cases[2].overrides.anchors.r.motion.omega"),
    (("hours = 3000", "hours = 0"), "cases[0].hours"),
    (('name = "low"\nhours = 3000', 'name = "low"\nhours = 3000\nseeds = -1'),
     "cases[0].seeds"),
    (('name = "low"\nhours = 3000', 'name = "low"\nhours = 3000\nseeds = 2'),
     "cases[0].seeds"),
    (('name = "mid"', 'name = "low"'), "cases[1].name"),
    (("probability = 0.25", "probability = 1.5"), "cases[1].probability"),
    (('"dynamics.t_end" = 7.0', '"dynamics.dt" = -0.1'), "dynamics.dt"),
    (('"dynamics.t_end" = 7.0', '"anchors.q.motion.omega" = "fast"'),
     "anchors[1].motion.omega"),
])
def test_bad_set_files_are_refused_before_any_run(mpi_tmp_path, capsys, edit, key):
    """Exit 2, the key named on stderr, no output folder: nothing ran."""
    old, new = edit
    assert old in SET
    path = write_set(mpi_tmp_path, SET.replace(old, new, 1))
    out = mpi_tmp_path / "out"
    assert main(["batch", str(path), "--output", str(out)]) == 2
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:
        assert key in err, err
    assert not out.exists()
    with pytest.raises(CaseError):
        load_loadset(path)


def test_a_failed_case_leaves_the_design_incomplete(mpi_tmp_path, capsys):
    """A case whose Newton solve cannot converge (1 iteration, an unreachable tolerance:
    as tests/test_dynamics.py) fails; the batch runs the others, design.json says the design
    is incomplete with the case's status, and the command exits 1."""
    text = SET.replace('"dynamics.t_end" = 7.0', '"solver.petsc_options" = {snes_max_it = 1, '
                       'ts_max_reject = 0, snes_rtol = 1e-14, snes_atol = 1e-30}')
    path, out = write_set(mpi_tmp_path, text), mpi_tmp_path / "out"
    assert main(["batch", str(path), "--output", str(out), "--no-figures"]) == 1
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:  # a line per run on rank 0, the design at the end
        assert "[3/3]" in err and "high seed 0: failed" in err, err
        assert "design damage over 50 years" in err and "INCOMPLETE" in err, err
    design = json.loads((out / "design.json").read_text())
    assert not design["complete"]
    assert [c["status"] for c in design["cases"]] == ["completed", "completed", "failed"]
    assert any("'high'" in w and "did not finish" in w for w in design["warnings"])
    low = json.loads((out / "low" / "seed0" / "fatigue.json").read_text())["anchors"]["p"]
    share = design["cases"][0]["damage"]["p"]  # the finished cases still count
    assert share == pytest.approx(low["damage"] / low["duration"] * 3000 * 3600 * LIFE,
                                  rel=1e-14)  # the same product: round-off


@pytest.mark.parametrize("option", [["--ranks-per-case", "3"], ["--ranks-per-case", "0"],
                                    ["--t-end", "0"]])
def test_bad_options_are_refused_before_any_run(mpi_tmp_path, capsys, option):
    """--ranks-per-case must divide the number of ranks (1 or 2 here: 3 never does);
    --t-end must be > 0: exit 2 naming the option, nothing written."""
    path, out = write_set(mpi_tmp_path), mpi_tmp_path / "out"
    assert main(["batch", str(path), "--output", str(out), *option]) == 2
    assert option[0] in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.single_rank  # text only
def test_keys_lists_the_set_file_keys(capsys):
    from cablefem.case.loadset import LOADSET_KEYS

    assert main(["keys", "--loadset"]) == 0
    out = capsys.readouterr().out
    assert all(key in out for key in LOADSET_KEYS) and "cases[].overrides" in out


@pytest.mark.single_rank  # pure Python: dicts
def test_seed_k_shifts_every_seed_key():
    """Seed k adds k to the seed key of every table whose schema has one, given or not
    (the default then), and leaves the base untouched."""
    base = {"fluid": {"spectrum": {"hs": 1.0, "tp": 8.0}, "density": 1025.0},
            "dynamics": {"t_end": 10.0}}
    d = case_dict(base, {"fluid.spectrum.hs": 2.0}, 3, t_end=5.0)
    assert d["fluid"]["spectrum"] == {"hs": 2.0, "tp": 8.0, "seed": 1 + 3}  # default 1
    assert d["dynamics"]["t_end"] == 5.0 and "seed" not in base["fluid"]["spectrum"]
    base["fluid"]["spectrum"]["seed"] = 7
    assert case_dict(base, {}, 2)["fluid"]["spectrum"]["seed"] == 9


def cablefem(*args, env=None):
    return subprocess.run([sys.executable, "-m", "cablefem", *map(str, args)],
                          capture_output=True, text=True, timeout=600,
                          env={**os.environ, **(env or {})})


@pytest.mark.serial  # a subprocess killed with SIGKILL
def test_killed_batch_resumes_to_the_same_design(tmp_path):
    """SIGKILL in the second case's dynamics (step 160 of the command: the first case has
    120 steps, the second checkpoints every 20); the same command again leaves the first
    case's files untouched, resumes the second from its checkpoint, and design.json equals
    that of an uninterrupted batch (the restart reproduces the run: round-off, 1e-12)."""
    path = write_set(tmp_path)
    cmd = ["batch", path, "--no-figures", "-q", "--output"]
    full = cablefem(*cmd, tmp_path / "full")
    assert full.returncode == 0, full.stderr
    killed = cablefem(*cmd, tmp_path / "out", env={"CABLEFEM_KILL_AT": "step:160"})
    assert killed.returncode == -9, killed.stderr
    first = tmp_path / "out" / "low" / "seed0"
    before = {f: (f.stat().st_mtime_ns, f.read_bytes()) for f in first.rglob("*")
              if f.is_file() and f.name != ".cablefem.lock"}
    assert json.loads((first / "summary.json").read_text())["status"] == "completed"
    second = json.loads((tmp_path / "out" / "mid" / "seed0" / "summary.json").read_text())
    assert second["status"] == "running"
    again = cablefem(*cmd, tmp_path / "out")
    assert again.returncode == 0, again.stderr
    after = {f: (f.stat().st_mtime_ns, f.read_bytes()) for f in before}
    assert after == before
    resumed = json.loads((tmp_path / "out" / "mid" / "seed0" / "summary.json").read_text())
    assert resumed["restarted_from"] > 0  # from its checkpoint, not from the start
    a = numbers(json.loads((tmp_path / "full" / "design.json").read_text()))
    b = numbers(json.loads((tmp_path / "out" / "design.json").read_text()))
    for loc in a["fatigue"]:
        assert b["fatigue"][loc]["damage"] == pytest.approx(a["fatigue"][loc]["damage"],
                                                            rel=1e-12)
        assert b["extremes"][loc]["max_moment"] == pytest.approx(
            a["extremes"][loc]["max_moment"], rel=1e-12)
    assert [c["status"] for c in b["cases"]] == ["completed"] * 3


def test_overrides_for_every_case(mpi_tmp_path):
    """``load_loadset(..., overrides=)`` sets its keys in every case after the case's own
    (what the set demos do for a short run); a key the base case does not set is refused
    once, under ``overrides.<key>``."""
    path = write_set(mpi_tmp_path)
    ls = load_loadset(path, overrides={"dynamics.statistics_start": 1.5,
                                       "anchors.q.motion.amplitude": [0.0, 0.0, 1e-3]})
    for case in ls.cases:
        for d in case.cases:
            assert d["dynamics"]["statistics_start"] == 1.5
            assert d["anchors"][1]["motion"]["amplitude"] == [0.0, 0.0, 1e-3]
    assert ls.cases[2].cases[0]["dynamics"]["t_end"] == 7.0  # the case's own key stays
    with pytest.raises(CaseError) as err:
        load_loadset(path, overrides={"fluid.current": [1.0, 0.0, 0.0]})
    keys = [k for k, _ in err.value.problems]
    assert keys == ["overrides.fluid.current"]
