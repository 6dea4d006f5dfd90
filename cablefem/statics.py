"""Static equilibrium of the string with PETSc SNES (Newton with line search).

Start: the elastic catenary through the anchors (exact for the bare cable up to the
discretisation, :mod:`cablefem.catenary`). If Newton fails from there, the *extra* loads
(point masses' weight, point loads, distributed loads beyond the cable's own weight) are
ramped by load continuation from the bare-cable catenary (where they are zero and the guess
is an equilibrium) to their full value, with an adaptive load increment. A network's guess
is its pretensioned mesh, an equilibrium without gravity: there the weight is ramped too.

PETSc options prefix: ``<model prefix>static_`` (default ``cable_static_``).
:class:`StaticProblem` owns the solver; :func:`solve_static` makes, solves and destroys one.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
from dolfinx import fem
from dolfinx.fem import petsc as fpetsc
from mpi4py import MPI
from petsc4py import PETSc

from cablefem import junctions
from cablefem.errors import StaticError
from cablefem.hinge import hinge_fixed_point
from cablefem.petsc_utils import (
    SNESHistory,
    assemble_jacobian,
    assemble_residual,
    case_options,
    copy_in,
    default_options,
    lu_options,
    model_dofs,
)
from cablefem.reactions import AnchorReactions
from cablefem.units import unit

__all__ = ["StaticProblem", "StaticResult", "StaticError", "HingeSteps", "solve_static"]

log = logging.getLogger(__name__)


@dataclass
class StaticResult:
    anchor_forces: np.ndarray  #: (n_anchors, 3) N, force of the span at each anchor
    newton_iterations: int
    continuation_steps: int
    slack_elements: int
    max_tension: float
    min_tension: float
    wall_time: float


def _make_snes(model, history: SNESHistory, bilateral: bool = False, prefix: str | None = None,
               petsc_options: dict | None = None, defaults: dict | None = None
               ) -> tuple[PETSc.SNES, tuple]:
    """The static SNES of ``model`` and its (residual vector, Jacobian matrix), under
    ``prefix`` (default ``<model prefix>static_``), ``defaults`` over the usual ones; the
    caller destroys all three."""
    extra = defaults or {}
    prefix = model.prefix + "static_" if prefix is None else prefix
    # absolute tolerance: round-off of the residual grows with the tension (EA v3), so
    # scale it with the larger of the cable's weight and its catenary tension
    defaults = {"snes_type": "newtonls", "snes_linesearch_type": "bt", "snes_max_it": 50,
                "snes_rtol": 1e-10,
                "snes_atol": max(1e-10 * model.force_scale,
                                 10.0 * model.residual_floor(displaced=True)),
                "snes_stol": 1e-14,
                **lu_options(model.comm.size, model_dofs(model)), **model.static_options,
                **extra}
    f_form = model.f_static_bilateral if bilateral else model.f_static
    j_form = model.j_static_bilateral if bilateral else model.j_static
    b = fpetsc.create_vector(f_form)
    A = junctions.create_matrix(model, j_form)
    snes = PETSc.SNES().create(model.comm)
    snes.setOptionsPrefix(prefix)
    fixed = junctions.fixed_dofs(model) if model.node_terms else None

    def F(snes, x, f):
        copy_in(x, model.u)
        assemble_residual(f, f_form, j_form, model.bcs, x,
                          extra=lambda arr: junctions.add_residual(model, arr))

    def J(snes, x, jac, pre):
        copy_in(x, model.u)
        assemble_jacobian(jac, j_form, model.bcs,
                          extra=lambda A: junctions.add_jacobian(model, A, fixed))

    snes.setFunction(F, b)
    snes.setJacobian(J, A)
    snes.setMonitor(history)
    user = {**case_options(model, "static"), **(petsc_options or {})}
    with default_options(prefix, defaults, user):
        snes.setFromOptions()
    return snes, (b, A)


def _try(snes, x, history) -> tuple[bool, int]:
    history.clear()
    snes.solve(None, x)
    ok = snes.getConvergedReason() > 0
    if not ok and snes.getKSP().getConvergedReason() == \
            PETSc.KSP.ConvergedReason.DIVERGED_PCSETUP_FAILED:
        _fresh_pc(snes.getKSP())
    return ok, snes.getIterationNumber()


def _fresh_pc(ksp: PETSc.KSP) -> None:
    """Give ``ksp`` a new preconditioner of the same kind. A factorisation that failed (a
    wild iterate) fails every later solve of the same KSP at its first iteration, even on a
    good matrix (a rod on 2 ranks, ``pc_type redundant``; resetting the PC does not clear
    it): the continuation's and the relaxation's next steps could never succeed."""
    old = ksp.getPC()
    pc = PETSc.PC().create(old.getComm())
    pc.setOptionsPrefix(old.getOptionsPrefix())
    pc.setType(old.getType())
    if old.getType() == PETSc.PC.Type.LU:
        pc.setFactorSolverType(old.getFactorSolverType())
    elif old.getType() == PETSc.PC.Type.PYTHON:  # e.g. cablefem.gathered_lu: a new one
        pc.setPythonContext(type(old.getPythonContext())())
    ksp.setPC(pc)
    pc.destroy()


class HingeSteps:
    """Statics' hooks for the virtual hinges' fixed point
    (:func:`cablefem.hinge.hinge_fixed_point`, which drives them): Newton at the current
    hinges (:meth:`solve`), the state of the last equilibrium kept and restored, the
    anchor forces at the equilibrium. ``x`` is the solution vector (updated in place);
    :meth:`destroy` frees the vectors and solvers made here."""

    def __init__(self, model, snes: PETSc.SNES, x: PETSc.Vec, history: SNESHistory,
                 reaction: AnchorReactions):
        self.model, self.snes, self.x, self.reaction = model, snes, x, reaction
        self._history = history
        self.rtol, self.atol, _, _ = snes.getTolerances()
        self.last = x.copy()
        self.bilateral: PETSc.SNES | None = None  # compression allowed, made on first need

    def solve(self, it: int) -> tuple[bool, int]:
        """Newton at the current hinges from the current state: (converged, iterations)."""
        model, x, history = self.model, self.x, self._history
        ok, its = _try(self.snes, x, history)
        if not ok and model.tension_only:
            # as for the leading order: an element the hinge step leaves slack (H is ~h into
            # the first element; a cable's strain T/EA can be far smaller) can make the
            # tension-only Jacobian singular; compression allowed first, then tension-only
            self.last.copy(x)
            if self.bilateral is None:
                self.bilateral = _make_snes(model, history, bilateral=True)[0]
            ok2, its2 = _try(self.bilateral, x, history)
            its += its2
            if ok2:
                ok, its3 = _try(self.snes, x, history)
                its += its3
        if not ok and history.norms and history.norms[-1][1] <= 100.0 * self.atol:
            ok = True  # stagnated at round-off near Newton's tolerance (a fine mesh)
            log.info("statics: virtual hinges, iteration %d: Newton stagnated at |F| = "
                     "%.2e (atol %.2e), accepted", it, history.norms[-1][1], self.atol)
        return ok, its

    def keep(self) -> None:
        """The current state is the last equilibrium."""
        self.x.copy(self.last)

    def restore(self) -> None:
        """Back to the last equilibrium."""
        self.last.copy(self.x)

    def anchor_forces(self) -> np.ndarray:
        """The anchor forces at the current state (put into ``model.u``)."""
        copy_in(self.x, self.model.u)
        return self.reaction.compute(0.0, dynamic=False)

    def history(self) -> str:
        """The last Newton history."""
        return self._history.text()

    def destroy(self) -> None:
        for obj in (self.last, self.bilateral):
            if obj is not None:
                obj.destroy()


class StaticProblem:
    """The static equilibrium of a model as an object that owns its PETSc solvers.

    Creates the SNES (``.snes``, Newton with a backtracking line search), its residual
    vector and Jacobian matrix, under the options prefix ``petsc_options_prefix`` (default
    ``<model prefix>static_``, i.e. ``cable_static_``: ``-cable_static_snes_max_it``,
    ``-cable_static_ksp_type``, ...). The options come, from lowest to highest priority,
    from the built-in defaults, the case file's ``solver.petsc_options`` (keys starting
    with ``static_``), ``petsc_options`` (a dict, keys without the prefix) and the options
    database (the command line). The tension-only model's fallback with compression
    allowed gets a second SNES with the same prefix, made when first needed.

    :meth:`solve` finds the equilibrium (it may be called again, e.g. after changing a
    load) and leaves it in ``model.u`` and ``model.u_static``; :meth:`destroy` frees the
    PETSc objects (also at the end of a ``with`` block)::

        with StaticProblem(model, petsc_options={"snes_monitor": None}) as problem:
            result = problem.solve()
    """

    def __init__(self, model, *, petsc_options_prefix: str | None = None,
                 petsc_options: dict | None = None, max_continuation_steps: int = 200):
        self.model = model
        self.prefix = (model.prefix + "static_" if petsc_options_prefix is None
                       else petsc_options_prefix)
        self.petsc_options = dict(petsc_options or {})
        self.max_continuation_steps = max_continuation_steps
        self.history = SNESHistory()
        self.snes, self._work = self._make_snes(bilateral=False)
        self.bilateral_snes: PETSc.SNES | None = None
        self._bilateral_work: tuple = ()
        self.reactions: AnchorReactions | None = None

    def _make_snes(self, bilateral: bool) -> tuple[PETSc.SNES, tuple]:
        return _make_snes(self.model, self.history, bilateral, self.prefix,
                          self.petsc_options)

    def solve(self) -> StaticResult:
        """Solve the static equilibrium of the model from its initial guess; leaves it in
        ``model.u`` and ``model.u_static``. Raises :class:`StaticError`."""
        model, history, snes = self.model, self.history, self.snes
        max_continuation_steps = self.max_continuation_steps
        t_start = time.perf_counter()
        model.set_time(0.0)
        guess = model.initial_guess()
        model.scatter_nodal(guess, model.u)
        x = model.u.vector.copy()
        model.load_factor.value = 1.0
        total_its, steps = 0, 0
        #: the strategies tried on the way, said once in the final line (their Newton
        #: histories at debug level): Newton failing from the guess is part of the method
        self.route: list[str] = []
        # a network's kink corners (cablefem.junctions) from the plain string's equilibrium:
        # their offset jumps where a cable goes slack, which the continuation and the
        # relaxation from an unstressed mesh do not pass
        junctions.set_active(model, False)
        stages = model.static_stages  # a rod: soft-shear pre-solves
        if stages is not None:
            last = x.copy()
            for label in stages():
                ok, its = _try(snes, x, history)
                total_its += its
                if ok:
                    x.copy(last)
                    log.info("statics: pre-solve with %s converged in %d iterations", label,
                             its)
                else:
                    last.copy(x)
                    self._note(f"pre-solve with {label} failed", history)
        ok, its = _try(snes, x, history)
        total_its += its
        if not ok and model.tension_only:
            # every element slack on the guess (e.g. a coarse mesh of a stiff cable: the
            # chords of the sampled catenary are shorter than the elements): compression
            # allowed first
            self._note("tension-only Newton failed from the catenary; compression allowed "
                       "first", history)
            if self.bilateral_snes is None:
                self.bilateral_snes, self._bilateral_work = self._make_snes(bilateral=True)
            model.scatter_nodal(guess, model.u)
            x = model.u.vector.copy()
            ok, its = _try(self.bilateral_snes, x, history)
            total_its += its
            if ok:
                ok, its = _try(snes, x, history)
                total_its += its
        buckled = None
        if ok and stages is not None:
            # a rod may find a buckled equilibrium from a guess far from its layers (a fine
            # mesh of a sagging cable with horizontal clamps: compressed elements, a
            # negative eigenvalue); the relaxation's descent from the guess is tried too
            copy_in(x, model.u)
            n_slack = model.slack_elements()
            if n_slack:
                buckled, ok = (x.copy(), n_slack), False
        if not ok:
            failure = None if buckled is None else (
                f"Newton reached a state with {buckled[1]} compressed element(s)")
            try:
                x, its, steps = self._fallback(guess, max_continuation_steps, failure)
                total_its += its
            except StaticError:
                if buckled is None:
                    raise
                x = buckled[0]
            if buckled is not None:
                copy_in(x, model.u)
                if model.slack_elements() >= buckled[1]:
                    x = buckled[0]  # no better: the compressed state stands (warned below)
        if model.node_terms:
            total_its += self._corners(x)
        copy_in(x, model.u)
        if not np.all(np.isfinite(model.u.x.array)):
            raise StaticError("static solution contains NaN/inf")
        model.v.x.array[:] = 0.0
        if self.reactions is None:
            self.reactions = AnchorReactions(model)
        reaction = self.reactions
        forces = reaction.compute(0.0, dynamic=False)
        if model.hinges:
            hooks = HingeSteps(model, snes, x, history, reaction)
            try:
                total_its += hinge_fixed_point(model, hooks, forces)
            finally:
                hooks.destroy()
        model.u_static.x.array[:] = model.u.x.array
        if model.is_network and not model.is_beam:  # the kinks' offsets, for the estimates
            junctions.junction_state(model)
        T = model.tension_field()
        n_owned = model.mesh.topology.index_map(1).size_local
        T_cab = T.x.array[:n_owned][model.cable_cells()]  # a network's dampers: no tension
        tmax = model.comm.allreduce(float(np.max(T_cab, initial=-np.inf)), op=MPI.MAX)
        tmin = model.comm.allreduce(float(np.min(T_cab, initial=np.inf)), op=MPI.MIN)
        slack = model.slack_elements()
        if slack:
            log.warning("statics: %d slack element(s) carry no tension", slack)
        res = StaticResult(forces, total_its, steps, slack, tmax, tmin,
                           time.perf_counter() - t_start)
        route = f"; {', then '.join(self.route)}" if self.route else ""
        log.info("statics: converged in %d Newton iterations (%d continuation steps%s), "
                 "tension %.6g..%.6g %s, %.2f s", total_its, steps, route, tmin, tmax,
                 unit(model.case.units, "force"), res.wall_time)
        return res

    def _note(self, what: str, history: SNESHistory | None = None) -> None:
        """A step of the route to the equilibrium: kept for the final line, logged at
        debug level with its Newton history (``logging.getLogger("cablefem").setLevel(
        logging.DEBUG)`` shows it)."""
        if not hasattr(self, "route"):
            self.route = []
        self.route.append(what)
        if history is not None:
            log.debug("statics: %s; Newton history: %s", what, history.text())
        else:
            log.debug("statics: %s", what)

    def _fallback(self, guess: np.ndarray, max_steps: int,
                  failure: str | None = None) -> tuple[PETSc.Vec, int, int]:
        """Newton failed from ``guess`` (``failure``: how, default its history): load
        continuation, or the relaxation when there is nothing to ramp. Returns the
        solution, Newton iterations and steps."""
        model, history = self.model, self.history
        # what load_factor scales: the extra loads, and for a network the weight as well
        has_extra = bool(model.case.point_masses or model.case.point_loads
                         or model.case.loads or model.ramp_weight
                         or getattr(model.case, "fluid", None) is not None)
        if not has_extra:
            # nothing to ramp: relaxation from the guess (e.g. a fine rod whose
            # clamped layers the guess misses by more than Newton can cross)
            self._note(failure or "Newton failed from the elastic catenary", history)
            why = (f"{failure or 'Newton failed from the elastic catenary'} and there is no "
                   "extra load to ramp")
            self._note("relaxation from the guess")
            model.scatter_nodal(guess, model.u)
            x = model.u.vector.copy()
            its, steps = self._relax(x, "static equilibrium not found: " + why)
        else:
            self._note(failure or "Newton failed from the catenary", history)
            x, its, steps = self._continue(guess, max_steps)
            self._note(f"load continuation, {steps} steps")
        return x, its, steps

    def _continue(self, guess: np.ndarray, max_steps: int) -> tuple[PETSc.Vec, int, int]:
        """Load continuation from ``guess`` (the extra loads, and a network's weight,
        scaled by ``model.load_factor`` from 0 to 1), with the relaxation when it stalls.
        Returns the solution, Newton iterations and steps."""
        model, history, snes = self.model, self.history, self.snes
        model.scatter_nodal(guess, model.u)
        x = model.u.vector.copy()
        lam, dlam, total_its, steps = 0.0, 0.25, 0, 0
        last = x.copy()
        try:
            while lam < 1.0:
                # no step from the unloaded state in three tries: it has no stiffness to
                # start from (a slack line that the load has to hang): relaxation
                if steps >= max_steps or dlam < 1e-6 or (lam == 0.0 and dlam < 0.25 / 6):
                    stalled = (f"load continuation stalled at load factor {lam:.4g} "
                               f"(increment {dlam:.2e}); last Newton history: "
                               f"{history.text()}")
                    self._note(f"load continuation stalled at load factor {lam:.4g}", history)
                    self._note("relaxation from the guess")
                    model.load_factor.value = 1.0
                    model.scatter_nodal(guess, model.u)
                    model.u.vector.copy(x)
                    its, n_relax = self._relax(x, stalled)
                    return x, total_its + its, steps + n_relax
                trial = min(1.0, lam + dlam)
                model.load_factor.value = trial
                x.copy(last)
                ok, its = _try(snes, x, history)
                total_its += its
                steps += 1
                if ok:
                    lam = trial
                    dlam *= 1.5
                    log.debug("statics: load factor %.4g converged in %d iterations", lam, its)
                else:
                    last.copy(x)  # back to the last converged state
                    dlam *= 0.5
            return x, total_its, steps
        finally:
            model.load_factor.value = 1.0
            last.destroy()

    #: the relaxation's first proximal stiffness, per unit mass: (2 pi/1 s)^2 (the
    #: load is applied as if over about a second), divided by RELAX_DECAY per step taken
    RELAX_START = 4.0 * np.pi**2
    RELAX_DECAY = 4.0
    RELAX_STEPS = 200

    def _corners(self, x: PETSc.Vec) -> int:
        """Newton with the kinks' corners on, from the plain equilibrium ``x`` (updated);
        StaticError naming them when it fails. Returns the iterations."""
        junctions.set_active(self.model, True)
        y = x.copy()
        ok, its = _try(self.snes, y, self.history)
        total = its
        if not ok:  # the layers grown in steps (ℓ from a quarter of its size)
            x.copy(y)
            for share in (0.25, 0.5, 0.75, 1.0):
                junctions.set_active(self.model, True, share)
                ok, its = _try(self.snes, y, self.history)
                total += its
                if not ok:
                    break
            junctions.set_active(self.model, True)
            if not ok:  # the plain equilibrium stands, said and estimated (not silent)
                y.destroy()
                junctions.give_up(self.model, "Newton did not converge with the corners "
                                  f"from the plain string's equilibrium ({self.history.text()})")
                return total
            self._note("the kinks' corners grown in 4 steps")
        y.copy(x)
        y.destroy()
        return total

    def _relax(self, x: PETSc.Vec, why: str) -> tuple[int, int]:
        """Statics by proximal steps (a pseudo-time of implicit Euler steps, overdamped):
        each step solves the equilibrium with a spring ``κ m`` per stress-free length
        pulling every point back to the last step's state, which gives every degree of
        freedom stiffness (a slack cable has none transverse to itself), the next
        step with ``κ`` divided by :attr:`RELAX_DECAY` (multiplied by 10 after a failed
        one); every third step plain Newton is tried from the step's state and ends it.
        The potential energy of a tension-only string under gravity and a seabed is
        convex (``EA/2 (λ − 1)₊²`` of a convex ``λ = |∂s r|``, a linear weight, a convex
        penalty), so the steps converge to the equilibrium; buoyancy per current length
        and a steady drag add small parts that are not. Each step takes full Newton
        steps (``<prefix>relax_``): its problem is strongly convex and starts near its
        solution. Returns (Newton iterations, steps); StaticError after
        :attr:`RELAX_STEPS` steps."""
        model, history = self.model, self.history
        prev = fem.Function(model.V, name="relaxation_anchor")
        kappa = fem.Constant(model.mesh, PETSc.ScalarType(self.RELAX_START))
        # the translational parts, their product as the model integrates its mass (a
        # rod: every cell term with one point, the exact P1 product)
        u_t, p_t, d_t = (model.translational(f) for f in (model.u, prev, model.du))
        spring, dx = model.translational_inner(u_t - p_t, d_t)
        model.forms.add("static_relaxation", kappa * model.m * model.c * spring * dx,
                        kind="static")
        # full Newton steps: each step's problem is strongly convex and starts near its
        # solution, and a backtracking line search on |F| stalls at the kinks of the
        # tension-only law (measured: 120 steps and 4900 iterations against 6 and 165 for
        # a mooring line meshed as an L, no convergence against 18 and 380 for a U chain)
        snes, work = _make_snes(model, history, False, self.prefix + "relax_",
                                self.petsc_options, {"snes_linesearch_type": "basic",
                                                     "snes_max_it": 100})
        total, last = 0, x.copy()
        try:
            for step in range(1, self.RELAX_STEPS + 1):
                copy_in(x, prev)
                x.copy(last)
                ok, its = _try(snes, x, history)
                total += its
                if not ok:
                    last.copy(x)
                    kappa.value = 10.0 * float(kappa.value)
                    continue
                kappa.value = float(kappa.value) / self.RELAX_DECAY
                if step % 3 == 0:
                    y = x.copy()
                    ok, its = _try(self.snes, y, history)
                    total += its
                    if ok:
                        y.copy(x)
                        y.destroy()
                        self._note(f"equilibrium after {step} relaxation steps")
                        return total, step
                    y.destroy()
            raise StaticError(f"{why}; the relaxation did not reach the equilibrium either "
                              f"in {self.RELAX_STEPS} steps (last Newton history: "
                              f"{history.text()})")
        finally:
            last.destroy()
            snes.destroy()
            for w in work:
                w.destroy()
            model.forms.remove("static_relaxation")

    def destroy(self) -> None:
        """Free the PETSc objects (SNES, matrices, vectors, the reactions' solver)."""
        for obj in (self.snes, *self._work, self.bilateral_snes, *self._bilateral_work):
            if obj is not None:
                obj.destroy()
        if self.reactions is not None:
            self.reactions.destroy()
            self.reactions = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.destroy()


def solve_static(model, max_continuation_steps: int = 200) -> StaticResult:
    """Solve the static equilibrium of ``model``; leaves it in ``model.u`` and
    ``model.u_static`` (a :class:`StaticProblem` made, solved and destroyed)."""
    with StaticProblem(model, max_continuation_steps=max_continuation_steps) as problem:
        return problem.solve()
