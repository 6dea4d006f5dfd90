"""The time integrator's Newton solve at each step: its predictor, its stopping test and
the reuse of its Jacobian (docs/theory.md §2, "Newton at each step").

PETSc's ``alpha2`` starts Newton from the step's start displacement, ``x_{n+1} = x_n``, and
its default test stops on the residual alone (``snes_rtol``, ``snes_atol``, ``snes_stol``).
Here, on the steps of a run of equal steps:

* *Predictor* (``-cable_newton_predictor velocity``, the default): the second-order
  Adams-Bashforth extrapolation ``x_{n+1} = x_n + h (3 v_n - v_{n-1})/2`` from the last two
  step-start velocities (its error ``O(h^3)``, the order of generalised-α's own local error),
  on a step when it came nearer to the last step's end than PETSc's ``x_n`` did (both are
  compared after every step: two norms); otherwise, and on the first step of a run of equal
  steps, ``x_n``. On a stiff cable whose velocity rings axially (``ρ∞ = 1``) the
  extrapolation starts Newton farther than ``x_n``. ``constant``: always ``x_n``.
* *Stopping test*: PETSc's default test, and also, from the first iteration on, the
  estimated error ``e_k`` of the iterate against the step's displacement increment,
  ``e_k <= η |x_k - x_n|`` (``η``: ``-cable_newton_increment_rtol``, default
  :data:`INCREMENT_RTOL`; 0: the residual tests alone). After an iteration with a fresh
  Jacobian ``e_k = |δx_k| |F_k| / |F_{k-1}|``, the size of the next Newton correction at
  the observed contraction: mostly above the next correction, not always (at paper case
  A's stops the next correction was 5 % of the tolerance at the median, above it at 13 of
  287, at most twice it; docs/benchmarks.md, "The grounded line's second iteration
  found"); where that estimate does not stop Newton, the next correction itself is
  computed with the factorisation just used, as below (one triangular solve instead of
  an iteration: an axially stiff line's residual ratio overstates the error). After an
  iteration with a kept Jacobian (modified Newton, linear convergence) that ratio is no
  estimate: an axially stiff line's residual is ruled by its stiff directions, and the
  last iterations meet its round-off floor, so ``|F_k|/|F_{k-1}|`` overstated the
  contraction of ``x`` 18 times on a grounded mooring line and cost a second iteration on
  most steps. There the test applies the kept factorisation to ``F_k``: ``δ̄ = J^{-1}
  F_k`` is the next correction itself (Deuflhard's simplified Newton correction, one
  triangular solve), ``θ = |δ̄|/|δx_k|`` the contraction, and ``e_k = |δ̄|/(1 − θ)`` the
  sum of the corrections still to come (no stop while ``θ >= 1``).
* *Jacobian reuse* (``-cable_newton_jacobian_reuse N``; 0: never): an iteration keeps the
  Jacobian (and its factorisation) of an earlier step when it was assembled with the same
  shifts (the same step size and parameters) at most ``N`` steps ago and, after a step's
  first iteration, while Newton's residual still falls by :data:`CONTRACTION` per
  iteration; otherwise it is assembled afresh. Default :data:`JACOBIAN_REUSE` for a model
  with a fluid or a seabed, whose Jacobian costs four to five residuals (mooring demo:
  1.1 ms against 0.26 ms), or with a network's kink corners (:mod:`cablefem.junctions`,
  their Jacobian by complex step: the 94 000-dof roof's step 0.50 s against 0.25 s of CPU
  with it, 1.2e3 dofs 9.7 ms against 6.2 ms), 0 without (the string's Jacobian costs
  about a residual; kept, the extra iterations cost what it saves: paper case B 176
  against 180 µs a step).
* *A split Jacobian*: when the model has terms of ``slow_jacobian`` (a fluid's drag and
  added mass: their Jacobian is most of the whole one's cost and changes slowly), the
  caller keeps their part apart; an assembly refreshes the other terms' part and adds the
  slow part as assembled at most ``-cable_newton_slow_jacobian_reuse`` steps ago
  (default :data:`SLOW_REUSE`; 0: both parts assembled every time). With it, after a step that
  a kept Jacobian did not finish in one iteration, the next steps assemble the fast part
  at their first iteration (*rough* steps, with a back-off:
  :meth:`StepNewton.keep_jacobian`): a wet line whose touchdown slaps the seabed took two
  iterations and a whole Jacobian a step otherwise.

On the steps PETSc takes inside a restart of ``alpha2`` (two backward Euler half steps that
estimate the start acceleration, after ``TSRestartStep``), whose start is not ``x_n``, all
three are PETSc's own.
"""

from __future__ import annotations

from petsc4py import PETSc

__all__ = ["INCREMENT_RTOL", "JACOBIAN_REUSE", "SLOW_REUSE", "StepNewton"]

#: η: Newton stops once its estimated error is below this fraction of the step's
#: displacement increment. Generalised-α's local error is about (ω h)²/12 of the increment
#: for a motion of frequency ω: 2e-4 for paper case B's second mode (ω h = 0.05), 1.2e-5
#: for the mooring demo's surge (ω h = 0.012). Measured (docs/benchmarks.md, "Newton at each
#: step"): the anchor forces move by 1.2e-7 (case B) and 8e-5 (mooring) of their dynamic
#: range against the residual tests alone, while a halved time step moves them by 1.5e-2
#: and 5e-2.
INCREMENT_RTOL = 1.0e-7

#: steps over which a Jacobian of the same shifts is kept for a step's first iteration
JACOBIAN_REUSE = 10

#: steps over which a split Jacobian's slow part (a fluid's) is kept when the rest is
#: assembled again (measured on the mooring demo: docs/benchmarks.md, "The mooring demo's
#: rough steps, and the fluid's Jacobian kept apart")
SLOW_REUSE = 5

#: a kept Jacobian serves the next iteration while Newton's residual falls by this factor
#: or more per iteration; otherwise it is assembled afresh
CONTRACTION = 0.1

#: PETSc's SNESConvergedReason values used here
_ABS, _REL, _SNORM = 2, 3, 4
_NAN, _DTOL = -4, -9


def default_reason(it: int, fnorm: float, f0: float, xnorm: float, ynorm: float,
                   rtol: float, atol: float, stol: float, divtol: float) -> int:
    """PETSc's default stopping test (``SNESConvergedDefault``) at iteration ``it``, the
    solve's first residual norm ``f0``: a NaN norm, ``atol``, then (after the first
    iteration) ``rtol``, ``stol`` and the divergence tolerance; 0 to go on."""
    if fnorm != fnorm:
        return _NAN
    if fnorm < atol:
        return _ABS
    if it == 0:
        return 0
    if fnorm <= rtol * f0:
        return _REL
    if ynorm < stol * xnorm:
        return _SNORM
    if divtol > 0 and fnorm > divtol * f0:
        return _DTOL
    return 0


def _same(a: float, b: float) -> bool:
    """Equal to round-off: a step size, a shift computed from grid times."""
    return abs(a - b) <= 1e-9 * max(abs(a), abs(b))


class StepNewton:
    """The predictor, stopping test and Jacobian reuse of :mod:`cablefem.stepnewton` on
    ``ts``'s SNES. Reads its options (``<prefix>newton_predictor``,
    ``<prefix>newton_increment_rtol``, ``<prefix>newton_jacobian_reuse``,
    ``<prefix>snes_divergence_tolerance``): make it after ``ts.setFromOptions()``.
    ``costly_jacobian``: the model's Jacobian costs several residuals (a fluid, a seabed,
    a network's kink corners):
    reuse it by default. ``history``: called with every residual norm (a
    :class:`cablefem.petsc_utils.SNESHistory`).

    :meth:`expect` is told each step's size before ``ts.step()``; the Jacobian callback
    asks :meth:`keep_jacobian` before it assembles; :meth:`reset` forgets the velocity
    history and the kept Jacobian (a checkpoint, a restore: the next step starts a new run
    of equal steps, in the resumed run and in the uninterrupted one alike)."""

    def __init__(self, ts: PETSc.TS, prefix: str, costly_jacobian: bool = False,
                 history=None) -> None:
        self.ts = ts
        #: called ``history(snes, it, fnorm)`` at every residual, as a SNES monitor would
        #: be (the test sees every residual norm: one Python call fewer per iteration)
        self.history = history
        snes = ts.getSNES()
        opts = PETSc.Options()
        predictor = opts.getString(prefix + "newton_predictor", "velocity")
        if predictor not in ("velocity", "constant"):
            raise ValueError(f"-{prefix}newton_predictor must be 'velocity' or 'constant', "
                             f"got {predictor!r}")
        self.eta = opts.getReal(prefix + "newton_increment_rtol", INCREMENT_RTOL)
        self.reuse = opts.getInt(prefix + "newton_jacobian_reuse",
                                 JACOBIAN_REUSE if costly_jacobian else 0)
        #: steps over which a split Jacobian's slow part is kept (0: assembled every time)
        self.slow_reuse = opts.getInt(prefix + "newton_slow_jacobian_reuse",
                                      min(SLOW_REUSE, self.reuse))
        for name, value in (("newton_increment_rtol", self.eta),
                            ("newton_jacobian_reuse", self.reuse),
                            ("newton_slow_jacobian_reuse", self.slow_reuse)):
            if not value >= 0:  # a negative count or tolerance (or NaN): no meaning here
                raise ValueError(f"-{prefix}{name} must be 0 or more (0: off), got {value}")
        self.divtol = opts.getReal(prefix + "snes_divergence_tolerance", 1.0e4)
        self.rtol, self.atol, self.stol, _ = snes.getTolerances()
        self.h: float | None = None  # the step size of the step being taken
        #: the last step's start time and size, its velocity predictor, its start x and v
        self.last: tuple | None = None
        self.velocity = False  # the velocity predictor serves this step
        self.work: PETSc.Vec | None = None
        self.own = False  # this solve is a step of the run (not a restart's half step)
        self.f0 = self.f_prev = 0.0
        self.f_before = self.f_last = 0.0  # the last two residual norms of the solve
        self.kept: tuple[float, float] | None = None  # the shifts of the Jacobian in J
        self.age = 0  # steps since it was assembled
        #: steps whose first iteration assembles afresh (a kept Jacobian failed to finish
        #: a step in one iteration), and the length of the last such run
        self.rough = self.backoff = 0
        #: the caller's Jacobian has a slow part kept apart (set by the caller): an
        #: assembly then refreshes the fast part alone while the slow one is young
        self.split = False
        #: the last assembly's slow part is assembled too; its shifts and age in steps
        self.slow = True
        self.slow_kept: tuple[float, float] | None = None
        self.slow_age = 0
        self.stale = False  # the last iteration solved with a kept Jacobian
        self.next: PETSc.Vec | None = None  # the simplified Newton correction
        #: counts, for the statistics (a split Jacobian's slow part: ``slow_assemblies``)
        self._assemblies = self.residuals = self.slow_assemblies = 0
        #: whole Jacobians assembled without asking :meth:`keep_jacobian` (the C route,
        #: where its answer is known: no reuse, no split)
        self.elsewhere = lambda: 0
        if predictor == "velocity":
            snes.setInitialGuess(self.guess)
        snes.setConvergenceTest(self.test)

    @property
    def assemblies(self) -> int:
        """Jacobians assembled (a split one's fast part; for the statistics)."""
        return self._assemblies + self.elsewhere()

    def expect(self, h: float, cut: bool = False) -> None:
        """The next ``ts.step()`` takes a step of ``h``; ``cut``: a sub-step of a cut step
        (after a failed Newton solve), solved by PETSc's own Newton alone."""
        self.h = None if cut else h

    def reset(self) -> None:
        if self.last is not None:
            for vec in self.last[2:]:
                vec.destroy()
        self.last = None
        self.kept = self.slow_kept = None
        self.rough = self.backoff = 0

    def destroy(self) -> None:
        self.reset()
        for vec in (self.work, self.next):
            if vec is not None:
                vec.destroy()

    def _own_step(self) -> bool:
        h = self.ts.getTimeStep()
        return self.h is not None and abs(h - self.h) <= 1e-12 * self.h

    def keep_jacobian(self, shift_v: float, shift_a: float) -> bool:
        """True when the Jacobian already in the matrix serves this call: assembled with
        the same shifts at most ``reuse`` steps ago, and Newton contracted by at least
        :data:`CONTRACTION` in the step's last iteration (always true at its first), and
        the step is not a *rough* one; otherwise the caller assembles it (its slow part
        too when :attr:`slow`), and it is kept from now on.

        Rough steps, with a split Jacobian (:attr:`split`: its fast part is what an
        assembly then costs): when a kept Jacobian did not finish a step in one iteration
        (a line landing on the seabed: the contact's stiffness comes and goes within a
        step), the next ``b`` steps assemble it at their first iteration (Newton's own
        convergence from a good predictor: mostly one iteration); then a kept one is tried
        again, and ``b`` doubles (1, 2, 4, ... up to ``reuse``) while it fails, and is 0
        again once a kept Jacobian finishes a step in one iteration. Without a split a
        whole Jacobian costs too much for that (a roof's kink corners and factorisation:
        its step 24 -> 38 ms with 1.4 instead of 2.5 iterations)."""
        first = self.ts.getSNES().getIterationNumber() == 0
        own = self._own_step()
        fast = first or self.f_last <= CONTRACTION * self.f_before
        if self.split and not first and self.stale and own:  # a kept one did not finish it
            self.backoff = min(max(1, 2 * self.backoff), self.reuse)
            self.rough = self.backoff
        if first and own:
            self.slow_age += 1
            if self.rough > 0:
                self.rough -= 1
                fast = False
        if (fast and self.reuse > 0 and self.kept is not None
                and _same(self.kept[0], shift_v) and _same(self.kept[1], shift_a)
                and self.age + first <= self.reuse and own):
            self.age += first
            self.stale = True
            return True
        self.kept, self.age, self.stale = (shift_v, shift_a), 0, False
        self._assemblies += 1
        # a split Jacobian's slow part: assembled too unless kept under the same rule
        kept_slow = self.slow_kept
        self.slow = not (self.split and self.slow_reuse > 0 and own and kept_slow is not None
                         and _same(kept_slow[0], shift_v) and _same(kept_slow[1], shift_a)
                         and self.slow_age <= self.slow_reuse)
        if self.slow:
            self.slow_kept, self.slow_age = (shift_v, shift_a), 0
            self.slow_assemblies += self.split
        return False

    def guess(self, snes: PETSc.SNES, x: PETSc.Vec) -> None:
        """The predictor into ``x`` (SNES calls it at the start of every solve, ``x`` then
        holds PETSc's own, ``x_n``)."""
        if not self._own_step():
            return  # a restart's half step, a cut step's retry: PETSc's start
        ts, h = self.ts, self.h
        X0, V0 = ts.getSolution2()
        t = ts.getTime()
        last = self.last
        # the same step size to round-off (h is a difference of grid times: its last digits
        # change from step to step), and the last step's end is this one's start
        if last is not None and _same(last[1], h) and abs(t - h - last[0]) <= 1e-9 * h:
            # the last step's end is this one's start: which predictor was nearer to it
            _, _, pred, start, v_prev = last
            pred.axpy(-1.0, X0)
            start.axpy(-1.0, X0)
            self.velocity = pred.norm() < start.norm()
            pred.waxpy(1.5 * h, V0, X0)
            pred.axpy(-0.5 * h, v_prev)
            have = True
        else:
            if last is not None:  # a new run of equal steps: PETSc's start, and compare
                for vec in last[2:]:
                    vec.destroy()
            pred, start, v_prev = X0.duplicate(), X0.duplicate(), V0.duplicate()
            pred.waxpy(h, V0, X0)  # the candidate of a first step, compared at the next
            self.velocity, have = False, False
        X0.copy(start)
        V0.copy(v_prev)
        self.last = (t, h, pred, start, v_prev)
        if have and self.velocity:
            pred.copy(x)

    def test(self, snes: PETSc.SNES, it: int, norms) -> int:
        """PETSc's default test, and the error against the step's increment."""
        xnorm, ynorm, fnorm = norms
        if self.history is not None:
            self.history(snes, it, fnorm)
        self.f_before, self.f_last = (fnorm, fnorm) if it == 0 else (self.f_last, fnorm)
        self.residuals += 1  # SNES tests after each residual (basic line search)
        if it == 0:
            self.own = self._own_step()
            self.f0 = fnorm
        f_prev, self.f_prev = self.f_prev if it else fnorm, fnorm
        reason = default_reason(it, fnorm, self.f0, xnorm, ynorm, self.rtol, self.atol,
                                self.stol, self.divtol)
        if reason or it == 0:
            if reason in (_NAN, _DTOL):
                self.kept = None  # a wild iterate: no Jacobian of it is kept
            return reason
        if self.own and self.eta > 0 and f_prev > 0:
            X0, _ = self.ts.getSolution2()
            if self.work is None:
                self.work = X0.duplicate()
            self.work.waxpy(-1.0, X0, snes.getSolution())
            allowed = self.eta * self.work.norm()
            if self.stale:  # modified Newton: the next correction from the kept factors
                error = self._error_left(snes, ynorm)
            else:  # at the residual's round-off floor (no contraction left) the step itself
                error = ynorm * min(1.0, fnorm / f_prev)
                if error > allowed:  # the residual's ratio can overstate
                    error = min(error, self._error_left(snes, ynorm))
            if error <= allowed:
                if it == 1 and self.stale:
                    self.backoff = 0  # a kept Jacobian finished the step in one iteration
                return _SNORM  # the error left small against the step's increment
        return 0

    def _error_left(self, snes: PETSc.SNES, ynorm: float) -> float:
        """The error of the iterate after an iteration with a kept Jacobian: the next
        correction ``J^{-1} F_k`` (the factorisation the iteration used, applied to the
        residual SNES holds) over ``1 − θ``; infinite while the corrections do not
        contract."""
        F = snes.getFunction()[0]
        if self.next is None:
            self.next = F.duplicate()
        snes.getKSP().solve(F, self.next)
        step = self.next.norm()
        theta = step / ynorm if ynorm > 0 else float("inf")
        return step / (1.0 - theta) if theta < 1.0 else float("inf")
