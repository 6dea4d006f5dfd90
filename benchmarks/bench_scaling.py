"""Benchmark: cost of a network time step from 1e3 to 1e6 degrees of freedom, and the
speed-up from 1 to 2 MPI ranks on a large network (the fastest of ``--repeat`` alternated
runs on each rank count). Prints JSON.

Each size is a cable-net roof (meshes/make_roof.py, k = 10 elements per bay) run in a fresh
process: build, statics, then ``--steps`` time steps of the harmonic uplift case
(demos/roof.toml's physics) without file output; the step time is the mean over the steps
(anchor forces included), memory is the peak resident set size of the process, also per
degree of freedom above the empty process's. Cost should grow about linearly.

    python benchmarks/bench_scaling.py                  # 1e3, 1e4, 1e5; speed-up at 1e5
    python benchmarks/bench_scaling.py --large          # adds 1e6 (a few minutes, ~4 GB)
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SIZES = {1e3: 4, 1e4: 12, 1e5: 40, 1e6: 128}  # target dofs -> cables per family (k = 10)


def case_text(mesh: str, steps: int, dt: float) -> str:
    roof = (ROOT / "demos" / "roof.toml").read_text()
    roof = roof.replace('mesh = "../meshes/roof_small.msh"', f'mesh = "{mesh}"')
    roof = roof.replace("t_end = 5.0", f"t_end = {steps * dt!r}")
    roof = roof.replace("modes = 6", "modes = 1")
    return roof


def worker(n: int, steps: int) -> None:
    from mpi4py import MPI

    sys.path.insert(0, str(ROOT / "meshes"))
    import meshio
    from make_roof import roof

    from cablefem.case import load_case
    from cablefem.dynamics import DynamicsStats, integrate
    from cablefem.network import NetworkModel
    from cablefem.statics import solve_static

    comm = MPI.COMM_WORLD
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    tmp = Path(comm.bcast(tempfile.mkdtemp() if comm.rank == 0 else None, root=0))
    mesh = tmp / "roof.msh"
    if comm.rank == 0:
        meshio.write(mesh, roof(n, 10), file_format="gmsh22", binary=False)
        (tmp / "case.toml").write_text(case_text(str(mesh), steps, 0.005))
    comm.Barrier()
    t0 = time.perf_counter()
    case = load_case(tmp / "case.toml")
    model = NetworkModel(comm, case)
    t_build = time.perf_counter() - t0
    t0 = time.perf_counter()
    solve_static(model)
    t_static = time.perf_counter() - t0
    stats = DynamicsStats()
    it = integrate(model, steps * 0.005, 0.005, 0.9, 10**9, stats)
    next(it)  # t = 0
    t0 = time.perf_counter()
    for _ in it:
        pass
    t_dyn = time.perf_counter() - t0
    rss = comm.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, op=MPI.SUM)
    rss0 = comm.allreduce(rss0, op=MPI.SUM)
    dofs = 3 * model.V.dofmap.index_map.size_global
    if comm.rank == 0:
        print(json.dumps({"dofs": dofs, "ranks": comm.size, "build_s": t_build,
                          "statics_s": t_static, "step_s": t_dyn / stats.steps,
                          "newton_per_step": stats.newton_iterations / stats.steps,
                          "peak_rss_MB": rss / 1024, "rss_per_dof_kB": (rss - rss0) / dofs}))


def run(n: int, steps: int, ranks: int = 1) -> dict:
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", str(n), "--steps",
           str(steps)]
    if ranks > 1:
        env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1",
               "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}
        cmd = ["mpirun", "-n", str(ranks), *cmd]
    else:
        env = os.environ
    out = subprocess.run(cmd, capture_output=True, text=True, env=env, check=True)
    return json.loads([line for line in out.stdout.splitlines() if line.startswith("{")][-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--worker", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--large", action="store_true", help="include 1e6 dofs")
    ap.add_argument("--repeat", type=int, default=3,
                    help="1- and 2-rank runs of the largest size, alternated")
    a = ap.parse_args()
    if a.worker is not None:
        worker(a.worker, a.steps)
        return
    sizes = [s for s in SIZES if a.large or s < 1e6]
    rows = [run(SIZES[s], a.steps) for s in sizes]
    big = SIZES[max(sizes)]
    # single-core speed drifts by ~25 % over minutes on shared machines: alternate 1- and
    # 2-rank runs and compare the fastest of each
    pairs = [(run(big, a.steps, 1), run(big, a.steps, 2)) for _ in range(a.repeat)]
    one = min((p[0] for p in pairs), key=lambda r: r["step_s"])
    two = min((p[1] for p in pairs), key=lambda r: r["step_s"])
    base = rows[0]
    out = {"case": "cable-net roof, harmonic uplift, dt = 0.005 s, no file output",
           "sizes": rows,
           "cost_per_dof_ratio_vs_smallest": [
               round((r["step_s"] / r["dofs"]) / (base["step_s"] / base["dofs"]), 3)
               for r in rows],
           "speedup_1_to_2_ranks": {"dofs": one["dofs"], "step_s_1": one["step_s"],
                                    "step_s_2": two["step_s"],
                                    "speedup": one["step_s"] / two["step_s"], "aim": 1.6,
                                    "pairs_step_s": [[round(p[0]["step_s"], 4),
                                                      round(p[1]["step_s"], 4)]
                                                     for p in pairs]}}
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
