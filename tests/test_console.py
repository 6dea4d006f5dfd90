"""What a user sees on the console and in the figures: no compiler chatter, no "nan" ETA,
units named, axes that show the data."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cablefem.app.log import Progress
from cablefem.app.plots import moment_axis_range

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.serial
def test_no_compiler_lines_with_an_empty_form_cache(tmp_path):
    """FFCx compiles every element and form anew into an empty cache; setuptools logs each
    gcc command through the root logger ("INFO:root:..."). None of it may reach the console,
    while cablefem's own messages do, with the case's units (a dimensionless case)."""
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path / "cache"))
    proc = subprocess.run([sys.executable, "-m", "cablefem", "run",
                           str(ROOT / "demos" / "paper_inplane.toml"), "-o",
                           str(tmp_path / "out"), "--static-only", "--no-figures"],
                          env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert any((tmp_path / "cache").rglob("*.so")), "the cache was not used: no compile"
    assert "INFO:root" not in proc.stderr and "gcc" not in proc.stderr, proc.stderr[:2000]
    assert "[cablefem] statics: converged" in proc.stderr
    assert "w l" in proc.stderr and " N," not in proc.stderr  # dimensionless, not N


def test_progress_never_prints_nan(capsys):
    bar = Progress(10.0, "dynamics", enabled=True, every_s=0.0)
    bar.enabled = True  # rank 0 or not: the text is what is tested
    bar.update(0.0, "step 0")
    bar.update(5.0, "step 5")
    err = capsys.readouterr().err
    assert "nan" not in err.lower() and "ETA" in err


def test_moment_axis_range_shows_a_small_variation():
    """A +-1.3 % variation about 1.0: the axis spans the data (with 5 % margins), so the
    variation fills the axes instead of being squeezed next to a forced zero."""
    t = np.linspace(0, 1, 200)
    m = 1.0 + 0.013 * np.sin(20 * t)
    lo, hi = moment_axis_range(m)
    span = m.max() - m.min()
    assert lo == pytest.approx(m.min() - 0.05 * span) and hi == pytest.approx(m.max() + 0.05 * span)
    assert lo > 0.9  # zero is not forced in
    assert moment_axis_range(np.array([np.nan])) is None


def test_log_follows_the_current_stderr(monkeypatch):
    """The log handler writes to sys.stderr as it is at each message: a runner that swaps
    (and closes) the stream between uses must not get "I/O operation on closed file"."""
    import io
    import logging

    from cablefem.app.log import setup_logging

    setup_logging(logging.INFO)
    first = io.StringIO()
    monkeypatch.setattr("sys.stderr", first)
    logging.getLogger("cablefem.test").warning("one")
    first.close()
    second = io.StringIO()
    monkeypatch.setattr("sys.stderr", second)
    logging.getLogger("cablefem.test").warning("two")
    from mpi4py import MPI

    if MPI.COMM_WORLD.rank == 0:  # the handler lets rank 0's records through only
        assert "[cablefem] two" in second.getvalue()


def test_the_console_shows_the_static_anchor_moments_and_the_sag(make_case, mpi_tmp_path):
    """After the statics the run logs each anchor's tension and, at a clamped anchor, its
    moment (the tool's main result), and the sag, as summary.json has them: 6 significant
    digits on the console, so within 5e-6 of them relative."""
    import logging
    import re

    from cablefem.app.run import run_case

    records = []

    class Keep(logging.Handler):
        def emit(self, record):
            records.append(record.getMessage())

    logger = logging.getLogger("cablefem")
    handler, old_level = Keep(), logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    try:
        res = run_case(make_case(), mpi_tmp_path, dynamics=False, figures=False,
                       progress=False)
    finally:
        logger.removeHandler(handler)
        logger.setLevel(old_level)
    text = "\n".join(records)
    for name, entry in res.summary["anchors"].items():
        m = re.search(rf"static: anchor {name}: tension (\S+) N, moment (\S+) N m ", text)
        assert m, text
        assert float(m.group(1)) == pytest.approx(entry["static_tension"], rel=5e-6)
        assert float(m.group(2)) == pytest.approx(entry["static_moment"], rel=5e-6)
        assert entry["static_moment"] > 0
    m = re.search(r"static: sag (\S+) of the chord", text)
    assert m, text
    assert float(m.group(1)) == pytest.approx(res.summary["static"]["sag_ratio"], rel=5e-6)


def test_static_state_lines_show_the_most_loaded_of_many_anchors():
    """A network with 20 clamped anchors: the console shows the 12 largest moments
    (console.MAX_LINES) and says how many more summary.json has."""
    from cablefem.app.console import MAX_LINES, static_state_lines

    entries = {f"a{i}": {"static_tension": 100.0 + i, "static_moment": float(i),
                         "static_error_estimate": 1e-3} for i in range(20)}
    lines = static_state_lines(entries, {}, None, "SI", "string")
    shown = [ln.split(":")[1].split()[-1] for ln in lines if ln.startswith("static: anchor")]
    assert MAX_LINES == 12 and shown == [f"a{i}" for i in range(19, 7, -1)]
    assert lines[-1] == "static: 8 more anchors (those with smaller moments or tensions) " \
        "in summary.json"
