"""The checks of input values, shared by the case parser (:mod:`cablefem.case`) and the
Python constructors (:func:`cablefem.create_cable`): one wording of every message.

Each check returns a message (``None`` when the value is fine); the caller files it under
its key path, e.g. ``("geometry.sag_ratio", "must be > 0 and <= 10, got -1.0")``.
Pure Python/NumPy.
"""

from __future__ import annotations

import math
import numbers
import operator
from typing import Any

import numpy as np

__all__ = ["show", "is_number", "is_sequence", "bounds_text", "number_problem",
           "vector_problem"]

_COMPARE = {"gt": operator.gt, "ge": operator.ge, "lt": operator.lt, "le": operator.le}
_SYMBOL = {"gt": ">", "ge": ">=", "lt": "<", "le": "<="}


def show(value: Any) -> str:
    """Describe a raw value for a type error, e.g. "string 'abc'"."""
    if value is None:
        return "None"
    if isinstance(value, (bool, np.bool_)):
        return f"boolean {str(bool(value)).lower()}"
    if isinstance(value, str):
        return f"string {value!r}"
    if isinstance(value, numbers.Integral):
        return f"integer {value}"
    if isinstance(value, numbers.Real):
        return f"number {value!r}"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, (list, tuple, np.ndarray)):
        return f"an array of {len(value)}"
    return type(value).__name__


def is_number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def is_sequence(value: Any) -> bool:
    return isinstance(value, (list, tuple)) or (isinstance(value, np.ndarray) and value.ndim == 1)


def bounds_text(**bounds: float | None) -> str:
    """E.g. '> 0 and <= 10' (floats in %g, integers as they are)."""
    return " and ".join(f"{_SYMBOL[k]} {v:g}" if isinstance(v, float) else f"{_SYMBOL[k]} {v}"
                        for k, v in bounds.items() if v is not None)


def number_problem(value: Any, unit: str = "", **bounds: float | None) -> str | None:
    """What is wrong with ``value`` as a finite number within ``bounds`` (gt, ge, lt, le)."""
    if not is_number(value):
        return f"expected a number, got {show(value)}"
    value = float(value)
    if not math.isfinite(value):
        return f"must be finite, got {value!r}"
    if not all(_COMPARE[k](value, b) for k, b in bounds.items() if b is not None):
        unit_text = f" ({unit})" if unit and unit != "-" else ""
        return f"must be {bounds_text(**bounds)}{unit_text}, got {value!r}"
    return None


def vector_problem(value: Any, count: int = 3, nonzero: bool = False) -> str | None:
    """What is wrong with ``value`` as ``count`` finite numbers (non-zero if asked)."""
    if not is_sequence(value) or len(value) != count:
        return f"expected {count} numbers, got {show(value)}"
    bad = [number_problem(v) for v in value]
    if any(bad):
        return next(b for b in bad if b)
    if nonzero and not np.any(np.asarray(value, dtype=float)):
        return "must be a non-zero vector"
    return None
