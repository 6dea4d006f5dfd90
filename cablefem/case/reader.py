"""Typed getters that read a TOML table and collect every problem under its key path."""

from __future__ import annotations

import difflib
import numbers
import os
from pathlib import Path
from typing import Any

import numpy as np

from cablefem.case.keys import REQUIRED
from cablefem.errors import CaseError
from cablefem.validation import bounds_text, is_sequence, number_problem, show

# ---------------------------------------------------------------------------------------------
# Reading: typed getters that collect problems under key paths.

_UNSET = object()


class Reader:
    """One table of the case: unknown keys are reported on creation, getters type-check.

    Args:
        data: The table's keys and values.
        path: Its key path (``""`` for the top level).
        doc: Its keys' :class:`~cablefem.case.keys.KeyDoc` and
            :class:`~cablefem.case.keys.TableDoc`.
        problems: The list every problem is appended to, as ``(key path, message)``.
    """

    def __init__(self, data: dict, path: str, doc: dict, problems: list) -> None:
        self.data, self.path, self.doc, self.problems = data, path, doc, problems
        known = list(doc)
        lower = {k.lower(): k for k in known}
        for key in data:
            if key in doc:
                continue
            close = difflib.get_close_matches(str(key).lower(), list(lower), n=1, cutoff=0.6)
            hint = (f"; did you mean '{lower[close[0]]}'?" if close
                    else f" (known keys: {', '.join(known)})")
            problems.append((self.key(key), f"unknown key '{key}'{hint}"))

    def key(self, name: str) -> str:
        return f"{self.path}.{name}" if self.path else str(name)

    def add(self, name: str, message: str) -> None:
        self.problems.append((self.key(name), message))

    def has(self, name: str) -> bool:
        return name in self.data

    def raw(self, name: str) -> tuple[Any, bool]:
        """(value, given); a missing required key is reported and returns (None, False)."""
        if name in self.data:
            return self.data[name], True
        default = self.doc[name].default
        if default is REQUIRED:
            self.add(name, "missing required key")
            return None, False
        return default, False

    def _number(self, value: Any, key: str, unit: str, **bounds) -> float | None:
        problem = number_problem(value, unit, **bounds)
        if problem is not None:
            self.problems.append((key, problem))
            return None
        return float(value)

    def number(self, name: str, **bounds) -> float | None:
        value, given = self.raw(name)
        if not given:
            return None if value is None else float(value)
        return self._number(value, self.key(name), self.doc[name].unit, **bounds)

    def integer(self, name: str, ge: int = 1, le: int | None = None) -> int | None:
        value, given = self.raw(name)
        if not given:
            return value
        if not isinstance(value, numbers.Integral) or isinstance(value, (bool, np.bool_)):
            self.add(name, f"expected an integer, got {show(value)}")
            return None
        if value < ge or (le is not None and value > le):
            self.add(name, f"must be {bounds_text(ge=ge, le=le)}, got {value}")
            return None
        return int(value)

    def string(self, name: str, choices: tuple[str, ...] | None = None,
               path: bool = False) -> str | None:
        """A string (one of ``choices`` if given); ``path`` also accepts os.PathLike."""
        value, given = self.raw(name)
        if not given:
            return value
        if path and isinstance(value, os.PathLike):
            value = os.fspath(value)
        if not isinstance(value, str):
            self.add(name, f"expected a string, got {show(value)}")
            return None
        if choices is not None and value not in choices:
            close = difflib.get_close_matches(value, choices, n=1)
            hint = f"; did you mean '{close[0]}'?" if close else ""
            self.add(name, f"must be one of {', '.join(repr(c) for c in choices)}, "
                           f"got {value!r}{hint}")
            return None
        return value

    def boolean(self, name: str) -> bool | None:
        value, given = self.raw(name)
        if given and not isinstance(value, (bool, np.bool_)):
            self.add(name, f"expected a boolean (true or false), got {show(value)}")
            return None
        return None if value is None else bool(value)

    def boolean_or(self, name: str, word: str) -> bool | str | None:
        """A boolean, or the string ``word`` (e.g. "auto")."""
        value, given = self.raw(name)
        if given and value == word:
            return word
        if given and not isinstance(value, (bool, np.bool_)):
            self.add(name, f"expected true, false or {word!r}, got {show(value)}")
            return None
        return value if value == word else (None if value is None else bool(value))

    def numbers(self, name: str, count: int, nonzero: bool = False, value: Any = _UNSET,
                key: str | None = None, **bounds) -> np.ndarray | None:
        """A list of ``count`` numbers; ``value``/``key`` override the raw value/key path."""
        given = True
        if value is _UNSET:
            value, given = self.raw(name)
        if not given:
            return None if value is None else np.array(value, dtype=float)
        key = key or self.key(name)
        if not is_sequence(value) or len(value) != count:
            self.problems.append((key, f"expected {count} numbers, got {show(value)}"))
            return None
        items = [self._number(v, f"{key}[{i}]", self.doc[name].unit, **bounds)
                 for i, v in enumerate(value)]
        if any(v is None for v in items):
            return None
        array = np.array(items, dtype=float)
        if nonzero and not np.any(array):
            self.problems.append((key, "must be a non-zero vector"))
            return None
        return array

    def number_list(self, name: str, min_count: int = 2, **bounds) -> np.ndarray | None:
        """A list of at least ``min_count`` numbers (any length above)."""
        value, given = self.raw(name)
        if not given:
            return None if value is None else np.array(value, dtype=float)
        if not is_sequence(value) or len(value) < min_count:
            self.add(name, f"expected a list of at least {min_count} numbers, got "
                           f"{show(value)}")
            return None
        return self.numbers(name, len(value), value=value, **bounds)

    def vector(self, name: str, unit_vector: bool = False) -> np.ndarray | None:
        """A 3-vector; normalised (and checked non-zero) if ``unit_vector``."""
        array = self.numbers(name, 3, nonzero=unit_vector)
        return array / np.linalg.norm(array) if unit_vector and array is not None else array

    def number_or_vector(self, name: str, **bounds) -> float | np.ndarray | None:
        value, given = self.raw(name)
        if given and is_sequence(value):
            return self.numbers(name, 3, value=value, **bounds)
        return self.number(name, **bounds)

    def table(self, name: str) -> Reader | None:
        value, given = self.raw(name)
        if not given:
            return None
        if not isinstance(value, dict):
            self.add(name, f"expected a table, got {show(value)}")
            return None
        return Reader(value, self.key(name), self.doc[name].keys, self.problems)

    def tables(self, name: str) -> list[Reader]:
        value, given = self.raw(name)
        if not given:
            return []
        if not is_sequence(value) or not all(isinstance(v, dict) for v in value):
            self.add(name, f"expected an array of tables ([[{name}]]), got {show(value)}")
            return []
        return [Reader(v, f"{self.key(name)}[{i}]", self.doc[name].keys, self.problems)
                for i, v in enumerate(value)]

    def csv(self, name: str, reader: Any, base_dir: Path) -> Any:
        """Read the CSV named by key ``name`` (relative to ``base_dir``) with ``reader``."""
        filename = self.string(name, path=True)
        if filename is None:
            return None
        try:
            return reader(base_dir / filename, key=self.key(name))
        except CaseError as exc:
            self.problems.extend((k, f"in '{exc.source}': {m}") for k, m in exc.problems)
            return None

    def require(self, name: str, what: str) -> bool:
        """Report ``name`` missing (it is required for ``what``); True if present."""
        if name not in self.data:
            self.add(name, f"missing required key for {what}")
        return name in self.data

    def only(self, allowed: tuple[str, ...], what: str, kind_key: str = "type") -> None:
        """Report every known key but ``kind_key`` that does not apply to ``what``."""
        for name in self.data:
            if name != kind_key and name in self.doc and name not in allowed:
                keys = ", ".join(allowed) or "none"
                self.add(name, f"does not apply to {what} (its keys: {keys})")
