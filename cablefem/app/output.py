"""The files of a run as it goes, written as the integrator steps: ``anchors.csv`` rows
(their moment columns computed in vectorised blocks by :class:`cablefem.moments.
AnchorMoments`), ``kinks.csv``, ``touchdown.csv`` and, at field times, the string's fields
and the composite moment field (``string.xdmf``; ``moments.xdmf`` from
:mod:`cablefem.composite`). It computes no physics of its own; :meth:`RunOutput.histories`
hands what was recorded to the reports. Restart-safe: see ``docs/outputs.md``."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cablefem.app.damperout import DamperHistory, DamperOutput
from cablefem.app.kinkout import KinkHistory, KinkOutput
from cablefem.app.rowbuffer import RowBuffer
from cablefem.app.touchdownout import TouchdownOutput, TouchdownRows
from cablefem.asymptotics import wrap_azimuth
from cablefem.cable import CableModel
from cablefem.composite import composite_for
from cablefem.io import anchorcsv
from cablefem.io.anchorcsv import FORCE_COLUMNS, INTEGER_COLUMNS
from cablefem.io.series import (
    MomentsWriter,
    OutputError,
    StringWriter,
)
from cablefem.moments import MOMENT_COLUMNS, AnchorMoments
from cablefem.rodcolumns import rod_moment_columns

__all__ = ["RunOutput", "Histories", "rod_moment_columns"]

log = logging.getLogger(__name__)


@dataclass
class Histories:
    """What a run's output recorded (this run's rows after a resumed run's), for the
    reports: the output times, per anchor the forces (n_t, 3), per clamped anchor the
    moment columns, why each row of this process is invalid and, with a virtual hinge,
    which rows fell outside the tension range the layer's law follows; the kinks' columns
    and the touchdown's summary (None without a seabed or rows)."""

    times: np.ndarray
    forces: dict[str, np.ndarray]
    moments: dict[str, dict[str, np.ndarray]]
    reasons: dict[str, list[str]]
    fallback: dict[str, list[bool]]
    kinks: KinkHistory
    touchdown: dict | None
    #: the dampers' columns (dampers.csv; none recorded: no names)
    dampers: DamperHistory | None = None
    #: the touchdown's rows (touchdown.csv's: :class:`cablefem.app.touchdownout.
    #: TouchdownRows`)
    touchdown_rows: TouchdownRows | None = None


def _column(name: str, rows: RowBuffer) -> np.ndarray:
    """A moment column's history: ``valid`` as the integers the moment columns give (a
    resumed run's rows, read back, included), the others as floats."""
    if name in INTEGER_COLUMNS and np.all(np.isfinite(rows.array)):
        return rows.array.astype(np.int64)
    return rows.array.copy()


class RunOutput:
    """Writes the output: anchor rows (buffered, their moment columns computed in vectorised
    batches) and, at field times, the string fields and the composite moment field."""

    FLUSH_ROWS = 256
    #: the waiting composite fields' states are kept up to this size, then written
    WAITING_BYTES = 64 * 2**20

    def __init__(self, model: CableModel, outdir: Path, columns: AnchorMoments, kind: str,
                 static_forces: np.ndarray, resume_after: float | None = None,
                 frames: dict | None = None):
        """``columns``: the moment columns from the anchor forces; ``kind``: the model's
        (:func:`cablefem.app.kinds.model_kind`); ``resume_after``: continue the files of an
        earlier run after that time (``anchors.csv`` is truncated to it); ``frames``: the
        number of frames of each series up to then (``"string"``, ``"moments"``), from the
        checkpoint. Open it in the static state (collective)."""
        self.model = model
        self.outdir = outdir
        self.resume_after = resume_after
        self.clamped = [a for a in model.anchors if a.kind == "clamped"]
        #: the moment columns from the anchor forces (the numbers; this class writes them)
        self.moment_columns = columns
        self.beam = model.is_beam  # a rod: moments from the model, no composite field
        # the histories, as the run goes (row buffers: 8 bytes a number)
        self.rod: dict[str, RowBuffer] = {a.name: RowBuffer((3,)) for a in self.clamped}
        self.times = RowBuffer()
        self.forces: dict[str, RowBuffer] = {a.name: RowBuffer((3,)) for a in model.anchors}
        self.columns: dict[str, dict[str, RowBuffer]] = {
            a.name: {k: RowBuffer() for k in MOMENT_COLUMNS} for a in self.clamped}
        #: per clamped anchor: why each row of this process is invalid ("" when valid)
        self.reasons: dict[str, list[str]] = {}
        #: per clamped anchor with a virtual hinge: the rows outside the tension range the
        #: layer's law follows (cablefem.hinge; this process's rows, not a resumed run's)
        self.fallback: dict[str, list[bool]] = {}
        self._names = [a.name for a in model.anchors]
        self._index = {name: j for j, name in enumerate(self._names)}
        # resumed: the rows up to the checkpoint, without a kill's rest
        self.csv = anchorcsv.open_series(model.comm, outdir / "anchors.csv",
                                         anchorcsv.columns(bool(self.clamped)), resume_after,
                                         self._load_history)
        frames = frames or {}
        self.kinkout = KinkOutput(model, outdir, columns.omega, resume_after)  # kinks.csv
        self.touchdown = TouchdownOutput(model, outdir, resume_after)  # touchdown.csv
        self.dampers = DamperOutput(model, outdir, resume_after)  # dampers.csv
        self.string = StringWriter(model, outdir, resume_after, frames.get("string"))
        self._pending = 0  # rows recorded, not yet written
        self._last: dict = {}  # the moment columns of the last written block, per anchor
        self._last_time = None  # and its last time
        #: composite fields waiting for their row's layers: (row index, field state)
        self._waiting: list[tuple[int, dict]] = []
        self.last_fields_time = None
        self.moments = None
        #: the composite moment field (None: nothing clamped or kinked, or a rod)
        self.composite = composite_for(kind, model, columns, static_forces,
                                       self.kinkout.moments, self.kinkout.static)
        if self.composite is not None:
            self.moments = MomentsWriter(outdir, self.composite.points0, model.comm,
                                         resume_after, frames.get("moments"),
                                         cells=self.composite.cells)

    def _load_history(self, path: Path) -> None:
        """Histories written before a restart (rank 0 reads ``anchors.csv``, already
        truncated to the checkpoint; all ranks get them). OutputError if it is not the file
        this run writes."""
        comm = self.model.comm
        data = error = None
        if comm.rank == 0:
            try:
                data = anchorcsv.read(path, FORCE_COLUMNS + (MOMENT_COLUMNS if self.clamped
                                                             else []), empty_ok=True)
                counts = {name: data[name]["time"].size if name in data else 0
                          for name in self._names}
                if len(set(counts.values())) > 1 or set(data) - set(counts):
                    raise ValueError(f"{path}: not the rows of this run's anchors "
                                     f"{self._names} at the same times (rows: {counts})")
            except ValueError as err:
                error = str(err)
        data, error = comm.bcast((data, error), root=0)
        if error is not None:
            raise OutputError(error)
        if not data:
            return
        self.times = RowBuffer((), data[self._names[0]]["time"])
        for name in self._names:
            d = data[name]
            self.forces[name] = RowBuffer((3,), np.column_stack([d[c] for c in FORCE_COLUMNS]))
            if name in self.rod:  # a rod's own moment: the moment vector it wrote
                self.rod[name] = RowBuffer((3,), np.column_stack([d[c] for c in
                                                                 ("Mx", "My", "Mz")]))
            if name in self.columns:
                self.columns[name] = {k: RowBuffer((), d[k]) for k in MOMENT_COLUMNS}

    def _moments(self, anc, times: np.ndarray, N: np.ndarray) -> dict:
        """The moment columns of clamped anchor ``anc`` (:class:`AnchorMoments`)."""
        return self.moment_columns.anchor(anc.name, times, N)

    def add(self, t: float, forces: np.ndarray) -> None:
        """Record the anchor forces at ``t`` (written in batches)."""
        self.times.append(t)
        F = np.array(forces, float)  # a copy: the rows below are views of it
        for name, N in zip(self._names, F):
            self.forces[name].append(N[:3])
            if self.beam and name in self.rod:  # a rod's own moment
                self.rod[name].append(N[3:6])
        self.kinkout.add(t)
        self.touchdown.add(t)
        self.dampers.add(t)
        self._pending += 1
        if self._pending >= self.FLUSH_ROWS:
            self.flush()

    def flush(self) -> None:
        """Compute the moment columns of the pending rows (vectorised per anchor) and
        write them to anchors.csv as one block."""
        self.kinkout.flush()
        self.touchdown.flush()
        self.dampers.flush()
        n = self._pending
        if n == 0:
            return
        times = self.times[-n:].copy()
        N = np.array([self.forces[name][-n:] for name in self._names])  # (anchor, time, 3)
        if self.model.hinges:  # rows outside the layer law's range
            for name, flags in self.model.hinges.fallback(N).items():
                self.fallback.setdefault(name, []).extend(flags.tolist())
        A = len(self._names)
        table = {"time": np.repeat(times, A), "anchor": self._names * n,
                 "tension": np.linalg.norm(N, axis=2).T.ravel()}
        for k, c in enumerate(FORCE_COLUMNS):
            table[c] = N[:, :, k].T.ravel()
        self._last = {}
        if self.clamped:
            cols = {k: np.full((n, A), np.nan) for k in MOMENT_COLUMNS}
            for anc in self.clamped:
                res = self._moments(anc, times, N[self._index[anc.name]])
                if self.beam:
                    res = rod_moment_columns(res, np.array(self.rod[anc.name][-n:]),
                                             anc.direction)
                # psi0 on the branch of the history's first row (its static state)
                held = self.columns[anc.name]["psi0"]
                res["psi0"] = wrap_azimuth(res["psi0"], held[0] if len(held) else
                                           res["psi0"][0])
                self.reasons.setdefault(anc.name, []).extend(res["invalid_reason"].tolist())
                for k in MOMENT_COLUMNS:
                    self.columns[anc.name][k].extend(res[k])
                    cols[k][:, self._index[anc.name]] = res[k]
                self._last[anc.name] = res
            table.update({k: v.ravel() for k, v in cols.items()})
        self._last_time = self.times[-1]
        self.csv.write(table)
        self._pending = 0
        first = len(self.times) - n  # the block's first row
        for row, state in self._waiting:  # the composite fields that waited for this block
            j = row - first
            self._write_moments(state, {c.name: {k: v[j:j + 1] for k, v in
                                                 self._last[c.name].items()}
                                        for c in self.clamped})
        self._waiting = []

    def fields(self, t: float, forces: np.ndarray) -> None:
        """Write the string fields at ``t`` and the composite moment field (collective).
        When ``t``'s row is pending, the composite field waits for the row's layers, which
        the next :meth:`flush` computes with its batch (its state is kept till then)."""
        self.string.write(t)
        self.last_fields_time = t
        if self.moments is None:  # nothing clamped or kinked; a beam's is in string.xdmf
            return
        state = self.composite.state(t, forces)
        if self._pending and self.times[-1] == t:  # its layers come with the batch
            self._waiting.append((len(self.times) - 1, state))
            # a state holds at most the nodes' positions and accelerations (on rank 0):
            # the same count on every rank
            if len(self._waiting) * 48 * len(self.model.geometry.points) > self.WAITING_BYTES:
                self.flush()
            return
        if self._waiting:  # the frames in time order
            self.flush()
        if self._last_time == t and self._last:
            layers = {c.name: {k: v[-1:] for k, v in self._last[c.name].items()}
                      for c in self.clamped}
        else:  # a time without a row (a failed step's state)
            idx = self._index
            layers = {c.name: self._moments(c, np.array([t]), forces[idx[c.name]][None, :])
                      for c in self.clamped}
        self._write_moments(state, layers)

    def _write_moments(self, state: dict, layers: dict) -> None:
        pos, kap, mom = self.composite.finish(state, layers)
        self.moments.write(state["t"], pos, kap, mom, self.composite.stations)

    def checkpoint(self) -> dict:
        """Make every output complete and listed as it is now (at checkpoints); the number
        of frames of each series (rank 0's), for the checkpoint."""
        self.flush()
        self.string.checkpoint()
        if self.moments is not None:
            self.moments.checkpoint()
        return {"string": self.string.frames,
                "moments": self.moments.frames if self.moments is not None else 0}

    def close(self) -> None:
        try:
            self.flush()
        finally:
            self.kinkout.close()
            self.touchdown.close()
            self.dampers.close()
            self.string.close()
            self.csv.close()
            if self.moments is not None:
                self.moments.close()

    def histories(self) -> Histories:
        """What was recorded, as arrays (every rank); call it after :meth:`close`."""
        td = self.touchdown
        return Histories(
            self.times.array.copy(),
            {k: v.array.copy() for k, v in self.forces.items()},
            {name: {k: _column(k, v) for k, v in cols.items()}
             for name, cols in self.columns.items()},
            self.reasons, self.fallback, self.kinkout.history(),
            td.summary() if td.active and len(td.rows) else None, self.dampers.history(),
            td.rows if td.active else None)
