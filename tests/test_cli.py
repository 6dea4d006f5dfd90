"""The command line as users meet it: bad input ends with exit code 2 and one line per
problem naming the key, before any solve and without a traceback; a run writes its files;
``cablefem post`` on our own anchor forces reproduces the run's moments."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.serial  # subprocesses: not under mpirun

BASE = """
title = "cli test"
[section]
EA = 17857.14
EI = 4.0e-4
mass = 1.0
[gravity]
g = 1.0
[geometry]
{geometry}
[mesh]
elements = 12
[[anchors]]
name = "p"
position = [0, 0, 0]
{p_extra}
[[anchors]]
name = "q"
position = {q_pos}
[anchors.motion]
{motion}
[dynamics]
t_end = 0.1
dt = 0.005
fields_every = 5
[modal]
modes = 2
"""
GOOD = dict(geometry="length = 1.0", p_extra="", q_pos="[1.0013333, 0, 0]",
            motion='type = "harmonic"\namplitude = [2e-4, 0, 0]\nomega = 32.814')


def cablefem(*args, cwd=None, timeout=300):
    return subprocess.run([sys.executable, "-m", "cablefem", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout)


def write_case(tmp: Path, **changes) -> Path:
    text = BASE.format(**{**GOOD, **changes})
    path = tmp / "case.toml"
    path.write_text(text)
    return path


BAD = [
    ({"geometry": "length = 1.0\nsag_ratio = 0.01"}, "geometry"),
    ({"geometry": "sag_ratio = 20.0"}, "geometry.sag_ratio"),
    ({"geometry": "sag_ratio = -0.01"}, "geometry.sag_ratio"),
    ({"q_pos": "[0, 0, 0]"}, "anchors"),
    ({"p_extra": "direction = [0, 0, 0]"}, "anchors[0].direction"),
    ({"p_extra": "typ = 'clamped'"}, "anchors[0].typ"),
    ({"motion": 'type = "table"\nfile = "missing.csv"'}, "anchors[1].motion.file"),
    ({"motion": 'type = "harmonic"\namplitude = [2e-4, 0, 0]\nomega = -1.0'},
     "anchors[1].motion.omega"),
]


@pytest.mark.parametrize("changes,key", BAD)
def test_bad_input_exit_2_names_key(tmp_path, changes, key):
    case = write_case(tmp_path, **changes)
    res = cablefem("run", case, "--output", tmp_path / "out")
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr
    assert key in res.stderr
    assert not (tmp_path / "out").exists()  # rejected before any work


@pytest.mark.parametrize("field,value", [("EA", "0.0"), ("EI", "-1.0"), ("mass", "0")])
def test_bad_section_values(tmp_path, field, value):
    case = write_case(tmp_path)
    text = case.read_text().replace(f"\n{field} = ", f"\n{field} = {value}\n#", 1)
    case.write_text(text)
    res = cablefem("run", case, "--output", tmp_path / "out")
    bound = ">= 0" if field == "EI" else "> 0"  # EI = 0: the string alone (test_chain.py)
    assert res.returncode == 2 and f"section.{field}" in res.stderr and bound in res.stderr
    assert "Traceback" not in res.stderr


def test_misspelt_key_suggests(tmp_path):
    case = write_case(tmp_path)
    case.write_text(case.read_text().replace("elements = 12", "elemnts = 12"))
    res = cablefem("run", case, "--output", tmp_path / "out")
    assert res.returncode == 2 and "did you mean 'elements'" in res.stderr


def test_malformed_motion_csv(tmp_path):
    (tmp_path / "m.csv").write_text("time,ux,uy,uz\n0,0,0,0\n0.1,abc,0,0\n")
    case = write_case(tmp_path, motion='type = "table"\nfile = "m.csv"')
    res = cablefem("run", case, "--output", tmp_path / "out")
    assert res.returncode == 2 and "m.csv" in res.stderr and "line 3" in res.stderr
    assert "Traceback" not in res.stderr


def test_table_ends_follow_t_end_and_static_only(tmp_path, capsys):
    """A motion table that ends at 0.06 s, dynamics.t_end = 0.1 s: refused for the case's
    own end (exit 2, naming the table's file), but not for --t-end 0.05 nor for
    --static-only, which were refused before ("before the end of the run t = 0.1 s")."""
    from cablefem.app.cli import main

    t = np.linspace(0.0, 0.06, 13)
    rows = "".join(f"{ti!r},{1e-4 * (1 - np.cos(50 * ti)) ** 2!r},0,0\n" for ti in t)
    (tmp_path / "m.csv").write_text("time,ux,uy,uz\n" + rows)
    case = write_case(tmp_path, motion='type = "table"\nfile = "m.csv"')
    assert main(["run", str(case), "-o", str(tmp_path / "a"), "-q", "--no-figures"]) == 2
    assert "anchors[1].motion.file" in capsys.readouterr().err
    assert main(["run", str(case), "-o", str(tmp_path / "b"), "-q", "--no-figures",
                 "--t-end", "0.05"]) == 0
    assert json.loads((tmp_path / "b" / "summary.json").read_text())["dynamics"][
        "t_end"] == 0.05
    assert main(["run", str(case), "-o", str(tmp_path / "c"), "-q", "--no-figures",
                 "--static-only"]) == 0


def test_one_sagging_element_is_refused(tmp_path, capsys):
    """mesh.elements = 1 with a sag (l = 1.0065 > chord 1): the one element is straight
    along the chord, slack; the run reached the dynamics and failed (exit 1). Refused
    before any solve (exit 2, mesh.elements); a taut single element (l < chord) runs."""
    from cablefem.app.cli import main

    case = write_case(tmp_path, geometry="sag_ratio = 0.05", q_pos="[1.0, 0, 0]")
    case.write_text(case.read_text().replace("elements = 12", "elements = 1"))
    assert main(["run", str(case), "-o", str(tmp_path / "a"), "-q", "--no-figures"]) == 2
    assert "mesh.elements" in capsys.readouterr().err
    case.write_text(case.read_text().replace("sag_ratio = 0.05", "length = 0.999"))
    assert main(["run", str(case), "-o", str(tmp_path / "b"), "-q", "--no-figures",
                 "--static-only"]) == 0


def test_restart_of_a_missing_folder_says_so(tmp_path, capsys):
    """--restart of a folder that does not exist said "no checkpoint": now exit 2 with
    "no such folder"; an existing folder without a checkpoint still says no checkpoint."""
    from cablefem.app.cli import main

    assert main(["run", "--restart", str(tmp_path / "nope"), "-q"]) == 2
    assert "nope: no such folder" in capsys.readouterr().err
    assert main(["run", "--restart", str(tmp_path), "-q"]) == 2
    assert "no checkpoint" in capsys.readouterr().err


def test_run_writes_everything_and_post_reproduces(tmp_path):
    case = write_case(tmp_path)
    out = tmp_path / "out"
    res = cablefem("run", case, "--output", out)
    assert res.returncode == 0, res.stderr
    for name in ("summary.json", "anchors.csv", "string.xdmf", "series/string/mesh.h5",
                 "modes.xdmf", "moments.xdmf", "series/moments/mesh.h5",
                 "anchor_moments.png"):
        assert (out / name).is_file(), name
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["dynamics"]["steps"] == 20
    with open(out / "anchors.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 2 * 21  # 21 output times (t = 0 and 20 steps) x 2 anchors
    assert {"delta", "moment", "Mx", "psi0", "layer_length", "valid"} <= set(rows[0])
    # the XDMF time series hold the number of field outputs: t = 0 and every 5 steps
    import meshio

    for name in ("string.xdmf", "moments.xdmf"):
        with meshio.xdmf.TimeSeriesReader(out / name) as reader:
            assert reader.num_steps == 5, name

    post = tmp_path / "post"
    res = cablefem("post", out / "anchors.csv", "--case", case, "--output", post)
    assert res.returncode == 0, res.stderr
    with open(post / "anchors.csv") as fh:
        prow = list(csv.DictReader(fh))
    # the same formulas on the same forces: equal to the 17 digits repr() writes
    a = np.array([float(r["moment"]) for r in rows])
    b = np.array([float(r["moment"]) for r in prow])
    np.testing.assert_allclose(a, b, rtol=1e-14)


def test_modes_command_and_keys(tmp_path):
    case = write_case(tmp_path)
    res = cablefem("modes", case, "--output", tmp_path / "m", "--n", "3")
    assert res.returncode == 0, res.stderr
    s = json.loads((tmp_path / "m" / "summary.json").read_text())
    assert len(s["modes"]) == 3 and s["modes"][0]["omega"] > 0
    res = cablefem("keys")
    assert res.returncode == 0 and "sag_ratio" in res.stdout and "fields_every" in res.stdout
    # a network's keys: its own tables, its dampers by group, no single-cable geometry
    res = cablefem("keys", "--network")
    assert res.returncode == 0, res.stderr
    assert "network.kinks" in res.stdout and "dampers.group" in res.stdout
    assert "sag_ratio" not in res.stdout


def test_fatigue_after_run_and_command(tmp_path):
    """A case with [fatigue] gets fatigue.json/md/png from 'cablefem run'; 'cablefem
    fatigue' on the same folder reproduces its damage (same data, same computation: 1e-12);
    without a [fatigue] table the command exits 2 naming it."""
    case = write_case(tmp_path)
    text = case.read_text().replace("mass = 1.0", "mass = 1.0\ndiameter = 0.05")
    case.write_text(text + '\n[fatigue]\ndetail_category = 1.0e3\nm1 = 4.0\nknee = false\n'
                    'window = "all"\n')  # the whole 0.1 s run lies within the motion's ramp
    out = tmp_path / "out"
    res = cablefem("run", case, "--output", out, "--no-figures")
    assert res.returncode == 0, res.stderr
    for name in ("fatigue.json", "fatigue.md", "fatigue_histogram.png"):
        assert (out / name).is_file(), name
    d_run = json.loads((out / "summary.json").read_text())["fatigue"]["p"]["damage"]
    assert d_run > 0
    res = cablefem("fatigue", out, "--case", case, "--output", tmp_path / "f")
    assert res.returncode == 0, res.stderr
    d_cmd = json.loads((tmp_path / "f" / "fatigue.json").read_text())["anchors"]["p"]["damage"]
    assert d_cmd == pytest.approx(d_run, rel=1e-12)
    plain = write_case(tmp_path / "..")
    res = cablefem("fatigue", out, "--case", plain)
    assert res.returncode == 2 and "fatigue" in res.stderr and "Traceback" not in res.stderr


@pytest.mark.serial
def test_output_cut_short_by_the_reader_is_not_an_error():
    """`cablefem keys | true`: the reader closes the pipe before reading. The command
    stops quietly with exit 0 (before: "internal error: BrokenPipeError", exit 1)."""
    proc = subprocess.Popen([sys.executable, "-m", "cablefem", "keys"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader goes away before the command has written anything
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 0, err
    assert "error" not in err.lower(), err


def test_one_version_number():
    """The installed distribution's version is cablefem.__version__ (pyproject.toml said
    0.1.0 while the package said 0.2.0.dev0)."""
    import importlib.metadata

    import cablefem

    assert importlib.metadata.version("cablefem") == cablefem.__version__
