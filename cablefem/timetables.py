"""Time tables: a history given as rows of times and values (an anchor motion, a load
factor, a fluid velocity), checked, read from CSV and interpolated.

Pure NumPy/SciPy: no dolfinx import. A table is a C2 cubic spline through its rows with
not-a-knot end conditions (:class:`Spline`), held at its first and last values outside its
time range; :func:`table_resolution` says what a time step cannot resolve of it;
:func:`read_csv` reads one from a CSV file and names the line of every problem.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from cablefem.errors import CaseError

__all__ = ["check_table", "Spline", "table_resolution", "read_csv",
           "ACCELERATION_STEP_FRACTION"]

#: a table's acceleration may change by at most this fraction of its range within one time
#: step; above it the case warns. For ``A sin(omega t)`` the range is ``2 A omega^2`` and the
#: largest change in a step ``A omega^3 dt``: the limit is ``omega dt <= 0.2``, about 31
#: steps per period
ACCELERATION_STEP_FRACTION = 0.1


def check_table(times: Any, values: Any, columns: int | None) -> tuple[np.ndarray, np.ndarray]:
    """Validate a table: >= 2 strictly increasing finite times, matching finite values.

    Args:
        times: (n,) times (s).
        values: (n,) values, or (n, columns).
        columns: Number of columns of ``values``, or None for a 1-D table.

    Returns:
        ``(times, values)`` as read-only float arrays.

    Raises:
        ValueError: Naming what is wrong.
    """
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


class Spline:
    """C2 cubic spline (not-a-knot ends) through a table, held constant outside it.

    Args:
        times: (n,) strictly increasing times (s), n >= 2.
        values: (n,) or (n, k) values at those times.

    Calling it with ``(t, nu)`` gives the ``nu``-th time derivative at ``t`` (s).
    """

    def __init__(self, times: np.ndarray, values: np.ndarray) -> None:
        from scipy.interpolate import CubicSpline

        self.t0, self.t1 = float(times[0]), float(times[-1])
        self.first, self.last = values[0].copy(), values[-1].copy()
        self.spline = CubicSpline(times, values, axis=0, bc_type="not-a-knot")

    def __call__(self, t: float, nu: int = 0) -> np.ndarray:
        if t < self.t0 or t > self.t1:
            edge = self.first if t < self.t0 else self.last
            return edge.copy() if nu == 0 else np.zeros_like(edge)
        return np.asarray(self.spline(t, nu))


def table_resolution(times: np.ndarray, values: np.ndarray, dt: float) -> list[str]:
    """What a time step ``dt`` (s) cannot resolve of a table's spline: rows closer than
    ``dt`` (what happens between two steps is lost), and an acceleration (second derivative,
    piecewise linear in the spline) that changes within one step by more than
    :data:`ACCELERATION_STEP_FRACTION` of its range over the table. Messages, [] if none.

    Args:
        times: (n,) times of the rows (s).
        values: (n,) or (n, k) values at the rows.
        dt: The time step (s).
    """
    times = np.asarray(times, float)
    values = np.asarray(values, float).reshape(times.size, -1)
    out = []
    h = np.diff(times)
    if np.min(h) < dt * (1 - 1e-9):
        i = int(np.argmin(h))
        n_close = int(np.count_nonzero(h < dt * (1 - 1e-9)))
        out.append(f"{n_close} of its {h.size} row intervals are shorter than dynamics.dt = "
                   f"{dt:g} s (the shortest {h[i]:g} s, after t = {times[i]:g} s): what the "
                   "table does between two time steps is lost; resample it at >= dt or "
                   "reduce dt")
    if times.size >= 3:
        spline = Spline(times, values).spline
        acc = spline(times, 2).reshape(times.size, -1)  # the second derivative at the rows
        span = np.ptp(acc, axis=0)
        # on a segment the acceleration is linear: its change over one step is at most the
        # largest slope (jerk) times dt (exact when the step lies in one segment), and at
        # most its range
        change = np.minimum(np.abs(np.diff(acc, axis=0)) / h[:, None] * dt, span)
        with np.errstate(divide="ignore", invalid="ignore"):
            frac = np.where(span > 0, change / span, 0.0)
        worst = float(np.max(frac))
        if worst > ACCELERATION_STEP_FRACTION:
            i, k = np.unravel_index(int(np.argmax(frac)), frac.shape)
            jerk = np.max(np.abs(np.diff(acc, axis=0)) / h[:, None], axis=0)
            with np.errstate(divide="ignore", invalid="ignore"):
                dt_ok = float(np.min(np.where(jerk > 0, ACCELERATION_STEP_FRACTION * span
                                              / jerk, np.inf)))
            col = f" (column {k + 1})" if values.shape[1] > 1 else ""
            out.append(f"its spline's acceleration{col} changes by {100 * worst:.3g} % of its "
                       f"range within one time step (dt = {dt:g} s, between t = "
                       f"{times[i]:g} and {times[i + 1]:g} s; limit "
                       f"{100 * ACCELERATION_STEP_FRACTION:g} %): the integrator cannot "
                       f"follow it; use dt <= {dt_ok:.3g} s or a smoother table")
    return out


_MAX_REPORTED = 10  # problems reported per CSV file; the rest are counted


def read_csv(path: str | os.PathLike, columns: tuple[str, ...],
              key: str) -> tuple[np.ndarray, np.ndarray]:
    """Read a numeric CSV with the header ``columns``; return (first column, other columns).

    Blank lines and lines starting with ``#`` are skipped. Every problem names its line.

    Args:
        path: The CSV file.
        columns: The header's column names, the first the time.
        key: Key path reported in errors.

    Raises:
        CaseError: Naming the file, the key and the line of every problem (at most 10,
            then their count).
    """


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
