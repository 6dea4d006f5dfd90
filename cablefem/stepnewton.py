"""The time integrator's Newton solve at each step: its predictor and its stopping test
(docs/theory.md §2, "Newton at each step").

PETSc's ``alpha2`` starts Newton from the step's start displacement, ``x_{n+1} = x_n``, and
its default test stops on the residual alone (``snes_rtol``, ``snes_atol``, ``snes_stol``).
Here, when the step is one of a run of equal steps:

* *Predictor* (``-cable_newton_predictor velocity``, the default): the second-order
  Adams-Bashforth extrapolation ``x_{n+1} = x_n + h (3 v_n - v_{n-1})/2`` from the last two
  step-start velocities (its error ``O(h^3)``, the order of generalised-α's own local error);
  the first step of a run of equal steps, ``x_n + h v_n``. ``constant``: PETSc's own.
* *Stopping test*: PETSc's default test, and also, from the first iteration on, the
  estimated error of the iterate against the step's displacement increment,
  ``|δx_k| |F_k| / |F_{k-1}| <= η |x_k - x_n|`` (``η``: ``-cable_newton_increment_rtol``,
  default :data:`INCREMENT_RTOL`; 0: the residual tests alone). ``|δx_k| |F_k|/|F_{k-1}|``
  is the size of the next Newton correction at the observed contraction (an upper bound
  once Newton converges quadratically).

On the steps PETSc takes inside a restart of ``alpha2`` (two backward Euler half steps that
estimate the start acceleration, after ``TSRestartStep``), whose start is not ``x_n``, both
are PETSc's own.
"""

from __future__ import annotations

from petsc4py import PETSc

__all__ = ["INCREMENT_RTOL", "StepNewton"]

#: η: Newton stops once its estimated error is below this fraction of the step's
#: displacement increment. Generalised-α's local error is about (ω h)²/12 of the increment
#: (ω the frequency that moves): 2e-4 for paper case B's second mode at its time step
#: (ω h = 0.05); 1e-6 leaves the solver's error more than 100 times below it, for every mode
#: up to ω h = 0.004 (docs/benchmarks.md: case B's anchor forces move by 4e-7 of their
#: dynamic range in 1000 steps, against 1.5e-2 for a halved time step).
INCREMENT_RTOL = 1.0e-6

#: PETSc's SNESConvergedReason values used here
_ABS, _REL, _SNORM = 2, 3, 4
_NAN, _DTOL = -4, -9


class StepNewton:
    """The predictor and stopping test of :mod:`cablefem.stepnewton` installed on ``ts``'s
    SNES. Read its options (``<prefix>newton_predictor``, ``<prefix>newton_increment_rtol``,
    ``<prefix>snes_divergence_tolerance``) after ``ts.setFromOptions()``.

    :meth:`expect` is told each step's size before ``ts.step()``; :meth:`reset` forgets the
    velocity history (a checkpoint, a restore: the next step starts a new run of equal
    steps, in the resumed run and in the uninterrupted one alike)."""

    def __init__(self, ts: PETSc.TS, prefix: str) -> None:
        self.ts = ts
        snes = ts.getSNES()
        opts = PETSc.Options()
        predictor = opts.getString(prefix + "newton_predictor", "velocity")
        if predictor not in ("velocity", "constant"):
            raise ValueError(f"-{prefix}newton_predictor must be 'velocity' or 'constant', "
                             f"got {predictor!r}")
        self.eta = opts.getReal(prefix + "newton_increment_rtol", INCREMENT_RTOL)
        self.divtol = opts.getReal(prefix + "snes_divergence_tolerance", 1.0e4)
        self.rtol, self.atol, self.stol, _ = snes.getTolerances()
        self.h: float | None = None  # the step size of the step being taken
        self.records: list[tuple[float, float, PETSc.Vec]] = []  # (t, h, v) at step starts
        self.work: PETSc.Vec | None = None
        self.own = False  # this solve is a step of the run (not a restart's half step)
        self.f0 = self.f_prev = 0.0
        if predictor == "velocity":
            snes.setInitialGuess(self.guess)
        snes.setConvergenceTest(self.test)

    def expect(self, h: float) -> None:
        self.h = h

    def reset(self) -> None:
        for _, _, v in self.records:
            v.destroy()
        self.records.clear()

    def destroy(self) -> None:
        self.reset()
        if self.work is not None:
            self.work.destroy()

    def _own_step(self) -> bool:
        h = self.ts.getTimeStep()
        return self.h is not None and abs(h - self.h) <= 1e-12 * self.h

    def guess(self, snes: PETSc.SNES, x: PETSc.Vec) -> None:
        """The predictor into ``x`` (SNES calls it at the start of every solve)."""
        if not self._own_step():
            return  # a restart's half step: PETSc's start, x = its own start
        ts = self.ts
        X0, V0 = ts.getSolution2()
        t, h = ts.getTime(), self.h
        prev = None
        for tr, hr, v in self.records:
            if abs(hr - h) <= 1e-12 * h and abs(t - h - tr) <= 1e-9 * h:
                prev = v
        if prev is None:
            x.waxpy(h, V0, X0)
        else:
            x.waxpy(1.5 * h, V0, X0)
            x.axpy(-0.5 * h, prev)
        if not any(abs(tr - t) <= 1e-9 * h for tr, _, _ in self.records):  # not a retry
            if len(self.records) == 2:
                _, _, v = self.records.pop(0)
                v.destroy()
            self.records.append((t, h, V0.copy()))

    def test(self, snes: PETSc.SNES, it: int, norms) -> int:
        """PETSc's default test, and the error against the step's increment."""
        xnorm, ynorm, fnorm = norms
        if fnorm != fnorm:
            return _NAN
        if it == 0:
            self.own = self._own_step()
            self.f0 = self.f_prev = fnorm
            return _ABS if fnorm < self.atol else 0
        f_prev, self.f_prev = self.f_prev, fnorm
        if fnorm < self.atol:
            return _ABS
        if fnorm <= self.rtol * self.f0:
            return _REL
        if ynorm < self.stol * xnorm:
            return _SNORM
        if self.divtol > 0 and fnorm > self.divtol * self.f0:
            return _DTOL
        if self.own and self.eta > 0 and f_prev > 0:
            X0, _ = self.ts.getSolution2()
            if self.work is None:
                self.work = X0.duplicate()
            self.work.waxpy(-1.0, X0, snes.getSolution())
            if ynorm * fnorm / f_prev <= self.eta * self.work.norm():
                return _SNORM  # the step (the error left) small against the increment
        return 0
