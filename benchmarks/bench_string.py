"""Benchmark: the paper's case A string run (30 elements, t in [0, 30], dt = 0.005).

Three measurements, printed as one JSON document:

* ``integrate`` (in this process, best of ``--repeat``): statics + time integration alone
  (anchor forces at every step, no files);
* ``run_case`` (in this process, best of ``--repeat``): the whole run as users get it
  (modes, ``anchors.csv`` every step, moments, XDMF fields every 50 steps, figures), and
  the ratio run/integrate (the cost of the output);
* ``whole_run`` (``--runs`` pairs): ``python -m cablefem run demos/paper_inplane.toml`` as
  a user types it (interpreter start, imports, the default output), of this tree and of a
  baseline revision (``--baseline``, default ``f32c472``: the state before issue 14) checked
  out into a temporary ``git worktree``, alternately (baseline, current, baseline, ...) so
  that both see the same load of a shared machine; medians and the pairwise ratio
  current/baseline of the wall times (and of the CPU times of the child processes, less
  sensitive to other processes). Both use this interpreter with ``PYTHONPATH`` set to the
  tree; the case file is this tree's. Issue 14's aim: a ratio of at most 0.6.

    python benchmarks/bench_string.py [--repeat 3] [--runs 5] [--baseline REV|none]
                                      [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "demos" / "paper_inplane.toml"
BASELINE = "f32c472"  #: the state before issue 14's work
TARGET_RATIO = 0.6  #: issue 14: the whole run of case A in at most 0.6 of the baseline's time


def bare(case) -> tuple[float, int, int]:
    from mpi4py import MPI

    from cablefem.cable import CableModel
    from cablefem.dynamics import DynamicsStats, integrate
    from cablefem.statics import solve_static

    t0 = time.perf_counter()
    model = CableModel(MPI.COMM_WORLD, case)
    solve_static(model)
    dyn = case.dynamics
    stats = DynamicsStats()
    for _ in integrate(model, dyn.t_end, dyn.dt, dyn.rho_inf, 1, stats):
        pass
    return time.perf_counter() - t0, stats.steps, 3 * len(model.geometry.stations)


def full(case) -> float:
    from mpi4py import MPI

    from cablefem.app.run import run_case

    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        run_case(case, Path(tmp) / "out", MPI.COMM_WORLD, progress=False)
        return time.perf_counter() - t0


def in_process(repeat: int) -> dict:
    """integrate alone and run_case, best of ``repeat`` each, in this process."""
    from mpi4py import MPI

    from cablefem.case import load_case

    case = load_case(CASE)
    bare(case)  # warm-up: JIT-compiled forms are cached after the first build
    b = min((bare(case) for _ in range(repeat)), key=lambda r: r[0])
    f = min(full(case) for _ in range(repeat))
    t_bare, steps, ndofs = b
    return {
        "mpi_ranks": MPI.COMM_WORLD.size, "steps": steps, "dofs": ndofs,
        "integrate_s": round(t_bare, 4), "run_case_s": round(f, 4),
        "time_per_step_ms": round(1e3 * t_bare / steps, 4),
        "time_per_step_per_dof_us": round(1e6 * t_bare / steps / ndofs, 4),
        "ratio_run_over_integrate": round(f / t_bare, 3),
    }


def git(*args: str) -> str:
    return subprocess.run(["git", "-C", str(ROOT), *args], check=True, capture_output=True,
                          text=True).stdout.strip()


def one_run(tree: Path, out: Path) -> tuple[float, float]:
    """Wall and CPU time (s) of ``python -m cablefem run CASE`` with ``tree`` first on
    the path; a fresh output folder each time."""
    shutil.rmtree(out, ignore_errors=True)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(tree)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run([sys.executable, "-m", "cablefem", "run", str(CASE), "--output",
                          str(out)], env=env, cwd=out.parent, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode != 0:
        raise RuntimeError(f"run of {tree} failed ({res.returncode}):\n{res.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def which_cablefem(tree: Path) -> str:
    """The file ``import cablefem`` finds with ``tree`` first on the path (a check that
    the baseline is the one timed, not an installed copy)."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    return subprocess.run([sys.executable, "-c", "import cablefem; print(cablefem.__file__)"],
                          env=env, check=True, capture_output=True, text=True,
                          cwd=tempfile.gettempdir()).stdout.strip()


def whole_run(rev: str, runs: int) -> dict:
    """The whole run of this tree and of ``rev``, alternately, ``runs`` times each."""
    commit = git("rev-parse", "--verify", f"{rev}^{{commit}}")
    tmp = Path(tempfile.mkdtemp(prefix="cablefem-bench-"))
    base = tmp / "baseline"
    git("worktree", "add", "--detach", str(base), commit)
    try:
        trees = {"baseline": base, "current": ROOT}
        for name, tree in trees.items():
            found = Path(which_cablefem(tree)).resolve()
            if tree.resolve() not in found.parents:
                raise RuntimeError(f"{name}: python imports {found}, not {tree}'s cablefem")
        wall = {k: [] for k in trees}
        cpu = {k: [] for k in trees}
        for name, tree in trees.items():  # warm-up: JIT compilation of each tree's forms
            one_run(tree, tmp / f"out-{name}")
        for _ in range(runs):
            for name, tree in trees.items():
                w, c = one_run(tree, tmp / f"out-{name}")
                wall[name].append(round(w, 3))
                cpu[name].append(round(c, 3))
    finally:
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(base)],
                       capture_output=True)
        shutil.rmtree(tmp, ignore_errors=True)
    pair = [c / b for c, b in zip(wall["current"], wall["baseline"])]
    pair_cpu = [c / b for c, b in zip(cpu["current"], cpu["baseline"])]
    out = {"command": "python -m cablefem run demos/paper_inplane.toml --output DIR",
           "runs": runs, "order": "alternating, baseline first, after one warm-up run each"}
    for name in ("baseline", "current"):
        out[name] = {"wall_s": wall[name], "median_wall_s": statistics.median(wall[name]),
                     "cpu_s": cpu[name], "median_cpu_s": statistics.median(cpu[name])}
    out["baseline"].update(rev=rev, commit=commit)
    dirty = bool(git("status", "--porcelain", "--untracked-files=no"))
    out["current"].update(commit=git("rev-parse", "HEAD"), uncommitted_changes=dirty)
    ratio = statistics.median(pair)
    out.update({
        "ratio_pairwise_median": round(ratio, 3),
        "ratio_of_medians": round(out["current"]["median_wall_s"]
                                  / out["baseline"]["median_wall_s"], 3),
        "ratio_cpu_pairwise_median": round(statistics.median(pair_cpu), 3),
        "target_ratio": TARGET_RATIO, "meets_target": ratio <= TARGET_RATIO})
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3,
                    help="in-process measurements: best of this many (0: skip them)")
    ap.add_argument("--runs", type=int, default=5,
                    help="whole runs of each tree, alternately (0: skip them)")
    ap.add_argument("--baseline", default=BASELINE, metavar="REV",
                    help=f"git revision to compare with (default {BASELINE}; 'none': skip)")
    ap.add_argument("--json", type=Path, help="also write the JSON document to this file")
    args = ap.parse_args()
    out = {"case": "paper case A (string, 30 elements, t in [0, 30], dt = 0.005)",
           "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
           "machine": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
           "python": platform.python_version(),
           "load_average_1min": round(os.getloadavg()[0], 2)}
    if args.repeat > 0:
        out["in_process"] = in_process(args.repeat)
    from mpi4py import MPI

    if args.runs > 0 and args.baseline.lower() != "none" and MPI.COMM_WORLD.size == 1:
        out["whole_run"] = whole_run(args.baseline, args.runs)  # serial runs only
    out["load_average_1min_after"] = round(os.getloadavg()[0], 2)
    text = json.dumps(out, indent=2)
    if MPI.COMM_WORLD.rank == 0:
        print(text)
        if args.json:
            args.json.write_text(text + "\n")


if __name__ == "__main__":
    main()
