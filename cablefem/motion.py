"""Prescribed anchor motions and time functions of loads.

Pure Python/NumPy: no dolfinx import. An anchor motion is the displacement (m) of an anchor
from its static position, with its velocity (m/s) and acceleration (m/s^2) in closed form, so
that a time integrator can impose all three consistently. A :class:`TimeFunction` is the
dimensionless factor that multiplies a load.

Tables (:class:`TableMotion`, ``TimeFunction.table``) interpolate linearly and are held
constant outside their time range. Their velocity is the slope of the current segment (taken
on the right at a breakpoint) and their acceleration is zero: the velocity jumps at every
breakpoint, so a table should sample a smooth motion finely enough (many points per period of
the highest frequency of interest) for those jumps to stay small.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

__all__ = [
    "Motion", "HarmonicMotion", "EllipseMotion", "TableMotion", "TimeFunction",
    "read_motion_csv", "read_factor_csv",
]


@runtime_checkable
class Motion(Protocol):
    """A prescribed anchor displacement ``u(t)`` from the static position (m)."""

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


def _check_table(times: Any, values: Any, columns: int | None) -> tuple[np.ndarray, np.ndarray]:
    """Validate a table: >= 2 strictly increasing finite times, matching finite values."""
    times = np.array(times, dtype=float)
    values = np.array(values, dtype=float)
    if times.ndim != 1 or times.size < 2:
        raise ValueError(f"times: expected a 1D array of >= 2 entries, got shape {times.shape}")
    expected = (times.size,) if columns is None else (times.size, columns)
    if values.shape != expected:
        raise ValueError(f"values: expected shape {expected}, got {values.shape}")
    if not (np.all(np.isfinite(times)) and np.all(np.isfinite(values))):
        raise ValueError("times and values must be finite")
    if np.any(np.diff(times) <= 0):
        raise ValueError("times must be strictly increasing")
    times.flags.writeable = False
    values.flags.writeable = False
    return times, values


def _segment(times: np.ndarray, t: float) -> int | None:
    """Index ``i`` with ``times[i] <= t < times[i+1]``, or None outside the table."""
    i = int(np.searchsorted(times, t, side="right")) - 1
    return i if 0 <= i < times.size - 1 else None


@dataclass(frozen=True, eq=False)
class HarmonicMotion:
    """Harmonic motion ``u_k(t) = A_k sin(omega_k t + phi_k)`` per component ``k``.

    Not zero at ``t = 0`` unless every ``A_k sin(phi_k)`` is.

    Parameters
    ----------
    amplitude : array_like, shape (3,)
        Amplitudes ``A`` (m).
    omega : float or array_like, shape (3,)
        Circular frequencies (rad/s); a scalar applies to all components.
    phase : float or array_like, shape (3,)
        Phases ``phi`` (rad), default 0.
    """

    amplitude: np.ndarray
    omega: np.ndarray
    phase: np.ndarray = 0.0  # type: ignore[assignment]

    def __post_init__(self) -> None:
        for name in ("amplitude", "omega", "phase"):
            object.__setattr__(self, name, _frozen_array(getattr(self, name), (3,), name))

    def displacement(self, t: float) -> np.ndarray:
        """Displacement (m), shape (3,)."""
        return self.amplitude * np.sin(self.omega * t + self.phase)

    def velocity(self, t: float) -> np.ndarray:
        """Velocity (m/s), shape (3,)."""
        return self.amplitude * self.omega * np.cos(self.omega * t + self.phase)

    def acceleration(self, t: float) -> np.ndarray:
        """Acceleration (m/s^2), shape (3,)."""
        return -self.amplitude * self.omega**2 * np.sin(self.omega * t + self.phase)

    def describe(self) -> dict:
        """JSON-serialisable description."""
        return {"type": "harmonic", "amplitude": self.amplitude.tolist(),
                "omega": self.omega.tolist(), "phase": self.phase.tolist()}


@dataclass(frozen=True, eq=False)
class EllipseMotion:
    """Elliptic motion starting at rest position: ``u = a_s sin(w t) + a_c (cos(w t) - 1)``.

    ``u(0) = 0``. Case B of ``docs/theory.md`` §9 is ``axis_sin = (0, 0, 1e-3)``,
    ``axis_cos = (0, 5e-4, 0)``.

    Parameters
    ----------
    omega : float
        Circular frequency ``w`` (rad/s).
    axis_sin, axis_cos : array_like, shape (3,)
        Semi-axes (m) multiplying ``sin(w t)`` and ``cos(w t) - 1``.
    """

    omega: float
    axis_sin: np.ndarray
    axis_cos: np.ndarray

    def __post_init__(self) -> None:
        omega = float(self.omega)
        if not math.isfinite(omega):
            raise ValueError("omega must be finite")
        object.__setattr__(self, "omega", omega)
        for name in ("axis_sin", "axis_cos"):
            object.__setattr__(self, name, _frozen_array(getattr(self, name), (3,), name))

    def displacement(self, t: float) -> np.ndarray:
        """Displacement (m), shape (3,)."""
        wt = self.omega * t
        return self.axis_sin * math.sin(wt) + self.axis_cos * (math.cos(wt) - 1.0)

    def velocity(self, t: float) -> np.ndarray:
        """Velocity (m/s), shape (3,)."""
        wt = self.omega * t
        return self.omega * (self.axis_sin * math.cos(wt) - self.axis_cos * math.sin(wt))

    def acceleration(self, t: float) -> np.ndarray:
        """Acceleration (m/s^2), shape (3,)."""
        wt = self.omega * t
        return -self.omega**2 * (self.axis_sin * math.sin(wt) + self.axis_cos * math.cos(wt))

    def describe(self) -> dict:
        """JSON-serialisable description."""
        return {"type": "ellipse", "omega": self.omega, "axis_sin": self.axis_sin.tolist(),
                "axis_cos": self.axis_cos.tolist()}


@dataclass(frozen=True, eq=False)
class TableMotion:
    """Piecewise-linear displacement through tabulated points, constant outside the table.

    The velocity is the slope of the current segment and the acceleration is zero (see the
    module docstring: sample finely enough).

    Parameters
    ----------
    times : array_like, shape (n,)
        Strictly increasing times (s), n >= 2.
    values : array_like, shape (n, 3)
        Displacements (m) at those times.
    source : str or None
        The file the table came from, for :meth:`describe`.
    """

    times: np.ndarray
    values: np.ndarray
    source: str | None = None

    def __post_init__(self) -> None:
        times, values = _check_table(self.times, self.values, 3)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "values", values)

    def displacement(self, t: float) -> np.ndarray:
        """Displacement (m), shape (3,)."""
        return np.array([np.interp(t, self.times, self.values[:, k]) for k in range(3)])

    def velocity(self, t: float) -> np.ndarray:
        """Velocity (m/s): slope of the segment ``[t_i, t_i+1)`` holding ``t``, else 0."""
        i = _segment(self.times, t)
        if i is None:
            return np.zeros(3)
        return (self.values[i + 1] - self.values[i]) / (self.times[i + 1] - self.times[i])

    def acceleration(self, t: float) -> np.ndarray:
        """Acceleration (m/s^2): zero (piecewise-linear displacement)."""
        return np.zeros(3)

    def describe(self) -> dict:
        """JSON-serialisable description (the data itself only when there is no file)."""
        out: dict = {"type": "table", "file": self.source, "rows": int(self.times.size),
                     "t_first": float(self.times[0]), "t_last": float(self.times[-1])}
        if self.source is None:
            out.update(times=self.times.tolist(), values=self.values.tolist())
        return out


@dataclass(frozen=True, eq=False)
class TimeFunction:
    """Dimensionless load factor ``f(t)``: constant 1, ``sin(omega t + phase)`` or a table.

    Build with :meth:`constant`, :meth:`harmonic` or :meth:`table`.

    Parameters
    ----------
    kind : {"constant", "harmonic", "table"}
    omega : float
        Circular frequency (rad/s), > 0 for ``harmonic``.
    phase : float
        Phase (rad) for ``harmonic``.
    times, factors : ndarray or None
        Table (s, -) for ``table``: piecewise linear, constant outside.
    source : str or None
        The file a table came from.
    """

    kind: str = "constant"
    omega: float = 0.0
    phase: float = 0.0
    times: np.ndarray | None = None
    factors: np.ndarray | None = None
    source: str | None = None

    def __post_init__(self) -> None:
        if self.kind not in ("constant", "harmonic", "table"):
            raise ValueError(f"kind must be 'constant', 'harmonic' or 'table', got {self.kind!r}")
        if self.kind == "harmonic" and not (math.isfinite(self.omega) and self.omega > 0):
            raise ValueError(f"omega must be > 0 (rad/s), got {self.omega!r}")
        if not math.isfinite(self.phase):
            raise ValueError("phase must be finite")
        if self.kind == "table":
            times, factors = _check_table(self.times, self.factors, None)
            object.__setattr__(self, "times", times)
            object.__setattr__(self, "factors", factors)

    @classmethod
    def constant(cls) -> TimeFunction:
        """The factor 1 at all times."""
        return cls()

    @classmethod
    def harmonic(cls, omega: float, phase: float = 0.0) -> TimeFunction:
        """``sin(omega t + phase)``, omega in rad/s, phase in rad."""
        return cls("harmonic", float(omega), float(phase))

    @classmethod
    def table(cls, times: Any, factors: Any, source: str | None = None) -> TimeFunction:
        """Piecewise-linear factor through ``(times, factors)``, constant outside."""
        return cls("table", times=times, factors=factors, source=source)

    def value(self, t: float) -> float:
        """The factor at time ``t`` (s)."""
        if self.kind == "harmonic":
            return math.sin(self.omega * t + self.phase)
        if self.kind == "table":
            return float(np.interp(t, self.times, self.factors))
        return 1.0

    def describe(self) -> dict:
        """JSON-serialisable description (table data only when there is no file)."""
        if self.kind == "harmonic":
            return {"type": "harmonic", "omega": self.omega, "phase": self.phase}
        if self.kind == "table":
            out: dict = {"type": "table", "file": self.source, "rows": int(self.times.size)}
            if self.source is None:
                out.update(times=self.times.tolist(), factors=self.factors.tolist())
            return out
        return {"type": "constant"}


_MAX_REPORTED = 10  # problems reported per CSV file; the rest are counted


def _read_csv(path: str | os.PathLike, columns: tuple[str, ...],
              key: str) -> tuple[np.ndarray, np.ndarray]:
    """Read a numeric CSV with the header ``columns``; return (first column, other columns).

    Blank lines and lines starting with ``#`` are skipped. Every problem names its line.
    """
    from cablefem.case import CaseError  # case.py imports this module: import at call time

    path = Path(path)
    problems: list[tuple[str, str]] = []

    def fail(message: str) -> CaseError:
        return CaseError([(key, message)], source=str(path))

    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise fail(f"cannot read the file: {getattr(exc, 'strerror', None) or exc}") from None
    lines = [(n, line.strip()) for n, line in enumerate(text.splitlines(), start=1)]
    lines = [(n, line) for n, line in lines if line and not line.startswith("#")]
    header = ",".join(columns)
    if not lines:
        raise fail(f"the file is empty; expected the header line '{header}'")
    n0, first = lines[0]
    if [c.strip().lower() for c in first.split(",")] != list(columns):
        raise fail(f"line {n0}: expected the header '{header}', got '{first}'")
    rows, row_lines = [], []
    for n, line in lines[1:]:
        cells = [c.strip() for c in line.split(",")]
        if len(cells) != len(columns):
            problems.append((key, f"line {n}: expected {len(columns)} columns, got {len(cells)}"))
            continue
        row = []
        for name, cell in zip(columns, cells):
            try:
                value = float(cell)
            except ValueError:
                problems.append((key, f"line {n}: column '{name}': expected a number, "
                                      f"got '{cell}'"))
                break
            if not math.isfinite(value):
                problems.append((key, f"line {n}: column '{name}': must be finite, got '{cell}'"))
                break
            row.append(value)
        else:
            if rows and row[0] <= rows[-1][0]:
                problems.append((key, f"line {n}: times must be strictly increasing "
                                      f"({row[0]!r} after {rows[-1][0]!r} on line "
                                      f"{row_lines[-1]})"))
            rows.append(row)
            row_lines.append(n)
    if not problems and len(rows) < 2:
        problems.append((key, f"expected at least 2 data rows after the header, got {len(rows)}"))
    if problems:
        extra = len(problems) - _MAX_REPORTED
        problems = problems[:_MAX_REPORTED]
        if extra > 0:
            problems.append((key, f"... and {extra} more problems in this file"))
        raise CaseError(problems, source=str(path))
    data = np.array(rows)
    return data[:, 0], data[:, 1:]


def read_motion_csv(path: str | os.PathLike, key: str = "file") -> TableMotion:
    """Read an anchor motion table from a CSV file with the header ``time,ux,uy,uz``.

    Parameters
    ----------
    path : path-like
        CSV file: times (s) and displacements (m), one row per time, >= 2 rows, times
        strictly increasing; whitespace around cells is ignored; blank lines and lines
        starting with ``#`` are skipped.
    key : str
        Key path reported in errors (the case reader passes e.g. ``anchors[1].motion.file``).

    Raises
    ------
    cablefem.case.CaseError
        Naming the file (its ``source``), the key and the line of every problem.
    """
    times, values = _read_csv(path, ("time", "ux", "uy", "uz"), key)
    return TableMotion(times, values, source=str(path))


def read_factor_csv(path: str | os.PathLike, key: str = "file") -> TimeFunction:
    """Read a load-factor table from a CSV file with the header ``time,factor``.

    Same rules and errors as :func:`read_motion_csv`; times in s, factors dimensionless.
    """
    times, factors = _read_csv(path, ("time", "factor"), key)
    return TimeFunction.table(times, factors[:, 0], source=str(path))
