"""``kinks.csv`` and the kinks' summary: the moment at every interior kink of a run
(:mod:`cablefem.kinks`), one row per kink and output time, beside ``anchors.csv``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cablefem.app.report import steady_state_stats
from cablefem.app.rowbuffer import RowBuffer
from cablefem.io import anchorcsv
from cablefem.kinks import KINK_COLUMNS, KinkMoments
from cablefem.rod_kinks import rod_kink_moments

__all__ = ["KinkOutput", "KinkHistory"]


class KinkOutput:
    """Records the kinks' columns at each output time (collective: :meth:`add` reads the
    model's state) and writes them to ``kinks.csv`` in blocks; :meth:`summary` gives the
    per-kink entries of ``summary.json``. Nothing is written for a model without kinks."""

    FLUSH_ROWS = 256

    def __init__(self, model, outdir: Path, omega: float | None,
                 resume_after: float | None = None):
        self.model = model
        self.moments = KinkMoments(model, omega)
        self.kinks = self.moments.kinks
        self.beam = model.is_beam
        # the history: per column a row of every kink at each output time (row buffers:
        # 8 bytes a number, one append a column and time)
        n = len(self.kinks)
        self.cols: dict[str, RowBuffer] = {c: RowBuffer((n,)) for c in KINK_COLUMNS[3:]}
        self.times = RowBuffer()
        self.static = self._columns() if self.kinks else None  # model.u: the static state
        self.csv = None
        self._pending = []
        if not self.kinks:
            return
        self.csv = anchorcsv.open_series(model.comm, outdir / "kinks.csv", KINK_COLUMNS,
                                         resume_after, self._load)

    def _columns(self, t: float = 0.0) -> dict[str, np.ndarray]:
        cols = self.moments.measure(t)
        if self.beam:  # the rod resolves the kink: its own moment at the node
            cols = {k: np.full(len(self.kinks), np.nan) for k in cols}
            from cablefem.rod_network import network_rod_kink_moments  # a network rod's only

            cols["moment"] = (network_rod_kink_moments(self.model, self.kinks)
                              if self.model.is_network else
                              rod_kink_moments(self.model, self.kinks))
            cols["valid"] = np.ones(len(self.kinks), dtype=int)
        return cols

    def _load(self, path: Path) -> None:
        """The rows written before a restart (every rank reads them: small)."""
        index = {k.name: i for i, k in enumerate(self.kinks)}
        times, rows = [], {c: [] for c in KINK_COLUMNS[3:]}
        for row in anchorcsv.read_rows(self.model.comm, path):
            i = index.get(row["kink"])
            if i is None:
                continue
            if i == 0:  # a new time: a row of every kink
                times.append(float(row["time"]))
                for c in rows:
                    rows[c].append(np.full(len(self.kinks), np.nan))
            for c in rows:
                rows[c][-1][i] = float(row[c]) if row[c] else np.nan
        self.times = RowBuffer((), times)
        n = len(self.kinks)
        self.cols = {c: RowBuffer((n,), np.reshape(v, (-1, n))) for c, v in rows.items()}

    def add(self, t: float) -> None:
        """Record the kinks at ``t`` (collective): a rod's moments now; a string's state,
        its columns computed for the block at :meth:`flush` (one vectorised evaluation)."""
        if not self.kinks:
            return
        self.times.append(t)
        if self.beam:
            self._pending.append((t, self._columns(t)))
        else:
            self._pending.append((t, self.moments.state(t)))
        if len(self._pending) >= self.FLUSH_ROWS:
            self.flush()

    def flush(self) -> None:
        """The pending rows' columns into the history and ``kinks.csv``."""
        if not self._pending:
            return
        if self.beam:
            rows = self._pending
        else:
            cols = self.moments.columns_of([st for _, st in self._pending])
            rows = [(t, {c: v[j] for c, v in cols.items()})
                    for j, (t, _) in enumerate(self._pending)]
        for _, cols in rows:
            for c in KINK_COLUMNS[3:]:
                self.cols[c].append(cols[c])
        if self.csv is not None:
            labels = {"kink": [k.name for k in self.kinks], "s": [k.s for k in self.kinks]}
            self.csv.write(anchorcsv.stacked_rows(rows, labels, KINK_COLUMNS[3:]))
        self._pending = []

    def close(self) -> None:
        self.flush()
        if self.csv is not None:
            self.csv.close()

    def history(self) -> KinkHistory:
        """What was recorded (this run's rows and a resumed run's), for the reports."""
        return KinkHistory(list(self.kinks), self.static, self.times.array.copy(),
                           {k.name: {c: buf.array[:, i] for c, buf in self.cols.items()}
                            for i, k in enumerate(self.kinks)})

    def summary(self, start: float | None = None) -> dict:
        """:meth:`KinkHistory.summary` of what was recorded."""
        return self.history().summary(start)


@dataclass
class KinkHistory:
    """The kinks' recorded columns: the kinks, their static columns, the output times and
    per kink the rows of each column (``KINK_COLUMNS[3:]``)."""

    kinks: list
    static: dict | None
    times: np.ndarray
    rows: dict[str, dict[str, np.ndarray]]

    def summary(self, start: float | None = None) -> dict:
        """Per kink: its station (a network's: its node and section), the static moment,
        tension, angle and layer length, the fraction of valid rows and the steady-state
        peak and RMS of the moment (from ``start``, s; default: the last third)."""
        out = {}
        times = np.array(self.times)
        for i, k in enumerate(self.kinks):
            rows = {c: np.array(v, float) for c, v in self.rows[k.name].items()}
            # a single cable's kink by its station, a network's by its node and section
            entry = ({"s": k.s} if k.section is None else {"node": k.node,
                                                           "section": k.section})
            if k.anchor is not None:  # at a support: a pinned anchor's
                entry["anchor"] = k.anchor
            entry["static_valid"] = bool(self.static["valid"][i])
            for key, col in (("static_moment", "moment"),
                             ("static_moment_layer", "moment_layer"),
                             ("static_tension", "tension"),
                             ("static_delta", "delta"), ("layer_length", "layer_length")):
                if np.isfinite(self.static[col][i]):  # the rod has a moment only
                    entry[key] = float(self.static[col][i])
            if times.size:
                entry["valid_fraction"] = float(np.mean(rows["valid"] == 1))
            if times.size > 1:
                entry["steady_state_moment"] = steady_state_stats(times, rows["moment"],
                                                                 start=start)
            out[k.name] = entry
        return out
