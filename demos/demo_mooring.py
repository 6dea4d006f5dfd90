# %% [markdown]
# # A catenary mooring line: water, current, seabed and a bend stiffener at the fairlead
#
# A 400 m spiral strand (`demos/mooring.toml`: $EA = 5.5\times10^8$ N,
# $EI = 4\times10^4$ N m², 30 kg/m, $D = 76$ mm) runs from an anchor on the seabed, 100 m
# down, to a floater's fairlead 20 m below the surface and 350 m away, where a bend
# stiffener clamps it along its static direction. The water (1025 kg/m³) gives it
# buoyancy, added mass ($C_a = 1$) and Morison drag ($C_{dn} = 1.2$, $C_{dt} = 0.008$) in a
# current of 0.5 m/s at the surface that decays towards the seabed as the 1/7 power law,
# and in a 4 m swell of 10.5 s (Airy waves on 100 m of water, built up over three periods);
# the seabed holds the lying part (contact stiffness $10^5$ N/m², damping, friction 0.5).
# The floater surges $\pm 2$ m at the swell's frequency, 0.6 rad/s. What is the bending
# moment where the line enters the bend stiffener?
#
# **The line on the seabed** (docs/seabed.md). With the submerged weight
# $w = m g - \rho g \pi D^2/4$ (248 N/m) and the fairlead $h$ above the seabed, the
# inextensible catenary with a grounded part has the horizontal tension $H$ that makes
#
# $$l - l_s + \frac{H}{w}\operatorname{asinh}\frac{l_s w}{H} = X,\qquad
#   l_s = \sqrt{h^2 + 2hH/w},\qquad T_{fairlead} = H + w h,$$
#
# $l_s$ the suspended length, $l - l_s$ the grounded one (the touchdown's station from the
# anchor), $X$ the horizontal distance.
#
# **Water** (docs/fluid.md): drag on the relative velocity, normal and tangential, added
# mass normal to the line, the waves' inertia $(1 + C_a)\rho A \dot u_{f,n}$, buoyancy
# below the surface; their Jacobians are derived, so Newton stays quadratic.
#
# Run: `python demos/demo_mooring.py --output output/mooring` (with the environment variable
# `CI` set, the dynamics stop at 12 s).

# %%
import argparse
import copy
import json
import os
from pathlib import Path

import numpy as np
from mpi4py import MPI

from cablefem.app.log import setup_logging
from cablefem.app.run import run_case
from cablefem.case import load_case
from cablefem.fluid import submerged_weight
from cablefem.seabed import GroundedCatenary

here = Path(__file__).resolve().parent
parser = argparse.ArgumentParser(description=__doc__)
parser.add_argument("--output", type=Path, default=Path("output/mooring"))
args = parser.parse_args()
setup_logging()
comm = MPI.COMM_WORLD
case = load_case(here / "mooring.toml")
t_end = 12.0 if os.environ.get("CI") else case.dynamics.t_end

# %% [markdown]
# ## Run: statics (from the grounded catenary), modes, dynamics
# And a statics-and-modes run of the same line in still water with the fairlead pinned,
# the paper's leading order and no span bending: the closed forms above are for that line,
# a string. (The run in the current has the span's bending: `"auto"` finds that it moves
# its sixth mode by 0.8 %; the touchdown's curvature over a low tension is where.)

# %%
result = run_case(case, args.output, comm, t_end=t_end)
s = result.summary
still = copy.deepcopy(case)
still.fluid.current = np.zeros(3)
still.anchors[1].kind, still.anchors[1].direction, still.anchors[1].motion = \
    "pinned", None, None
still.solver.outer_correction = "none"
still.solver.span_bending = False
still.dynamics = None
s0 = run_case(still, args.output / "still_water", comm, progress=False, figures=False).summary

# %% [markdown]
# ## Checks
# 1. **The grounded catenary** (still water, pinned fairlead): the fairlead's horizontal
#    and total tension within 1e-3 of the closed forms (the stretch $T/EA$ = 5e-5, the
#    seabed's penetration 2.5 mm, the mesh), the touchdown within half an element (2 m) of
#    the closed form's grounded length (the contact's transition spans an element or two).
# 2. **The fairlead moment** has valid rows only, an estimated error below 2 %, and every
#    mode a damping ratio or the reason it has none (a 0.5 m/s current's linearised drag
#    overdamps the slowest modes of the line).

# %%
w = submerged_weight(case.fluid, case.section.mass, case.gravity.g)
a, f = (np.array(x.position, float) for x in case.anchors)
up = np.array([0.0, 0.0, 1.0])
gc = GroundedCatenary(a, f, case.geometry.value, w, up, True)
F = np.array(s0["anchors"]["fairlead"]["static_tension"])
td0, td = s0["static"]["touchdown"], s["static"]["touchdown"]
h_el = case.geometry.value / case.mesh.elements
# the fairlead's horizontal force: from the anchor row of anchors.csv at t = 0
rows = [line.split(",") for line in (args.output / "still_water" / "anchors.csv")
        .read_text().splitlines()[1:]]
Nx = next(float(r[2]) for r in rows if r[1] == "fairlead")
ok_cat = (abs(abs(Nx) / gc.H - 1) < 1e-3 and abs(F / gc.fairlead_tension - 1) < 1e-3
          and abs(td0["s"] - gc.grounded_length) < 0.5 * h_el)
fl = s["anchors"]["fairlead"]
ok_moment = (fl["validity"]["invalid_fraction"] == 0.0 and fl["validity"]["max"] < 0.02
             and all("damping_ratio" in m or "damping_ratio_missing" in m
                     for m in s["modes"]))
ss = fl.get("steady_state_moment", {})
lines = [
    f"submerged weight {w:.4g} N/m; still water: H = {abs(Nx):.6g} N (closed form "
    f"{gc.H:.6g}), fairlead tension {F:.6g} N ({gc.fairlead_tension:.6g}), touchdown "
    f"at s = {td0['s']:.4g} m ({gc.grounded_length:.4g}): {'OK' if ok_cat else 'FAILED'}",
    f"in the current, clamped: touchdown at s = {td['s']:.4g} m, fairlead tension "
    f"{fl['static_tension']:.6g} N; in the swell the touchdown moves along the line by "
    f"{s['touchdown']['cable'].get('excursion', float('nan')):.3g} m (touchdown.csv)",
    f"fairlead (bend stiffener): static moment {fl['static_moment']:.4g} N m, anchor angle "
    f"{fl['static_delta']:.4f} rad, layer length {fl['layer_length']:.3f} m; steady state "
    f"peak {ss.get('peak', float('nan')):.4g} N m, RMS {ss.get('rms', float('nan')):.4g} N m; "
    f"estimated error at most {100 * fl['validity']['max']:.2f} %: "
    f"{'OK' if ok_moment else 'FAILED'}",
    "modes (rad/s, damping ratio): " + ", ".join(
        f"{m['omega']:.4f} ({m['damping_ratio']:.3f})" if "damping_ratio" in m
        else f"{m['omega']:.4f} (overdamped)" for m in s["modes"]),
    f"wall time {s['wall_time']['total']:.1f} s; results in {args.output}",
]
if comm.rank == 0:
    print("\n".join(lines))
    (args.output / "checks.json").write_text(json.dumps(
        {"catenary_ok": bool(ok_cat),
         "moment_ok": bool(ok_moment), "H": abs(Nx), "H_closed_form": gc.H,
         "touchdown_s": td0["s"], "grounded_length": gc.grounded_length}, indent=2))
if not (ok_cat and ok_moment):
    raise SystemExit("demo check FAILED")
