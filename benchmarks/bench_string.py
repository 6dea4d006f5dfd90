"""Benchmark: the paper's case A string run (30 elements, t in [0, 30], dt = 0.005).

Measured side by side in one process, best of ``--repeat`` runs each:
  * ``integrate``: statics + time integration alone (anchor forces at every step, no files);
  * ``run_case``: the whole run as users get it (modes, anchors.csv every step, moments,
    XDMF fields every 50 steps, figures).
Prints JSON with wall times, time per step and per step and degree of freedom, and the
ratio run/integrate (the cost of the output). Target: the whole run under 3 s on one core.

    python benchmarks/bench_string.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import platform
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

from cablefem.app.run import run_case
from cablefem.cable import CableModel
from cablefem.case import load_case
from cablefem.dynamics import DynamicsStats, integrate
from cablefem.statics import solve_static

CASE = Path(__file__).resolve().parents[1] / "demos" / "paper_inplane.toml"


def bare(case) -> tuple[float, int, int]:
    t0 = time.perf_counter()
    model = CableModel(MPI.COMM_WORLD, case)
    solve_static(model)
    dyn = case.dynamics
    stats = DynamicsStats()
    for _ in integrate(model, dyn.t_end, dyn.dt, dyn.rho_inf, 1, stats):
        pass
    return time.perf_counter() - t0, stats.steps, 3 * len(model.geometry.stations)


def full(case) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        run_case(case, Path(tmp) / "out", MPI.COMM_WORLD, progress=False)
        return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    case = load_case(CASE)
    bare(case)  # warm-up: JIT-compiled forms are cached after the first build
    b = min((bare(case) for _ in range(args.repeat)), key=lambda r: r[0])
    f = min(full(case) for _ in range(args.repeat))
    t_bare, steps, ndofs = b
    out = {
        "case": "paper case A (string, 30 elements, t in [0, 30], dt = 0.005)",
        "machine": platform.processor() or platform.machine(), "mpi_ranks": MPI.COMM_WORLD.size,
        "steps": steps, "dofs": ndofs,
        "integrate_s": round(t_bare, 4), "run_case_s": round(f, 4),
        "time_per_step_ms": round(1e3 * t_bare / steps, 4),
        "time_per_step_per_dof_us": round(1e6 * t_bare / steps / ndofs, 4),
        "ratio_run_over_integrate": round(f / t_bare, 3),
        "target_run_case_s": 3.0, "meets_target": f < 3.0,
    }
    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
