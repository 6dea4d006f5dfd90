"""benchmarks/bench_peers.py runs its command line without the peers (OpenSees, MoorDyn):
they live in a benchmark-only environment that only a measurement creates, and neither
cablefem nor its tests import them."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "bench_peers.py"

pytestmark = pytest.mark.serial  # a subprocess of its own: nothing to share between ranks


def run(*args: str, venv: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args, "--venv", str(venv)],
                          capture_output=True, text=True, timeout=60)


def test_help_without_peers(tmp_path):
    venv = tmp_path / "no-venv"
    res = run("--help", venv=venv)
    assert res.returncode == 0, res.stderr
    for flag in ("--runs", "--jobs", "--quick", "--json"):
        assert flag in res.stdout
    assert not venv.exists()  # --help installs nothing


def test_unknown_job_refused_before_installing(tmp_path):
    venv = tmp_path / "no-venv"
    res = run("--jobs", "caseA", venv=venv)
    assert res.returncode == 2 and "caseA" in res.stderr
    assert not venv.exists()


def test_peers_not_imported_by_cablefem():
    """Neither peer is a dependency: importing cablefem's post-processing leaves them out."""
    code = ("import sys, cablefem.asymptotics, cablefem.moments; "
            "print(any(m.split('.')[0] in ('openseespy', 'moordyn') for m in sys.modules))")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert res.stdout.strip() == "False"
