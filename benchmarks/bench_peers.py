"""Benchmark: cablefem against the codes its users would pick instead (issue 31, item 4).

Two jobs, each done by cablefem and by a peer as whole processes, timed side by side:

* ``caseB``: the paper's case B (``demos/paper_spatial.toml``) by ``cablefem run CASE
  --no-figures`` and by OpenSees (openseespy): the same chain of corotational truss
  elements, statics, modes, the transient and the anchor moments from the anchor forces by
  cablefem's pure-NumPy inner solution (``benchmarks/peers/opensees_caseB.py``);
* ``mooring``: a mooring line in a current on a seabed with a surging fairlead
  (``benchmarks/peers/mooring.toml``) by ``cablefem run`` and by MoorDyn v2 (the ``moordyn``
  package, ``benchmarks/peers/moordyn_line.py``), each at two discretisations for its
  convergence.

The peers live in a benchmark-only virtual environment that this script creates when it is
missing (``benchmarks/.peers-venv``, git-ignored; ``--venv`` elsewhere) with pinned
versions; cablefem never imports them. Whole processes are timed alternately (cablefem,
peer, cablefem, ...; ``--runs`` each, after the accuracy runs that warm both up): wall and
CPU (user + system of the child) times, their medians and the median of the pairwise
ratios cablefem/peer. One JSON document on standard output (and ``--json FILE``).

    python benchmarks/bench_peers.py [--runs 3] [--jobs caseB,mooring] [--quick]
                                     [--json FILE] [--venv DIR]
"""

from __future__ import annotations

import argparse
import csv
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
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PEERS = ROOT / "benchmarks" / "peers"
VENV = ROOT / "benchmarks" / ".peers-venv"
#: the peers' versions (PyPI); openseespy 3.8 needs Python >= 3.12, Debian 12 has 3.11
PINS = ("openseespy==3.7.1.2", "moordyn==2.7.2", "numpy==2.4.6")
CASE_B = ROOT / "demos" / "paper_spatial.toml"
MOORING = PEERS / "mooring.toml"


class PeerUnavailable(RuntimeError):
    """A peer cannot be installed or run here."""


def venv_python(venv: Path) -> Path:
    """The benchmark-only interpreter with the peers, created if missing."""
    py = venv / "bin" / "python"
    probe = [str(py), "-c", "import openseespy.opensees, moordyn, numpy"]
    if py.exists() and subprocess.run(probe, capture_output=True).returncode == 0:
        return py
    base = shutil.which("python3") or sys.executable
    steps = [[base, "-m", "venv", str(venv)],
             [str(py), "-m", "pip", "install", "--quiet", *PINS]]
    for cmd in steps:
        res = subprocess.run(cmd, capture_output=True, text=True)
        if res.returncode != 0:
            raise PeerUnavailable(f"{' '.join(cmd)} failed ({res.returncode}):\n"
                                  f"{(res.stderr or res.stdout)[-1500:]}")
    res = subprocess.run(probe, capture_output=True, text=True)
    if res.returncode != 0:
        raise PeerUnavailable(f"the peers do not import in {venv}:\n{res.stderr[-1500:]}")
    return py


def timed(cmd: list[str], cwd: Path) -> tuple[float, float, str]:
    """Wall and CPU time (s) of one whole process, and its standard output."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({res.returncode}):\n"
                           f"{(res.stderr or res.stdout)[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, res.stdout


def alternate(cmds: dict[str, list[str]], runs: int, cwd: Path) -> dict:
    """``runs`` whole runs of each command, in turn; medians and cablefem/peer ratios."""
    wall = {k: [] for k in cmds}
    cpu = {k: [] for k in cmds}
    for _ in range(runs):
        for name, cmd in cmds.items():
            w, c, _ = timed(cmd, cwd)
            wall[name].append(round(w, 3))
            cpu[name].append(round(c, 3))
    (a, b) = cmds
    out = {"order": f"alternating, {a} first", "runs": runs,
           "commands": {k: " ".join(Path(x).name if "/" in x else x for x in v)
                        for k, v in cmds.items()}}
    for k in cmds:
        out[k] = {"wall_s": wall[k], "median_wall_s": statistics.median(wall[k]),
                  "cpu_s": cpu[k], "median_cpu_s": statistics.median(cpu[k])}
    out["ratio_wall_pairwise_median"] = round(statistics.median(
        [x / y for x, y in zip(wall[a], wall[b])]), 3)
    out["ratio_cpu_pairwise_median"] = round(statistics.median(
        [x / y for x, y in zip(cpu[a], cpu[b])]), 3)
    out["ratio_means"] = f"{a}/{b}: above 1, cablefem takes longer"
    return out


def anchor_rows(path: Path, anchor: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """time, forces (n, 3) and (where written) moments of one anchor in anchors.csv."""
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["anchor"] == anchor]
    t = np.array([float(r["time"]) for r in rows])
    N = np.array([[float(r[k]) for k in ("Nx", "Ny", "Nz")] for r in rows])
    M = np.array([float(r.get("moment") or "nan") for r in rows])
    return t, N, M


def rel(a: float, b: float) -> float:
    return round((a - b) / abs(b), 5)


def history_compare(t, x, y, start: float) -> dict:
    """Peak, RMS of x (cablefem) and y (peer) for t >= start, their relative differences
    and the history error RMS(x - y)/RMS(y)."""
    w = t >= start
    px, py = float(np.max(np.abs(x[w]))), float(np.max(np.abs(y[w])))
    rx, ry = float(np.sqrt(np.mean(x[w] ** 2))), float(np.sqrt(np.mean(y[w] ** 2)))
    err = float(np.sqrt(np.mean((x[w] - y[w]) ** 2)) / ry)
    return {"window": [round(start, 3), round(float(t[-1]), 3)], "peak": [px, py],
            "peak_diff": rel(px, py), "rms": [rx, ry], "rms_diff": rel(rx, ry),
            "history_error": round(err, 5)}


def case_b(py: Path, runs: int, quick: bool, tmp: Path) -> dict:
    t_end = ["--t-end", "3"] if quick else []
    cf = [sys.executable, "-m", "cablefem", "run", str(CASE_B), "--no-figures", "--quiet"]
    os_cmd = [str(py), str(PEERS / "opensees_caseB.py"), str(CASE_B), str(tmp / "os.npz")]
    # accuracy (and warm-up): the default run, the leading-order run, the OpenSees run
    timed(cf + ["--output", str(tmp / "cf")] + t_end, tmp)
    timed(cf + ["--output", str(tmp / "cf0"), "--outer-correction", "none"] + t_end, tmp)
    _, _, text = timed(os_cmd + t_end, tmp)
    peer = json.loads(text.strip().splitlines()[-1])
    o = np.load(tmp / "os.npz")
    acc = {"opensees_omegas": [round(w, 6) for w in peer["omegas"]]}
    for run, label in (("cf0", "outer_correction_none"), ("cf", "default_hinge")):
        summary = json.loads((tmp / run / "summary.json").read_text())
        acc[label] = {"cablefem_omegas": [round(m["omega"], 6) for m in summary["modes"]]}
        for j, name in enumerate(("p", "q")):
            t, N, M = anchor_rows(tmp / run / "anchors.csv", name)
            Mo = np.interp(t, o["time"], o["moment"][:, j])
            To = np.interp(t, o["time"], np.linalg.norm(o["forces"][:, j], axis=1))
            start = t[-1] * 2 / 3
            acc[label][name] = {
                "moment": history_compare(t, M, Mo, start),
                "tension": history_compare(t, np.linalg.norm(N, axis=1), To, start),
                "static_moment": [float(M[0]), float(Mo[0])]}
    timing = alternate({"cablefem": cf + ["--output", str(tmp / "cf")] + t_end,
                        "opensees": os_cmd + t_end}, runs, tmp)
    return {"case": "demos/paper_spatial.toml", "t_end": 3.0 if quick else 30.0,
            "peer": "OpenSees " + PINS[0].split("==")[1] + " (openseespy)",
            "accuracy": acc, "timing": timing}


def tension_stats(t, T, start: float, omega: float) -> dict:
    """Fairlead tension statistics for t >= start: raw and smoothed over 1 s (the axial
    and touchdown ringing of both models left out), the mean, and the amplitudes of the
    harmonics k omega (k = 1, 2, 3) of the surge frequency (least squares)."""
    w = t >= start
    dt = t[1] - t[0]
    k = max(1, int(round(1.0 / dt)))
    s = np.convolve(T, np.ones(k) / k, mode="same")
    ws = w & (np.arange(len(t)) >= k) & (np.arange(len(t)) < len(t) - k)
    out = {"peak": float(T[w].max()), "trough": float(T[w].min()),
           "rms": float(np.sqrt(np.mean(T[w] ** 2))), "mean": float(T[w].mean()),
           "peak_1s": float(s[ws].max()), "trough_1s": float(s[ws].min())}
    y = T[w] - T[w].mean()
    for n in (1, 2, 3):
        A = np.column_stack([np.cos(n * omega * t[w]), np.sin(n * omega * t[w])])
        out[f"harmonic_{n}"] = float(np.hypot(*np.linalg.lstsq(A, y, rcond=None)[0]))
    return out


def compare_stats(a: dict, b: dict) -> dict:
    return {k: rel(a[k], b[k]) for k in a}


def mooring(py: Path, runs: int, quick: bool, tmp: Path, elements: list[int],
            segments: list[int]) -> dict:
    t_end = ["--t-end", "10"] if quick else []
    text = MOORING.read_text()
    omega = float(tomllib.loads(text)["anchors"][1]["motion"]["omega"])
    cf_stats, md_stats, cmds = {}, {}, {}
    for n in elements:
        case = tmp / f"mooring_{n}.toml"
        case.write_text(text.replace("elements = 80\n", f"elements = {n}\n"))
        cmd = [sys.executable, "-m", "cablefem", "run", str(case), "--no-figures", "--quiet",
               "--output", str(tmp / f"cf{n}")] + t_end
        timed(cmd, tmp)
        t, N, _ = anchor_rows(tmp / f"cf{n}" / "anchors.csv", "fairlead")
        cf_stats[n] = tension_stats(t, np.linalg.norm(N, axis=1), t[-1] / 2, omega)
        cmds.setdefault("cablefem", cmd)
    for n in segments:
        cmd = [str(py), str(PEERS / "moordyn_line.py"), str(MOORING), str(tmp / f"md{n}.npz"),
               "--segments", str(n)] + t_end
        timed(cmd, tmp)
        o = np.load(tmp / f"md{n}.npz")
        md_stats[n] = tension_stats(o["time"], np.linalg.norm(o["force"], axis=1),
                                    o["time"][-1] / 2, omega)
        cmds.setdefault("moordyn", cmd)
    e, s = elements, segments
    acc = {"cablefem": {str(n): v for n, v in cf_stats.items()},
           "moordyn": {str(n): v for n, v in md_stats.items()},
           "cablefem_refinement_change": compare_stats(cf_stats[e[0]], cf_stats[e[-1]]),
           "moordyn_refinement_change": compare_stats(md_stats[s[0]], md_stats[s[-1]]),
           "cablefem_vs_moordyn_finest": compare_stats(cf_stats[e[-1]], md_stats[s[-1]]),
           "cablefem_vs_moordyn_timed": compare_stats(cf_stats[e[0]], md_stats[s[-1]])}
    timing = alternate(cmds, runs, tmp)
    timing["discretisations"] = {"cablefem_elements": e[0], "moordyn_segments": s[0]}
    return {"case": "benchmarks/peers/mooring.toml", "t_end": 10.0 if quick else 90.0,
            "peer": "MoorDyn " + PINS[1].split("==")[1] + " (moordyn)",
            "accuracy": acc, "timing": timing}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=3, help="timed runs of each code (default 3)")
    ap.add_argument("--jobs", default="caseB,mooring", help="caseB, mooring or both")
    ap.add_argument("--quick", action="store_true",
                    help="smoke run: one timed run each, short t_end (3 s, 10 s)")
    ap.add_argument("--elements", default="80,160",
                    help="cablefem's mooring elements: timed, refined (default 80,160)")
    ap.add_argument("--segments", default="80,160",
                    help="MoorDyn's segments: timed, refined (default 80,160)")
    ap.add_argument("--venv", type=Path, default=VENV, help=f"the peers' venv ({VENV})")
    ap.add_argument("--json", type=Path, help="also write the JSON document to this file")
    args = ap.parse_args()
    jobs = [j.strip() for j in args.jobs.split(",") if j.strip()]
    bad = [j for j in jobs if j not in ("caseB", "mooring")]
    if bad or not jobs:
        ap.error(f"--jobs: unknown job(s) {bad}; choose caseB, mooring")
    runs = 1 if args.quick else args.runs
    try:
        py = venv_python(args.venv)
    except PeerUnavailable as exc:
        print(f"bench_peers: the peers are not available, nothing measured: {exc}",
              file=sys.stderr)
        return 1
    out = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
           "machine": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
           "python": platform.python_version(), "peers": list(PINS), "quick": args.quick,
           "load_average_1min": round(os.getloadavg()[0], 2)}
    with tempfile.TemporaryDirectory(prefix="cablefem-peers-") as tmp:
        tmp = Path(tmp)
        if "caseB" in jobs:
            (tmp / "b").mkdir()
            out["caseB"] = case_b(py, runs, args.quick, tmp / "b")
        if "mooring" in jobs:
            (tmp / "m").mkdir()
            out["mooring"] = mooring(py, runs, args.quick, tmp / "m",
                                     [int(x) for x in args.elements.split(",")],
                                     [int(x) for x in args.segments.split(",")])
    out["load_average_1min_after"] = round(os.getloadavg()[0], 2)
    text = json.dumps(out, indent=2)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
