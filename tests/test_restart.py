"""A long run never loses what it computed: a run stopped by a signal leaves valid files and
says how to resume; ``cablefem run --restart`` then gives the uninterrupted run's
anchors.csv to round-off (here: exactly, as the same operations are repeated)."""

from __future__ import annotations

import csv
import json
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.serial  # subprocesses and signals: not under mpirun

CASE = """
[section]
EA = 17857.14
EI = 4.0e-4
mass = 1.0
[gravity]
g = 1.0
[geometry]
length = 1.0
[[anchors]]
name = "p"
position = [0, 0, 0]
[[anchors]]
name = "q"
position = [1.0013333, 0, 0]
[anchors.motion]
type = "harmonic"
amplitude = [2e-4, 0, 0]
omega = 32.814
[damping]
ratio = 0.005
frequencies = [16.407, 32.814]
[dynamics]
t_end = 10.0
dt = 0.005
fields_every = 20
checkpoint_every = 100
[modal]
modes = 2
"""


def cablefem(*args):
    return subprocess.run([sys.executable, "-m", "cablefem", *map(str, args)],
                          capture_output=True, text=True, timeout=600)


def rows(path: Path) -> np.ndarray:
    with open(path, newline="") as fh:
        return np.array([[float(r[k]) if r[k] else np.nan
                          for k in ("time", "Nx", "Ny", "Nz", "moment", "psi0")]
                         for r in csv.DictReader(fh)])


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("ref")
    case = tmp / "case.toml"
    case.write_text(CASE)
    res = cablefem("run", case, "--output", tmp / "out", "--no-figures", "-q")
    assert res.returncode == 0, res.stderr
    return case, tmp / "out"


@pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_interrupt_and_restart_reproduces(reference, tmp_path, sig, code):
    case, ref = reference
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "cablefem", "run", str(case), "--output",
                             str(out), "--no-figures", "-q"], stderr=subprocess.PIPE,
                            text=True)
    t0 = time.time()
    while not (out / "checkpoint.npz").is_file():
        assert proc.poll() is None and time.time() - t0 < 120, "no checkpoint written"
        time.sleep(0.02)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == code, err
    assert "--restart" in err and "Traceback" not in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    # every file is valid as it stands: the CSV has complete rows, the XDMF files parse
    part = rows(out / "anchors.csv")
    assert part.shape[0] >= 2 and np.all(np.isfinite(part[:, :4]))
    for name in ("string.xdmf", "moments.xdmf"):
        ET.parse(out / name)
    res = cablefem("run", "--restart", out, "--no-figures", "-q")
    assert res.returncode == 0, res.stderr
    a, b = rows(out / "anchors.csv"), rows(ref / "anchors.csv")
    assert a.shape == b.shape
    # the restarted run repeats the operations of the uninterrupted one from the checkpoint
    # (the integrator restarts at every checkpoint in both): equal to round-off
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)
    times = lambda p: [t.get("Value") for t in ET.parse(p).getroot().iter("Time")]  # noqa
    assert times(out / "string.xdmf") == times(ref / "string.xdmf")
    assert times(out / "moments.xdmf") == times(ref / "moments.xdmf")


def test_restart_refuses_changed_case_or_no_checkpoint(reference, tmp_path):
    case, ref = reference
    res = cablefem("run", "--restart", tmp_path)  # an empty folder
    assert res.returncode == 2 and "no checkpoint" in res.stderr
    changed = tmp_path / "case.toml"
    changed.write_text(CASE.replace("t_end = 10.0", "t_end = 11.0"))
    res = cablefem("run", changed, "--restart", ref, "-q")
    assert res.returncode == 2 and "has changed since the checkpoint" in res.stderr
