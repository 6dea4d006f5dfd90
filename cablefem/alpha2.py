"""Two workarounds for PETSc's ``alpha2`` (generalised-α for second-order systems) that
:mod:`cablefem.dynamics` needs when a step is cut: a retry from the failed step's own start
state (:func:`retry_from_start`) and a backward Euler step at a change of step size
(:class:`BackwardEuler`); docs/theory.md §2, "Cut steps"."""

from __future__ import annotations

import ctypes

from petsc4py import PETSc

__all__ = ["BackwardEuler", "retry_from_start"]


def retry_from_start(ts: PETSc.TS, t: float, number: int) -> None:
    """Prepare ``ts`` (``alpha2``, after a step from ``t`` that failed) to retry that step
    from its start: its displacement, velocity *and acceleration* there. ``TSRollBack``
    marks the step rolled back, so that the next ``TSStep`` keeps ``alpha2``'s start state
    (``X0``, ``V0``, ``A0``) instead of copying the failed attempt's acceleration into
    ``A0``; it also moves the clock back a step, which is set again here.

    The alternatives both changed the answer at every cut: a plain retry starts from the
    failed iterate's acceleration, and a restart (``TSRestartStep``) re-estimates ``A0``
    from two backward Euler half steps, which PETSc 3.18 divides by the half step instead
    of the whole one, twice the acceleration (docs/rod.md, "Noticed, not changed"): the
    sub-steps' first residual grew fourfold with each cut, and the mooring line of
    demos/mooring.toml showed spikes in its fairlead force at every cut (issue 29 item 7)."""
    ts.rollBack()
    ts.setTime(t)
    ts.setStepNumber(number)


class BackwardEuler:
    """Within the block (when ``active``) ``alpha2``'s parameters are those of backward
    Euler, ``α_m = α_f = γ = 1``, ``β = 1/2`` (PETSc's own for its start-up steps): the
    equation of motion holds at the step's end, and neither the step nor its end state
    depends on the acceleration it starts from; its end acceleration is the one the
    equations of motion give there, generalised-α's consistent start. First order, and
    strongly damping: used for the one step after a change of step size. petsc4py has no
    call for ``TSAlpha2SetParams``: it is called through ctypes from the PETSc library
    petsc4py is linked to."""

    _lib = None

    def __init__(self, ts: PETSc.TS, active: bool) -> None:
        self.ts, self.active, self.saved = ts, active, None

    @classmethod
    def _functions(cls):
        if cls._lib is None:
            lib = ctypes.CDLL(PETSc.__file__)  # its dependencies hold libpetsc's symbols
            real = ctypes.c_double
            lib.TSAlpha2SetParams.argtypes = [ctypes.c_void_p] + [real] * 4
            lib.TSAlpha2GetParams.argtypes = [ctypes.c_void_p] + [ctypes.POINTER(real)] * 4
            cls._lib = (lib, real)
        return cls._lib

    def _set(self, params) -> None:
        lib, _ = self._functions()
        if lib.TSAlpha2SetParams(self.ts.handle, *params) != 0:
            raise RuntimeError("TSAlpha2SetParams failed")

    def __enter__(self):
        if self.active:
            lib, real = self._functions()
            vals = [real() for _ in range(4)]
            if lib.TSAlpha2GetParams(self.ts.handle, *map(ctypes.byref, vals)) != 0:
                raise RuntimeError("TSAlpha2GetParams failed")
            self.saved = [v.value for v in vals]
            self._set((1.0, 1.0, 1.0, 0.5))
        return self

    def __exit__(self, *exc):
        if self.saved is not None:
            self._set(self.saved)
        return False
