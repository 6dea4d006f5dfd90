"""Figures of every kind of case (cablefem.app.historyplots): a mooring line (no clamped
anchor needed) gets its anchors' tensions and its touchdown drawn, a cable with a damper its
damper's force and stroke and its kink's moment; each figure's axes say their quantity and
unit, and its curves are the recorded histories (serially and under mpirun -n 2)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from cablefem.app import historyplots
from cablefem.app.run import run_case
from cablefem.case import load_case, parse_case

comm = MPI.COMM_WORLD
DEMOS = Path(__file__).resolve().parents[1] / "demos"
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture
def drawn(monkeypatch):
    """The figures' axes as drawn: file name -> [(y label, x label, [curves' y data])]."""
    out = {}
    save = historyplots._save

    def spy(fig, outdir, name, title, tu, axes):
        got = save(fig, outdir, name, title, tu, axes)
        out[name] = [(ax.get_ylabel(), ax.get_xlabel(),
                      [np.asarray(line.get_ydata(), float) for line in ax.get_lines()])
                     for ax in axes]
        return got
    monkeypatch.setattr(historyplots, "_save", spy)
    return out


def _pngs(outdir: Path, names) -> None:
    for n in names:
        assert (outdir / n).read_bytes()[:8] == PNG, n


def test_mooring_run_draws_tensions_and_touchdown(mpi_tmp_path, drawn):
    """demos/mooring.toml for 1 s: anchor_tensions.png with one panel per anchor (the
    fairlead's included) whose curve is |N| of the recorded forces (exactly), in N over
    s, and touchdown.png with the touchdown's station in m."""
    res = run_case(load_case(DEMOS / "mooring.toml"), mpi_tmp_path, comm, t_end=1.0,
                   progress=False, modes=0)
    names = res.summary["figures"]
    assert {"anchor_tensions.png", "touchdown.png"} <= set(names), names
    if comm.rank != 0:
        return
    _pngs(mpi_tmp_path, names)
    panels = drawn["anchor_tensions.png"]
    assert [p[0] for p in panels] == [f"T at {a} [N]" for a in res.forces]
    assert panels[-1][1] == "time t [s]"
    for (_, _, curves), F in zip(panels, res.forces.values()):
        np.testing.assert_array_equal(curves[0], np.linalg.norm(F, axis=1))
    (ylabel, _, curves), = drawn["touchdown.png"]
    assert ylabel.endswith("[m]")
    s = res.summary["touchdown"]["cable"]
    assert np.nanmin(curves[0]) == s["s_min"] and np.nanmax(curves[0]) == s["s_max"]


def test_damper_run_draws_force_stroke_and_kink(mpi_tmp_path, drawn):
    """A cable with a damper: dampers.png (force in N, stroke in m: the peaks of the curves
    are the summary's run peaks, exactly) and kink_moments.png (N m); no touchdown."""
    from test_damperout import taut

    res = run_case(parse_case(taut(direction=None, correction="hinge")), mpi_tmp_path, comm,
                   progress=False, modes=0)
    names = res.summary["figures"]
    assert {"dampers.png", "kink_moments.png", "anchor_tensions.png"} <= set(names)
    assert "touchdown.png" not in names
    if comm.rank != 0:
        return
    _pngs(mpi_tmp_path, names)
    (fl, _, fc), (sl, xl, sc) = drawn["dampers.png"]
    assert (fl, sl, xl) == ("damper force [N]", "stroke [m]", "time t [s]")
    entry = res.summary["dampers"]["damper0"]
    assert np.max(np.abs(fc[0])) == entry["force_run_peak"]
    assert np.max(np.abs(sc[0])) == entry["stroke_run_peak"]
    (kl, _, _), = drawn["kink_moments.png"]
    assert kl == "kink moment |M| [N m]"
