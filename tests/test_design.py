"""The design of a load-case set (cablefem.design): Miner's damage over the design life as
the exact sum of the records' shares, a hand-computed 2-case x 2-seed design, the life and
the governing case, the Gumbel most probable maximum against closed forms, incomplete sets,
and a record read from a real run's folder."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from cablefem.design import (
    CaseRecord,
    assemble_design,
    case_record,
    gumbel_moments,
    write_design_figures,
)

DEMOS = Path(__file__).resolve().parents[1] / "demos"
EPS = np.finfo(float).eps


def rec(name, seed, hours, damages, duration=600.0, status="finished", maxima=None,
        window=(0.0, 600.0)):
    """A synthetic record: location -> damage in a window of ``duration`` s."""
    fat = {loc: {"damage": d, "duration": duration} for loc, d in damages.items()}
    return CaseRecord(name, seed, hours, status, 1.0, window, fat, maxima or {},
                      f"{name}/seed{seed}")


def test_design_damage_is_the_sum_of_the_shares():
    """3 cases with 1, 2 and 3 seeds, damages over 9 orders of magnitude: the cases' shares
    add up to the design damage at every location, to the round-off of the sum."""
    rng = np.random.default_rng(3)
    records = []
    for c, (n, hours) in enumerate(((1, 7000.0), (2, 1500.0), (3, 3.5))):
        for s in range(n):
            dmg = {loc: float(10 ** rng.uniform(-12, -3)) for loc in ("p", "q", "kink:d")}
            records.append(rec(f"c{c}", s, hours, dmg, duration=float(rng.uniform(300, 900))))
    design = assemble_design(records, 50.0)
    assert design["complete"] and design["warnings"] == []
    for loc, entry in design["fatigue"].items():
        shares = [case["damage"][loc] for case in design["cases"]]
        # 6 additions: at most 6 roundings of the sum (the design uses fsum: 0 here)
        assert abs(sum(shares) - entry["damage"]) <= 6 * EPS * entry["damage"]
        assert math.fsum(shares) == entry["damage"]
        assert math.isclose(math.fsum(entry["cases"].values()), entry["damage"],
                            rel_tol=4 * EPS)  # 3 case sums, each rounded once


def two_by_two():
    """calm: 6000 h/year, seeds 1e-6 in 600 s and 3e-6 in 1200 s; storm: 20 h/year, seeds
    4e-4 and 2e-4 in 600 s each."""
    return [rec("calm", 0, 6000.0, {"p": 1e-6}, 600.0),
            rec("calm", 1, 6000.0, {"p": 3e-6}, 1200.0),
            rec("storm", 0, 20.0, {"p": 4e-4}, 600.0),
            rec("storm", 1, 20.0, {"p": 2e-4}, 600.0)]


def test_two_cases_two_seeds_by_hand():
    """By hand, over 25 years: calm's mean rate (1e-6/600 + 3e-6/1200)/2 = 2.0833e-9 /s
    times 6000*3600*25 s = 1.125; storm's (4e-4 + 2e-4)/600/2 = 5e-7 /s times 20*3600*25 s
    = 0.9; design damage 2.025, life 25/2.025 = 12.3457 years, governing case calm (1.125 >
    0.9). Seed shares: calm 0.45 and 0.675, storm 0.6 and 0.3."""
    design = assemble_design(two_by_two(), 25.0)
    f = design["fatigue"]["p"]
    # a few multiplications and divisions: each rounding <= eps; 1e-13 leaves a margin
    tol = dict(rel_tol=1e-13)
    assert math.isclose(f["damage"], 2.025, **tol)
    assert math.isclose(f["life_years"], 25.0 / 2.025, **tol)
    assert f["governing_case"] == "calm"
    assert math.isclose(f["cases"]["calm"], 1.125, **tol)
    assert math.isclose(f["cases"]["storm"], 0.9, **tol)
    got = [c["damage"]["p"] for c in design["cases"]]
    for g, want in zip(got, (0.45, 0.675, 0.6, 0.3)):
        assert math.isclose(g, want, **tol)
    assert [(c["name"], c["seed"]) for c in design["cases"]] == [
        ("calm", 0), ("calm", 1), ("storm", 0), ("storm", 1)]
    json.dumps(design, allow_nan=False)  # design.json is strict JSON


def test_no_damage_has_no_life_and_says_why():
    design = assemble_design([rec("a", 0, 100.0, {"p": 0.0})], 20.0)
    f = design["fatigue"]["p"]
    assert f["damage"] == 0.0 and "life_years" not in f and "governing_case" not in f
    assert "no damage" in f["note"]


def test_a_failed_seed_makes_the_design_incomplete():
    """The failed seed of 'storm' counts as zero: the damage 2.025 - 0.3 = 1.725 is a lower
    bound; the record stays in 'cases' with its status; warnings name it."""
    records = two_by_two()
    records[3].status, records[3].fatigue, records[3].window = "failed", {}, None
    design = assemble_design(records, 25.0)
    f = design["fatigue"]["p"]
    assert not design["complete"] and not f["complete"] and f["missing"] == ["storm/1"]
    assert math.isclose(f["damage"], 1.725, rel_tol=1e-13)  # as in the hand computation
    assert design["cases"][3]["status"] == "failed" and design["cases"][3]["damage"] == {}
    assert any("'storm'" in w and "incomplete" in w for w in design["warnings"])
    assert any("lower bound" in w and "storm/1" in w for w in design["warnings"])


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="design_life_years"):
        assemble_design(two_by_two(), 0.0)
    with pytest.raises(ValueError, match="at least one record"):
        assemble_design([], 25.0)
    records = two_by_two()
    records[1].hours_per_year = 5000.0
    with pytest.raises(ValueError, match="'calm'.*hours per year"):
        assemble_design(records, 25.0)
    records = two_by_two()
    records[1].seed = 0
    with pytest.raises(ValueError, match="'calm': a seed appears more than once"):
        assemble_design(records, 25.0)


def test_gumbel_fit_recovers_exact_moments():
    """Maxima whose sample mean and standard deviation are exactly those of a Gumbel(mu0,
    beta0) (mean mu0 + gamma beta0, standard deviation pi beta0 / sqrt 6) give back mu0 and
    beta0; the MPM over 10 windows is the mode of the largest of 10 independent maxima,
    mu0 + beta0 ln 10 (a Gumbel is max-stable)."""
    mu0, beta0, window = 1.0e4, 750.0, 600.0
    z = np.array([-1.0, 0.0, 1.0])  # sample mean 0, sample standard deviation (ddof 1) 1
    x = mu0 + np.euler_gamma * beta0 + math.pi * beta0 / math.sqrt(6.0) * z
    mu, beta = gumbel_moments(x)
    assert math.isclose(mu, mu0, rel_tol=1e-14) and math.isclose(beta, beta0, rel_tol=1e-14)
    records = [CaseRecord("storm", s, 3.0, "finished", 1.0, (100.0, 100.0 + window), {},
                          {"q": {"max_moment": float(v), "max_tension": 1.0e6 + s}}, "")
               for s, v in enumerate(x)]
    design = assemble_design(records, 20.0, extreme_duration=10 * window)
    mpm = design["extremes"]["q"]["cases"]["storm"]["moment"]
    # round-off of the mean, the standard deviation and the logarithm: 1e-12 relative
    assert math.isclose(mpm["mpm"], mu0 + beta0 * math.log(10.0), rel_tol=1e-12)
    assert mpm["estimator"] == "gumbel-moments" and mpm["duration"] == 10 * window
    e = design["extremes"]["q"]
    assert (e["max_moment"], e["case"], e["seed"]) == (float(x.max()), "storm", 2)
    assert (e["max_tension"], e["tension_seed"]) == (1.0e6 + 2, 2)


def test_gumbel_fit_of_drawn_maxima_within_sampling_error():
    """n = 1000 maxima drawn from Gumbel(5, 2): the method of moments' estimates within 4
    standard errors: SE(beta) = beta sqrt(1.1/n) (the sample standard deviation of a
    Gumbel, excess kurtosis 2.4: var(s) = sigma^2 (2.4 + 2) / (4 n)), SE(mu) <= sigma /
    sqrt(n) + gamma SE(beta); the MPM over 50 windows within SE(mu) + ln 50 SE(beta)."""
    n, mu0, beta0 = 1000, 5.0, 2.0
    x = np.random.default_rng(11).gumbel(mu0, beta0, n)
    se_beta = beta0 * math.sqrt(1.1 / n)
    se_mu = math.pi * beta0 / math.sqrt(6.0 * n) + np.euler_gamma * se_beta
    records = [CaseRecord("c", s, 1.0, "finished", 1.0, (0.0, 60.0), {},
                          {"p": {"max_moment": float(v), "max_tension": float(v)}}, "")
               for s, v in enumerate(x)]
    q = assemble_design(records, 1.0, extreme_duration=50 * 60.0)["extremes"]["p"]
    q = q["cases"]["c"]["moment"]
    assert abs(q["beta"] - beta0) < 4 * se_beta
    assert abs(q["mu"] - mu0) < 4 * se_mu
    assert abs(q["mpm"] - (mu0 + beta0 * math.log(50))) < 4 * (se_mu + math.log(50) * se_beta)


def test_one_seed_gives_its_maximum_flagged():
    r = CaseRecord("c", 0, 1.0, "finished", 1.0, (0.0, 60.0), {},
                   {"p": {"max_moment": 3.0, "max_tension": 7.0}}, "")
    d = assemble_design([r], 1.0, extreme_duration=600.0)
    q = d["extremes"]["p"]["cases"]["c"]["moment"]
    assert q["mpm"] == 3.0 and q["estimator"] == "single seed" and q["duration"] == 60.0
    assert any("one seed" in w for w in d["warnings"])


def test_figures_drawn_on_rank_0(mpi_tmp_path):
    records = two_by_two()
    for r in records:
        r.maxima = {"p": {"max_moment": 1.0 + r.seed, "max_tension": 10.0 + r.seed}}
    paths = write_design_figures(assemble_design(records, 25.0), mpi_tmp_path,
                                 comm=MPI.COMM_WORLD)
    assert [Path(p).name for p in paths] == ["design_damage.png", "design_extremes.png"]
    assert all(Path(p).stat().st_size > 10_000 for p in paths)  # a drawn PNG, not empty


def test_case_record_from_a_real_run(mpi_tmp_path):
    """demos/stay_cable_si.toml for 12 s: the record's fatigue is fatigue.json's, its
    window the summary's statistics window, its maxima those of anchors.csv in it (read
    here with the csv module); a folder without summary.json is 'missing'."""
    from cablefem.app.run import run_case
    from cablefem.case import load_case

    out = mpi_tmp_path / "run"
    run_case(load_case(DEMOS / "stay_cable_si.toml"), out, MPI.COMM_WORLD, t_end=12.0,
             progress=False)
    r = case_record(out, "A", 0, 100.0, relative_to=mpi_tmp_path)
    summary = json.loads((out / "summary.json").read_text())
    fat = json.loads((out / "fatigue.json").read_text())["anchors"]
    assert r.status == "completed" and r.folder == "run"
    assert r.window == tuple(summary["anchors"]["p"]["steady_state_moment"]["window"])
    assert set(r.fatigue) == {"p", "q"} and r.fatigue["p"]["damage"] == fat["p"]["damage"]
    with open(out / "anchors.csv", newline="") as fh:
        rows = [row for row in csv.DictReader(fh) if row["anchor"] == "q"
                and r.window[0] <= float(row["time"]) <= r.window[1]]
    # the same samples, the same maximum: exact
    assert r.maxima["q"]["max_tension"] == max(float(row["tension"]) for row in rows)
    assert r.maxima["q"]["max_moment"] == max(float(row["moment"]) for row in rows)
    # the summary's steady-state peak is the same maximum over the same window
    assert r.maxima["p"]["max_moment"] == summary["anchors"]["p"]["steady_state_moment"]["peak"]
    design = assemble_design([r], 20.0)
    # the demo's fatigue.window is 'all': the start-up is in every window: said
    assert any("A/0 is the whole run" in w for w in design["warnings"])
    per_s = fat["p"]["damage"] / fat["p"]["duration"]
    # one product of 4 factors: a few roundings
    assert math.isclose(design["fatigue"]["p"]["damage"], per_s * 100 * 3600 * 20,
                        rel_tol=1e-14)
    gone = case_record(mpi_tmp_path / "never-ran", "B", 0, 1.0)
    assert gone.status == "missing" and gone.fatigue == {} and gone.maxima == {}
    assert assemble_design([r, gone], 20.0)["complete"] is False


def test_case_record_window_and_maxima_from_the_files(tmp_path):
    """A run with pinned anchors only (no moment statistics in summary.json): the window is
    the run's rule on anchors.csv's times (0..9 s: the last third, [6, 9]; from
    statistics_start when the summary has it); the maxima are over it, a kink's over its
    valid samples only; a pinned anchor has no moment (None)."""
    from cablefem.io.anchorcsv import ANCHOR_COLUMNS, AnchorCSV

    t = np.arange(10.0)
    with AnchorCSV(tmp_path / "anchors.csv", ANCHOR_COLUMNS, MPI.COMM_SELF) as out:
        out.write({"time": t, "anchor": ["a"] * 10, "Nx": t, "Ny": 0 * t, "Nz": 0 * t,
                   "tension": 100.0 - (t - 7.0) ** 2})  # largest at t = 7: 100
    moment = [5.0] * 10
    moment[8], moment[2] = 50.0, 70.0  # t = 8: invalid; t = 2: outside the window
    with open(tmp_path / "kinks.csv", "w") as fh:
        fh.write("time,kink,s,tension,delta,moment,Mx,My,Mz,layer_length,valid\n")
        for k in range(10):
            fh.write(f"{t[k]},d/main,3.0,{10 + k},0,{moment[k]},0,{moment[k]},0,0.4,"
                     f"{0 if k == 8 else 1}\n")
    summary = {"status": "completed", "wall_time": {"total": 2.5},
               "anchors": {"a": {"kind": "pinned"}}}
    (tmp_path / "summary.json").write_text(json.dumps(summary))
    r = case_record(tmp_path, "c", 1, 2.0)
    assert r.window == (6.0, 9.0) and r.wall_time == 2.5 and r.seed == 1
    assert r.maxima["a"] == {"max_moment": None, "max_tension": 100.0}
    assert r.maxima["kink:d/main"] == {"max_moment": 5.0, "max_tension": 19.0}
    summary["statistics_start"] = 1.5
    (tmp_path / "summary.json").write_text(json.dumps(summary))
    r = case_record(tmp_path, "c", 1, 2.0)
    assert r.window == (1.5, 9.0) and r.maxima["kink:d/main"]["max_moment"] == 70.0
    d = assemble_design([r], 1.0)
    assert "max_moment" not in d["extremes"]["a"] and d["extremes"]["a"]["max_tension"] == 100


def _drawn(monkeypatch, draw):
    """The matplotlib Figure that ``draw`` saves (kept for inspection)."""
    from matplotlib.figure import Figure

    figs = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: figs.append(self))
    draw()
    return figs[0]


@pytest.mark.serial
def test_damage_figure_scales_to_a_small_damage(monkeypatch, tmp_path):
    """A design damage far below 1 (a stay cable's: 1e-7 over 100 years) fills the axis
    (the axis ends at 1.2x the largest stack; before, it ended at 1.05 and the bars were
    invisible), and the failure line, off the scale, is left out; a damage near 1 keeps it."""
    from cablefem.app.designplots import damage_figure

    for damage, top, line in ((1e-7, 1.2e-7, False), (0.9, 1.08, True)):
        design = assemble_design([rec("c", 0, 100.0, {"p": damage * 600.0 / (100.0 * 3600.0
                                                                           * 25.0)})], 25.0)
        fig = _drawn(monkeypatch, lambda: damage_figure(design, tmp_path / "d.png"))
        ax = fig.axes[0]
        assert ax.get_ylim()[1] == pytest.approx(top, rel=1e-9)  # 1.2 x the damage
        assert (len(ax.lines) == 1) is line  # the axhline at 1


@pytest.mark.serial
def test_extremes_figure_says_when_a_location_has_no_moment(monkeypatch, tmp_path):
    """A pinned anchor has a tension but no moment: its moment panel says so (no empty
    frame with an empty legend)."""
    from cablefem.app.designplots import extremes_figure

    records = two_by_two()
    for r in records:
        r.maxima = {"p": {"max_moment": 1.0 + r.seed, "max_tension": 10.0 + r.seed},
                    "pin": {"max_tension": 5.0 + r.seed}}
    design = assemble_design(records, 25.0)
    fig = _drawn(monkeypatch, lambda: extremes_figure(design, tmp_path / "e.png"))
    texts = {ax.get_ylabel(): [t.get_text() for t in ax.texts] for ax in fig.axes}
    assert any("no moment at pin" in t for t in texts["max moment\nat pin"])
    assert texts["max tension\nat pin"] == [] and texts["max moment\nat p"] == []


def test_damper_peaks_over_the_set(tmp_path):
    """A damper is specified by its force and stroke: the design's ``dampers`` holds the
    largest peak of every finished record with its case and seed, and per case the Gumbel
    MPM of the seeds' peaks (the same estimator as the extremes: checked against
    gumbel_moments); ``case_record`` reads the peaks from summary.json's ``dampers``."""
    peaks = {("calm", 0): (100.0, 0.01), ("calm", 1): (140.0, 0.02),
             ("storm", 0): (900.0, 0.09), ("storm", 1): (700.0, 0.11)}
    records = []
    for (name, seed), (force, stroke) in peaks.items():
        folder = tmp_path / name / f"seed{seed}"
        folder.mkdir(parents=True)
        summary = {"status": "completed", "wall_time": {"total": 1.0},
                   "dampers": {"damper0": {"window": [2.0, 12.0], "force_peak": force,
                                           "stroke_peak": stroke, "velocity_peak": 1.0,
                                           "force_rms": force / 2}}}
        (folder / "summary.json").write_text(json.dumps(summary))
        records.append(case_record(folder, name, seed, 10.0))
    assert records[0].dampers["damper0"]["force_peak"] == 100.0
    d = assemble_design(records, 10.0, extreme_duration=100.0)["dampers"]["damper0"]
    assert (d["max_force"], d["force_case"], d["force_seed"]) == (900.0, "storm", 0)
    assert (d["max_stroke"], d["stroke_case"], d["stroke_seed"]) == (0.11, "storm", 1)
    assert d["complete"]
    mu, beta = gumbel_moments([900.0, 700.0])
    # the MPM over 100 s from 10 s windows: mu + beta ln 10 (round-off of the log only)
    assert math.isclose(d["cases"]["storm"]["force"]["mpm"], mu + beta * math.log(10.0),
                        rel_tol=1e-14)
    failed = records[:3] + [CaseRecord("storm", 1, 10.0, "failed", 1.0, None)]
    assert not assemble_design(failed, 10.0)["dampers"]["damper0"]["complete"]


def test_the_runs_warnings_reach_the_design(tmp_path):
    """A design is only as good as its runs: a run's own warnings (summary.json) are
    repeated in design.json's warnings, named by case and seed, and counted per record."""
    folder = tmp_path / "gust" / "seed1"
    folder.mkdir(parents=True)
    warning = {"key": "anchors.p", "message": "the moment is still building up"}
    (folder / "summary.json").write_text(json.dumps(
        {"status": "completed", "wall_time": {"total": 1.0}, "warnings": [warning]}))
    r = case_record(folder, "gust", 1, 5.0)
    assert r.warnings == [warning]
    design = assemble_design([r, rec("calm", 0, 10.0, {"p": 1e-6})], 1.0)
    assert "case 'gust' seed 1: anchors.p: the moment is still building up" \
        in design["warnings"]
    assert [c["warnings"] for c in design["cases"]] == [1, 0]
