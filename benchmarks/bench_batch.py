"""Benchmark: a load-case set of 16 short cases with ``cablefem batch`` on 1 and on 2 MPI
ranks, whole commands side by side (alternated, ``--repeat`` times each), and the speed-up
on P ranks estimated from the measured run times. Prints JSON.

The cases: a clamped string of 40 elements whose end moves harmonically (the fixture of
tests/test_batch.py, longer), 16 amplitudes, 1 seed each, a [fatigue] table over the
statistics window; no figures of the single runs. The design of both commands must agree
(checked: the same design damage to 1e-12).

The estimate for P groups replays the queue: each group takes the next run when it is
free, each run taking the wall time it took in the 1-rank command (from design.json),
plus the command's fixed cost (start-up, reading, the design) measured as the 1-rank
command's wall time less the sum of its runs.

    python benchmarks/bench_batch.py [--repeat 2] [--cases 16]
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
BASE = """title = "bench_batch"
[section]
EA = 17857.14
EI = 4e-4
mass = 1.0
[gravity]
g = 1.0
[geometry]
length = 1.0
[mesh]
elements = 40
[solver]
outer_correction = "none"
[[anchors]]
name = "p"
position = [0.0, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
[[anchors]]
name = "q"
position = [1.0013333, 0.0, 0.0]
direction = [-1.0, 0.0, 0.0]
[anchors.motion]
type = "harmonic"
amplitude = [0.0, 0.0, 2e-3]
omega = 3.0
ramp = 2.0
[dynamics]
t_end = 12.0
dt = 0.02
statistics_start = 4.0
[fatigue]
detail_category = 0.02
area = 1.0
modulus = 1.0
window = "steady"
"""


def set_text(n: int) -> str:
    lines = ['base = "base.toml"', "design_life = 50"]
    for i in range(n):
        lines += ["[[cases]]", f'name = "a{i:02d}"', f"hours = {100.0 * (i + 1)!r}",
                  "[cases.overrides]",
                  f'"anchors.q.motion.amplitude" = [0.0, 0.0, {1e-3 * (1 + 0.2 * i)!r}]']
    return "\n".join(lines) + "\n"


def command(ranks: int, folder: Path, out: Path) -> dict:
    cmd = [sys.executable, "-m", "cablefem", "batch", str(folder / "set.toml"), "--output",
           str(out), "--no-figures", "-q"]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), sys.executable, "-m", "mpi4py"] + cmd[1:]
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1",
           "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1", "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=3600)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({res.returncode}):\n{res.stderr}")
    design = json.loads((out / "design.json").read_text())
    return {"wall_s": wall, "cpu_s": (r1.ru_utime + r1.ru_stime) - (r0.ru_utime + r0.ru_stime),
            "design": design}


def replay(walls: list[float], groups: int, fixed: float) -> float:
    """The makespan of the queue on ``groups`` groups (each takes the next run when free)."""
    free = [0.0] * groups
    for w in walls:
        i = min(range(groups), key=free.__getitem__)
        free[i] += w
    return fixed + max(free)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--cases", type=int, default=16)
    args = ap.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="bench_batch_"))
    (folder / "base.toml").write_text(BASE)
    (folder / "set.toml").write_text(set_text(args.cases))
    load0 = os.getloadavg()[0]
    runs: dict[int, list[dict]] = {1: [], 2: []}
    for rep in range(args.repeat):
        for ranks in (1, 2) if rep % 2 == 0 else (2, 1):
            runs[ranks].append(command(ranks, folder, folder / f"out{ranks}_{rep}"))
    d1, d2 = runs[1][0]["design"], runs[2][0]["design"]
    for loc in d1["fatigue"]:
        a, b = d1["fatigue"][loc]["damage"], d2["fatigue"][loc]["damage"]
        assert abs(a - b) <= 1e-12 * abs(a), (loc, a, b)
    best = {r: min(x["wall_s"] for x in v) for r, v in runs.items()}
    one = min(runs[1], key=lambda x: x["wall_s"])
    walls = [c["wall_time"] for c in one["design"]["cases"]]
    fixed = max(one["wall_s"] - sum(walls), 0.0)
    estimate = {p: (sum(walls) + fixed) / replay(walls, p, fixed) for p in (2, 4, 8, 16)}
    print(json.dumps({
        "cases": args.cases, "repeat": args.repeat, "nproc": os.cpu_count(),
        "load_average_1min": [load0, os.getloadavg()[0]],
        "wall_s": {r: [x["wall_s"] for x in v] for r, v in runs.items()},
        "cpu_s": {r: [x["cpu_s"] for x in v] for r, v in runs.items()},
        "speedup_2_ranks_best": best[1] / best[2],
        "speedup_2_ranks_pairs": [a["wall_s"] / b["wall_s"] for a, b in zip(runs[1], runs[2])],
        "run_wall_s": {"sum": sum(walls), "min": min(walls), "max": max(walls)},
        "fixed_s": fixed,
        "estimated_speedup_P_groups": estimate,
        "design_damage_same": True}, indent=1))


if __name__ == "__main__":
    main()
