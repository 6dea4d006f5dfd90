"""Benchmark: a long run costs its length, not its square. Prints JSON.

A fatigue assessment runs sea states of hours: hundreds of thousands of steps, thousands of
field frames and checkpoints. Two measurements:

* ``runs``: ``cablefem run CASE --no-figures --t-end T`` (default paper case B) at a
  short and a ``--factor`` times longer end time, whole processes, alternated ``--repeat``
  times: CPU time (user + system) and peak resident memory of each; per extra step, the CPU
  (``cpu_per_step_ms``: it should not grow with the length) and the memory
  (``rss_per_step_kB``: what the run holds per step for its reports);
* ``series``: the XDMF series alone (``cablefem.io.series.Series``, the string's five
  fields on 21 nodes), ``--frames`` frames with a checkpoint every 25 (the defaults'
  ``checkpoint_every`` / ``fields_every``): the CPU of its frames and of its checkpoints, at
  the full count and at a quarter of it (constant cost per checkpoint: the ratio of the
  checkpoints' CPU is about 4; a whole rewrite at each checkpoint gave about 16).

    python benchmarks/bench_long.py                      # case B, 30 and 300 time units
    python benchmarks/bench_long.py --t-end 20 --factor 20 --frames 8000
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run(case: str, t_end: float) -> dict:
    """One whole ``cablefem run`` process: its CPU time (s) and peak memory (MB)."""
    with tempfile.TemporaryDirectory() as out:
        script = ("import resource, subprocess, sys, json; "
                  "r = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, "
                  "stderr=subprocess.DEVNULL); u = resource.getrusage("
                  "resource.RUSAGE_CHILDREN); print(json.dumps([r.returncode, "
                  "u.ru_utime + u.ru_stime, u.ru_maxrss / 1024]))")
        cmd = [sys.executable, "-c", script, sys.executable, "-m", "cablefem", "run", case,
               "--no-figures", "--quiet", "--t-end", repr(t_end), "--output", out]
        code, cpu, rss = json.loads(subprocess.run(cmd, cwd=ROOT, check=True,
                                                   capture_output=True, text=True).stdout)
        if code != 0:
            raise RuntimeError(f"cablefem run {case} --t-end {t_end} failed ({code})")
        steps = json.loads((Path(out) / "summary.json").read_text())["dynamics"]["steps"]
    return {"cpu_s": cpu, "peak_rss_MB": rss, "steps": steps}


def series(frames: int, every: int = 25) -> dict:
    """The CPU (s) of ``frames`` frames of a series and of its checkpoints."""
    import numpy as np
    from mpi4py import MPI

    from cablefem.io.series import Series

    rng = np.random.default_rng(0)
    points, cells = rng.random((21, 3)), np.array([[i, i + 1] for i in range(20)])
    point = {k: rng.random((21, 3)) for k in ("displacement", "dynamic_displacement",
                                             "velocity")}
    cell = {k: rng.random(20) for k in ("tension", "strain")}
    with tempfile.TemporaryDirectory() as out:
        s = Series(out, "string", points, cells, MPI.COMM_SELF)
        t_frames = t_checks = 0.0
        for k in range(frames):
            t0 = time.process_time()
            s.write(0.1 * k, point, cell)
            t1 = time.process_time()
            if (k + 1) % every == 0:
                s.checkpoint()
            t_frames += t1 - t0
            t_checks += time.process_time() - t1
        s.close()
    return {"frames": frames, "frames_cpu_s": round(t_frames, 3),
            "checkpoints_cpu_s": round(t_checks, 3)}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("case", nargs="?", default="demos/paper_spatial.toml")
    p.add_argument("--t-end", type=float, default=30.0, help="the short run's end time")
    p.add_argument("--factor", type=float, default=10.0, help="the long run's, times it")
    p.add_argument("--repeat", type=int, default=2)
    p.add_argument("--frames", type=int, default=8000)
    args = p.parse_args()
    ends = (args.t_end, args.t_end * args.factor)
    pairs = []
    for i in range(args.repeat):  # alternated: short, long, long, short, ...
        order = ends if i % 2 == 0 else ends[::-1]
        res = {t: run(args.case, t) for t in order}
        pairs.append([res[ends[0]], res[ends[1]]])
    short = min((p[0] for p in pairs), key=lambda r: r["cpu_s"])
    long = min((p[1] for p in pairs), key=lambda r: r["cpu_s"])
    extra = long["steps"] - short["steps"]
    quarter, full = series(args.frames // 4), series(args.frames)
    out = {"case": args.case, "t_end": list(ends),
           "runs": pairs,
           "cpu_per_step_ms": {"short": round(1e3 * short["cpu_s"] / short["steps"], 4),
                               "extra_steps": round(1e3 * (long["cpu_s"] - short["cpu_s"])
                                                    / extra, 4)},
           "rss_per_step_kB": round(1024 * (long["peak_rss_MB"] - short["peak_rss_MB"])
                                    / extra, 3),
           "series": [quarter, full],
           "checkpoints_cpu_ratio": round(full["checkpoints_cpu_s"]
                                          / max(quarter["checkpoints_cpu_s"], 1e-9), 2)}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
