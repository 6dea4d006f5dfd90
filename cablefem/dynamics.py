"""Time integration of the string with PETSc TS, generalised-α for second-order systems.

``M ü + C u̇ + f_int(u) = f_ext(t)`` is integrated by PETSc's ``alpha2`` (J. Chung and
G. M. Hulbert, "A time integration algorithm for structural dynamics with improved numerical
dissipation: the generalized-α method", J. Appl. Mech. 60 (1993) 371-375): second-order
accurate, unconditionally stable, with high-frequency dissipation set by the spectral radius
``ρ∞`` (``ρ∞ = 1``: no dissipation, the trapezoidal rule). Newton (SNES) at every step.

The residual ``F(t, U, V, A)`` is the model's UFL form ``F_dynamic``; the Jacobian is
``dF/du + shift_v dF/du̇ + shift_a dF/dü`` (PETSc passes the shifts). An anchor's prescribed
motion ``g(t)`` enters as the rows ``U − g(t)`` at the stage time.

A step whose Newton solve fails is retried from its start (displacement, velocity and the
integrator's acceleration: :func:`cablefem.alpha2.retry_from_start`) as 4, 16, ... equal
sub-steps up to the next point of the nominal time grid (at most ``max_cuts`` times). The
first step after a change of step size is a backward Euler step
(:class:`cablefem.alpha2.BackwardEuler`): generalised-α's acceleration belongs to its step
size, and carried into a smaller one it set off a spike in the anchor forces. The run then
goes on with the sub-steps (``cooldown``, off by default, allows the larger step again after
that many calm nominal steps; docs/theory.md §2). Outputs stay on the nominal grid. When it
cannot continue, :class:`DynamicsError` says at which time, with the last Newton history,
and leaves the last converged state in ``model.u`` and ``model.v``.

On one rank, a model whose residual is its UFL forms alone has its residual and Jacobian
assembled in C (:mod:`cablefem.native_rows`; the same numbers to the last bit).

Options prefix: the model's (``cable_``): ``-cable_ts_type``, ``-cable_snes_rtol``, ...
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from decimal import Decimal

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from cablefem.alpha2 import BackwardEuler, retry_from_start
from cablefem.errors import DynamicsError, Interrupted
from cablefem.hinge import HingeError
from cablefem.initial import initial_velocity
from cablefem.petsc_utils import SNESHistory, copy_in
from cablefem.reactions import AnchorReactions
from cablefem.timestepper import bc_row_scale, make_ts

__all__ = ["Checkpoint", "DynamicProblem", "DynamicsError", "DynamicsStats", "Interrupted",
           "integrate", "initial_velocity", "grid_time", "bc_row_scale"]

log = logging.getLogger(__name__)


@dataclass
class Checkpoint:
    """What a resumed run needs beyond ``model.u`` and ``model.v``."""

    time: float
    step: int
    level: int = 0
    calm: int = 0
    #: this rank's ``model.u.x.array`` and ``model.v.x.array`` at the checkpoint, when
    #: :meth:`DynamicProblem.checkpoint` took it (a checkpoint read from a file has None:
    #: the state is then put into ``model.u``, ``model.v`` before restoring)
    u: np.ndarray | None = field(default=None, repr=False)
    v: np.ndarray | None = field(default=None, repr=False)


@dataclass
class DynamicsStats:
    steps: int = 0
    rejected_steps: int = 0
    newton_iterations: int = 0
    linear_iterations: int = 0
    wall_time: float = 0.0
    output_times: list[float] = field(default_factory=list)
    #: every cut of the step: (the failed step's start time, the step the run went on with)
    cuts: list[tuple[float, float]] = field(default_factory=list)
    assembly: str = ""  #: "c" (cablefem.native_rows) or "python": the residual's route


def grid_time(step: int, dt: float) -> float:
    """Time of point ``step`` of the nominal grid: ``step x dt`` computed exactly in decimal
    from ``dt`` as written (0.005 -> 0.06 at step 12, not 0.060000000000000005), then
    rounded once to the nearest double."""
    return float(Decimal(repr(float(dt))) * step)


_TS_REASONS = {-1: "Newton failed (TS_DIVERGED_NONLINEAR_SOLVE)",
               -2: "Newton failed and the step was rejected more than -cable_ts_max_reject "
                   "times (TS_DIVERGED_STEP_REJECTED)"}


_NO_END = 1e300  #: the TS's end time when none is given: TSStep refuses to run without


class _StopPoll:
    """``should_stop()`` polled after every step so that all ranks stop after the same one,
    without a blocking collective per step: on one rank the flag itself; on several, the
    logical or of the flags of step ``k`` is reduced by a non-blocking ``Iallreduce``
    started after step ``k`` and completed after step ``k + 1`` (by then long done), so a
    request to stop takes effect one step later, on every rank at the same step."""

    def __init__(self, comm: MPI.Comm, should_stop) -> None:
        self.comm, self.should_stop = comm, should_stop
        self._send = np.zeros(1, np.int32)
        self._recv = np.zeros(1, np.int32)
        self._request: MPI.Request | None = None

    def __call__(self) -> bool:
        if self.should_stop is None:
            return False
        if self.comm.size == 1:
            return bool(self.should_stop())
        stop = self.complete()
        self._send[0] = int(bool(self.should_stop()))
        self._request = self.comm.Iallreduce(self._send, self._recv, op=MPI.LOR)
        return stop

    def complete(self) -> bool:
        """Wait for the reduction in flight (collective: every rank has started it)."""
        if self._request is None:
            return False
        self._request.Wait()
        self._request = None
        return bool(self._recv[0])


class DynamicProblem:
    """Time integration of a model as an object that owns its PETSc ``TS``.

    Creates the generalised-α integrator (``.ts``, type ``alpha2``, with its SNES, KSP and
    Jacobian matrix) under the options prefix ``petsc_options_prefix`` (default the model's,
    ``cable_``: ``-cable_ts_alpha_radius``, ``-cable_snes_rtol``, ``-cable_ksp_type``,
    ``-cable_mat_type``, ...), options from lowest to highest priority: the defaults, the
    case file's ``solver.petsc_options``, ``petsc_options`` (keys without the prefix), the
    options database. The anchor forces come from an :class:`~cablefem.reactions.
    AnchorReactions` (``.reactions``, prefix ``<model prefix>mass_``).

    Without ``start`` the problem begins at ``t = 0`` from ``model.u`` (normally the static
    equilibrium) with the initial velocity ``initial`` (:func:`initial_velocity`):
    "quasi-static" or "rest". With ``start`` (a :class:`Checkpoint`) it resumes from it
    (:meth:`restore`).

    * :meth:`step` advances one step of the nominal grid ``k dt`` (with the step cutting of
      the module docs) and returns the new time; :meth:`anchor_forces` gives the anchor
      forces at the current time (and puts the state into ``model.u``, ``model.v``,
      ``model.a``).
    * :meth:`run` is the generator of :func:`integrate`: ``(t, anchor_forces)`` at the
      start, every ``output_every`` steps and at ``t_end``; it can be called again to go
      on to a later ``t_end``.
    * :meth:`checkpoint` / :meth:`restore`: a restored problem repeats the run from the
      checkpoint bit for bit.
    * :meth:`destroy` (or the end of a ``with`` block) frees every PETSc object.

    Use::

        with DynamicProblem(model, dt=0.005) as problem:
            for t, forces in problem.run(1.0):
                ...
    """

    def __init__(self, model, dt: float, *, rho_inf: float = 0.9,
                 petsc_options_prefix: str | None = None, petsc_options: dict | None = None,
                 initial: str = "quasi-static", start: Checkpoint | None = None,
                 max_cuts: int = 6, cooldown: int | None = None,
                 stats: DynamicsStats | None = None):
        if initial not in ("quasi-static", "rest"):
            raise ValueError(f"initial must be 'quasi-static' or 'rest', got {initial!r}")
        self._wall0 = time.perf_counter()
        self.model, self.dt = model, float(dt)
        self.max_cuts, self.cooldown = max_cuts, cooldown
        self.stats = stats if stats is not None else DynamicsStats()
        self.prefix = model.prefix if petsc_options_prefix is None else petsc_options_prefix
        self.history = SNESHistory()
        # _work: F, J live as long as ts
        self.ts, self._work, self._rows = make_ts(model, dt, rho_inf, self.history,
                                                  self.prefix, petsc_options)
        self.newton = self._work[-1]
        self.stats.assembly = "python" if self._rows.native is None else "c"
        self.ts.setMaxTime(_NO_END)  # PETSc steps only with an end; step(t_end) sets it
        self.reactions = AnchorReactions(model)
        self.reactions.packer = self._rows  # the step's packing, its state copied in
        self.hinges = model.hinges
        self.time, self.step_number, self.level, self.calm = 0.0, 0, 0, 0
        #: the level of the last step taken (a step at another level starts with backward
        #: Euler); None: the integrator estimates its acceleration itself at its next step
        self._done_level: int | None = None
        #: the state at the start is an output of the first run() (not after a restore)
        self._initial_output = start is None
        if self.hinges:  # the layers' law, from the static state (also on a restart)
            try:
                self.hinges.start_dynamics(model.u_static.x.array)
            except HingeError as err:
                raise DynamicsError(str(err), 0.0) from err
        if start is not None:
            self.restore(start)
            return
        model.set_time(0.0)
        U = model.u.vector.copy()
        V = model.v.vector.copy()
        initial_velocity(model, V, 0.0, quasi_static=initial == "quasi-static")
        copy_in(V, model.v)
        self.ts.setTime(0.0)
        self.ts.setStepNumber(0)
        self.ts.setSolution2(U, V)
        self.ts.setUp()
        U.destroy()  # the TS keeps its own references
        V.destroy()

    # ------------------------------------------------------------------ state
    def restore(self, ck: Checkpoint) -> None:
        """Continue from ``ck``: its time, step, step-cutting state and hinge laws, and the
        state ``ck.u``, ``ck.v`` (or, when None, the one in ``model.u``, ``model.v``). The
        integrator re-estimates the acceleration from ``(u, v)``, as the run that took the
        checkpoint did at that step."""
        m = self.model
        if ck.u is not None:
            m.u.x.array[:] = ck.u
            m.v.x.array[:] = ck.v
        self.time, self.step_number = float(ck.time), int(ck.step)
        self.level, self.calm = int(ck.level), int(ck.calm)
        self._done_level = None
        self._initial_output = False  # the checkpoint's time was an output already
        self.newton.reset()  # the predictor's history starts again, as in checkpoint()
        m.set_time(self.time)
        U = m.u.vector.copy()
        V = m.v.vector.copy()
        self.ts.setTime(self.time)
        self.ts.setStepNumber(self.step_number)
        self.ts.setSolution2(U, V)
        self.ts.setUp()
        self.ts.restartStep()
        U.destroy()
        V.destroy()

    def checkpoint(self) -> Checkpoint:
        """What :meth:`restore` needs to repeat the run from here, bit for bit (a
        :class:`Checkpoint` holding this rank's state). The integrator re-estimates its
        acceleration from ``(u, v)`` at the next step, as a restored one does."""
        self.ts.restartStep()  # the next step re-estimates A from (u, v), as a resumed run
        self.newton.reset()
        self._state_to_model()
        m = self.model
        return Checkpoint(self.time, self.step_number, self.level, self.calm,
                          m.u.x.array.copy(), m.v.x.array.copy())

    def _state_to_model(self) -> tuple[PETSc.Vec, PETSc.Vec]:
        U2, V2 = self.ts.getSolution2()
        serial = self.model.comm.size == 1
        copy_in(U2, self.model.u, serial)
        copy_in(V2, self.model.v, serial)
        return U2, V2

    def anchor_forces(self) -> np.ndarray:
        """The anchor forces (n_anchors, 3) at the current time, the same on every rank
        (collective); leaves the state in ``model.u``, ``model.v`` and ``model.a``."""
        self._state_to_model()
        self.model.set_time(self.time)
        return self.reactions.compute(self.time)

    # ------------------------------------------------------------------ stepping
    def step(self, t_end: float | None = None) -> float:
        """Advance one step of the nominal grid (to ``(k + 1) dt``, or to ``t_end`` when
        that comes first) and return the new time. A step whose Newton solve fails is cut
        as the module docs say; :class:`DynamicsError` when it cannot continue (the last
        converged state then in ``model.u``, ``model.v``)."""
        ts, dt, history, stats = self.ts, self.dt, self.history, self.stats
        t = self.time
        eps_t = 1e-9 * dt
        if t_end is not None:
            ts.setMaxTime(t_end)
        # one step of the nominal grid, its end step x dt (no round-off accumulated)
        t_start = t
        t_next = grid_time(self.step_number + 1, dt)
        if t_end is not None:
            t_next = min(t_next, t_end)
            if t_end - t_next < 1e-6 * dt:  # the sum of many dt falls short of t_end by
                t_next = t_end  # round-off: no extra step of ~1e-11 s (its velocity jump
                # at a moving anchor gave forces of 1e6 N in the last row)
        history.clear()
        if self.level and self.cooldown is not None and self.calm >= self.cooldown:
            self.level, self.calm = self.level - 1, 0  # a larger step again (see the module)
        failed = rolled = False
        while t < t_next - eps_t:
            sub = (t_next - t_start) / 4**self.level
            h = (t_next - t) / max(1, round((t_next - t) / sub))
            ts.setTimeStep(h)
            self.newton.expect(h, cut=failed)  # the retries of a failed step: PETSc alone
            number = ts.getStepNumber()
            self._rows.forget()  # the step's first residual packs every coefficient
            changed = self._done_level is not None and self._done_level != self.level
            try:
                with BackwardEuler(ts, changed):
                    ts.step()
            except PETSc.Error:  # raised when the step is rejected (ts_max_reject = 0)
                if self._rows.native is not None:  # an exception in a call from C
                    self._rows.native.reraise()
                if ts.getConvergedReason() >= 0:  # any other error: not a failed step
                    raise
            reason = ts.getConvergedReason()
            if reason >= 0:
                t = ts.getTime()
                rolled = False  # a step done: PETSc cleared its rolled-back state
                self._done_level = self.level
                continue
            stats.rejected_steps += 1
            failed = True
            ts.setConvergedReason(PETSc.TS.ConvergedReason.CONVERGED_ITERATING)
            if not rolled:  # the retry starts from the step's start, acceleration included
                retry_from_start(ts, t, number)
                rolled = True
            if self.level == self.max_cuts:
                self.time = t
                self._state_to_model()  # the last converged state (step rolled back)
                raise DynamicsError(
                    f"time integration stopped at t = {t:.6g} s (step "
                    f"{self.step_number + 1}): Newton failed with dt = {dt:.3g} s and with "
                    f"{self.max_cuts} cuts down to {dt / 4**self.max_cuts:.3g} s "
                    f"({_TS_REASONS.get(reason, reason)}); last Newton history: "
                    f"{history.text()}", t)
            self.level += 1
            stats.cuts.append((float(t), float(sub / 4)))
            log.info("t = %.6g: Newton failed with dt = %.3g; going on with dt = %.3g", t, h,
                     sub / 4)
        self.calm = 0 if failed else self.calm + 1
        self.time = t = t_next
        ts.setTime(t)  # the TS clock on the grid exactly, as a resumed run sets it
        self.step_number += 1
        stats.steps = self.step_number
        stats.newton_iterations = ts.getSNESIterations()
        stats.linear_iterations = ts.getKSPIterations()
        U2, V2 = ts.getSolution2()
        # a NaN or an infinity anywhere makes the 1-norm so (one reduction, every rank)
        if not math.isfinite(U2.norm(PETSc.NormType.NORM_1) + V2.norm(PETSc.NormType.NORM_1)):
            raise DynamicsError(f"non-finite state at t = {t:.6g} s; the last finite output "
                                "is kept", t)
        return t

    def run(self, t_end: float, output_every: int = 1, checkpoint_every: int = 0,
            on_checkpoint=None, should_stop=None) -> Iterator[tuple[float, np.ndarray]]:
        """Integrate to ``t_end``; yields ``(t, anchor_forces)`` at the start (the first
        run of a problem not made from a checkpoint), every ``output_every`` steps and at
        ``t_end``, with ``model.u``, ``model.v`` and ``model.a`` at that time.

        Every ``checkpoint_every`` steps ``on_checkpoint(Checkpoint)`` is called (the
        integrator restarts there, :meth:`checkpoint`). ``should_stop()`` is polled after
        every step; when it returns True on any rank, :class:`Interrupted` is raised on all
        ranks after the same step (on several ranks one step after the poll that saw it,
        :class:`_StopPoll`), after its output. Leaving the generator early (``break``,
        an exception) leaves the problem usable; the problem's PETSc objects go with
        :meth:`destroy`."""
        m, stats, dt = self.model, self.stats, self.dt
        self.ts.setMaxTime(t_end)
        poll = _StopPoll(m.comm, should_stop)
        try:
            if self._initial_output:
                self._initial_output = False
                stats.output_times.append(self.time)
                yield self.time, self.anchor_forces()
            eps_t = 1e-9 * dt
            while self.time < t_end - eps_t:
                t = self.step(t_end)
                last = t >= t_end - eps_t
                if self.step_number % output_every == 0 or last:
                    forces = self.anchor_forces()
                    stats.output_times.append(t)
                    stats.wall_time = time.perf_counter() - self._wall0
                    yield t, forces
                if checkpoint_every and self.step_number % checkpoint_every == 0 and not last:
                    ck = self.checkpoint()
                    if on_checkpoint is not None:
                        on_checkpoint(ck)
                if poll() and not last:
                    self._state_to_model()
                    raise Interrupted(f"stopped on request at t = {t:.6g} s (step "
                                      f"{self.step_number})", t)
            stats.wall_time = time.perf_counter() - self._wall0
        finally:
            poll.complete()

    # ------------------------------------------------------------------ clean-up
    def destroy(self) -> None:
        """Free the TS (with its SNES and KSP), its matrix and vectors, and the reactions'
        solver."""
        self.ts.destroy()
        for obj in self._work:
            obj.destroy()
        self._rows.destroy()
        self.reactions.destroy()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.destroy()


def integrate(model, t_end: float, dt: float, rho_inf: float = 0.9, output_every: int = 1,
              stats: DynamicsStats | None = None, max_cuts: int = 6,
              cooldown: int | None = None,
              start: Checkpoint | None = None, checkpoint_every: int = 0,
              on_checkpoint=None, should_stop=None, initial: str = "quasi-static"
              ) -> Iterator[tuple[float, np.ndarray]]:
    """Integrate from the current state to ``t_end``; yields ``(t, anchor_forces)`` at the
    start (not when resuming from ``start``), every ``output_every`` steps and at ``t_end``,
    with ``model.u``, ``model.v`` and ``model.a`` at that time: a :class:`DynamicProblem`
    made, run (:meth:`DynamicProblem.run`) and destroyed when the generator ends, is
    closed (``break`` out of its loop) or raises.

    ``anchor_forces`` is ``(n_anchors, 3)``, the force of the span at each anchor (N).

    Without ``start`` the run begins at ``t = 0`` from ``model.u`` (normally the static
    equilibrium) with the initial velocity ``initial`` (:func:`initial_velocity`):
    "quasi-static" (default), the velocity field with which the cable follows its anchors'
    velocity at ``t = 0`` quasi-statically, or "rest", the cable at rest and only the
    anchors moving (a velocity jump at a moving anchor, an impulse). With ``start`` it
    resumes from a checkpoint (``model.u``, ``model.v`` must hold its state). Every
    ``checkpoint_every`` steps ``on_checkpoint(Checkpoint)`` is called; at that step the
    integrator re-estimates its acceleration from ``(u, v)`` as a resumed run does, so that a
    resumed run repeats the uninterrupted one to round-off. ``should_stop()`` is polled after
    every step; when it returns True on any rank, :class:`Interrupted` is raised on all
    ranks after the same step, after its output.
    """
    if initial not in ("quasi-static", "rest"):
        raise ValueError(f"initial must be 'quasi-static' or 'rest', got {initial!r}")
    with DynamicProblem(model, dt, rho_inf=rho_inf, initial=initial, start=start,
                        max_cuts=max_cuts, cooldown=cooldown, stats=stats) as problem:
        yield from problem.run(t_end, output_every, checkpoint_every, on_checkpoint,
                               should_stop)
