"""Case B of the paper in OpenSees (openseespy): the job of ``cablefem run CASE`` by a peer.

Run by ``benchmarks/bench_peers.py`` with the benchmark-only interpreter (never imported by
cablefem or its tests). One whole process does what a user of OpenSees would do for the
same answer: read the case (TOML), build a chain of corotational truss elements (as many as
the case's ``[mesh] elements``, consistent mass, the same stress-free length), statics
under gravity, the first ``[modal] modes`` eigenvalues, the transient in the same
generalised-alpha family (Newmark's average acceleration, rho_inf = 1; the same dt) with
Rayleigh damping on the current tangent, the anchor forces at every step and, from them,
the anchor moments by cablefem's pure-NumPy inner solution (``cablefem.asymptotics``,
leading order, exact form).

    python opensees_caseB.py CASE.toml OUT.npz [--t-end T]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import openseespy.opensees as ops

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))  # cablefem.asymptotics: NumPy only (no dolfinx is imported)
from cablefem import asymptotics  # noqa: E402


def arc_nodes(chord: float, length: float, n: int) -> np.ndarray:
    """n + 1 nodes from (0, 0, 0) to (chord, 0, 0), n equal sides of length length/n, on a
    circular arc sagging along -z: the stress-free lengths of the elements (OpenSees takes
    an element's stress-free length from its nodes)."""
    h = length / n
    lo, hi = 1e-12, 2 * math.pi / n - 1e-12  # sin(n th/2)/sin(th/2) falls from n to 0
    for _ in range(200):
        th = 0.5 * (lo + hi)
        if math.sin(n * th / 2) / math.sin(th / 2) > chord / h:
            lo = th
        else:
            hi = th
    R = h / (2 * math.sin(th / 2))
    zc = R * math.cos(n * th / 2)
    phi = -n * th / 2 + th * np.arange(n + 1)
    x = chord / 2 + R * np.sin(phi)
    return np.column_stack([x, np.zeros_like(x), zc - R * np.cos(phi)])


def motion(mot: dict, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Displacement, velocity, acceleration (len(t), 3) of cablefem's ellipse motion
    a_s sin(w t) + a_c (cos(w t) - 1) (no ramp)."""
    if mot.get("type") != "ellipse" or float(mot.get("ramp", 0.0)) != 0.0:
        raise SystemExit("opensees_caseB: only an ellipse motion without ramp is written here")
    w = float(mot["omega"])
    a_s, a_c = np.asarray(mot["axis_sin"], float), np.asarray(mot["axis_cos"], float)
    s, c = np.sin(w * t)[:, None], np.cos(w * t)[:, None]
    return (a_s * s + a_c * (c - 1), w * (a_s * c - a_c * s), -w * w * (a_s * s + a_c * c))


def tangent_and_mass(x: np.ndarray, h0: float, EA: float, m: float, n: int):
    """Assembled tangent (material + geometric) and consistent mass of the truss chain at
    positions x (n+1, 3): for the consistent start (cablefem's 'quasi-static' start)."""
    K = np.zeros((3 * (n + 1), 3 * (n + 1)))
    M = np.zeros_like(K)
    for e in range(n):
        d = x[e + 1] - x[e]
        L = np.linalg.norm(d)
        t = d / L
        T = EA * (L - h0) / h0
        k = EA / h0 * np.outer(t, t) + T / L * (np.eye(3) - np.outer(t, t))
        me = m * h0 / 6 * np.eye(3)
        sl = slice(3 * e, 3 * e + 6)
        K[sl, sl] += np.block([[k, -k], [-k, k]])
        M[sl, sl] += np.block([[2 * me, me], [me, 2 * me]])
    return K, M


def consistent_start(n: int, h0: float, EA: float, m: float, alpha: float, beta: float,
                     vb: np.ndarray, ab: np.ndarray) -> None:
    """cablefem's 'quasi-static' start: the free nodes follow the anchor's velocity ``vb``
    quasi-statically (K_ff v_f = -K_fb v_b, static tangent) with the acceleration the
    equations of motion give (generalised-alpha's consistent start), set in OpenSees."""
    xs = np.array([ops.nodeCoord(i + 1) for i in range(n + 1)]) + np.array(
        [ops.nodeDisp(i + 1) for i in range(n + 1)])
    K, M = tangent_and_mass(xs, h0, EA, m, n)
    free = np.arange(3, 3 * n)
    bnd = np.arange(3 * n, 3 * n + 3)
    vf = np.linalg.solve(K[np.ix_(free, free)], -K[np.ix_(free, bnd)] @ vb)
    C = alpha * M + beta * K
    af = np.linalg.solve(M[np.ix_(free, free)], -C[np.ix_(free, free)] @ vf
                         - C[np.ix_(free, bnd)] @ vb - M[np.ix_(free, bnd)] @ ab)
    for i in range(1, n):
        for d in range(3):
            ops.setNodeVel(i + 1, d + 1, float(vf[3 * (i - 1) + d]), "-commit")
            ops.setNodeAccel(i + 1, d + 1, float(af[3 * (i - 1) + d]), "-commit")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("case", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--t-end", type=float)
    args = ap.parse_args()
    t_start = time.perf_counter()
    c = tomllib.loads(args.case.read_text())
    sec, n = c["section"], int(c["mesh"]["elements"])
    EA, EI, m = float(sec["EA"]), float(sec["EI"]), float(sec["mass"])
    g = float(c["gravity"]["g"]) * np.asarray(c["gravity"].get("direction", [0, 0, -1]), float)
    length = float(c["geometry"]["length"])
    (pa, qa) = c["anchors"]
    P, Q = np.asarray(pa["position"], float), np.asarray(qa["position"], float)
    if P.any() or Q[1] or Q[2] or g[0] or g[1]:
        raise SystemExit("opensees_caseB: written for anchors (0,0,0), (c,0,0) and gravity -z")
    dyn, damp = c["dynamics"], c["damping"]
    dt = float(dyn["dt"])  # rho_inf: Newmark below is rho_inf = 1 (docs/benchmarks.md)
    t_end = args.t_end if args.t_end is not None else float(dyn["t_end"])
    z, (w1, w2) = float(damp["ratio"]), (float(f) for f in damp["frequencies"])
    alpha, beta = 2 * z * w1 * w2 / (w1 + w2), 2 * z / (w1 + w2)
    h0 = length / n
    x0 = arc_nodes(Q[0], length, n)

    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 3)
    for i, xi in enumerate(x0):
        ops.node(i + 1, *xi)
    ops.fix(1, 1, 1, 1)
    ops.fix(n + 1, 1, 0, 0)  # q moves in y and z only (imposed below)
    for i in range(1, n):  # no stiffness across the plane before the cable is taut
        ops.fix(i + 1, 0, 1, 0)
    ops.uniaxialMaterial("Elastic", 1, EA)
    for e in range(n):
        # -doRayleigh 1: without it a corotTruss leaves the Rayleigh damping out altogether
        ops.element("corotTruss", e + 1, e + 1, e + 2, 1.0, 1, "-rho", m, "-cMass", 1,
                    "-doRayleigh", 1)
    # The run's clock: statics in pseudo-time [-1, 0] (gravity ramped 0 -> 1, anchors at
    # rest), the transient from t = 0 (gravity held, the anchor on its ellipse).
    nsteps = int(round(t_end / dt))
    times = dt * np.arange(nsteps + 2)
    u, v, a = motion(qa["motion"], times)
    ops.timeSeries("Path", 1, "-time", -1.0, 0.0, 1e30, "-values", 0.0, 1.0, 1.0)
    ops.pattern("Plain", 1, 1)
    for i in range(n + 1):  # the weight per stress-free length, consistent (= lumped for
        ops.load(i + 1, *(m * g * h0 * (0.5 if i in (0, n) else 1.0)))  # linear elements)
    ops.pattern("MultipleSupport", 2)
    tag = 10
    for dof in (2, 3):
        series = []
        for arr in (u, v, a):
            tag += 1
            vals = [0.0, *arr[:, dof - 1]]
            ops.timeSeries("Path", tag, "-time", -1.0, *times, "-values", *vals)
            series.append(tag)
        ops.groundMotion(dof, "Plain", "-disp", series[0], "-vel", series[1],
                         "-accel", series[2])
        ops.imposedMotion(n + 1, dof, dof)
    ops.setTime(-1.0)
    ops.constraints("Transformation")
    ops.numberer("Plain")
    ops.system("BandGeneral")
    ops.test("NormUnbalance", 1e-10 * np.linalg.norm(m * g) * length, 50)
    ops.algorithm("Newton")
    ops.integrator("LoadControl", 0.1)
    ops.analysis("Static")
    if ops.analyze(10) != 0:
        raise SystemExit("opensees_caseB: statics did not converge")
    for i in range(1, n):  # taut: free again across the plane (and held there by tension)
        ops.remove("sp", i + 1, 2)
    omegas = np.sqrt(np.asarray(ops.eigen(int(c["modal"]["modes"]))))
    consistent_start(n, h0, EA, m, alpha, beta, v[0], a[0])
    ops.wipeAnalysis()
    ops.setTime(0.0)
    ops.constraints("Transformation")
    ops.numberer("Plain")
    ops.system("BandGeneral")
    ops.test("NormUnbalance", 1e-9 * np.linalg.norm(m * g) * length, 25)
    ops.algorithm("Newton")
    # Newmark's average acceleration (the generalised-alpha family at rho_inf = 1, the
    # trapezoidal rule): OpenSees 3.7's GeneralizedAlpha stalls with a moving support
    # (Newton converges linearly, at a ratio of 0.7) and its HHT commits the support at
    # t_n + alpha dt while the span is at t_n + dt (the anchor force then jumps by 4 %).
    ops.integrator("Newmark", 0.5, 0.25)
    ops.rayleigh(alpha, beta, 0.0, 0.0)  # beta on the current tangent, as cablefem's default
    ops.analysis("Transient")
    forces = np.empty((nsteps + 1, 2, 3))

    def record(k):
        ops.reactions("-dynamic")  # with inertia and damping: the consistent reaction
        forces[k, 0] = -np.asarray(ops.nodeReaction(1))  # force of the span, into the span
        forces[k, 1] = -np.asarray(ops.nodeReaction(n + 1))

    record(0)
    for k in range(1, nsteps + 1):
        if ops.analyze(1, dt) != 0:
            raise SystemExit(f"opensees_caseB: step {k} did not converge")
        record(k)
    t = dt * np.arange(nsteps + 1)
    # the paper's asymptotics: inner solution + the string's own curvature at each clamp
    moments = []
    for j, (anchor, acc) in enumerate(((pa, np.zeros((nsteps + 1, 3))), (qa, a[:nsteps + 1]))):
        cdir = np.asarray(anchor["direction"], float)
        lay = asymptotics.layer(forces[:, j], cdir, EI, EA, form="exact")
        kap = asymptotics.string_curvature(lay.tangent, lay.tension, m, acc, m * g)
        moments.append(np.linalg.norm(lay.moment_vector + EI * kap, axis=1))
    wall = time.perf_counter() - t_start
    np.savez(args.out, time=t, forces=forces, moment=np.array(moments).T, omegas=omegas)
    print(json.dumps({"omegas": omegas.tolist(), "steps": nsteps, "wall_s": round(wall, 3)}))


if __name__ == "__main__":
    main()
