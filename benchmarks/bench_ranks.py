"""Benchmark: small cases launched on several ranks, run on one (``solver.ranks``). Prints
JSON.

For each case, three whole commands alternated ``--repeat`` times: ``cablefem run CASE``
without ``mpirun`` (one rank), and ``mpirun -n RANKS cablefem run`` with ``[solver] ranks =
"auto"`` (the default: a case below 20 000 unknowns runs on rank 0 alone) and with
``"all"`` (every rank, as before the choice existed). For each: wall time and CPU time of
all ranks together (user + system of the whole process tree), the medians, and the ratios
of the medians: ``auto_over_one`` (near 1: launching more ranks costs the waiting ranks'
start) and ``all_over_auto`` (what the choice saves).

    python benchmarks/bench_ranks.py                          # case B, the roof, the fan
    python benchmarks/bench_ranks.py --t-end 2 --repeat 5 demos/paper_spatial.toml

Run it alone on the machine: with another job on it, each of several ranks waits for the
other's time slice and the ``all`` runs get slower still.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ["demos/paper_spatial.toml", "demos/roof.toml", "demos/fan.toml"]


def with_ranks(case: Path, setting: str, folder: Path) -> Path:
    """A copy of ``case`` (in its own folder: relative mesh paths still resolve) with
    ``[solver] ranks = setting`` merged into its solver table."""
    text = case.read_text()
    line = f'ranks = "{setting}"\n'
    if "\n[solver]\n" in text:
        text = text.replace("\n[solver]\n", "\n[solver]\n" + line, 1)
    else:
        text = "[solver]\n" + line + "\n" + text if text.lstrip().startswith("[") else (
            text + "\n[solver]\n" + line)
    out = case.parent / f".bench_ranks_{setting}_{os.getpid()}_{case.name}"
    out.write_text(text)
    return out


def command(kind: str, case: Path, ranks: int, t_end: float | None, out: Path) -> list[str]:
    cmd = [sys.executable, "-m", "cablefem", "run", str(case), "--no-figures", "--quiet",
           "--output", str(out)]
    if t_end is not None:
        cmd += ["--t-end", repr(t_end)]
    if kind == "one":
        return cmd
    return ["mpirun", "-n", str(ranks), sys.executable, "-m", "mpi4py", *cmd[1:]]


def timed(cmd: list[str]) -> tuple[float, float, dict]:
    """Wall and CPU (s, the process tree) of ``cmd``, and the summary it wrote."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                         text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode not in (0, 3):
        raise RuntimeError(f"{' '.join(cmd)} failed ({res.returncode}): {res.stderr[-500:]}")
    out = Path(cmd[cmd.index("--output") + 1])
    summary = json.loads((out / "summary.json").read_text())
    return wall, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime), summary


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="*", default=DEFAULT)
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--t-end", type=float, default=None, help="each run's --t-end")
    args = ap.parse_args()
    env_ok = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}
    os.environ.update({k: v for k, v in env_ok.items() if os.geteuid() == 0})
    report = {"ranks": args.ranks, "repeat": args.repeat, "t_end": args.t_end, "cases": {}}
    for name in args.cases:
        case = (ROOT / name).resolve()
        files = {"one": case, "auto": with_ranks(case, "auto", case.parent),
                 "all": with_ranks(case, "all", case.parent)}
        runs: dict = {k: [] for k in files}
        info: dict = {}
        try:
            with tempfile.TemporaryDirectory() as tmp:
                for i in range(args.repeat):
                    order = list(files) if i % 2 == 0 else list(files)[::-1]
                    for kind in order:
                        cmd = command(kind, files[kind], args.ranks, args.t_end,
                                      Path(tmp) / kind)
                        wall, cpu, s = timed(cmd)
                        runs[kind].append({"wall_s": wall, "cpu_s": cpu})
                        info[kind] = {"mpi_ranks": s.get("mpi_ranks"),
                                      "mpi_ranks_launched": s.get("mpi_ranks_launched"),
                                      "degrees_of_freedom": s.get("degrees_of_freedom")}
        finally:
            for kind in ("auto", "all"):
                files[kind].unlink(missing_ok=True)
        med = {k: {q: statistics.median(r[q] for r in v) for q in ("wall_s", "cpu_s")}
               for k, v in runs.items()}
        report["cases"][name] = {
            "runs": runs, "median": med, "summary": info,
            "auto_over_one": {q: med["auto"][q] / med["one"][q] for q in ("wall_s", "cpu_s")},
            "all_over_auto": {q: med["all"][q] / med["auto"][q] for q in ("wall_s", "cpu_s")},
            "load_after": os.getloadavg()[0]}
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
