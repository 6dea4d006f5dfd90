"""Benchmark: string + asymptotics against the reference rod on the paper's two cases.

For case A and case B (demos/paper_inplane.toml, demos/paper_spatial.toml), in one process:

* the string run (``cablefem run CASE``): the whole run with its output, as users get it;
* the string run with the first-order outer correction (``--outer-correction hinge``);
* the beam run (``cablefem run CASE --model beam --refine r``) for r = 0.5, 1, 2, ... until
  the steady-state RMS anchor moment changes by less than 1 % (``--tol``) from the previous
  mesh; the converged mesh's run is the one compared;
* optionally (``--dt-check``) the converged beam mesh and both string runs again with half
  the time step, and their differences at that step.

Both models write the same files (figures off for both, the same output stride), after a
short warm-up run of each (JIT compilation of the forms is not timed). Prints
JSON: wall times, their ratio beam/string (the paper's claim: drastic; the issue's target:
at least 50), static moments, steady-state (last third of the run) peak and RMS anchor
moments of both models and their relative differences (target below 3 %), and the beam's
mesh (and time-step) convergence.

    python benchmarks/bench_paper.py [--cases A B] [--t-end 30] [--tol 0.01] [--dt-check]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import platform
import tempfile
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from cablefem.app.run import run_case
from cablefem.case import load_case

DEMOS = Path(__file__).resolve().parents[1] / "demos"
CASES = {"A": DEMOS / "paper_inplane.toml", "B": DEMOS / "paper_spatial.toml"}


def one_run(case, outdir: Path, **kw) -> dict:
    t0 = time.perf_counter()
    res = run_case(case, outdir, MPI.COMM_WORLD, progress=False, figures=False, **kw)
    wall = time.perf_counter() - t0
    out = {"wall_time": wall, "elements": res.summary["elements"],
           "degrees_of_freedom": res.summary["degrees_of_freedom"],
           "newton_per_step": res.summary.get("dynamics", {}).get("newton_per_step"),
           "anchors": {}}
    for name, a in res.summary["anchors"].items():
        if a["kind"] != "clamped":
            continue
        ss = a.get("steady_state_moment", {})
        out["anchors"][name] = {"static_moment": a["static_moment"],
                                "static_tension": a["static_tension"],
                                "peak": ss.get("peak"), "rms": ss.get("rms")}
    modes = res.summary.get("modes") or []
    out["omega_1"] = modes[0]["omega"] if modes else None
    return out


def rel(b, a):
    return None if a in (None, 0) or b is None else (b - a) / a


def compare(s: dict, b: dict) -> dict:
    out = {}
    for name in s["anchors"]:
        sa, ba = s["anchors"][name], b["anchors"][name]
        out[name] = {k: rel(ba[k], sa[k]) for k in ("static_moment", "static_tension",
                                                   "peak", "rms")}
    out["omega_1"] = rel(b["omega_1"], s["omega_1"])
    return out


def bench_case(label: str, t_end: float | None, tol: float, dt_check: bool,
               max_refine: float) -> dict:
    case = load_case(CASES[label])
    kw = {} if t_end is None else {"t_end": t_end}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(MPI.COMM_WORLD.bcast(tmp, root=0))
        # warm-up: the forms' JIT compilation (once per machine, seconds) is not timed
        two_steps = 2 * case.dynamics.dt
        one_run(case, tmp / "warm_string", t_end=two_steps)
        one_run(case, tmp / "warm_beam", t_end=two_steps, model="beam")
        hinged = dataclasses.replace(case, solver=dataclasses.replace(
            case.solver, outer_correction="hinge"))
        one_run(hinged, tmp / "warm_hinge", t_end=two_steps)  # its forms differ (c a field)
        string = one_run(case, tmp / "string", **kw)
        string_hinge = one_run(hinged, tmp / "string_hinge", **kw)
        beams, r, prev = [], 0.5, None
        converged = False
        while r <= max_refine:
            b = one_run(case, tmp / f"beam_{r:g}", model="beam", refine=r, **kw)
            b["refine"] = r
            name = next(iter(b["anchors"]))
            rms = b["anchors"][name]["rms"]
            if prev is not None and rms is not None and prev:
                b["rms_change_from_previous"] = (rms - prev) / prev
                if abs(b["rms_change_from_previous"]) < tol:
                    converged = True
                    beams.append(b)
                    break
            beams.append(b)
            prev = rms
            r *= 2
        beam = beams[-1]
        out = {"case": label, "file": str(CASES[label]), "string": string,
               "beam_mesh_study": beams, "beam_converged": converged, "beam": beam,
               "ratio_wall_time_beam_over_string": beam["wall_time"] / string["wall_time"],
               "relative_difference_beam_minus_string_over_string": compare(string, beam),
               "string_hinge": string_hinge,
               "relative_difference_beam_minus_string_hinge_over_string_hinge":
                   compare(string_hinge, beam)}
        if dt_check:
            dt = case.dynamics.dt / 2

            def half(c):
                return dataclasses.replace(c, dynamics=dataclasses.replace(
                    c.dynamics, dt=dt, output_every=2 * c.dynamics.output_every,
                    fields_every=2 * c.dynamics.fields_every,
                    checkpoint_every=2 * c.dynamics.checkpoint_every))

            bh = one_run(half(case), tmp / "beam_dt2", model="beam", refine=beam["refine"],
                         **kw)
            sh = one_run(half(case), tmp / "string_dt2", **kw)
            hh = one_run(half(hinged), tmp / "string_hinge_dt2", **kw)
            out["half_dt"] = {"dt": dt, "string": sh, "string_hinge": hh, "beam": bh,
                              "relative_difference_beam_minus_string_over_string":
                                  compare(sh, bh),
                              "relative_difference_beam_minus_string_hinge_over_"
                              "string_hinge": compare(hh, bh)}
            name = next(iter(bh["anchors"]))
            out["beam_half_dt"] = {"dt": dt, "wall_time": bh["wall_time"],
                                   "rms": bh["anchors"][name]["rms"],
                                   "peak": bh["anchors"][name]["peak"],
                                   "rms_change": rel(bh["anchors"][name]["rms"],
                                                     beam["anchors"][name]["rms"]),
                                   "peak_change": rel(bh["anchors"][name]["peak"],
                                                      beam["anchors"][name]["peak"])}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=["A", "B"], choices=["A", "B"])
    ap.add_argument("--t-end", type=float, default=None, help="override dynamics.t_end")
    ap.add_argument("--tol", type=float, default=0.01, help="beam mesh convergence: RMS "
                    "change below this (default 1 %%)")
    ap.add_argument("--max-refine", type=float, default=8.0)
    ap.add_argument("--dt-check", action="store_true", help="also the beam and the strings at dt/2")
    args = ap.parse_args()
    res = {"benchmark": "bench_paper", "machine": platform.node(),
           "mpi_ranks": MPI.COMM_WORLD.size,
           "cases": [bench_case(c, args.t_end, args.tol, args.dt_check, args.max_refine)
                     for c in args.cases]}
    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps(res, indent=2, default=lambda x: None if x is None else float(x)))


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
