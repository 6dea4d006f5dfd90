# %% [markdown]
# # A wave scatter diagram on a mooring line: fatigue at the fairlead over a field life
#
# The catenary line of `demos/mooring.toml` (a 76 mm spiral strand, 400 m, from a pinned
# anchor on the seabed in 100 m of water to a fairlead 20 m below the surface, clamped in a
# bend stiffener, in a 0.5 m/s current) in irregular seas (`demos/mooring_sea.toml`:
# long-crested JONSWAP, $\gamma = 3.3$, the floater surging at the peak frequency with an
# amplitude $0.25\,H_s$). The load-case set `demos/mooring_set.toml` runs four sea states
# of a scatter diagram ($H_s$ = 1.5, 3, 5, 7.5 m; $T_p$ = 7, 9, 11, 13 s; probabilities
# 0.50, 0.35, 0.12, 0.03 of the year), two random seas each, and `cablefem batch`
# combines them by Miner's rule into the damage at the fairlead over 25 years, with each
# sea state's share and most probable extremes over 3 hours (docs/loadsets.md,
# docs/design.md).
#
# Each run's fatigue window is its statistics window (`fatigue.window = "steady"` from
# `dynamics.statistics_start` = 60 s, after the 30 s ramps of the sea and the surge).
# Units: SI (N, m, s; damage dimensionless, lives in years).
#
# Run: `python demos/demo_mooring_set.py --output output/mooring_set` (on P ranks:
# `mpirun -n P python ...`). The full set is 8 runs of 1200 s (60 000 steps each: about
# 40 minutes a run on one core: 75 s of it took 152 s on a loaded machine); with the environment
# variable `CI` set, the short version runs the same set for 3 s each (its statistics
# window from 1 s, the ramps 1 s, 100 elements), which checks the machinery, not the design.

# %%
import argparse
import json
import math
import os
from pathlib import Path

from mpi4py import MPI

from cablefem.app.batch import run_batch
from cablefem.app.log import setup_logging
from cablefem.case.loadset import load_loadset

here = Path(__file__).resolve().parent
parser = argparse.ArgumentParser(description=__doc__)
parser.add_argument("--output", type=Path, default=Path("output/mooring_set"))
args = parser.parse_args()
setup_logging()
comm = MPI.COMM_WORLD
SHORT = {"dynamics.statistics_start": 1.0, "fluid.wave_ramp": 1.0,
         "anchors.fairlead.motion.ramp": 1.0, "mesh.elements": 100}



set_file, t_end, extra, figures = here / "mooring_set.toml", None, None, True
if os.environ.get("CI"):  # the short version: no figures of the single runs either
    t_end, extra, figures = 3.0, SHORT, False

# %% [markdown]
# ## Run the set
# `run_batch` is what `cablefem batch` calls: every case and seed into
# `output/<case>/seed<k>/`, then `design.json` and its figures.

# %%
ls = load_loadset(set_file, t_end=t_end, overrides=extra)
result = run_batch(ls, args.output, comm, figures=figures)
design = result.design

# %% [markdown]
# ## Checks
# 1. **The design is the sum of its runs.** For every location, each run's damage $D$
#    over its fatigue window of $T$ seconds (its own `fatigue.json`), scaled to its sea
#    state's $H = p \cdot 8766$ hours a year over the design life $L$ and averaged over
#    its $n$ seeds,
#    $D\,H\,3600\,L/(T\,n)$, summed over all runs, equals `design.json`'s damage: to
#    round-off (relative 1e-12: the same products summed in another order).
# 2. Every run completed and every run's fatigue window is its statistics window
#    (from `statistics_start` to the end: the start-up left out).
# 3. The fairlead is assessed (the seabed anchor is pinned: no bending moment).

# %%
life = design["design_life_years"]
terms: dict[str, list[float]] = {}
windows_ok = True
for case in ls.cases:
    for k in range(case.seeds):
        folder = args.output / case.name / f"seed{k}"
        reports = json.loads((folder / "fatigue.json").read_text())["anchors"]
        start = case.cases[k]["dynamics"]["statistics_start"]
        for loc, rep in reports.items():
            terms.setdefault(loc, []).append(rep["damage"] / rep["duration"]
                                             * case.hours_per_year * 3600.0 * life / case.seeds)
            end = case.cases[k]["dynamics"]["t_end"]
            windows_ok &= math.isclose(rep["duration"], end - start, rel_tol=1e-9)
errors = {loc: abs(math.fsum(t) - design["fatigue"][loc]["damage"])
          / max(design["fatigue"][loc]["damage"], 1e-300) for loc, t in terms.items()}
ok_sum = set(terms) == set(design["fatigue"]) and max(errors.values()) <= 1e-12
ok_runs = design["complete"] and windows_ok
ok_locs = "fairlead" in design["fatigue"]
fat = design["fatigue"]
gov = max(fat, key=lambda k: fat[k]["damage"])
lines = [f"{loc}: damage over {life:g} years {f['damage']:.4g}"
         + (f", life {f['life_years']:.4g} years, governing sea state {f['governing_case']} "
            f"({100 * f['governing_share']:.0f} %)" if "life_years" in f else ", no damage")
         for loc, f in fat.items()]
lines += [f"governing location: {gov}, life "
          + (f"{fat[gov]['life_years']:.4g} years" if "life_years" in fat[gov] else "unbounded"),
          f"design damage = sum of the runs' fatigue.json shares (largest relative difference "
          f"{max(errors.values()):.1e} <= 1e-12): {'OK' if ok_sum else 'FAILED'}",
          f"every run completed, its fatigue window its statistics window: "
          f"{'OK' if ok_runs else 'FAILED'}",
          f"fairlead assessed: {'OK' if ok_locs else 'FAILED'}"]
if comm.rank == 0:
    print("\n".join(lines))
    (args.output / "checks.json").write_text(json.dumps(
        {"sum_ok": bool(ok_sum), "runs_ok": bool(ok_runs), "locations_ok": bool(ok_locs),
         "relative_errors": errors, "governing": gov}, indent=2))
if not (ok_sum and ok_runs and ok_locs):
    raise SystemExit("demo check FAILED")
