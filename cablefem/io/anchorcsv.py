"""``anchors.csv``: the one owner of its schema, writing, reading and truncation."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from mpi4py import MPI


class AnchorCSV:
    """``anchors.csv``, one row per output time and anchor (rank 0 writes; others no-op)."""

    def __init__(self, path: Path, columns: list[str], comm: MPI.Comm = MPI.COMM_WORLD,
                 append: bool = False):
        self.columns = columns
        self.fh = None
        if comm.rank == 0:
            resume = append and Path(path).is_file()
            self.fh = open(path, "a" if resume else "w", newline="")
            if not resume:
                self.fh.write(",".join(columns) + "\n")
            self.fh.flush()

    def write(self, rows: list[dict]) -> None:
        if self.fh is None:
            return
        cols = self.columns
        self.fh.write("".join(",".join(_cell(row.get(c, "")) for c in cols) + "\n"
                              for row in rows))
        self.fh.flush()

    def close(self) -> None:
        if self.fh is not None:
            self.fh.close()
            self.fh = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _cell(v) -> str:
    if isinstance(v, str):
        return v if not any(ch in v for ch in ',"\n') else '"' + v.replace('"', '""') + '"'
    if isinstance(v, (bool, np.bool_)):
        return str(int(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    x = float(v)
    return "" if not math.isfinite(x) else repr(x)
