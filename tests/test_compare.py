"""``cablefem compare``: two hand-made run folders with known sinusoidal moment histories
(run b = 1.1 x run a over their common time range) give relative differences of 0.1 and the
closed-form steady-state peak and RMS; bad input exits 2 with one line naming the folder or
file. The in-process tests run serially and under ``mpirun -n 2`` (rank 0 writes the
folders); the subprocess tests are serial."""

from __future__ import annotations

import json
import logging
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from cablefem.app.cli import main
from cablefem.app.compare import compare_runs, format_table

COLUMNS = ["time", "anchor", "Nx", "Ny", "Nz", "tension", "delta", "moment", "Mx", "My", "Mz",
           "psi0", "layer_length", "moment_layer", "valid"]
M0, A, W = 2.0, 1.0, 2 * np.pi  # moment = M0 + A sin(W t): period 1
PER_PERIOD = 600  # samples per period; times k / 600 are exact at whole and quarter periods


def _cell(x) -> str:
    return "" if isinstance(x, float) and not math.isfinite(x) else (
        x if isinstance(x, str) else repr(float(x)))


def write_run(folder: Path, *, model: str | None, scale: float, t_end: float,
              after: float = 1.0, anchors=(("p", "clamped"), ("q", "pinned")),
              omega: float | None = 10.0, wall: dict | None = None,
              static_moment: float | None = None, mean: float = M0, phase: float = 0.0,
              per_period: int = PER_PERIOD, first_tension: float = 100.0,
              case: dict | None = None) -> Path:
    """A run folder as cablefem writes it: summary.json and anchors.csv. Clamped anchors
    have ``moment = scale (M0 + A sin(W t))`` for ``t <= 3`` and ``after`` times that
    beyond (what a window over the run's own range, not the common one, would see);
    pinned anchors have empty moment columns. ``model=None``: an old run without the key.
    ``mean`` and ``phase``: ``moment = scale (mean + A sin(W t + phase))``; ``per_period``
    samples per period; the static moment defaults to the first row's (a run that starts
    clean), the static tension is 100 and the first row's ``first_tension``; ``case``: the
    echoed case file. Rank 0 writes; collective."""
    if MPI.COMM_WORLD.rank == 0:
        folder.mkdir(parents=True)
        times = np.arange(round(t_end * per_period) + 1) / per_period
        lines = [",".join(COLUMNS)]
        for t in times:
            for name, kind in anchors:
                tension = first_tension if t == 0 else 100.0
                row = {"time": t, "anchor": name, "Nx": tension, "Ny": 0.0, "Nz": 0.0,
                       "tension": tension}
                if kind == "clamped":
                    m = scale * (mean + A * np.sin(W * t + phase)) * (after if t > 3.0 else 1.0)
                    row.update({"delta": 0.1, "moment": m, "Mx": 0.0, "My": m, "Mz": 0.0,
                                "psi0": 0.0, "layer_length": 0.01, "moment_layer": m,
                                "valid": "1"})
                lines.append(",".join(_cell(row.get(c, math.nan)) for c in COLUMNS))
        (folder / "anchors.csv").write_text("\n".join(lines) + "\n")
        entries = {}
        for name, kind in anchors:
            e = {"kind": kind, "static_tension": 100.0}
            if kind == "clamped":
                e.update({"static_moment": scale * (mean + A * np.sin(phase))
                          if static_moment is None else static_moment * scale,
                          "steady_state_moment": {"peak": 0.0, "rms": 0.0, "mean": 0.0,
                                                  "window": [0.0, 0.0]}})
            entries[name] = e
        summary = {"cablefem": "0.1.0", "status": "completed",
                   "case": case or {"title": "compare test"}, "anchors": entries,
                   "wall_time": wall or {"total": 2.0, "dynamics": 1.5}}
        if model is not None:
            summary["model"] = model
        if omega is not None:
            summary["modes"] = [{"omega": omega, "frequency_hz": omega / (2 * np.pi)}]
        (folder / "summary.json").write_text(json.dumps(summary))
    MPI.COMM_WORLD.Barrier()
    return folder


@pytest.fixture
def runs(mpi_tmp_path):
    """Run a: an old string run (no "model" key), t in [0, 3]. Run b: a beam run, t in
    [0, 4.5], 1.1 x run a up to t = 3 and 5.5 x beyond: the common range is [0, 3], its
    last third [2, 3] holds one whole period."""
    a = write_run(mpi_tmp_path / "string", model=None, scale=1.0, t_end=3.0)
    b = write_run(mpi_tmp_path / "beam", model="beam", scale=1.1, t_end=4.5, after=5.0,
                  omega=10.5, wall={"total": 20.0, "dynamics": 18.0})
    return a, b


def test_compare_known_differences(runs):
    a, b = runs
    res = compare_runs(a, b)
    p = res["anchors"]["p"]
    assert list(res["anchors"]) == ["p"] and res["skipped_anchors"] == []
    assert res["runs"]["a"]["model"] == "string" and res["runs"]["b"]["model"] == "beam"
    assert res["runs"]["a"]["label"] == "string (string)"
    assert res["runs"]["b"]["label"] == "beam (beam)"
    # the last third of the COMMON range [0, 3] (run b alone would give [3, 4.5]); the
    # times k/600 and 3 - 3/3 are exact in binary
    assert res["common_time_range"] == [0.0, 3.0]
    assert p["window"] == [2.0, 3.0]
    # peak |M0 + A sin| = M0 + A, sampled exactly at t = 2.25 (sin = 1 to 1e-15)
    assert p["steady_peak"]["a"] == pytest.approx(M0 + A, rel=1e-14)
    # RMS over a whole period sqrt(M0^2 + A^2/2); the window's 601 samples include both
    # ends of the period (one extra sample with sin = 0): mean(sin^2) = 300/601 instead of
    # 1/2, a relative error of (A^2/2)/(601 (M0^2 + A^2/2)) = 1.8e-4 in RMS^2, half in RMS
    assert p["steady_rms"]["a"] == pytest.approx(math.sqrt(M0 ** 2 + A ** 2 / 2), rel=1e-4)
    assert p["steady_mean"]["a"] == pytest.approx(M0, rel=1e-12)  # sin sums to 0 (round-off)
    # b = 1.1 a sample by sample: the relative differences are 0.1 up to round-off
    for key in ("static_moment", "steady_peak", "steady_rms", "steady_mean"):
        assert p[key]["rel_diff"] == pytest.approx(0.1, abs=1e-12), key
    assert p["static_tension"]["rel_diff"] == 0.0
    assert res["first_frequency"]["omega"]["rel_diff"] == pytest.approx(0.05, abs=1e-14)
    assert res["wall_time"]["total"] == {"a": 2.0, "b": 20.0, "ratio": 10.0}
    assert res["wall_time"]["dynamics"]["ratio"] == pytest.approx(12.0, rel=1e-14)

    # outputs in dir_b (the default): the JSON is the returned dict; a markdown table with
    # one row per quantity; one figure per clamped anchor (none for the pinned q)
    assert json.loads((b / "compare.json").read_text()) == res
    md = (b / "compare.md").read_text()
    assert "| p: steady-state RMS \\|M\\| |" in md and "+10.00 %" in md
    assert "x 10" in md and "+5.00 %" in md
    assert res["figures"] == ["compare_p.png"]
    assert (b / "compare_p.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not (b / "compare_q.png").exists()


def test_the_window_follows_a_common_statistics_start(mpi_tmp_path):
    """Both runs' case files set dynamics.statistics_start = 1: the window is [1, 3] of the
    common range [0, 3] (two whole periods), not its last third [2, 3], as the runs' own
    statistics are; runs that set different starts fall back to the last third."""
    def case(start):
        return {"title": "compare test", "dynamics": {"t_end": 3.0, "statistics_start": start}}

    a = write_run(mpi_tmp_path / "a", model=None, scale=1.0, t_end=3.0, case=case(1.0))
    b = write_run(mpi_tmp_path / "b", model="beam", scale=1.1, t_end=3.0, case=case(1.0))
    res = compare_runs(a, b)
    p = res["anchors"]["p"]
    assert res["statistics_start"] == 1.0 and p["window"] == [1.0, 3.0]
    # RMS over two whole periods, 1201 samples with both ends (sin = 0 twice): as in
    # test_compare_known_differences, a relative error below 1e-4
    assert p["steady_rms"]["a"] == pytest.approx(math.sqrt(M0 ** 2 + A ** 2 / 2), rel=1e-4)
    assert p["steady_rms"]["rel_diff"] == pytest.approx(0.1, abs=1e-12)
    c = write_run(mpi_tmp_path / "c", model="beam", scale=1.1, t_end=3.0, case=case(1.5))
    res = compare_runs(a, c)
    assert res["statistics_start"] is None and res["anchors"]["p"]["window"] == [2.0, 3.0]


def test_compare_static_runs_and_output_folder(mpi_tmp_path):
    """Runs with the static state only (one time): static quantities compared, steady state
    not (no common time range), missing modes and dynamics wall time give nulls."""
    a = write_run(mpi_tmp_path / "a", model="string", scale=1.0, t_end=0.0, omega=None,
                  wall={"total": 1.0})
    b = write_run(mpi_tmp_path / "b", model="beam", scale=1.1, t_end=0.0, omega=None,
                  wall={"total": 3.0})
    out = mpi_tmp_path / "out" / "cmp"
    res = compare_runs(a, b, out)
    p = res["anchors"]["p"]
    assert p["static_moment"]["rel_diff"] == pytest.approx(0.1, abs=1e-12)
    assert p["window"] is None and p["steady_rms"]["rel_diff"] is None
    assert res["common_time_range"] is None
    assert res["first_frequency"]["omega"] == {"a": None, "b": None, "rel_diff": None}
    assert "dynamics" not in res["wall_time"] and res["wall_time"]["total"]["ratio"] == 3.0
    for name in ("compare.json", "compare.md", "compare_p.png"):
        assert (out / name).is_file(), name
    assert not (b / "compare.json").exists()


def _bad_summary(folder: Path) -> None:
    if MPI.COMM_WORLD.rank == 0:
        (folder / "summary.json").write_text('{"anchors": {"p": ')
    MPI.COMM_WORLD.Barrier()


def _bad_csv(folder: Path) -> None:
    if MPI.COMM_WORLD.rank == 0:
        path = folder / "anchors.csv"
        lines = path.read_text().splitlines()
        cells = lines[3].split(",")  # line 4 of the file: anchor p at t = 1/600
        cells[COLUMNS.index("moment")] = "abc"
        lines[3] = ",".join(cells)
        path.write_text("\n".join(lines) + "\n")
    MPI.COMM_WORLD.Barrier()


def _no_csv(folder: Path) -> None:
    if MPI.COMM_WORLD.rank == 0:
        (folder / "anchors.csv").unlink()
    MPI.COMM_WORLD.Barrier()


@pytest.mark.parametrize("spoil,message", [
    (None, "no such run folder"),
    (_bad_summary, "summary.json: not valid JSON (line 1"),
    (_no_csv, "anchors.csv: no such file"),
    (_bad_csv, "anchors.csv:4: column 'moment'"),
])
def test_cli_bad_folder_exit_2(runs, capsys, spoil, message):
    a, b = runs
    if spoil is None:
        b = b.parent / "missing"
    else:
        spoil(b)
    assert main(["compare", str(a), str(b), "-q"]) == 2
    err = capsys.readouterr().err
    assert message in err and str(b) in err, err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_cli_different_anchors_exit_2(runs, mpi_tmp_path, capsys):
    a, _ = runs
    c = write_run(mpi_tmp_path / "other", model="beam", scale=1.0, t_end=1.0,
                  anchors=(("p", "clamped"), ("r", "pinned")))
    assert main(["compare", str(a), str(c)]) == 2
    err = capsys.readouterr().err
    assert "different anchors" in err and "'q'" in err and "'r'" in err, err
    assert not (c / "compare.json").exists()


def test_cli_no_clamped_anchor_exit_2(mpi_tmp_path, capsys):
    pinned = (("p", "pinned"), ("q", "pinned"))
    a = write_run(mpi_tmp_path / "a", model=None, scale=1.0, t_end=1.0, anchors=pinned)
    b = write_run(mpi_tmp_path / "b", model="beam", scale=1.0, t_end=1.0, anchors=pinned)
    assert main(["compare", str(a), str(b)]) == 2
    err = capsys.readouterr().err
    assert "nothing to compare" in err and str(a) in err and str(b) in err, err


def cablefem(*args):
    return subprocess.run([sys.executable, "-m", "cablefem", *map(str, args)],
                          capture_output=True, text=True, timeout=120)


@pytest.mark.serial  # a subprocess: not under mpirun
def test_cli_prints_table(runs, tmp_path):
    a, b = runs
    out = tmp_path / "cmp"
    res = cablefem("compare", a, b, "--output", out)
    assert res.returncode == 0, res.stderr
    assert "p: steady-state RMS |M|" in res.stdout and "+10.00 %" in res.stdout
    assert "steady state: t in [2, 3]" in res.stdout
    assert json.loads((out / "compare.json").read_text())["anchors"]["p"]["window"] == [2, 3]
    res = cablefem("compare", a, b, "-o", out, "-q")
    assert res.returncode == 0 and res.stdout == "" and res.stderr == "", res.stderr
    res = cablefem("compare", a, b, "--bogus")
    assert res.returncode == 2 and "--bogus" in res.stderr
    help_ = cablefem("--help").stdout
    assert "compare" in help_ and "two runs" in help_


# ----------------------------------------------------------------------------- history error
def test_history_error_of_identical_runs_is_zero(mpi_tmp_path):
    a = write_run(mpi_tmp_path / "a", model="string", scale=1.0, t_end=3.0)
    b = write_run(mpi_tmp_path / "b", model="beam", scale=1.0, t_end=3.0)
    res = compare_runs(a, b)
    h = res["anchors"]["p"]["history_error"]
    assert h["value"] == 0.0  # the same samples: the difference is 0 exactly
    assert h["interpolated"] is False and h["samples"] == PER_PERIOD + 1  # window [2, 3]
    assert res["warnings"] == []  # both start clean
    md = (b / "compare.md").read_text()
    assert "| p: history error RMS(b-a)/RMS(a) |  |  | 0.00 % |" in md
    assert "history error" in format_table(res)


@pytest.mark.parametrize("phi", [np.pi, np.pi / 3, 0.1])
@pytest.mark.parametrize("mean", [0.0, M0])
def test_history_error_of_a_phase_shift(mpi_tmp_path, phi, mean):
    """Run b = run a shifted by the phase phi: m_a = mean + A sin(W t), m_b = mean +
    A sin(W t + phi). Over whole periods m_b - m_a = 2 A sin(phi/2) cos(W t + phi/2), whose
    mean square is 2 A^2 sin^2(phi/2), against mean^2 + A^2/2 for run a:
        history error = sqrt(2) A |sin(phi/2)| / sqrt(mean^2 + A^2/2),
    2 |sin(phi/2)| for a pure sinusoid (mean = 0): 2 for half a period. The window [2, 3] is
    one whole period sampled uniformly: the trapezoidal rule integrates these
    trigonometric polynomials exactly, so the only error is round-off (1e-12)."""
    a = write_run(mpi_tmp_path / "a", model="string", scale=1.0, t_end=3.0, mean=mean)
    b = write_run(mpi_tmp_path / "b", model="beam", scale=1.0, t_end=3.0, mean=mean,
                  phase=phi)
    res = compare_runs(a, b)
    h = res["anchors"]["p"]["history_error"]
    exact = np.sqrt(2.0) * A * abs(np.sin(phi / 2)) / np.sqrt(mean**2 + A**2 / 2)
    if mean == 0.0:
        assert exact == pytest.approx(2 * abs(np.sin(phi / 2)), rel=1e-15)
    assert h["value"] == pytest.approx(exact, rel=1e-12)
    assert h["interpolated"] is False


def test_history_error_interpolates_a_different_output_grid(mpi_tmp_path):
    """Run b written at 250 samples per period (run a: 600): b is interpolated linearly
    onto a's times; the interpolation error is at most (W dt_b)^2/8 A = 7.9e-5 A pointwise,
    so the history error of half a period's shift (2 for a pure sinusoid) is within
    7.9e-5 A / RMS_a = 1.1e-4 of 2."""
    a = write_run(mpi_tmp_path / "a", model="string", scale=1.0, t_end=3.0, mean=0.0)
    b = write_run(mpi_tmp_path / "b", model="beam", scale=1.0, t_end=3.0, mean=0.0,
                  phase=np.pi, per_period=250)
    h = compare_runs(a, b)["anchors"]["p"]["history_error"]
    assert h["interpolated"] is True
    bound = (W / 250) ** 2 / 8 * A / (A / np.sqrt(2))
    assert abs(h["value"] - 2.0) < bound
    assert h["value"] != 2.0  # interpolation did change the samples


class _Collect(logging.Handler):
    def __init__(self):
        super().__init__(logging.WARNING)
        self.messages = []

    def emit(self, record):
        self.messages.append(record.getMessage())


@pytest.mark.parametrize("spoil", [None, "moment", "tension"])
def test_first_row_warning(mpi_tmp_path, spoil):
    """A run whose first anchors.csv row is not its static state (here: the static moment
    0.5 against a first row of M0 = 2, or a first-row tension 1.5 times the static 100,
    what an impulsive start gives) makes compare warn: on the console (rank 0's log) and
    under compare.json 'warnings'; a clean run (first row = static state) does not. The
    tolerance (1 % of the larger of the static value and the run's peak) lies between a
    clean start's difference (0.09 %) and the impulsive starts' (3.6 % and more)."""
    a = write_run(mpi_tmp_path / "a", model="string", scale=1.0, t_end=3.0)
    kw = {"moment": {"static_moment": 0.5}, "tension": {"first_tension": 150.0}}.get(spoil, {})
    b = write_run(mpi_tmp_path / "b", model="beam", scale=1.0, t_end=3.0, **kw)
    handler = _Collect()
    logger = logging.getLogger("cablefem.app.compare")
    logger.addHandler(handler)
    try:
        res = compare_runs(a, b)
    finally:
        logger.removeHandler(handler)
    saved = json.loads((b / "compare.json").read_text())
    assert saved["warnings"] == res["warnings"]
    if spoil is None:
        assert res["warnings"] == []
        assert not any("start clean" in m for m in handler.messages)
        return
    # the moment: b's clamped p only; the tension: b's p and q (both first rows spoiled)
    names = ["p"] if spoil == "moment" else ["p", "q"]
    assert [(w["run"], w["anchor"], w["quantity"]) for w in res["warnings"]] == [
        ("b", n, spoil) for n in names]
    for w in res["warnings"]:
        assert w["static"] == (0.5 if spoil == "moment" else 100.0)
        assert w["first_row"] == (M0 if spoil == "moment" else 150.0)
        assert "did not start clean" in w["message"]
        if MPI.COMM_WORLD.rank == 0:  # rank 0 computes and logs
            assert w["message"] in handler.messages
    assert "did not start clean" in (b / "compare.md").read_text()
    assert f"warning: {len(names)} first output row" in format_table(res)


def test_network_anchor_matches_the_single_cable(mpi_tmp_path):
    """A network names the only vertex of anchor group p ``p:0``: compared with a single
    cable (anchors p and q), p:0 is p; b = 1.1 a sample by sample, so the relative
    differences are 0.1 to round-off. A group with two vertices keeps its indices (and the
    anchors then differ: exit 2 as for any other pair of cases)."""
    a = write_run(mpi_tmp_path / "cable", model="beam", scale=1.0, t_end=3.0)
    b = write_run(mpi_tmp_path / "net", model=None, scale=1.1, t_end=3.0,
                  anchors=(("p:0", "clamped"), ("q:0", "pinned")))
    res = compare_runs(a, b)
    assert list(res["anchors"]) == ["p"] and res["skipped_anchors"] == []
    assert res["anchors"]["p"]["steady_rms"]["rel_diff"] == pytest.approx(0.1, abs=1e-12)
    c = write_run(mpi_tmp_path / "net2", model=None, scale=1.0, t_end=1.0,
                  anchors=(("p:0", "clamped"), ("p:1", "clamped"), ("q:0", "pinned")))
    with pytest.raises(ValueError, match="different anchors"):
        compare_runs(a, c)


def _add_kink(folder: Path, scale: float, case: dict, name: str = "damper") -> None:
    """Give a run folder of :func:`write_run` a kink ``name`` (kinks.csv at the times of its
    anchors.csv, ``moment = scale (M0 + A sin(W t))``, static moment ``scale M0``) and the
    echoed case ``case``. Rank 0 writes; collective."""
    if MPI.COMM_WORLD.rank == 0:
        times = sorted({float(line.split(",")[0]) for line in
                        (folder / "anchors.csv").read_text().splitlines()[1:]})
        lines = ["time,kink,s,tension,delta,moment,Mx,My,Mz,layer_length,valid"]
        for t in times:
            m = scale * (M0 + A * np.sin(W * t))
            lines.append(f"{t!r},{name},0.3,100.0,0.1,{m!r},0.0,{m!r},0.0,0.01,1")
        (folder / "kinks.csv").write_text("\n".join(lines) + "\n")
        summary = json.loads((folder / "summary.json").read_text())
        summary["case"] = case
        summary["kinks"] = {name: {"s": 0.3, "static_valid": True,
                                   "static_moment": scale * M0}}
        (folder / "summary.json").write_text(json.dumps(summary))
    MPI.COMM_WORLD.Barrier()


def test_compare_kinks_and_the_model_keys(mpi_tmp_path):
    """A damper stay run by the string and by the rod: pinned anchors, the moment at the
    damper's kink only. The echoed cases differ only in solver.span_bending (the string
    resolves "auto" to false, the rod keeps "auto") and solver.model: the same case. The
    kink is compared as a clamped anchor is: b = 1.1 a sample by sample, so every relative
    difference is 0.1 up to round-off, and the steady peak is M0 + A as in
    test_compare_known_differences (the same window [2, 3])."""
    pinned = (("p", "pinned"), ("q", "pinned"))
    case = {"title": "stay", "section": {"EI": 1.0}}
    a = write_run(mpi_tmp_path / "a", model="string", scale=1.0, t_end=3.0, anchors=pinned)
    b = write_run(mpi_tmp_path / "b", model="beam", scale=1.1, t_end=3.0, anchors=pinned)
    _add_kink(a, 1.0, {**case, "solver": {"span_bending": False, "model": "string"}})
    _add_kink(b, 1.1, {**case, "solver": {"span_bending": "auto", "model": "auto"}})
    res = compare_runs(a, b)
    assert res["same_case"] is True
    assert res["anchors"] == {} and list(res["kinks"]) == ["damper"]
    k = res["kinks"]["damper"]
    assert k["window"] == [2.0, 3.0]
    assert k["steady_peak"]["a"] == pytest.approx(M0 + A, rel=1e-14)
    for key in ("static_moment", "steady_peak", "steady_rms", "steady_mean"):
        assert k[key]["rel_diff"] == pytest.approx(0.1, abs=1e-12), key
    # |1.1 m - m| / |m| = 0.1 at every sample
    assert k["history_error"]["value"] == pytest.approx(0.1, abs=1e-12)
    assert "kink damper: steady-state peak |M|" in format_table(res)
    # another section is another case
    c = write_run(mpi_tmp_path / "c", model="beam", scale=1.1, t_end=3.0, anchors=pinned)
    _add_kink(c, 1.1, {**case, "section": {"EI": 2.0}, "solver": {"span_bending": "auto"}})
    assert compare_runs(a, c)["same_case"] is False
