# %% [markdown]
# # A saddle-shaped cable-net roof under a harmonic uplift (cable network, SI units)
#
# `demos/roof.toml`: two families of 3 cables (`meshes/roof_small.msh`, made by
# `meshes/make_roof.py --n 3 --k 2`) over a 40 m × 40 m plan, a hyperbolic paraboloid of
# 2 m saddle height at the junctions, clamped at the edges. Spiral strands,
# $EA = 2.0\times10^{8}$ N, $EI = 2.0\times10^{3}$ N m², $m = 10$ kg/m (with the cladding's
# share), pretension 100 kN in both families. Besides the weight, a wind-like uplift
# $q(t) = 150\,\text{N/m}\,\sin(8\,\text{rad/s}\;t)$ per stress-free length; Rayleigh
# damping 1 % at 5 and 20 rad/s.
#
# What it shows: a network with junctions (cables of the two families share their crossing
# nodes), a boundary layer at each of the 12 clamped edge anchors and at each crossing
# (both cables kink there), and three checks:
#
# * **Global equilibrium at rest**: $\sum_a \mathbf N_a = \sum_c m\,g\,l_c\,\mathbf e_g$
#   (the anchor forces carry the weight; at $t = 0$ the uplift is $q(0) = 0$), with the
#   stress-free lengths $l_c = L_c/(1 + T_0/EA)$ from the mesh;
# * **the inner solution at every anchor**, recomputed here from the anchor force
#   $\mathbf N_a$ and the clamp direction $\mathbf c$ alone: $T = |\mathbf N_a|$,
#   $\cos\Delta = \mathbf c\cdot\mathbf N_a/T$,
#   $M(0) = 2\sqrt{EI\,T}\,\sin(\Delta/2)\sqrt{1 + (T/EA)\cos^2(\Delta/2)}$
#   (docs/theory.md §3; the virtual hinge multiplies it by the factor of the tension's
#   gradient along the layer, §6.2), against the layer moment the run reports;
# * **the kinks at the crossings** (docs/kinks.md), from their tension and kink angle.
#
# Run: `python demos/demo_roof.py --output output/roof` (5 s of motion; 1 s with the
# environment variable `CI` set). The same case on 2 MPI ranks:
# `mpirun -n 2 python demos/demo_roof.py`.

# %%
import argparse
import json
import os
from pathlib import Path

import meshio
import numpy as np
from mpi4py import MPI

from cablefem.app.log import setup_logging
from cablefem.app.run import run_case
from cablefem.case import load_case

here = Path(__file__).resolve().parent
parser = argparse.ArgumentParser(description=__doc__)
parser.add_argument("--output", type=Path, default=Path("output/roof"))
args = parser.parse_args()
setup_logging()
comm = MPI.COMM_WORLD
case = load_case(here / "roof.toml")
t_end = 1.0 if os.environ.get("CI") else case.dynamics.t_end  # s

# %%
result = run_case(case, args.output, comm, t_end=t_end)
s = result.summary

# %% [markdown]
# ## The weight from the mesh [N]

# %%
mesh = meshio.read(case.network.mesh)
tag_of = {name: int(v[0]) for name, v in mesh.field_data.items() if int(v[1]) == 1}
tags = next(np.asarray(d) for b, d in zip(mesh.cells, mesh.cell_data["gmsh:physical"])
            if b.type == "line")
lines_ = mesh.cells_dict["line"]
gdir = np.asarray(case.gravity.direction, float)
weight = np.zeros(3)
for cab in case.network.cables:
    sec = case.network.sections[cab.section]
    cells = lines_[tags == tag_of[cab.group]]
    L_mesh = np.linalg.norm(mesh.points[cells[:, 1]] - mesh.points[cells[:, 0]], axis=1).sum()
    weight += sec.mass * case.gravity.g * L_mesh / (1 + cab.pretension / sec.EA) * gdir

# %% [markdown]
# ## Checks
# 1. $\sum_a \mathbf N_a$ against the weight: the consistent reactions balance the discrete
#    loads exactly, only Newton's tolerance remains; tolerance $10^{-8}$ of the weight.
# 2. The layer moment [N m] at every clamped anchor against the closed form above, times
#    the first-order factor of the weight's tension gradient along the layer (a few
#    $10^{-6}$ here): the same formula evaluated twice in double precision; tolerance
#    $10^{-10}$.
# 3. At each of the 9 junctions both cables kink (`kinks.csv`, `summary.json`'s `kinks`):
#    each side of the node carries the clamped layer about the bisector, half the kink
#    angle $\Delta$: $M = 2\sqrt{EI\,T}\,\sin(\Delta/4)\sqrt{1 + (T/EA)\cos^2(\Delta/4)}$;
#    tolerance $10^{-10}$ (`static_moment_layer`: the layer's part; the reported moment
#    adds the string's own curvature, as at the anchors). These moments (peaks of about
#    840 N m) exceed the anchors' (about 240 N m): the crossings' clamps, not the edge
#    anchors, are where this net's strands bend most.

# %%
forces = s["static"]["anchor_forces"]
N_sum = np.sum([np.asarray(f) for f in forces.values()], axis=0)
err_eq = float(np.linalg.norm(N_sum - weight) / np.linalg.norm(weight))
ok_eq = err_eq < 1e-8
sec = next(iter(case.network.sections.values()))
err_m = 0.0
for name, a in s["anchors"].items():
    if a["kind"] != "clamped":
        continue
    N = np.asarray(forces[name])
    T = float(np.linalg.norm(N))
    delta = float(np.arccos(np.clip(np.dot(a["direction"], N) / T, -1, 1)))
    M = 2 * np.sqrt(sec.EI * T) * np.sin(delta / 2) * np.sqrt(
        1 + T / sec.EA * np.cos(delta / 2) ** 2)
    # with the virtual hinge, the weight's tension gradient along the layer, dT/ds = -w.t:
    # the factor 1 + ell0 (dT/ds)/(4 T cos^2(Delta/4)) (docs/theory.md §6.2)
    dTds = -sec.mass * case.gravity.g * float(np.dot(gdir, N)) / T
    M *= 1 + np.sqrt(sec.EI / T) * dTds / (4 * T * np.cos(delta / 4) ** 2)
    err_m = max(err_m, abs(M / a["static_moment_layer"] - 1))
ok_m = err_m < 1e-10
# each cable passing through a junction kinks there (docs/kinks.md): the clamped layer
# about the bisector on each side, M = 2 sqrt(EI T) sin(Delta/4) sqrt(1 + T/EA cos^2(Delta/4))
err_k = 0.0
for k in s["kinks"].values():
    T, delta = k["static_tension"], k["static_delta"]
    M = 2 * np.sqrt(sec.EI * T) * np.sin(delta / 4) * np.sqrt(
        1 + T / sec.EA * np.cos(delta / 4) ** 2)
    err_k = max(err_k, abs(M / k["static_moment_layer"] - 1))
ok_k = err_k < 1e-10 and len(s["kinks"]) == 18  # 9 junctions, two cables through each
peak = max(a["steady_state_moment"]["peak"] for a in s["anchors"].values())
peak_k = max(k["steady_state_moment"]["peak"] for k in s["kinks"].values())
out = [
    f"sum of the static anchor forces {np.array2string(N_sum, precision=1)} N, weight "
    f"{np.array2string(weight, precision=1)} N (relative difference {err_eq:.1e}): "
    f"{'OK' if ok_eq else 'FAILED'}",
    f"layer moments at {len(s['anchors'])} anchors against the closed form: largest "
    f"relative difference {err_m:.1e}: {'OK' if ok_m else 'FAILED'}",
    f"kink moments at {len(s['kinks'])} cable crossings against the closed form: largest "
    f"relative difference {err_k:.1e}: {'OK' if ok_k else 'FAILED'}",
    f"largest moment over the last third of the run: {peak:.1f} N m at an anchor, "
    f"{peak_k:.1f} N m at a crossing; wall time "
    f"{s['wall_time']['total']:.2f} s; results in {args.output}",
]
if comm.rank == 0:
    print("\n".join(out))
    (args.output / "checks.json").write_text(json.dumps(
        {"equilibrium_ok": bool(ok_eq), "layer_moment_ok": bool(ok_m),
         "kink_moment_ok": bool(ok_k), "equilibrium_error": err_eq,
         "layer_moment_error": err_m, "kink_moment_error": err_k}, indent=2))
if not (ok_eq and ok_m and ok_k):
    raise SystemExit("demo check FAILED")
if comm.rank == 0:
    print("demo checks passed")
