"""A run's histories in memory: rows of numbers appended as the run goes, kept in a float64
array that doubles its length when it fills.

A Python list of floats costs 32 bytes a number (the float object and the list's pointer),
a list of NumPy rows more than 100 bytes a row; a row buffer costs 8 bytes a number (16 while
it has just doubled), so that a long run's histories stay small: paper case B's run held 2.3
kB a step in lists, which for a three-hour sea state at 0.02 s (540 000 steps) is 1.2 GB
for two anchors, and a hundred times that for a network's 160.
"""

from __future__ import annotations

import numpy as np

__all__ = ["RowBuffer"]


class RowBuffer:
    """Rows of shape ``shape`` (``()``: single numbers) appended one at a time
    (:meth:`append`) or in blocks (:meth:`extend`). Indexing and ``len`` are those of
    :attr:`array`, the rows so far (a view: copy it to keep it past the next append).

    Args:
        shape: The shape of a row.
        rows: The first rows (an array of shape ``(n, *shape)``), copied.
    """

    def __init__(self, shape: tuple = (), rows=None) -> None:
        self.shape = tuple(shape)
        first = np.asarray(rows, float).reshape(-1, *self.shape) if rows is not None else None
        self._n = 0 if first is None else len(first)
        self._data = np.empty((max(64, 2 * self._n), *self.shape))
        if first is not None:
            self._data[:self._n] = first

    def _room(self, k: int) -> None:
        if self._n + k > len(self._data):
            bigger = np.empty((max(2 * len(self._data), self._n + k), *self.shape))
            bigger[:self._n] = self._data[:self._n]
            self._data = bigger

    def append(self, row) -> None:
        """Add one row."""
        self._room(1)
        self._data[self._n] = row
        self._n += 1

    def extend(self, rows) -> None:
        """Add the rows of ``rows`` (shape ``(k, *shape)``)."""
        rows = np.asarray(rows, float).reshape(-1, *self.shape)
        self._room(len(rows))
        self._data[self._n:self._n + len(rows)] = rows
        self._n += len(rows)

    @property
    def array(self) -> np.ndarray:
        """The rows so far, ``(n, *shape)`` (a view of the buffer)."""
        return self._data[:self._n]

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, index):
        return self.array[index]
