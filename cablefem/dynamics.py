"""Time integration of the string with PETSc TS, generalised-α for second-order systems.

``M ü + C u̇ + f_int(u) = f_ext(t)`` is integrated by PETSc's ``alpha2`` (J. Chung and
G. M. Hulbert, "A time integration algorithm for structural dynamics with improved numerical
dissipation: the generalized-α method", J. Appl. Mech. 60 (1993) 371-375): second-order
accurate, unconditionally stable, with high-frequency dissipation set by the spectral radius
``ρ∞`` (``ρ∞ = 1``: no dissipation, the trapezoidal rule). Newton (SNES) at every step.

The residual ``F(t, U, V, A)`` is the model's UFL form ``F_dynamic``; the Jacobian is
``dF/du + shift_v dF/du̇ + shift_a dF/dü`` (PETSc passes the shifts). An anchor's prescribed
motion ``g(t)`` enters as the rows ``U − g(t)`` at the stage time.

A step whose Newton solve fails is cut (PETSc's ``-ts_adapt_scale_solve_failed``, 0.25 by
default) and retried, up to ``-ts_max_reject`` times; the step then grows back to the nominal
``dt`` by doubling. When it cannot continue, :class:`DynamicsError` says at which time, with
the last Newton history; everything written up to then stays valid.

Options prefix: the model's (``cable_``): ``-cable_ts_type``, ``-cable_snes_rtol``, ...
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
from dolfinx.fem import petsc as fpetsc
from petsc4py import PETSc

from .anchors import AnchorForces
from .petsc_utils import (SNESHistory, assemble_jacobian, assemble_residual, copy_in,
                          case_options, default_options, lu_options)

__all__ = ["DynamicsError", "DynamicsStats", "integrate"]

log = logging.getLogger(__name__)


class DynamicsError(RuntimeError):
    """The time integration cannot continue; ``.time`` is the last time reached."""

    def __init__(self, message: str, time: float) -> None:
        super().__init__(message)
        self.time = time


@dataclass
class DynamicsStats:
    steps: int = 0
    rejected_steps: int = 0
    newton_iterations: int = 0
    linear_iterations: int = 0
    wall_time: float = 0.0
    output_times: list[float] = field(default_factory=list)


_TS_REASONS = {-1: "Newton failed (TS_DIVERGED_NONLINEAR_SOLVE)",
               -2: "Newton failed and the step was rejected more than -cable_ts_max_reject "
                   "times (TS_DIVERGED_STEP_REJECTED)"}


def _make_ts(model, dt: float, rho_inf: float, history: SNESHistory):
    prefix = model.prefix
    scale = model.force_scale
    defaults = {"ts_type": "alpha2", "ts_alpha_radius": rho_inf, "ts_max_reject": 8,
                "ts_max_snes_failures": -1, "snes_type": "newtonls",
                "snes_linesearch_type": "basic", "snes_rtol": 1e-9,
                "snes_atol": 1e-11 * scale, "snes_stol": 0.0, "snes_max_it": 25,
                **lu_options(model.comm.size)}

    F_vec = fpetsc.create_vector(model.f_dynamic)
    J_mat = fpetsc.create_matrix(model.j_dynamic)

    def I2Function(ts, t, U, V, A, F):
        model.set_time(t)
        copy_in(U, model.u)
        copy_in(V, model.v)
        copy_in(A, model.a)
        assemble_residual(F, model.f_dynamic, model.j_dynamic, model.bcs, U)

    def I2Jacobian(ts, t, U, V, A, shift_v, shift_a, J, P):
        model.shift_v.value = shift_v
        model.shift_a.value = shift_a
        # SNES evaluates the residual at the same state just before: model.u/v/a are current
        assemble_jacobian(J, model.j_dynamic, model.bcs)

    ts = PETSc.TS().create(model.comm)
    ts.setOptionsPrefix(prefix)
    ts.setType(PETSc.TS.Type.ALPHA2)
    ts.setI2Function(I2Function, F_vec)
    ts.setI2Jacobian(I2Jacobian, J_mat)
    ts.setTimeStep(dt)
    ts.setExactFinalTime(PETSc.TS.ExactFinalTime.MATCHSTEP)
    with default_options(prefix, defaults, case_options(model, "")):
        ts.setFromOptions()
    ts.getSNES().setMonitor(history)
    return ts, (F_vec, J_mat)


def integrate(model, t_end: float, dt: float, rho_inf: float = 0.9, output_every: int = 1,
              stats: DynamicsStats | None = None) -> Iterator[tuple[float, np.ndarray]]:
    """Integrate from the current state (``model.u``, normally the static equilibrium, at rest)
    to ``t_end``; yields ``(t, anchor_forces)`` at ``t = 0`` and every ``output_every`` steps
    and at ``t_end``, with ``model.u``, ``model.v`` and ``model.a`` at that time.

    ``anchor_forces`` is ``(n_anchors, 3)``, the force of the span at each anchor (N).
    """
    stats = stats if stats is not None else DynamicsStats()
    wall0 = time.perf_counter()
    history = SNESHistory()
    ts, _work = _make_ts(model, dt, rho_inf, history)  # _work: F and J live as long as ts
    forces = AnchorForces(model)
    model.set_time(0.0)
    U = model.u.vector.copy()
    V = model.v.vector.copy()
    V.set(0.0)
    n_owned = model.V.dofmap.index_map.size_local
    for anc in model.anchors:  # the anchors start with their prescribed velocity
        vel = anc.velocity(0.0)
        for d in anc.dofs[anc.dofs < n_owned]:
            V.array[3 * d: 3 * d + 3] = vel
    copy_in(V, model.v)
    ts.setTime(0.0)
    ts.setMaxTime(t_end)
    ts.setStepNumber(0)
    ts.setSolution2(U, V)
    ts.setUp()
    stats.output_times.append(0.0)
    yield 0.0, forces.compute(0.0)

    t = 0.0
    step = 0
    eps_t = 1e-9 * dt
    while t < t_end - eps_t:
        h = ts.getTimeStep()
        if t + h > t_end - eps_t:
            ts.setTimeStep(t_end - t)
        history.clear()
        rejected_before = ts.getStepRejections()
        try:
            ts.step()
        except PETSc.Error:  # raised when the step is rejected more than ts_max_reject times
            pass
        reason = ts.getConvergedReason()
        stats.rejected_steps += ts.getStepRejections() - rejected_before
        if reason < 0:
            raise DynamicsError(
                f"time integration stopped at t = {t:.6g} s (step {step + 1}, dt = "
                f"{ts.getTimeStep():.3g} s): {_TS_REASONS.get(reason, reason)}; last Newton "
                f"history: {history.text()}", t)
        t = ts.getTime()
        step += 1
        stats.steps = step
        stats.newton_iterations = ts.getSNESIterations()
        stats.linear_iterations = ts.getKSPIterations()
        U2, V2 = ts.getSolution2()
        if not (np.all(np.isfinite(U2.array_r)) and np.all(np.isfinite(V2.array_r))):
            raise DynamicsError(f"non-finite state at t = {t:.6g} s; the last finite output "
                                "is kept", t)
        if ts.getTimeStep() < dt:  # grow back after a cut
            ts.setTimeStep(min(dt, 2.0 * ts.getTimeStep()))
        if step % output_every == 0 or t >= t_end - eps_t:
            copy_in(U2, model.u)
            copy_in(V2, model.v)
            model.set_time(t)
            stats.output_times.append(t)
            stats.wall_time = time.perf_counter() - wall0
            yield t, forces.compute(t)
    stats.wall_time = time.perf_counter() - wall0
    ts.destroy()
