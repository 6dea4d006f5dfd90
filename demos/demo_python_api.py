# %% [markdown]
# # Scripting cablefem: a cable built in Python, a dashpot added in UFL
#
# This demo uses the library instead of a case file. It builds a taut steel strand in a test
# rig from Python objects, adds a term of its own to the equations (a distributed viscous
# damper, written in UFL), and runs statics, modes and dynamics through the problem objects,
# which hold their PETSc solvers. Each result is checked against a closed form.
#
# **The cable.** A strand with stress-free length $l = 20$ m is stretched between two clamps
# $L = 20.02$ m apart. It has axial stiffness $EA = 2\times10^7$ N, bending stiffness
# $EI = 50$ N m$^2$ and mass $m = 2$ kg/m. Its weight is left out ($g = 0$): the rig carries
# it, and without it the static state and the modes have exact closed forms.
#
# **Statics.** The strand is straight, with the tension
# $T = EA\,(L/l - 1) = 2\times10^4$ N.
#
# **Modes.** A taut string of length $L$ with mass $m\,l/L$ per deformed length vibrates
# at $\omega_n = \dfrac{n\pi}{L}\sqrt{\dfrac{T L}{m\,l}}$.
#
# **The added term.** A dashpot force $-c\,\dot{\mathbf u}$ per unit stress-free length
# enters the residual (internal − external + inertia + damping + user terms = 0) as
#
# $$\int_0^l c\,\dot{\mathbf u}\cdot\delta\mathbf u\,ds .$$
#
# Its damping matrix is $(c/m)\,M$. Every mode is therefore damped on its own, with
# $\zeta_n = c/(2 m \omega_n)$. Here $c$ is chosen to give $\zeta_1 = 2\,\%$. Jacobians are
# derived by `model.forms` (`docs/extending.md`), so Newton keeps converging in about 2
# iterations per step.
#
# **Dynamics.** The strand is released from rest in its first mode, with amplitude 5 mm.
# The trapezoidal rule is used (generalised-α with $\rho_\infty = 1$), at 60 steps per
# period. The decay of the mid-span deflection gives $\zeta_1$ through the logarithmic
# decrement.
#
# Run: `python demos/demo_python_api.py --output output/python_api` (shorter when the
# environment variable `CI` is set). Also on MPI ranks: `mpirun -n 2 python ...`.

# %%
import argparse
import json
import os
from pathlib import Path

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from cablefem import Anchor, Section, create_cable
from cablefem.description import Gravity
from cablefem.dynamics import DynamicProblem
from cablefem.modal import ModalProblem
from cablefem.moments import AnchorMoments
from cablefem.statics import StaticProblem

parser = argparse.ArgumentParser(description="cablefem's Python API on a taut strand")
parser.add_argument("--output", type=Path, default=Path("output/python_api"))
args = parser.parse_args()
comm = MPI.COMM_WORLD
rank0 = comm.rank == 0


def say(text: str) -> None:
    if rank0:
        print(text, flush=True)


# %% [markdown]
# ## The cable, from Python objects
# Two clamped anchors, each with its clamp direction along the chord, into the cable. The
# section and the geometry are given in SI units. `create_cable` is collective: the mesh is
# partitioned over `comm`.

# %%
EA, EI, m, l, L = 2.0e7, 50.0, 2.0, 20.0, 20.02  # N, N m^2, kg/m, m, m
elements = 40
section = Section(EA=EA, EI=EI, GJ=0.0, mass=m)
anchors = [Anchor("p", np.array([0.0, 0.0, 0.0]), direction=np.array([1.0, 0.0, 0.0])),
           Anchor("q", np.array([L, 0.0, 0.0]), direction=np.array([-1.0, 0.0, 0.0]))]
# the paper's leading order (outer_correction="none"): the taut string's closed forms below
# are its own; the default first-order correction moves them by about 2h/l (docs/hinge.md)
model = create_cable(comm, anchors, section, length=l, elements=elements,
                     gravity=Gravity(g=0.0), outer_correction="none")

T = EA * (L / l - 1.0)  # N
omega = [n * np.pi / L * np.sqrt(T * L / (m * l)) for n in (1, 2, 3)]  # rad/s
zeta = 0.02
c = 2.0 * zeta * m * omega[0]  # N s/m^2

# %% [markdown]
# ## A term of our own: the dashpot
# `model.forms.add` takes a UFL form that is linear in the test function `model.du` and
# written with the unknowns `model.u`, `model.v` and `model.a`. `kind="dynamic"` makes it
# act in the dynamics only. `model.compile()` then derives every residual, Jacobian and
# mass form again, including the $\partial F/\partial v$ part that PETSc's integrator
# needs.

# %%
c_const = fem.Constant(model.mesh, PETSc.ScalarType(c))
model.forms.add("dashpot", c_const * ufl.inner(model.v, model.du) * ufl.dx, kind="dynamic")
model.compile()
say("terms of the residual: " + ", ".join(f"{name} ({kind})" for name, (_, kind)
                                          in model.forms.terms.items()))

# %% [markdown]
# ## Statics, then modes
# Each problem object owns its SNES or EPS under an options prefix (`cable_static_`,
# `cable_modal_`), so `-cable_static_snes_monitor` on the command line reaches it. A `with`
# block destroys the PETSc objects at its end.

# %%
with StaticProblem(model) as problem:
    say(f"static solver: {problem.snes.getType()}, prefix {problem.snes.getOptionsPrefix()}")
    static = problem.solve()
tension = float(np.linalg.norm(static.anchor_forces[0]))
say(f"static tension {tension:.6g} N (closed form {T:.6g} N)")

with ModalProblem(model, 6) as problem:
    modal = problem.solve()
# the string's modes come in pairs (two transverse directions): take every other one
omega_h = np.asarray(modal.omegas)[[0, 2, 4]]
for n, (wh, w) in enumerate(zip(omega_h, omega), start=1):
    say(f"mode {n}: omega = {wh:.6g} rad/s (taut string {w:.6g} rad/s)")

# %% [markdown]
# ## Dynamics, stepped by hand
# The strand is released from its first mode, at rest (`initial="rest"`). `step()`
# advances one step of the grid and `anchor_forces()` returns the anchor forces at that
# time. `AnchorMoments` turns the forces into the anchor moments: the columns of
# `anchors.csv`, without writing any file.

# %%
s = model.geometry.stations
u0 = comm.bcast(model.gather_nodal(model.u), root=0)
shape = np.zeros_like(u0)
shape[:, 1] = 5e-3 * np.sin(np.pi * s / l)  # m
model.scatter_nodal(u0 + shape, model.u)

per_period, periods = 60, (3 if os.environ.get("CI") else 8)
period = 2.0 * np.pi / omega[0]
dt = period / per_period  # s
t_end = (periods + 1.5) * period
mid = elements // 2
times, deflection, forces = [], [], []
with DynamicProblem(model, dt, rho_inf=1.0, initial="rest") as problem:
    say(f"time integrator: {problem.ts.getType()}, prefix {problem.ts.getOptionsPrefix()}")
    while problem.time < t_end - 1e-12 * t_end:
        problem.step(t_end)
        forces.append(problem.anchor_forces())
        times.append(problem.time)
        y = comm.bcast(model.gather_nodal(model.u), root=0)[mid, 1] - u0[mid, 1]
        deflection.append(y)
    stats = problem.stats
newton_per_step = stats.newton_iterations / stats.steps
moments = AnchorMoments.from_model(model, omega=omega[0], form="exact").compute(
    np.array(times), np.array(forces))
peak_moment = float(np.nanmax(moments["p"]["moment"]))
say(f"{stats.steps} steps, {newton_per_step:.2f} Newton iterations per step; "
    f"peak anchor moment at p {peak_moment:.4g} N m")

# %% [markdown]
# ## Damping ratio from the decay
# The maxima of the mid-span deflection come one damped period apart. The log decrement
# over $N$ periods is $d = \ln(y_0/y_N)/N$, and then $\zeta = d/\sqrt{4\pi^2 + d^2}$. The
# trapezoidal rule itself damps nothing, but it shifts the discrete ratio by
# $-\zeta(\omega\Delta t)^2/6$: 0.18 % here.

# %%
t_arr, y_arr = np.array(times), np.array(deflection)
peaks = []
for k in range(1, y_arr.size - 1):
    if y_arr[k] > y_arr[k - 1] and y_arr[k] >= y_arr[k + 1]:
        y0, y1, y2 = y_arr[k - 1: k + 2]
        peaks.append(y1 - (y0 - y2) ** 2 / (8.0 * (y0 - 2.0 * y1 + y2)))  # parabola's top
d = np.log(peaks[0] / peaks[-1]) / (len(peaks) - 1)
zeta_measured = d / np.sqrt(4.0 * np.pi**2 + d**2)
say(f"damping ratio {zeta_measured:.5g} from {len(peaks)} maxima (dashpot's {zeta:.5g})")

# %% [markdown]
# ## Checks
# * Tension. The strand is straight, so the finite elements are exact up to Newton's
#   tolerance ($10^{-10}$ relative): the bound is $10^{-8}$.
# * Frequencies. Linear elements with a consistent mass raise $\omega_n$ by
#   $(n\pi/N_e)^2/24$ at leading order, and the geometric stiffness is exact here. So the
#   error must be that much: $2.6\times10^{-4}$, $1.0\times10^{-3}$ and $2.3\times10^{-3}$
#   for $n = 1, 2, 3$ on 40 elements, to 5 % of itself (the next order is
#   $(n\pi/N_e)^2$ times smaller).
# * Damping ratio. The discrete prediction is $\zeta\,(\omega_1/\omega_{h,1})\,
#   (1 - (\omega_{h,1}\Delta t)^2/6)$: the dashpot's ratio on the discrete frequency,
#   times the trapezoidal rule's shift. The measured ratio must match it to $10^{-3}$,
#   which is the sampling of the maxima. It must also match $\zeta$ itself to the sum of
#   the two shifts plus $10^{-3}$.
# * Newton. At most 3 iterations per step: the dashpot's Jacobian is derived.

# %%
predicted_freq = [(n * np.pi / elements) ** 2 / 24.0 for n in (1, 2, 3)]
freq_err = [float(wh / w - 1.0) for wh, w in zip(omega_h, omega)]
zeta_discrete = zeta * omega[0] / omega_h[0] * (1.0 - (omega_h[0] * dt) ** 2 / 6.0)
checks = {
    "tension_rel_error": float(abs(tension / T - 1.0)),
    "frequency_rel_errors": freq_err,
    "frequency_rel_errors_predicted": predicted_freq,
    "damping_ratio": float(zeta_measured),
    "damping_ratio_discrete_prediction": float(zeta_discrete),
    "newton_iterations_per_step": float(newton_per_step),
}
verdicts = {
    "static tension = EA (L/l - 1)": checks["tension_rel_error"] < 1e-8,
    "frequencies: the taut string's, with the P1 mesh's predicted error":
        all(abs(e - p) < 0.05 * p for e, p in zip(freq_err, predicted_freq)),
    "damping ratio = c/(2 m omega_h) with the trapezoidal rule's shift":
        abs(zeta_measured / zeta_discrete - 1.0) < 1e-3,
    "damping ratio = c/(2 m omega) to the discretisation's shifts":
        abs(zeta_measured / zeta - 1.0) < abs(zeta_discrete / zeta - 1.0) + 1e-3,
    "Newton iterations per step <= 3 (the dashpot's Jacobian is derived)":
        newton_per_step <= 3.0,
}
ok = all(verdicts.values())
if rank0:
    args.output.mkdir(parents=True, exist_ok=True)
    (args.output / "checks.json").write_text(json.dumps({"ok": ok, **checks}, indent=2))
for label, good in verdicts.items():
    say(f"{label}: {'OK' if good else 'FAILED'}")
if not ok:
    raise SystemExit("demo_python_api: a check failed (see checks.json)")
