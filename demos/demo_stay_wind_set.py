# %% [markdown]
# # A wind climate on a stay cable with a damper: fatigue over a design life
#
# The 150 m stay of `demos/stay_damper.toml` ($EA = 1.5\times10^9$ N, $m = 60$ kg/m,
# horizontal tension $3\times10^6$ N, a viscous damper tuned to mode 1 at 3 m from the
# deck anchor) stands in a turbulent wind across its plane (`demos/stay_wind.toml`:
# Kaimal spectrum, $\sigma_u = 0.12\,U$, $L = 150$ m, Davenport's coherence
# $\exp(-10 f \Delta/U)$ between points $\Delta$ apart). A single ten-minute run says
# little about fatigue: the load-case set `demos/stay_wind_set.toml` runs the cable in
# four mean-speed bins of a Weibull wind climate (7.5, 12.5, 17.5, 22.5 m/s; 4124,
# 1050, 86.3 and 2.5 hours a year), each with two turbulence seeds, and `cablefem batch`
# combines them by Miner's rule into the damage over a design life of 100 years at the
# deck anchor, the pylon anchor and the cable at the damper (the kink `damper0`), with
# each bin's share (docs/loadsets.md, docs/design.md).
#
# Each run's fatigue window is its statistics window (`fatigue.window = "steady"` from
# `dynamics.statistics_start` = 15 s): the start-up from the static state is not a load
# that recurs every ten minutes, so it is left out. Units: SI (N, m, s; damage
# dimensionless, lives in years).
#
# Run: `python demos/demo_stay_wind_set.py --output output/stay_wind_set` (on P ranks:
# `mpirun -n P python ...`: P runs at a time). The full set is 8 runs of 600 s (about 8
# minutes a run on one core: `--t-end 20` takes 15 to 20 s a run); with the
# environment variable `CI` set, the short version runs the same set for 3 s of wind each
# (its statistics window from 1 s, a turbulence field of period 20 s), which checks the
# machinery, not the design.

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
parser.add_argument("--output", type=Path, default=Path("output/stay_wind_set"))
args = parser.parse_args()
setup_logging()
comm = MPI.COMM_WORLD
SHORT = {"dynamics.statistics_start": 1.0, "fluid.turbulence.duration": 20.0}



set_file, t_end, extra, figures = here / "stay_wind_set.toml", None, None, True
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
#    over its fatigue window of $T$ seconds (its own `fatigue.json`), scaled to its bin's
#    $H$ hours a year over the design life $L$ and averaged over the bin's $n$ seeds,
#    $D\,H\,3600\,L/(T\,n)$, summed over all runs, equals `design.json`'s damage: to
#    round-off (relative 1e-12: the same products summed in another order).
# 2. Every run completed and every run's fatigue window is its statistics window
#    (from `statistics_start` to the end: the start-up left out).
# 3. The deck anchor and the damper's kink are assessed.

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
ok_locs = {"deck", "kink:damper0"} <= set(design["fatigue"])
fat = design["fatigue"]
gov = max(fat, key=lambda k: fat[k]["damage"])
lines = [f"{loc}: damage over {life:g} years {f['damage']:.4g}"
         + (f", life {f['life_years']:.4g} years, governing bin {f['governing_case']} "
            f"({100 * f['governing_share']:.0f} %)" if "life_years" in f else ", no damage")
         for loc, f in fat.items()]
lines += [f"governing location: {gov}, life "
          + (f"{fat[gov]['life_years']:.4g} years" if "life_years" in fat[gov] else "unbounded"),
          f"design damage = sum of the runs' fatigue.json shares (largest relative difference "
          f"{max(errors.values()):.1e} <= 1e-12): {'OK' if ok_sum else 'FAILED'}",
          f"every run completed, its fatigue window its statistics window: "
          f"{'OK' if ok_runs else 'FAILED'}",
          f"deck anchor and damper kink assessed: {'OK' if ok_locs else 'FAILED'}"]
if comm.rank == 0:
    print("\n".join(lines))
    (args.output / "checks.json").write_text(json.dumps(
        {"sum_ok": bool(ok_sum), "runs_ok": bool(ok_runs), "locations_ok": bool(ok_locs),
         "relative_errors": errors, "governing": gov}, indent=2))
if not (ok_sum and ok_runs and ok_locs):
    raise SystemExit("demo check FAILED")
