"""Newton for the statics (:mod:`cablefem.statics`): the static SNES of a model, a solve
that reports (converged, iterations), full Newton steps from a neighbouring equilibrium,
and the hooks the virtual hinges' fixed point drives (:class:`HingeSteps`)."""

from __future__ import annotations

import logging

import numpy as np
from dolfinx.fem import petsc as fpetsc
from petsc4py import PETSc

from cablefem import junctions
from cablefem.petsc_utils import (
    LARGE_ABOVE,
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
from cablefem.stepnewton import default_reason

__all__ = ["FULL_STEPS", "HingeSteps", "STAGNATION", "StaticTest", "fresh_pc", "make_snes",
           "try_full", "try_solve"]

log = logging.getLogger("cablefem.statics")

#: Newton has reached the residual's round-off floor, and stops there, when an iteration
#: leaves ``|F|`` at more than half the last one's (no contraction: Newton's own
#: convergence would cut it by far more) while ``|F|`` is within this factor of ``atol``
#: (the band :class:`HingeSteps` accepts after a failed solve). ``atol`` sits 10 times
#: above an estimate of the floor (:meth:`cablefem.cable.CableModel.residual_floor`), which
#: the real floor can exceed: the 94 000-dof roof's statics wandered at |F| = 1.4e-4 to
#: 2.3e-4 N against an ``atol`` of 1.0e-4 N for up to 8 iterations a solve (20 of its 37
#: Newton iterations), until the noise dipped below.
STAGNATION = 100.0
#: "no contraction": ``|F_k| > STAGNATION_RATIO |F_{k-1}|``
STAGNATION_RATIO = 0.5


class StaticTest:
    """The static SNES's stopping test: PETSc's default one (``atol``, ``rtol``,
    ``stol``, the divergence tolerance) and Newton stagnating at the residual's round-off
    floor within :data:`STAGNATION` ``atol`` (reported as converged on the step,
    ``CONVERGED_SNORM_RELATIVE``). Also feeds ``history`` every residual norm (no
    monitor callback)."""

    def __init__(self, history: SNESHistory, divtol: float = 1.0e4) -> None:
        self.history, self.divtol = history, divtol
        self.f0 = self.f_prev = 0.0
        self.stagnated = 0  # solves stopped at the floor (a count, for tests and logs)

    def __call__(self, snes: PETSc.SNES, it: int, norms) -> int:
        xnorm, ynorm, fnorm = norms
        self.history(snes, it, fnorm)
        rtol, atol, stol, _ = snes.getTolerances()
        if it == 0:
            self.f0 = fnorm
        f_prev, self.f_prev = self.f_prev if it else fnorm, fnorm
        reason = default_reason(it, fnorm, self.f0, xnorm, ynorm, rtol, atol, stol,
                                self.divtol)
        if reason or it == 0:
            return reason
        if fnorm <= STAGNATION * atol and fnorm > STAGNATION_RATIO * f_prev:
            self.stagnated += 1
            return PETSc.SNES.ConvergedReason.CONVERGED_SNORM_RELATIVE
        return 0


def make_snes(model, history: SNESHistory, bilateral: bool = False, prefix: str | None = None,
               petsc_options: dict | None = None, defaults: dict | None = None
               ) -> tuple[PETSc.SNES, tuple]:
    """The static SNES of ``model`` and its (residual vector, Jacobian matrix), under
    ``prefix`` (default ``<model prefix>static_``), ``defaults`` over the usual ones; the
    caller destroys all three."""
    extra = defaults or {}
    prefix = model.prefix + "static_" if prefix is None else prefix
    n_dofs = model_dofs(model)
    # absolute tolerance: round-off of the residual grows with the tension (EA v3), so
    # scale it with the larger of the cable's weight and its catenary tension
    defaults = {"snes_type": "newtonls", "snes_linesearch_type": "bt", "snes_max_it": 50,
                "snes_rtol": 1e-10,
                "snes_atol": max(1e-10 * model.force_scale,
                                 10.0 * model.residual_floor(displaced=True)),
                "snes_stol": 1e-14,
                **lu_options(model.comm.size, n_dofs), **static_matrix(n_dofs),
                **model.static_options, **extra}
    f_form = model.f_static_bilateral if bilateral else model.f_static
    j_form = model.j_static_bilateral if bilateral else model.j_static
    b = fpetsc.create_vector(f_form)
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
    user = {**case_options(model, "static"), **(petsc_options or {})}
    with default_options(prefix, defaults, user):
        # -cable_static_mat_type (static_matrix) is read here: the matrix comes first
        A = junctions.create_matrix(model, j_form,
                                    PETSc.Options().getString(prefix + "mat_type", "") or None)
        snes.setJacobian(J, A)
        snes.setFromOptions()
        # PETSc's default divergence tolerance, or the one given
        divtol = PETSc.Options().getReal(prefix + "snes_divergence_tolerance", 1.0e4)
    snes.setConvergenceTest(StaticTest(history, divtol))
    return snes, (b, A)


def static_matrix(n_dofs: int) -> dict[str, str]:
    """The static Jacobian's matrix type: above :data:`~cablefem.petsc_utils.LARGE_ABOVE`
    unknowns a block matrix (``mat_type baij``, the node's 3 or 6 unknowns a block), as in
    the dynamics, below dolfinx's default (AIJ). Statics factors its Jacobian at every
    Newton iteration, and on blocks that is cheaper: the 94 000-dof roof of
    ``benchmarks/bench_scaling.py`` (29 factorisations, ``amd``, one rank, PETSc
    ``-log_view``) 1.44 s of numeric factorisation against 2.00 s, 0.04 s of symbolic
    against 0.23 s, 0.10 s of triangular solves against 0.17 s (docs/benchmarks.md,
    "Statics on blocks, the hinges over the ranks"). Small models keep AIJ: their factorisation
    costs little and their numbers stay as they were. ``-cable_static_mat_type``
    overrides."""
    return {"mat_type": "baij"} if n_dofs > LARGE_ABOVE else {}


def factorisation_failed(snes) -> bool:
    """Whether ``snes``'s last linear solve failed in its preconditioner's set-up (a
    factorisation that met a zero pivot)."""
    return snes.getKSP().getConvergedReason() == \
        PETSc.KSP.ConvergedReason.DIVERGED_PCSETUP_FAILED


def try_solve(snes, x, history) -> tuple[bool, int]:
    history.clear()
    snes.solve(None, x)
    ok = snes.getConvergedReason() > 0
    if not ok and factorisation_failed(snes):
        fresh_pc(snes.getKSP())
    return ok, snes.getIterationNumber()


#: Newton with full steps (no line search), tried first from a neighbouring equilibrium
FULL_STEPS = {"snes_linesearch_type": "basic", "snes_max_it": 25}


def try_full(snes, x, history) -> tuple[bool, int]:
    """Newton of ``snes`` (:data:`FULL_STEPS`) from ``x``; ``x`` left as it was when it
    fails. From a neighbouring equilibrium of a line on the seabed the backtracking line
    search stalls (|F| down by 0.3 % an iteration over 50 iterations, measured on the
    mooring demo: its contact law bends within a quarter millimetre), where full steps
    converge in 5 to 10."""
    y = x.copy()
    ok, its = try_solve(snes, y, history)
    if ok:
        y.copy(x)
    y.destroy()
    return ok, its


def fresh_pc(ksp: PETSc.KSP) -> None:
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
        ctx = old.getPythonContext()  # with the options it read, where it keeps them
        pc.setPythonContext(ctx.fresh() if hasattr(ctx, "fresh") else type(ctx)())
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
        self.full, self._full_work = make_snes(model, history, False,
                                                snes.getOptionsPrefix(), None, FULL_STEPS)

    def solve(self, it: int) -> tuple[bool, int]:
        """Newton at the current hinges from the current state (the last equilibrium's
        neighbour): with full steps first (:func:`try_full`), then with the line search
        for at most 10 iterations (where it stalls, as on the mooring demo's seabed over
        its 50, the fixed point's continuation towards the hinges converges in a few):
        (converged, iterations)."""
        model, x, history = self.model, self.x, self._history
        ok, its = try_full(self.full, x, history)
        # the Jacobian at x itself could not be factored (a slack element: see below): the
        # line search would start from the same x and fail the same way
        singular = not ok and its == 0 and factorisation_failed(self.full)
        if not ok and not singular:
            rtol, atol, stol, max_it = self.snes.getTolerances()
            self.snes.setTolerances(max_it=min(max_it, 10))
            try:
                ok, its2 = try_solve(self.snes, x, history)
            finally:
                self.snes.setTolerances(max_it=max_it)
            its += its2
        if not ok and model.tension_only:
            # as for the leading order: an element the hinge step leaves slack (H is ~h into
            # the first element; a cable's strain T/EA can be far smaller) can make the
            # tension-only Jacobian singular; compression allowed first, then tension-only
            self.last.copy(x)
            if self.bilateral is None:
                self.bilateral = make_snes(model, history, bilateral=True)[0]
            ok2, its2 = try_solve(self.bilateral, x, history)
            its += its2
            if ok2:
                ok, its3 = try_solve(self.snes, x, history)
                its += its3
        if not ok and history.norms and history.norms[-1][1] <= STAGNATION * self.atol:
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
        for obj in (self.last, self.bilateral, self.full, *self._full_work):
            if obj is not None:
                obj.destroy()
