# %% [markdown]
# # Spatial vibration: the bending plane at the anchor turns (the paper's case B)
#
# A cable with 5 % sag ($\varepsilon = 0.01$: $EI = 10^{-4}$, $\varepsilon_b = 10^{-4}$:
# $EA = 10^4$, dimensionless $l = w = g = 1$), 20 linear elements, clamped along the chord
# at both ends. Anchor $q$ moves on an ellipse in the plane normal to the chord,
# $u_Z = 10^{-3}\sin(\omega_2 t)$, $u_Y = 5\times10^{-4}(\cos(\omega_2 t) - 1)$, at the first
# in-plane (antisymmetric) frequency $\omega_2 = 2\pi\sqrt{H/m}/L = 9.9815$. The string
# swings out of its plane, so the bending plane at each clamp, given by the azimuth
# $\psi_0$ of the string tangent about the clamp direction, turns with time: the moment is
# best seen as a polar plot of $M$ against $\psi_0$ over the steady state (the paper's
# Fig. 3), drawn to `anchor_polar.png`.
#
# The method is the one of `demo_paper_inplane.py`: string by finite elements (PETSc TS
# `alpha2`), then at every step and clamp the closed-form inner solution from the anchor
# force: $M(0) = 2\sqrt{EI\,T}\sin(\Delta/2)\sqrt{1+(T/EA)\cos^2(\Delta/2)}$ in the plane
# normal to $\mathbf c\times\mathbf t$, plus the string curvature $EI\,\kappa_s(0)$.
#
# Run: `python demos/demo_paper_spatial.py --output output/paper_spatial`.

# %%
import argparse
import json
import os
from pathlib import Path

import numpy as np
from mpi4py import MPI

from cablefem.app.log import setup_logging
from cablefem.app.run import leading_order_summary, run_case
from cablefem.case import load_case
from cablefem.verify import closed_form_anchor_moments

here = Path(__file__).resolve().parent
parser = argparse.ArgumentParser(description=__doc__)
parser.add_argument("--output", type=Path, default=Path("output/paper_spatial"))
args = parser.parse_args()
setup_logging()
comm = MPI.COMM_WORLD
case = load_case(here / "paper_spatial.toml")
t_end = 6.0 if os.environ.get("CI") else case.dynamics.t_end

# %%
result = run_case(case, args.output, comm, t_end=t_end)
s = result.summary
# The closed forms checked below are the paper's leading order, checked on a statics-and-
# modes run of it; the run above is the default (the first-order correction, docs/hinge.md).
s_lo = leading_order_summary(case, args.output / "leading_order", comm)

# %% [markdown]
# ## Checks
# 1. $\omega_2 = 9.9815$ is the shallow-cable closed form $2\pi\sqrt{H/m}/L$. The string's
#    own first in-plane antisymmetric mode differs from it by the sag: the closed form
#    ignores the arc being longer than the chord ($\tfrac83(d/L)^2 = 0.7\,\%$) and the
#    tension rising towards the anchors; tolerance 1.5 %.
# 2. The static anchor moment equals the composite closed form with the exact catenary's
#    anchor force to the reaction's $O(h^2)$ accuracy: measured $5.8\times10^{-4}$ at 20
#    elements, $1.45\times10^{-4}$ at 40, $3.6\times10^{-5}$ at 80 (ten times case A's, the
#    sag being ten times larger); tolerance $10^{-3}$.
# 3. In the steady state the bending plane turns: $\psi_0$ spans more than 5 degrees.
#
# The run estimates the error of every moment it reports (`error_estimate`, docs/theory.md
# §5.1). This excitation is close to resonance: the estimate reaches 2-5 % in the steady
# state, and the run warns that rows are above the 2 % threshold; against the converged rod
# the history differs by 2.7 % pointwise (0.7 % in peak, 0.1 % in RMS, docs/verification.md).

# %%
w2 = next(m["omega"] for m in s_lo["modes"]
          if m["plane"] == "in-plane" and m["symmetry"] == "antisymmetric")
ok_freq = abs(w2 / 9.9815 - 1) < 0.015
ref = closed_form_anchor_moments(case)["p"]["moment"]
Mp = s_lo["anchors"]["p"]["static_moment"]
ok_static = abs(Mp / ref - 1) < 1e-3
mo = result.moments["p"]
tail = result.times >= result.times[-1] - (result.times[-1] - result.times[0]) / 3
psi = np.unwrap(mo["psi0"][tail])
spread = float(np.degrees(np.ptp(psi)))
ok_turn = spread > 5.0
ss = s["anchors"]["p"].get("steady_state_moment", {})
if comm.rank == 0:
    print(f"first in-plane antisymmetric frequency {w2:.5f} vs 9.9815: "
          f"{'OK' if ok_freq else 'FAILED'}")
    print(f"static anchor moment {Mp:.6e} vs closed form {ref:.6e}: "
          f"{'OK' if ok_static else 'FAILED'}")
    print(f"bending plane azimuth spans {spread:.1f} degrees in the steady state: "
          f"{'OK' if ok_turn else 'FAILED'}")
    val = s["anchors"]["p"]["validity"]
    print(f"estimated moment error in the steady state: median {100 * val['median']:.2f} %, "
          f"max {100 * val['max']:.2f} % (threshold 2 %)")
    print(f"steady state: peak M_p = {ss.get('peak', 0):.4e}, RMS = {ss.get('rms', 0):.4e}; "
          f"figures {s.get('figures')}; wall time {s['wall_time']['total']:.2f} s")
    (args.output / "checks.json").write_text(json.dumps(
        {"frequency_ok": bool(ok_freq), "static_moment_ok": bool(ok_static),
         "plane_turns": bool(ok_turn), "omega2_fe": w2, "psi0_spread_deg": spread}, indent=2))
if not (ok_freq and ok_static and ok_turn):
    raise SystemExit("demo check FAILED")
