"""The dampers' own numbers (``dampers.csv``, ``summary.json``'s ``dampers``): a dashpot's
force is ``c`` times its velocity at every row, the stroke and velocity are the node's
motion from the static state along the damper's axis, a spring-dashpot's force is
``-(c v + k stroke)``, the summary's peak and RMS are those of the written columns over the
statistics window, the same on 1 and 2 ranks, and a killed run resumed from its checkpoint
writes the uninterrupted run's file (serial and under mpirun -n 2, but the kill)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import numpy as np
import pytest
from mpi4py import MPI

from cablefem.app.damperout import DamperOutput
from cablefem.app.run import run_case
from cablefem.app.statistics import window_start
from cablefem.cable import CableModel
from cablefem.case import parse_case
from cablefem.dynamics import integrate
from cablefem.io import dampercsv
from cablefem.statics import solve_static

comm = MPI.COMM_WORLD
T, M, L, EA = 1.0e4, 1.0, 10.0, 1.0e8  # a taut cable (N, kg/m, m, N), as test_dampers'


def taut(direction=(0.0, 0.0, 1.0), stiffness=0.0, correction="none", t_end=0.2) -> dict:
    """A taut weightless cable between pinned anchors, 40 elements, Krenk's optimal
    dashpot (c = sqrt(T m)/(pi a/L)) at a = L/20 from p, the far anchor q moving across at
    30 rad/s (mode 1: 31.4 rad/s)."""
    lam = 1.0 + T / EA
    c = np.sqrt(T * M) / (np.pi * 0.05)
    damper = {"anchor": "p", "distance": 0.05 * L / lam, "coefficient": c,
              "stiffness": stiffness}
    if direction is not None:
        damper["direction"] = list(direction)
    return {"title": "taut", "section": {"EA": EA, "EI": 25.0, "mass": M},
            "gravity": {"g": 0.0}, "geometry": {"length": L / lam},
            "mesh": {"elements": 40},
            "anchors": [{"name": "p", "position": [0.0, 0, 0], "type": "pinned"},
                        {"name": "q", "position": [L, 0, 0], "type": "pinned",
                         "motion": {"type": "harmonic", "amplitude": [0, 2e-3, 1e-3],
                                    "omega": 30.0}}],
            "dampers": [damper], "solver": {"outer_correction": correction},
            "dynamics": {"t_end": t_end, "dt": 2e-3, "checkpoint_every": 25}}


def test_stroke_and_velocity_are_the_nodes_motion_along_the_axis():
    """At every output time of the integration: the damper's stroke and velocity are its
    node's displacement from the static state and velocity along the damper's direction
    (nodal values gathered independently; the damper acts at the node itself at leading
    order), and the force is c times the velocity (a dashpot), its vector -force d:
    round-off (1e-12 of the largest value)."""
    d = np.array([0.0, 0.6, 0.8])
    case = parse_case(taut(direction=d))
    model = CableModel(comm, case)
    solve_static(model)
    out = DamperOutput(model, None)
    c = case.dampers[0].coefficient
    k = model.damper_nodes[0]
    us = model.gather_nodal(model.u_static)
    got, want = [], []
    for _t, _ in integrate(model, 0.2, 2e-3, 0.9, 5):
        cols = out.measure()
        u, v = model.gather_nodal(model.u), model.gather_nodal(model.v)
        if comm.rank == 0:
            got.append([cols[q][0] for q in ("stroke", "velocity", "force", "Fx", "Fy", "Fz")])
            want.append([d @ (u[k] - us[k]), d @ v[k], c * (d @ v[k]), *(-c * (d @ v[k]) * d)])
    if comm.rank == 0:
        got, want = np.array(got), np.array(want)
        assert np.max(np.abs(want[:, 0])) > 1e-6  # the node moves (3.5e-6 m): not all zeros
        for j in range(want.shape[1]):  # each column to round-off of its own size
            np.testing.assert_allclose(got[:, j], want[:, j], rtol=0,
                                       atol=1e-12 * np.max(np.abs(want[:, j])))


def _run(tmp, d: dict, world=comm):
    res = run_case(parse_case(d), tmp, world, figures=False, progress=False, modes=0)
    return res.summary, dampercsv.read(tmp / "dampers.csv")["damper0"]


def test_spring_dashpot_force_and_the_summary(mpi_tmp_path):
    """A spring-dashpot acting in the normal plane, with the kink layer's offset (the
    default route): every row's force vector is -(c velocity + k stroke) (its vectors, to
    round-off), the magnitudes are the vectors' norms, and the summary's peaks and RMS are
    the written columns' over the window the kinks use (numpy on the file; round-off).
    The spring matters: the force is not c |v| (by more than 1 %)."""
    dd = taut(direction=None, stiffness=2e4, correction="hinge")
    summary, r = _run(mpi_tmp_path / "ks", dd)
    c, k = dd["dampers"][0]["coefficient"], 2e4
    F = np.column_stack([r[x] for x in dampercsv.VECTOR_COLUMNS["force"]])
    S = np.column_stack([r[x] for x in dampercsv.VECTOR_COLUMNS["stroke"]])
    V = np.column_stack([r[x] for x in dampercsv.VECTOR_COLUMNS["velocity"]])
    np.testing.assert_allclose(F, -(c * V + k * S), rtol=0, atol=1e-12 * np.abs(F).max())
    for q, vec in (("force", F), ("stroke", S), ("velocity", V)):
        np.testing.assert_allclose(r[q], np.linalg.norm(vec, axis=1), rtol=1e-13, atol=0)
    assert np.max(np.abs(r["force"] - c * r["velocity"])) > 0.01 * r["force"].max()
    entry = summary["dampers"]["damper0"]
    t = r["time"]
    t0 = window_start(t)
    assert entry["window"] == [t0, t[-1]]
    assert entry["window"][0] == summary["kinks"]["damper0"]["steady_state_moment"][
        "window"][0]
    sel = t >= t0
    for q in dampercsv.QUANTITIES:
        assert entry[f"{q}_peak"] == pytest.approx(np.max(np.abs(r[q][sel])), rel=1e-14)
        assert entry[f"{q}_rms"] == pytest.approx(np.sqrt(np.mean(r[q][sel] ** 2)),
                                                  rel=1e-13)
        assert entry[f"{q}_run_peak"] == pytest.approx(np.max(np.abs(r[q])), rel=1e-14)


def test_dashpot_rows_and_one_rank_against_all(mpi_tmp_path):
    """A dashpot along a direction: force == c velocity at every row of dampers.csv
    (round-off), signed (both signs occur); the run on every rank together writes what a
    run on rank 0 alone writes (1e-10: iterative solves' tolerance over 100 steps)."""
    dd = taut(direction=(0.0, 0.6, 0.8))
    _, r = _run(mpi_tmp_path / "all", dd)
    c = dd["dampers"][0]["coefficient"]
    np.testing.assert_allclose(r["force"], c * r["velocity"], rtol=0,
                               atol=1e-12 * np.abs(r["force"]).max())
    assert r["velocity"].min() < 0 < r["velocity"].max()
    if comm.size > 1:
        alone = None
        if comm.rank == 0:
            _, alone = _run(mpi_tmp_path / "alone", dd, MPI.COMM_SELF)
        alone = comm.bcast(alone, root=0)
        for col in dampercsv.DAMPER_COLUMNS[2:]:
            np.testing.assert_allclose(r[col], alone[col], rtol=0,
                                       atol=1e-10 * max(np.abs(alone[col]).max(), 1e-300))
        np.testing.assert_array_equal(r["time"], alone["time"])


def _toml(d: dict) -> str:
    """The TOML of :func:`taut`'s dict (tables, arrays of tables, one level of subtable)."""
    def val(x):
        return json.dumps([float(y) for y in x]) if isinstance(x, (list, tuple)) else (
            json.dumps(x) if isinstance(x, str) else repr(x))

    def table(head, t):
        lines = [head] + [f"{k} = {val(v)}" for k, v in t.items() if not isinstance(v, dict)]
        sub = [table(f"[{head.strip('[]')}.{k}]", v) for k, v in t.items()
               if isinstance(v, dict)]
        return "\n".join(lines + sub)

    parts = [f"title = {val(d['title'])}"]
    for key, t in d.items():
        if isinstance(t, dict):
            parts.append(table(f"[{key}]", t))
        elif isinstance(t, list):
            parts += [table(f"[[{key}]]", x) for x in t]
    return "\n".join(parts) + "\n"


@pytest.mark.serial  # a SIGKILL in a subprocess
def test_dampers_csv_survives_a_kill(tmp_path):
    """Killed between checkpoints and restarted: dampers.csv and kinks.csv (the damper's
    kink) hold the uninterrupted run's rows (those after the checkpoint dropped and written
    again: round-off) and the summary's peaks are the whole run's (the kink's history read
    back from kinks.csv at the restart, then continued)."""
    case = tmp_path / "taut.toml"
    case.write_text(_toml(taut(direction=None)))
    ref, out = tmp_path / "ref", tmp_path / "out"

    def cablefem(*args, env=None):
        return subprocess.run([sys.executable, "-m", "cablefem", *map(str, args)],
                              capture_output=True, text=True, timeout=600,
                              env={**os.environ, **(env or {})})

    assert cablefem("run", case, "--output", ref, "--no-figures", "-q").returncode == 0
    res = cablefem("run", case, "--output", out, "--no-figures", "-q",
                   env={"CABLEFEM_KILL_AT": "step:60"})
    assert res.returncode == -signal.SIGKILL, res.stderr
    assert cablefem("run", "--restart", out, "--no-figures", "-q").returncode == 0
    a, b = dampercsv.read(out / "dampers.csv"), dampercsv.read(ref / "dampers.csv")
    assert a["damper0"]["time"].size == b["damper0"]["time"].size == 101
    for col in dampercsv.DAMPER_COLUMNS[2:]:
        np.testing.assert_allclose(a["damper0"][col], b["damper0"][col], rtol=1e-12,
                                   atol=1e-15)
    sa = json.loads((out / "summary.json").read_text())["dampers"]["damper0"]
    sb = json.loads((ref / "summary.json").read_text())["dampers"]["damper0"]
    for key in ("force_peak", "force_rms", "stroke_peak", "velocity_rms"):
        assert sa[key] == pytest.approx(sb[key], rel=1e-12)
    ka, kb = (np.genfromtxt(d / "kinks.csv", delimiter=",", names=True, dtype=None,
                            encoding="utf-8") for d in (out, ref))
    assert ka.size == kb.size == 101
    for col in ("time", "tension", "delta", "moment", "layer_length", "valid"):
        np.testing.assert_allclose(ka[col], kb[col], rtol=1e-12, atol=1e-15)
    sa, sb = (json.loads((d / "summary.json").read_text())["kinks"]["damper0"]
              for d in (out, ref))
    assert sa["valid_fraction"] == sb["valid_fraction"] == 1.0
    for key in ("peak", "rms", "run_peak", "mean"):
        assert sa["steady_state_moment"][key] == pytest.approx(
            sb["steady_state_moment"][key], rel=1e-12)


def test_network_damper_cell_is_the_single_cables_damper(mpi_tmp_path):
    """A network's grounded damper cell, slanted at 45 degrees, acting along y
    (``direction``) is the single cable's damper along y at the same node (test_dampers:
    the same damping ratios to 1e-7): under a harmonic point load along y, step by step,
    its force, stroke and velocity are the single cable's with the sign of the cell's
    orientation (cable node to ground: the stroke is -u_y): measured 6e-12 of the peak,
    1e-9 allowed (the two models' Newton tolerances); force = c velocity + k stroke at
    every row (round-off)."""
    import test_dampers as td

    from cablefem.network import NetworkModel

    n, a, p = 50, 5, 15
    c, k = np.sqrt(td.T * td.M) / (np.pi * a / n), 2e3
    time = {"type": "harmonic", "omega": 20.0}
    net = NetworkModel(comm, td._tie_network(
        mpi_tmp_path / "slant.msh", True, c, k, n, a, slant=1.0, direction=[0.0, 1.0, 0.0],
        point_loads=[{"group": "load", "value": [0.0, 2.0, 0.0], "time": time}]))
    d = td.taut(a / n, 1.0, n, stiffness=k)
    d["dampers"][0].update(coefficient=c, direction=[0.0, 1.0, 0.0])
    d["point_loads"] = [{"s": p * td.L / n / td.LAM, "value": [0.0, 2.0, 0.0],
                         "time": time}]
    one = CableModel(comm, parse_case(d))
    runs = []
    for model in (net, one):
        solve_static(model)
        out = DamperOutput(model, None)
        assert out.names == (["tie"] if model is net else ["damper0"])
        runs.append(np.array([[out.measure()[q][0] for q in ("force", "stroke", "velocity")]
                              for _ in integrate(model, 0.3, 2e-3, 0.9, 1)]))
    got, ref = runs
    assert np.max(np.abs(ref[:, 1])) > 1e-5  # the node moves
    for j in range(3):
        np.testing.assert_allclose(-got[:, j], ref[:, j], rtol=0,
                                   atol=1e-9 * np.max(np.abs(ref[:, j])))
    np.testing.assert_allclose(got[:, 0], c * got[:, 2] + k * got[:, 1], rtol=0,
                               atol=1e-12 * np.max(np.abs(got[:, 0])))


def test_the_kinks_history_holds_about_8_bytes_a_number(tmp_path):
    """What a run keeps of its kinks' rows until the reports (8 columns a kink and time),
    in row buffers: below 20 bytes a number (8 a float64, 16 just after its buffer doubled,
    the first 64 rows' buffer and each time's own 8 bytes beside). In lists (before) each
    number was a Python float and its pointer, 32 bytes. Rows of the damper's kink at its
    static state, recorded 2000 times as a run records them."""
    import tracemalloc

    from cablefem.app import kinkout

    case = parse_case(taut(direction=None))
    model = CableModel(MPI.COMM_SELF, case)
    solve_static(model)
    out = kinkout.KinkOutput(model, tmp_path, None)
    assert len(out.kinks) == 1
    tracemalloc.start(8)
    try:
        for k in range(2000):
            out.add(1e-3 * k)
        out.close()
        snap = tracemalloc.take_snapshot().filter_traces(
            [tracemalloc.Filter(True, kinkout.__file__, all_frames=True)])
        held = sum(s.size for s in snap.statistics("filename"))
    finally:
        tracemalloc.stop()
    h = out.history()
    assert len(h.times) == 2000 and np.asarray(h.rows["damper0"]["moment"]).shape == (2000,)
    assert held / (2000 * 8) < 20
