"""``dampers.csv``: the one owner of its schema and its reader (docs/outputs.md).

One row per output time and damper of a single cable (``damper0``, ``damper1``, ... in the
order of the case's ``[[dampers]]``, the names of their kinks in ``kinks.csv``): the
damper's force on the cable, and the stroke and velocity it acts on, measured from the
static state (the damper is installed on the cable at rest). Written with
:mod:`cablefem.io.anchorcsv`'s writer (numbers that round-trip, blocks handed to the
operating system at once, truncated to the checkpoint on a restart).

With a ``direction`` ``d`` the scalar columns are signed along it: ``stroke = d·Δu``,
``velocity = d·v`` and ``force = c velocity + k stroke``, the damper's own force (positive:
it resists the node's motion along ``+d``; its force on the cable is ``-force d``). Without
one the damper acts in the plane normal to the cable, whose orientation turns with it: the
scalar columns are the magnitudes of the vectors (``force = |F|``, ``stroke = |P Δu|``,
``velocity = |P v|``), never negative.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

__all__ = ["DAMPER_COLUMNS", "VECTOR_COLUMNS", "QUANTITIES", "read", "name"]

#: the columns of ``dampers.csv``
DAMPER_COLUMNS = ["time", "damper", "Fx", "Fy", "Fz", "force",
                  "stroke_x", "stroke_y", "stroke_z", "stroke",
                  "velocity_x", "velocity_y", "velocity_z", "velocity"]
#: the vector columns of each quantity (force on the cable, stroke and velocity vectors)
VECTOR_COLUMNS = {"force": ["Fx", "Fy", "Fz"],
                  "stroke": ["stroke_x", "stroke_y", "stroke_z"],
                  "velocity": ["velocity_x", "velocity_y", "velocity_z"]}
#: the scalar quantities summary.json's ``dampers`` entries give the peak and RMS of
QUANTITIES = ("force", "stroke", "velocity")


def name(i: int) -> str:
    """The name of a single cable's ``i``-th damper (that of its kink too)."""
    return f"damper{i}"


def read(path: str | Path) -> dict[str, dict[str, np.ndarray]]:
    """damper -> column -> float array over its rows (dampers in the order of their first
    row). ``ValueError`` naming ``file:line`` for a missing column, a row with another
    number of fields, a cell that is not a number or an empty or decreasing time."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    rows: dict[str, list[list[float]]] = {}
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        head = [h.strip() for h in next(reader, [])]
        missing = [c for c in DAMPER_COLUMNS if c not in head]
        if missing:
            raise ValueError(f"{path}:1: header lacks column(s) {', '.join(missing)}")
        num = [c for c in DAMPER_COLUMNS if c != "damper"]
        idx = [head.index(c) for c in num]
        for row in reader:
            line = reader.line_num
            if not any(f.strip() for f in row):
                continue
            if len(row) != len(head):
                raise ValueError(f"{path}:{line}: {len(row)} fields, the header has "
                                 f"{len(head)}")
            vals = []
            for c, i in zip(num, idx):
                s = row[i].strip()
                try:
                    vals.append(float(s) if s else math.nan)
                except ValueError:
                    raise ValueError(f"{path}:{line}: column '{c}': not a number: "
                                     f"{s!r}") from None
            if not math.isfinite(vals[0]):
                raise ValueError(f"{path}:{line}: column 'time': empty or not finite")
            who = rows.setdefault(row[head.index("damper")].strip(), [])
            if who and vals[0] <= who[-1][0]:
                raise ValueError(f"{path}:{line}: column 'time': not after the damper's "
                                 f"previous row ({vals[0]!r} after {who[-1][0]!r})")
            who.append(vals)
    return {d: {c: a[:, k] for k, c in enumerate(num)}
            for d, a in ((d, np.array(r, float).reshape(-1, len(num)))
                         for d, r in rows.items())}
