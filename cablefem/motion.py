"""Prescribed anchor motions and time functions of loads.

Pure Python/NumPy/SciPy: no dolfinx import. An anchor motion is the displacement (m) of an
anchor from its static position, with its velocity (m/s) and acceleration (m/s^2) in closed
form, so that a time integrator can impose all three consistently. A :class:`TimeFunction` is
the dimensionless factor that multiplies a load.

Harmonic and elliptic motions can start with a smooth ramp of their amplitude
(:func:`ramp_factors`): ``u(t) = r(t) u0(t)`` with ``r`` rising from 0 to 1 over ``ramp``
seconds as ``10 x^3 - 15 x^4 + 6 x^5`` (``x = t/ramp``), whose value, first and second
derivatives are continuous at both ends; velocity and acceleration follow by the product rule
(``r' u0 + r u0'`` and ``r'' u0 + 2 r' u0' + r u0''``), so a ramped motion starts with zero
displacement, velocity and acceleration. ``ramp = 0`` is the motion itself from ``t = 0``
(a velocity jump there, and a displacement jump with a phase).

Tables (:class:`TableMotion`, ``TimeFunction.table``) are C2 cubic splines through their rows
with not-a-knot end conditions (the first two and the last two segments are one cubic each;
2 rows: the straight line, 3 rows: the parabola): velocity and acceleration are the spline's
own first and second derivatives, continuous everywhere inside the table. Outside their time
range tables are held at their first and last values (velocity and acceleration zero); a case
refuses a table that ends before ``dynamics.t_end`` unless it says ``hold = true``
(:mod:`cablefem.case`). The tables' checks, splines and CSV reading are in
:mod:`cablefem.timetables` (:func:`~cablefem.timetables.table_resolution` says what a time step
cannot resolve).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from cablefem.timetables import Spline, check_table, read_csv

__all__ = [
    "Motion", "HarmonicMotion", "EllipseMotion", "TableMotion", "TimeFunction",
    "read_motion_csv", "read_factor_csv", "ramp_factors", "default_ramp",
    "DEFAULT_RAMP_PERIODS", "accelerations", "factors",
]

#: default ramp of harmonic and elliptic anchor motions in a case file: this many periods of
#: the motion's lowest circular frequency (``2 pi / omega`` each)
DEFAULT_RAMP_PERIODS = 3.0


@runtime_checkable
class Motion(Protocol):
    """A prescribed anchor displacement ``u(t)`` from the static position (m).

    Implementations: :class:`HarmonicMotion`, :class:`EllipseMotion`, :class:`TableMotion`,
    or a user's class with these four methods, each taking the time ``t`` (s).
    """

    def displacement(self, t: float) -> np.ndarray:
        """Displacement (m), shape (3,)."""

    def velocity(self, t: float) -> np.ndarray:
        """Velocity (m/s), shape (3,)."""

    def acceleration(self, t: float) -> np.ndarray:
        """Acceleration (m/s^2), shape (3,)."""

    def describe(self) -> dict:
        """JSON-serialisable description (for ``summary.json``)."""


def _frozen_array(value: Any, shape: tuple[int, ...], name: str) -> np.ndarray:
    """A read-only float copy of ``value`` broadcast to ``shape``; finite values only."""
    try:
        array = np.array(np.broadcast_to(np.asarray(value, dtype=float), shape))
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{name}: expected shape {shape} (or broadcastable): {exc}") from None
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name}: values must be finite")
    array.flags.writeable = False
    return array


def ramp_factors(t: float, ramp: float) -> tuple[float, float, float]:
    """The ramp ``r(t)`` and its first two time derivatives, for a ramp of ``ramp`` s.

    ``r = 10 x^3 - 15 x^4 + 6 x^5`` with ``x = t/ramp`` on ``0 <= t <= ramp``, 0 before and
    1 after: ``r(0) = 0``, ``r(ramp) = 1``, and ``r'``, ``r''`` vanish at both ends, so ``r``
    is C2 everywhere. ``ramp = 0``: 1 at all times (no ramp).

    Args:
        t: Time (s).
        ramp: The ramp's duration (s), >= 0.

    Returns:
        ``(r, dr/dt, d2r/dt2)``.
    """
    if ramp <= 0.0 or t >= ramp:
        return 1.0, 0.0, 0.0
    if t <= 0.0:
        return 0.0, 0.0, 0.0
    x = t / ramp
    r = x**3 * (10.0 + x * (-15.0 + 6.0 * x))
    dr = 30.0 * x**2 * (1.0 - x) ** 2 / ramp
    ddr = 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x) / ramp**2
    return r, dr, ddr


def default_ramp(omega: Any, amplitude: Any = None) -> float:
    """:data:`DEFAULT_RAMP_PERIODS` periods of the lowest circular frequency (rad/s) among the
    components of non-zero ``amplitude`` (all components without one, or if all are zero).

    Args:
        omega: Circular frequency (rad/s), a scalar or per component (3,).
        amplitude: Amplitudes per component (3,), or None.

    Returns:
        The ramp (s); inf for a frequency so small that its periods overflow.
    """
    w = np.broadcast_to(np.asarray(omega, dtype=float), (3,))
    if amplitude is not None:
        moving = np.asarray(amplitude, dtype=float) != 0
        if np.any(moving):
            w = w[moving]
    with np.errstate(over="ignore", divide="ignore"):  # inf: the parser says so
        return float(DEFAULT_RAMP_PERIODS * 2.0 * math.pi / np.min(w))


def _check_ramp(ramp: Any) -> float:
    ramp = float(ramp)
    if not (math.isfinite(ramp) and ramp >= 0.0):
        raise ValueError(f"ramp must be finite and >= 0 (s), got {ramp!r}")
    return ramp


def _ramped(kind: str, ramp: float, t: float, u0, v0, a0) -> np.ndarray:
    """Displacement, velocity or acceleration of ``r(t) u0(t)`` (product rule); u0, v0, a0
    are callables of the unramped motion, evaluated only when needed."""
    r, dr, ddr = ramp_factors(t, ramp)
    if kind == "displacement":
        return r * u0()
    if kind == "velocity":
        return dr * u0() + r * v0() if dr else r * v0()
    return ddr * u0() + 2.0 * dr * v0() + r * a0() if (dr or ddr) else r * a0()


class _RampedMotion:
    """The ramped displacement, velocity and acceleration of a motion given unramped by its
    ``_u0``, ``_v0``, ``_a0`` and its ``ramp`` duration (:func:`ramp_factors`)."""

    def _eval(self, kind: str, t: float) -> np.ndarray:
        if self.ramp <= 0.0 or t >= self.ramp:  # r = 1, r' = r'' = 0: the motion itself
            # (what _ramped gives there, bit for bit; called several times a time step)
            return (self._u0 if kind == "displacement" else
                    self._v0 if kind == "velocity" else self._a0)(t)
        return _ramped(kind, self.ramp, t, lambda: self._u0(t), lambda: self._v0(t),
                       lambda: self._a0(t))

    def displacement(self, t: float) -> np.ndarray:
        """Displacement (m), shape (3,)."""
        return self._eval("displacement", t)

    def velocity(self, t: float) -> np.ndarray:
        """Velocity (m/s), shape (3,)."""
        return self._eval("velocity", t)

    def acceleration(self, t: float) -> np.ndarray:
        """Acceleration (m/s^2), shape (3,)."""
        return self._eval("acceleration", t)

    def accelerations(self, times: np.ndarray) -> np.ndarray:
        """(n, 3) :meth:`acceleration` at each of ``times``, the same numbers (the motion
        after its ramp in one array expression; the ramp's rows one by one)."""
        times = np.asarray(times, float).reshape(-1)
        out = np.empty((times.size, 3))
        after = times >= self.ramp if self.ramp > 0.0 else np.ones(times.size, bool)
        if after.any():
            out[after] = self._a0_many(times[after])
        for i in np.flatnonzero(~after):
            out[i] = self.acceleration(float(times[i]))
        return out


def _sines(x: np.ndarray, fn) -> np.ndarray:
    """``fn`` (``math.sin`` or ``math.cos``) of each of ``x``: the scalar function, as the
    single-time methods call it, so the arrays hold the same numbers to the last bit
    (NumPy's vectorised sine rounds differently)."""
    return np.fromiter((fn(v) for v in x.ravel()), float, x.size).reshape(x.shape)


@dataclass(frozen=True, eq=False)
class HarmonicMotion(_RampedMotion):
    """Harmonic motion ``u_k(t) = r(t) A_k sin(omega_k t + phi_k)`` per component ``k``.

    ``r`` is the smooth ramp over ``ramp`` s (:func:`ramp_factors`); with ``ramp = 0`` (the
    default of this class; a case file's default is :func:`default_ramp`) the motion is not
    zero at ``t = 0`` unless every ``A_k sin(phi_k)`` is, and its velocity jumps there.

    Args:
        amplitude (array_like, shape (3,)): Amplitudes ``A`` (m).
        omega (float or array_like, shape (3,)): Circular frequencies (rad/s); a scalar applies to
            all components.
        phase (float or array_like, shape (3,)): Phases ``phi`` (rad), default 0.
        ramp (float): Duration (s) of the smooth start, >= 0; 0: none.
    """

    amplitude: np.ndarray
    omega: np.ndarray
    phase: np.ndarray = 0.0  # type: ignore[assignment]
    ramp: float = 0.0

    def __post_init__(self) -> None:
        for name in ("amplitude", "omega", "phase"):
            object.__setattr__(self, name, _frozen_array(getattr(self, name), (3,), name))
        object.__setattr__(self, "ramp", _check_ramp(self.ramp))

    def _u0(self, t: float) -> np.ndarray:
        return self.amplitude * np.sin(self.omega * t + self.phase)

    def _v0(self, t: float) -> np.ndarray:
        return self.amplitude * self.omega * np.cos(self.omega * t + self.phase)

    def _a0(self, t: float) -> np.ndarray:
        return -self.amplitude * self.omega**2 * np.sin(self.omega * t + self.phase)

    def _a0_many(self, times: np.ndarray) -> np.ndarray:
        return np.array([self._a0(t) for t in times]).reshape(-1, 3)

    def describe(self) -> dict:
        """JSON-serialisable description."""
        return {"type": "harmonic", "amplitude": self.amplitude.tolist(),
                "omega": self.omega.tolist(), "phase": self.phase.tolist(),
                "ramp": self.ramp}


@dataclass(frozen=True, eq=False)
class EllipseMotion(_RampedMotion):
    """Elliptic motion from the rest position: ``u = r(t) (a_s sin(w t) + a_c (cos(w t) - 1))``.

    ``r`` is the smooth ramp over ``ramp`` s (:func:`ramp_factors`; 0, the default of this
    class: none, then ``u(0) = 0`` but the velocity ``w a_s`` jumps at ``t = 0``). Case B of
    ``docs/theory.md`` §9 is ``axis_sin = (0, 0, 1e-3)``, ``axis_cos = (0, 5e-4, 0)``,
    ``ramp = 0``.

    Args:
        omega (float): Circular frequency ``w`` (rad/s).
        axis_sin, axis_cos (array_like, shape (3,)): Semi-axes (m) multiplying ``sin(w t)`` and
            ``cos(w t) - 1``.
        ramp (float): Duration (s) of the smooth start, >= 0; 0: none.
    """

    omega: float
    axis_sin: np.ndarray
    axis_cos: np.ndarray
    ramp: float = 0.0

    def __post_init__(self) -> None:
        omega = float(self.omega)
        if not math.isfinite(omega):
            raise ValueError("omega must be finite")
        object.__setattr__(self, "omega", omega)
        for name in ("axis_sin", "axis_cos"):
            object.__setattr__(self, name, _frozen_array(getattr(self, name), (3,), name))
        object.__setattr__(self, "ramp", _check_ramp(self.ramp))

    def _u0(self, t: float) -> np.ndarray:
        wt = self.omega * t
        return self.axis_sin * math.sin(wt) + self.axis_cos * (math.cos(wt) - 1.0)

    def _v0(self, t: float) -> np.ndarray:
        wt = self.omega * t
        return self.omega * (self.axis_sin * math.cos(wt) - self.axis_cos * math.sin(wt))

    def _a0(self, t: float) -> np.ndarray:
        wt = self.omega * t
        return -self.omega**2 * (self.axis_sin * math.sin(wt) + self.axis_cos * math.cos(wt))

    def _a0_many(self, times: np.ndarray) -> np.ndarray:
        wt = self.omega * times
        return -self.omega**2 * (self.axis_sin[None, :] * _sines(wt, math.sin)[:, None]
                                 + self.axis_cos[None, :] * _sines(wt, math.cos)[:, None])

    def describe(self) -> dict:
        """JSON-serialisable description."""
        return {"type": "ellipse", "omega": self.omega, "axis_sin": self.axis_sin.tolist(),
                "axis_cos": self.axis_cos.tolist(), "ramp": self.ramp}


@dataclass(frozen=True, eq=False)
class TableMotion:
    """Displacement through tabulated points: a C2 cubic spline (not-a-knot ends), held at
    the first and last rows outside the table (see the module docstring).

    The velocity and acceleration are the spline's first and second derivatives.

    Args:
        times (array_like, shape (n,)): Strictly increasing times (s), n >= 2.
        values (array_like, shape (n, 3)): Displacements (m) at those times.
        source (str or None): The file the table came from, for :meth:`describe`.
        hold (bool): The case accepts that the table ends before ``dynamics.t_end`` (held at its
            last row); evaluation holds the end values either way.
    """

    times: np.ndarray
    values: np.ndarray
    source: str | None = None
    hold: bool = False

    def __post_init__(self) -> None:
        times, values = check_table(self.times, self.values, 3)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "hold", bool(self.hold))
        object.__setattr__(self, "_spline", Spline(times, values))

    def displacement(self, t: float) -> np.ndarray:
        """Displacement (m), shape (3,): the spline, or the first/last row outside."""
        return self._spline(t)

    def velocity(self, t: float) -> np.ndarray:
        """Velocity (m/s): the spline's first derivative, 0 outside the table."""
        return self._spline(t, 1)

    def acceleration(self, t: float) -> np.ndarray:
        """Acceleration (m/s^2): the spline's second derivative, 0 outside the table."""
        return self._spline(t, 2)

    def describe(self) -> dict:
        """JSON-serialisable description (the data itself only when there is no file)."""
        out: dict = {"type": "table", "file": self.source, "rows": int(self.times.size),
                     "t_first": float(self.times[0]), "t_last": float(self.times[-1]),
                     "interpolation": "cubic spline, not-a-knot", "hold": self.hold}
        if self.source is None:
            out.update(times=self.times.tolist(), values=self.values.tolist())
        return out


@dataclass(frozen=True, eq=False)
class TimeFunction:
    """Dimensionless load factor ``f(t)``: constant 1, ``sin(omega t + phase)`` or a table.

    Build with :meth:`constant`, :meth:`harmonic` or :meth:`table`.

    Args:
        kind (str): ``"constant"``, ``"harmonic"`` or ``"table"``.
        omega (float): Circular frequency (rad/s), > 0 for ``harmonic``.
        phase (float): Phase (rad) for ``harmonic``.
        times, factors (ndarray or None): Table (s, -) for ``table``: C2 cubic spline (not-a-knot
            ends), constant outside.
        source (str or None): The file a table came from.
        hold (bool): ``table``: the case accepts that it ends before ``dynamics.t_end`` (held).
    """

    kind: str = "constant"
    omega: float = 0.0
    phase: float = 0.0
    times: np.ndarray | None = None
    factors: np.ndarray | None = None
    source: str | None = None
    hold: bool = False

    def __post_init__(self) -> None:
        if self.kind not in ("constant", "harmonic", "table"):
            raise ValueError(f"kind must be 'constant', 'harmonic' or 'table', got {self.kind!r}")
        if self.kind == "harmonic" and not (math.isfinite(self.omega) and self.omega > 0):
            raise ValueError(f"omega must be > 0 (rad/s), got {self.omega!r}")
        if not math.isfinite(self.phase):
            raise ValueError("phase must be finite")
        if self.kind == "table":
            times, factors = check_table(self.times, self.factors, None)
            object.__setattr__(self, "times", times)
            object.__setattr__(self, "factors", factors)
            object.__setattr__(self, "_spline", Spline(times, factors))
        object.__setattr__(self, "hold", bool(self.hold))

    @classmethod
    def constant(cls) -> TimeFunction:
        """The factor 1 at all times."""
        return cls()

    @classmethod
    def harmonic(cls, omega: float, phase: float = 0.0) -> TimeFunction:
        """``sin(omega t + phase)``, omega in rad/s, phase in rad."""
        return cls("harmonic", float(omega), float(phase))

    @classmethod
    def table(cls, times: Any, factors: Any, source: str | None = None,
              hold: bool = False) -> TimeFunction:
        """C2 cubic spline (not-a-knot) through ``(times, factors)``, constant outside."""
        return cls("table", times=times, factors=factors, source=source, hold=hold)

    def values_at(self, times: np.ndarray) -> np.ndarray:
        """:meth:`value` at each of ``times``, the same numbers."""
        times = np.asarray(times, float).reshape(-1)
        if self.kind == "harmonic":
            return _sines(self.omega * times + self.phase, math.sin)
        if self.kind == "table":
            return np.array([self.value(float(t)) for t in times])
        return np.ones(times.size)

    def value(self, t: float) -> float:
        """The factor at time ``t`` (s)."""
        if self.kind == "harmonic":
            return math.sin(self.omega * t + self.phase)
        if self.kind == "table":
            return float(self._spline(t))
        return 1.0

    def describe(self) -> dict:
        """JSON-serialisable description (table data only when there is no file)."""
        if self.kind == "harmonic":
            return {"type": "harmonic", "omega": self.omega, "phase": self.phase}
        if self.kind == "table":
            out: dict = {"type": "table", "file": self.source, "rows": int(self.times.size),
                         "interpolation": "cubic spline, not-a-knot", "hold": self.hold}
            if self.source is None:
                out.update(times=self.times.tolist(), factors=self.factors.tolist())
            return out
        return {"type": "constant"}


def read_motion_csv(path: str | os.PathLike, key: str = "file") -> TableMotion:
    """Read an anchor motion table from a CSV file with the header ``time,ux,uy,uz``.

    Args:
        path (path-like): CSV file: times (s) and displacements (m), one row per time, >= 2 rows,
            times strictly increasing; whitespace around cells is ignored; blank lines and lines
            starting with ``#`` are skipped.
        key (str): Key path reported in errors (the case reader passes e.g.
            ``anchors[1].motion.file``).

    Raises:
        cablefem.case.CaseError: Naming the file (its ``source``), the key and the line of every
            problem.
    """
    times, values = read_csv(path, ("time", "ux", "uy", "uz"), key)
    return TableMotion(times, values, source=str(path))


def read_factor_csv(path: str | os.PathLike, key: str = "file") -> TimeFunction:
    """Read a load-factor table from a CSV file with the header ``time,factor``.

    Same rules and errors as :func:`read_motion_csv`; times in s, factors dimensionless.

    Args:
        path: The CSV file.
        key: Key path reported in errors.

    Returns:
        A table :class:`TimeFunction`.

    Raises:
        cablefem.case.CaseError: Naming the file, the key and the line of every problem.
    """
    times, factors = read_csv(path, ("time", "factor"), key)
    return TimeFunction.table(times, factors[:, 0], source=str(path))


def accelerations(motion, times) -> np.ndarray:
    """(n, 3) acceleration of ``motion`` (a :class:`Motion`; None: at rest) at each of
    ``times``: its ``accelerations`` when it has one, else ``acceleration`` time by time."""
    times = np.asarray(times, float).reshape(-1)
    if motion is None:
        return np.zeros((times.size, 3))
    many = getattr(motion, "accelerations", None)
    if many is not None:
        return np.asarray(many(times), float).reshape(-1, 3)
    return np.array([np.asarray(motion.acceleration(float(t)), float) for t in times]
                    ).reshape(-1, 3)


def factors(law, times) -> np.ndarray:
    """A load's time law ``law`` (a :class:`TimeFunction` or an object with ``value(t)``)
    at each of ``times``."""
    many = getattr(law, "values_at", None)
    if many is not None:
        return np.asarray(many(times), float)
    return np.array([float(law.value(float(t))) for t in np.asarray(times).reshape(-1)])
