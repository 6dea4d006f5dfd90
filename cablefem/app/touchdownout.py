"""``touchdown.csv`` and its summary: where a cable on the seabed leaves it, at every output
time (a case with ``[seabed]``; docs/seabed.md). The touchdown moves with the floater and
its excursion along the line is what the line's fatigue at the touchdown zone depends on.
The touchdown here is the penalty contact's end (cablefem.seabed.touchdown), which lies
about 1.048 sqrt(H/k) beyond the rigid seabed's touchdown; the rigid equivalent is in the
static summary only (docs/seabed.md)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from cablefem.app.kinkout import KinkOutput
from cablefem.app.rowbuffer import RowBuffer
from cablefem.io import anchorcsv

__all__ = ["TOUCHDOWN_COLUMNS", "TouchdownOutput", "TouchdownRows"]

#: the columns of ``touchdown.csv``: a single cable's ``line`` is "cable" and ``s`` its
#: touchdown's stress-free station; a network's rows name the cable group (``s`` empty),
#: one row per touchdown point of the group (a group lying wholly on the seabed: one row
#: without a point). A line that does not touch the seabed has a row with grounded length 0
#: and no point (single cable) or no row (network).
TOUCHDOWN_COLUMNS = ["time", "line", "s", "x", "y", "z", "grounded_length"]


@dataclass
class TouchdownRows:
    """The rows of ``touchdown.csv`` recorded in a run: each row's line (``lines``) and its
    numbers (``values``, (n, 6): time, s, x, y, z, grounded length; a row buffer while the
    run goes: 8 bytes a number, not a tuple of Python floats)."""

    lines: list = field(default_factory=list)
    values: RowBuffer = field(default_factory=lambda: RowBuffer((6,)))

    def __len__(self) -> int:
        return len(self.lines)

    def extend(self, rows: list[tuple]) -> None:
        """Add rows ``(time, line, s, x, y, z, grounded length)``."""
        self.lines += [r[1] for r in rows]
        self.values.extend([(r[0],) + tuple(r[2:]) for r in rows])

    def of(self, line: str) -> np.ndarray:
        """The numbers of ``line``'s rows, (k, 6)."""
        return self.values.array[np.array(self.lines, dtype=object) == line]


class TouchdownOutput:
    """Records the touchdown at each output time (collective: :meth:`add` gathers the
    nodes) and writes ``touchdown.csv`` in blocks; :meth:`summary` gives the range of the
    touchdown's station and of the grounded length. Nothing without a seabed."""

    FLUSH_ROWS = 256

    def __init__(self, model, outdir: Path, resume_after: float | None = None):
        self.model = model
        self.active = getattr(model.case, "seabed", None) is not None
        self.network = model.is_network
        self.rows = TouchdownRows()  # the rows so far
        self._pending: list[tuple] = []
        self.csv = None
        if not self.active:
            return
        self.csv = anchorcsv.open_series(model.comm, outdir / "touchdown.csv",
                                         TOUCHDOWN_COLUMNS, resume_after, self._load)

    def _load(self, path: Path) -> None:
        """The rows written before a restart (every rank reads them: small)."""
        self.rows.extend([(float(r["time"]), r["line"]) + tuple(
            float(r[c]) if r[c] else np.nan for c in TOUCHDOWN_COLUMNS[2:])
            for r in anchorcsv.read_rows(self.model.comm, path)])

    def _network_rows(self, t: float) -> list[tuple]:
        """A network's rows at the model's current state, time ``t`` (collective): per
        cable group that touches, one row per touchdown point."""
        from cablefem.seabed import network_contact

        nan3 = (np.nan, np.nan, np.nan)
        out = []
        for group, c in (network_contact(self.model) or {}).items():
            points = c["touchdown"] or [nan3]
            out += [(t, group, np.nan) + tuple(p) + (c["grounded_length"],) for p in points]
        return out

    def _rows(self, states: list[tuple]) -> list[tuple]:
        """A single cable's rows of a block of (time, positions) (collective: rank 0
        evaluates them at once, :func:`cablefem.seabed.touchdowns`, and sends them)."""
        from cablefem.seabed import touchdowns

        rows = None
        if self.model.comm.rank == 0:
            nan3 = (np.nan, np.nan, np.nan)
            tds = touchdowns(self.model, np.stack([r for _, r in states]))
            rows = [(t, "cable", np.nan) + nan3 + (0.0,) if td is None else
                    (t, "cable", td["s"]) + tuple(td["position"]) + (td["grounded_length"],)
                    for (t, _), td in zip(states, tds)]
        return self.model.comm.bcast(rows, root=0) if self.model.comm.size > 1 else rows

    def add(self, t: float) -> None:
        """Record the touchdown at ``t`` (collective): a network's rows now; a single
        cable's node positions, its rows evaluated for the block at :meth:`flush`."""
        if not self.active:
            return
        from cablefem.seabed import positions

        if self.network:
            rows = self._network_rows(t)
            self.rows.extend(rows)
            self._pending += rows
        else:
            self._pending.append((t, positions(self.model)))
        if len(self._pending) >= self.FLUSH_ROWS:
            self.flush()

    def flush(self) -> None:
        if not self._pending or self.csv is None:
            return
        if not self.network:
            self._pending = self._rows(self._pending)
            self.rows.extend(self._pending)
        cols = list(zip(*self._pending))
        self.csv.write({c: list(v) for c, v in zip(TOUCHDOWN_COLUMNS, cols)})
        self._pending = []

    close = KinkOutput.close  # flush, then close the file

    def summary(self) -> dict:
        """Per line: the range of its grounded length over the output times and, for a
        single cable, of the touchdown's station ``s`` (its excursion along the line) and
        the number of output times at which the line did not touch the seabed."""
        out = {}
        for line in dict.fromkeys(self.rows.lines):
            rows = self.rows.of(line)
            g = rows[:, 5]
            entry = {"grounded_length_min": float(np.min(g)),
                     "grounded_length_max": float(np.max(g))}
            if not self.network:
                s = rows[:, 1]
                ok = np.isfinite(s)
                entry["times_off_the_seabed"] = int(np.count_nonzero(g == 0.0))
                if np.any(ok):
                    entry.update({"s_min": float(np.min(s[ok])), "s_max": float(np.max(s[ok])),
                                  "excursion": float(np.ptp(s[ok]))})
            out[line] = entry
        return out
