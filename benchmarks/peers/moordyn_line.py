"""The mooring job of ``benchmarks/bench_peers.py`` in MoorDyn v2 (the ``moordyn`` package).

Run with the benchmark-only interpreter (never imported by cablefem or its tests). One
whole process does what a MoorDyn user does for the answer: read the case (TOML, the same
file cablefem runs), write MoorDyn's input file and its current profile, find the static
state (MoorDyn's own initial-condition solver), step the line with the fairlead moved as a
coupled point (its position at the start of each coupling step and the velocity that takes
it to the next one) and keep the fairlead force at every output step (the case's dt).
MoorDyn's initial conditions leave the current out, so the line first settles in it
(``--settle`` s, the fairlead held) before t = 0; that time is part of the job.

The coupling step is the output step divided by ``--substeps`` (default: 1 ms or less). A
coupled point moves at a constant velocity within a coupling step, so its velocity jumps by
``a h`` at every step (``a`` its acceleration, ``h`` the coupling step); the jump's part
along the line sends an axial stress wave of ``sqrt(EA m)`` times it (128 kN s/m for the
mooring case), and the force read at the same instant carries it. At the surge's
acceleration that bias is in phase with the motion: with ``h`` = 20 ms it put 160 N on the
fairlead tension's harmonic at the surge frequency (423 N against 267 N with ``h`` = 1 ms, 40
segments; docs/benchmarks.md).

    python moordyn_line.py CASE.toml OUT.npz --segments N [--t-end T] [--settle S]
                           [--substeps K]
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
import tomllib
from pathlib import Path

import moordyn
import numpy as np

#: the longest coupling step (s) by default: the force's bias from the fairlead's velocity
#: jumps (module docstring) is then about 1 % of the mooring case's surge harmonic (267 N
#: at 1 ms, 271 N at 2.5 ms, 285 N at 5 ms, 40 segments)
MAX_COUPLING_STEP = 1.0e-3


def ramp(t: float, T: float) -> tuple[float, float]:
    """cablefem's ramp r = 10 x^3 - 15 x^4 + 6 x^5 (x = t/T) and its derivative."""
    if T <= 0 or t >= T:
        return 1.0, 0.0
    x = max(t, 0.0) / T
    return 10 * x**3 - 15 * x**4 + 6 * x**5, 30 * x**2 * (1 - x) ** 2 / T


def fairlead_position(mot: dict, x0: np.ndarray, t: float) -> np.ndarray:
    """cablefem's harmonic motion A sin(w t + phase), ramped (default: three periods)."""
    w, A = float(mot["omega"]), np.asarray(mot["amplitude"], float)
    r, _ = ramp(t, float(mot.get("ramp", 3 * 2 * math.pi / w)))
    return x0 + r * A * math.sin(w * t + float(mot.get("phase", 0.0)))


def write_input(c: dict, folder: Path, segments: int) -> Path:
    """MoorDyn's input file and current profile for the case (conventions in
    docs/benchmarks.md: BA = beta EA, kBot = stiffness/D, cBot = damping/D)."""
    sec, fl, bed = c["section"], c["fluid"], c["seabed"]
    D, EA = float(sec["diameter"]), float(sec["EA"])
    beta = float(c.get("damping", {}).get("beta", 0.0))
    a, f = (np.asarray(x["position"], float) for x in c["anchors"])
    depth = -float(bed["z"])
    prof = fl["profile"]
    z = np.linspace(-depth, float(fl.get("surface", 0.0)), 201)
    fac = np.clip((z - float(prof["ground"])) / float(prof["reference"]), 0, None) ** float(
        prof["exponent"])
    U = np.asarray(fl["current"], float)
    rows = "\n".join(f"{zi:.6f} {fi * U[0]:.8f} {fi * U[1]:.8f} {fi * U[2]:.8f}"
                     for zi, fi in zip(z, fac))
    (folder / "current_profile.txt").write_text(
        "--------------------- MoorDyn steady currents File ----------------------\n"
        "Tabulated file with the water currents components\n"
        f"z (m), ux (m/s), uy (m/s), uz (m/s)\n{rows}\n")
    # MoorDyn's explicit step: RK4, with the axial wave's highest frequency 2 c/l
    # (c = sqrt(EA/m), l the segment) times dtM at 1.6 (RK4 is stable up to 2.8 there; RK2
    # grows by sqrt(1 + (w dt)^4/4) a step without damping: MoorDyn's own step from its
    # CFL = 0.5, pi l/c, diverges within 0.1 s here), and below the internal damping's own
    # limit (about m l^2 / (2 BA)) with a margin of 2.
    h, m = float(c["geometry"]["length"]) / segments, float(sec["mass"])
    dtm = 0.8 * h / math.sqrt(EA / m)
    if beta > 0:
        dtm = min(dtm, 0.25 * m * h * h / (beta * EA))
    cdt, cat = fl["cd_tangential"], fl.get("ca_tangential", 0.0)
    text = f"""--------------------- MoorDyn Input File ------------------------------------
cablefem peer benchmark: {c.get('title', '')}
----------------------- LINE TYPES ------------------------------------------
TypeName   Diam    Mass/m     EA         BA/-zeta    EI         Cd     Ca     CdAx    CaAx
(name)     (m)     (kg/m)     (N)        (N-s/-)     (N-m^2)    (-)    (-)    (-)     (-)
line  {D}  {sec['mass']}  {EA}  {beta * EA}  0.0  {fl['cd_normal']}  {fl['ca_normal']}  {cdt}  {cat}
---------------------- POINTS --------------------------------
ID    Attachment  X       Y       Z       Mass   Volume  CdA    Ca
(#)   (-)       (m)     (m)     (m)     (kg)   (m^3)   (m^2)  (-)
1     Fixed     {a[0]}  {a[1]}  {a[2]}  0      0       0      0
2     Coupled   {f[0]}  {f[1]}  {f[2]}  0      0       0      0
---------------------- LINES ----------------------------------------
ID   LineType   AttachA  AttachB  UnstrLen  NumSegs  LineOutputs
(#)   (name)     (#)      (#)       (m)       (-)     (-)
1     line       1        2         {c['geometry']['length']}   {segments}   -
---------------------- OPTIONS -----------------------------------------
0             writeLog
{float(c['gravity']['g'])}   g
{float(fl['density'])}   rho
{depth}   WtrDpth
{float(bed['stiffness']) / D}   kBot
{float(bed.get('damping', 0.0)) / D}   cBot
0.0           FrictionCoefficient
1             Currents
0             WaveKin
{dtm}   dtM
RK4           tScheme
1.0e-5        threshIC
1             disableOutput
1             disableOutTime
------------------------- need this line --------------------------------------
"""
    path = folder / "line.txt"
    path.write_text(text)
    return path


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("case", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--segments", type=int, required=True)
    ap.add_argument("--t-end", type=float)
    ap.add_argument("--settle", type=float, default=30.0,
                    help="s of MoorDyn run with the fairlead held before t = 0 (default 30)")
    ap.add_argument("--substeps", type=int,
                    help="coupling steps per output step (default: steps of 1 ms or less)")
    ap.add_argument("--workdir", type=Path)
    args = ap.parse_args()
    t_start = time.perf_counter()
    c = tomllib.loads(args.case.read_text())
    if c.get("fluid", {}).get("waves") or c.get("seabed", {}).get("friction", 0.0):
        raise SystemExit("moordyn_line: waves and seabed friction are not written here")
    dyn = c["dynamics"]
    dt = float(dyn["dt"])
    t_end = args.t_end if args.t_end is not None else float(dyn["t_end"])
    fair = c["anchors"][1]
    x0 = np.asarray(fair["position"], float)
    with tempfile.TemporaryDirectory(dir=args.workdir) as tmp:
        path = write_input(c, Path(tmp), args.segments)
        system = moordyn.Create(str(path))
        if moordyn.Init(system, list(x0), [0.0, 0.0, 0.0]) != 0:
            raise SystemExit("moordyn_line: MoorDyn's initial conditions failed")
        n = int(round(t_end / dt))
        sub = args.substeps or max(1, math.ceil(dt / MAX_COUPLING_STEP - 1e-9))
        h = dt / sub
        t = dt * np.arange(n + 1)
        ts = h * np.arange(n * sub + 1)
        pos = np.array([fairlead_position(fair["motion"], x0, ti) for ti in ts])
        force = np.empty((n + 1, 3))
        # MoorDyn's initial conditions leave the current out ("Water kinematics for IC gen:
        # No Waves or Currents"): the line settles in it with the fairlead held (after 30 s
        # its force is within 0.01 % of its limit here)
        ns = int(round(args.settle / dt))
        for k in range(ns):
            f0 = moordyn.Step(system, list(x0), [0.0, 0.0, 0.0], (k - ns) * dt, dt)
        force[0] = f0 if ns else moordyn.GetPointForce(moordyn.GetPoint(system, 2))
        for k in range(n * sub):
            vel = (pos[k + 1] - pos[k]) / h  # the point reaches pos[k + 1] at ts[k + 1]
            f = moordyn.Step(system, list(pos[k]), list(vel), float(ts[k]), h)
            if (k + 1) % sub == 0:
                force[(k + 1) // sub] = f
        moordyn.Close(system)
    np.savez(args.out, time=t, force=force)
    print(json.dumps({"segments": args.segments, "steps": n, "coupling_step": h,
                      "wall_s": round(time.perf_counter() - t_start, 3)}))


if __name__ == "__main__":
    main()
