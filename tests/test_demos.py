"""Every literate demo in demos/ runs to its end with ``CI=1`` (the short version) and its
own checks pass: each demo compares its run with a closed form or an independent number
(catenary, Irvine, taut string, the weight from the mesh, the inner solution) and exits
non-zero when a check fails, so the exit code and the "OK" lines are the assertions."""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DEMOS = sorted(p.name for p in (ROOT / "demos").glob("demo_*.py"))

pytestmark = pytest.mark.serial  # each demo is its own process, run once


def test_every_case_file_has_a_demo():
    """A shipped case file without a literate script that runs it is undocumented. A
    load-case set's base case (``base = ...`` in a ``*_set.toml``) is run by its set's demo."""
    files = sorted((ROOT / "demos").glob("*.toml"))
    scripts = {name[len("demo_"):-3] for name in DEMOS}
    bases = {Path(tomllib.loads(p.read_text())["base"]).stem for p in files
             if p.stem.endswith("_set") and p.stem in scripts}
    cases = {p.stem for p in files}
    assert cases <= scripts | bases, f"case files without a demo: {sorted(cases - scripts - bases)}"


@pytest.mark.parametrize("demo", DEMOS)
def test_demo_runs_and_checks(demo, tmp_path):
    env = dict(os.environ, CI="1")
    res = subprocess.run([sys.executable, str(ROOT / "demos" / demo), "--output",
                          str(tmp_path / "out")], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    assert "FAILED" not in res.stdout
    assert res.stdout.count(": OK") >= 1, res.stdout[-3000:]
    assert (tmp_path / "out" / "checks.json").is_file()
