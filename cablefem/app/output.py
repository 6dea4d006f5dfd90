"""The files of a run as it goes: ``anchors.csv`` rows (their moment columns computed in
vectorised blocks) and, at field times, the string's fields and the composite moment field
(``string.xdmf``, ``moments.xdmf``). Restart-safe: see ``docs/outputs.md``."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from cablefem import asymptotics
from cablefem.app.kinkout import KinkOutput
from cablefem.app.touchdownout import TouchdownOutput
from cablefem.cable import CableModel
from cablefem.io import anchorcsv
from cablefem.io.anchorcsv import FORCE_COLUMNS
from cablefem.io.series import (
    MomentsWriter,
    OutputError,
    StringWriter,
)
from cablefem.moments import (
    MOMENT_COLUMNS,
    AnchorMoments,
    composite_field,
)

log = logging.getLogger(__name__)


def rod_moment_columns(res: dict, M: np.ndarray, direction: np.ndarray) -> dict:
    """A beam run's moment columns: the rod's own moment ``M`` (n, 3) at the anchor replaces
    the asymptotic one; ``psi0`` is the azimuth of the rod's bending plane; ``delta``,
    ``layer_length`` and ``moment_layer`` stay those of the closed form evaluated with the
    beam's anchor force (what the asymptotics would say with the beam's force)."""
    out = dict(res)
    mag = np.linalg.norm(M, axis=1)
    out.update({"moment": mag, "Mx": M[:, 0], "My": M[:, 1], "Mz": M[:, 2]})
    f1, f2 = asymptotics.anchor_frame(direction)
    with np.errstate(invalid="ignore", divide="ignore"):
        tp = np.cross(M / mag[:, None], direction)  # in the bending plane, normal to c
        out["psi0"] = np.where(mag > 0, np.arctan2(tp @ f2, tp @ f1), np.nan)
    out["valid"] = np.isfinite(mag).astype(int)
    # the rod resolves the layer itself: the asymptotic error estimate does not apply
    out["error_estimate"] = np.full(mag.shape, np.nan)
    return out


class RunOutput:
    """Writes the output: anchor rows (buffered, their moment columns computed in vectorised
    batches) and, at field times, the string fields and the composite moment field."""

    FLUSH_ROWS = 256

    def __init__(self, model: CableModel, outdir: Path, form: str, omega: float | None,
                 static_forces: np.ndarray, resume_after: float | None = None,
                 frames: dict | None = None):
        """``resume_after``: continue the files of an earlier run after that time
        (``anchors.csv`` is truncated to it); ``frames``: the number of frames of each
        series up to then (``"string"``, ``"moments"``), from the checkpoint."""
        self.model = model
        self.outdir = outdir
        self.form = form
        self.omega = omega
        self.resume_after = resume_after
        self.clamped = [a for a in model.anchors if a.kind == "clamped"]
        #: the moment columns from the anchor forces (the numbers; this class writes them)
        self.moment_columns = AnchorMoments.from_model(model, omega, form)
        self.network = model.is_network
        self.beam = model.is_beam  # a rod: moments from the model, no composite field
        self.rod: dict[str, list[np.ndarray]] = {a.name: [] for a in self.clamped}
        sec = model.case.section  # the single cable's (a network: per anchor, below)
        self.EI, self.EA, self.m = sec.EI, sec.EA, sec.mass
        self.times: list[float] = []
        self.forces: dict[str, list[np.ndarray]] = {a.name: [] for a in model.anchors}
        self.columns: dict[str, dict[str, list]] = {
            a.name: {k: [] for k in MOMENT_COLUMNS} for a in self.clamped}
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
        self.kinkout = KinkOutput(model, outdir, omega, resume_after)  # kinks.csv
        self.touchdown = TouchdownOutput(model, outdir, resume_after)  # touchdown.csv
        self.string = StringWriter(model, outdir, resume_after, frames.get("string"))
        self._pending = 0  # rows recorded, not yet written
        self._last: dict = {}  # the moment columns of the last written block, per anchor
        self._last_time = None  # and its last time
        self.last_fields_time = None
        self.moments = None
        # the composite field's stations, from the static layers (resolve half the static
        # layer length: tension can rise in dynamics); fixed for the run and its restarts
        self.stations = None
        #: a single string's interior kinks: their layers join the composite field
        self.kinked = bool(self.kinkout.kinks) and not (self.beam or self.network)
        #: a network's kinks: each a segment of its own in the composite field
        self.net_kinks = bool(self.kinkout.kinks) and self.network and not self.beam
        if (self.clamped or self.net_kinks) and self.network:
            self._segments_setup(static_forces)
        elif (self.clamped or self.kinked) and not self.beam:
            idx = {a.name: i for i, a in enumerate(model.anchors)}
            ells = [0.5 * self._moments(c, np.zeros(1), static_forces[idx[c.name]][None, :]
                                        )["layer_length"][0] for c in self.clamped]
            s_a = [model.geometry.stations[c.node] for c in self.clamped]
            if self.kinked:  # model.u is the static state here
                s_a += [k.s for k in self.kinkout.kinks]
                ells += list(0.5 * self.kinkout.static["layer_length"])
            self.stations = asymptotics.graded_stations(
                model.length, s_a,
                [e if np.isfinite(e) and e > 0 else np.nan for e in ells])
            r = self._nodal_positions()  # model.u is the static state here
            pts = None
            if model.comm.rank == 0:
                pts = np.column_stack([np.interp(self.stations, model.geometry.stations,
                                                 r[:, k]) for k in range(3)])
            self.points0 = model.comm.bcast(pts, root=0)
        if self.stations is not None:
            cells = None
            if self.network:  # one polyline per clamped anchor and per kink
                offs = np.cumsum([0] + [s.size for s in self.sigmas[:-1]])
                cells = np.concatenate([np.column_stack([np.arange(s.size - 1),
                                                         np.arange(1, s.size)]) + off
                                        for s, off in zip(self.sigmas, offs)])
            self.moments = MomentsWriter(outdir, self.points0, model.comm, resume_after,
                                         frames.get("moments"), cells=cells)

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
        self.times = data[self._names[0]]["time"].tolist()
        for name in self._names:
            d = data[name]
            self.forces[name] = list(np.column_stack([d[c] for c in FORCE_COLUMNS]))
            if name in self.rod:  # a rod's own moment: the moment vector it wrote
                self.rod[name] = list(np.column_stack([d[c] for c in ("Mx", "My", "Mz")]))
            if name in self.columns:
                self.columns[name] = {k: d[k].tolist() for k in MOMENT_COLUMNS}

    def load_at(self, t: float, section=None) -> np.ndarray:
        """Distributed load per stress-free length at ``t`` on a cable of ``section`` (the
        single cable's by default), weight and buoyancy included
        (:meth:`cablefem.moments.AnchorMoments.load_at`)."""
        section = self.model.case.section if section is None else section
        fluid = getattr(self.model.case, "fluid", None)
        D = None if fluid is None else fluid.diameter_on(section)
        return self.moment_columns.load_at(t, section.mass, D)

    def _moments(self, anc, times: np.ndarray, N: np.ndarray) -> dict:
        """The moment columns of clamped anchor ``anc`` (:class:`AnchorMoments`)."""
        return self.moment_columns.anchor(anc.name, times, N)

    # a network: one short line per clamped anchor in moments.xdmf -----------------------
    def _segments_setup(self, static_forces: np.ndarray) -> None:
        idx = {a.name: i for i, a in enumerate(self.model.anchors)}
        self.sigmas = []
        for c in self.clamped:
            ell = self._moments(c, np.zeros(1), static_forces[idx[c.name]][None, :]
                                )["layer_length"][0]
            ell = ell if np.isfinite(ell) else 1e-3 * self.model.length
            self.sigmas.append(asymptotics.graded_stations(10 * ell, [0.0], [0.5 * ell],
                                                           n_span=5))
        if self.net_kinks:  # model.u is the static state here
            # a kink's segment: 10 static layer lengths each side of the node, graded
            # towards it, signed (< 0 back along the element before)
            for ell in self.kinkout.static["layer_length"]:
                ell = ell if np.isfinite(ell) and ell > 0 else 1e-3 * self.model.length
                half = asymptotics.graded_stations(10 * ell, [0.0], [0.5 * ell], n_span=5)
                self.sigmas.append(np.concatenate([-half[:0:-1], half]))
        self.points0 = self._segments(0.0, static_forces, None)[0]
        self.stations = np.concatenate(self.sigmas)

    def _segments(self, t: float, forces: np.ndarray, layers: dict | None):
        """Points, curvature and moment along each clamped anchor's layer at ``t``."""
        idx = {a.name: i for i, a in enumerate(self.model.anchors)}
        pts, kap, mom = [], [], []
        for c, sig in zip(self.clamped, self.sigmas):
            N = forces[idx[c.name]]
            tang = N / np.linalg.norm(N) if np.linalg.norm(N) > 0 else c.direction
            r0 = c.position + (c.motion.displacement(t) if c.motion is not None else 0.0)
            pts.append(r0 + sig[:, None] * tang[None, :])
            if layers is None:
                continue
            lay = layers[c.name]
            if lay["slack"][0]:
                k = np.zeros((sig.size, 3))
            else:
                k = asymptotics.curvature_profile(sig, lay["delta"][0], lay["layer_length"][0]
                                                  )[:, None] * np.nan_to_num(lay["normal"][0])
            kap.append(k)
            mom.append(c.section.EI * k)
        if self.net_kinks:
            self._kink_segments(t, pts, kap, mom, layers is not None)
        out = [np.concatenate(pts)]
        if layers is not None:
            out += [np.concatenate(kap), np.concatenate(mom)]
        return out

    def _kink_segments(self, t: float, pts: list, kap: list, mom: list,
                       fields: bool) -> None:
        """Append each network kink's segment at time ``t``, the current state
        (collective): the polyline from the node back along the element before and on
        along the one after, with the clamped layer of half the kink angle on each side
        about e- x e+ (docs/kinks.md)."""
        km = self.kinkout.moments
        r = km.positions()
        c = km.measure(t, r) if fields else None
        d = np.diff(r, axis=1)
        e = d / np.linalg.norm(d, axis=2)[..., None]
        for i, sig in enumerate(self.sigmas[len(self.clamped):]):
            side = np.where(sig[:, None] < 0, e[i, 0][None, :], e[i, 1][None, :])
            pts.append(r[i, 1][None, :] + sig[:, None] * side)
            if not fields:
                continue
            ell, delta = c["layer_length"][i], c["delta"][i]
            if np.isfinite(ell) and ell > 0 and np.isfinite(delta):
                k = asymptotics.curvature_profile(np.abs(sig), 0.5 * delta, ell
                                                  )[:, None] * c["normal"][i][None, :]
            else:  # slack: no layer
                k = np.zeros((sig.size, 3))
            kap.append(k)
            mom.append(km.EI[i] * k)

    def add(self, t: float, forces: np.ndarray) -> None:
        """Record the anchor forces at ``t`` (written in batches)."""
        self.times.append(t)
        F = np.array(forces, float)  # a copy: the rows below are views of it
        if self.model.hinges:  # rows outside the layer law's range
            for name, flag in self.model.hinges.fallback(F).items():
                self.fallback.setdefault(name, []).append(flag)
        for name, N in zip(self._names, F):
            self.forces[name].append(N[:3])
            if name in self.rod:
                self.rod[name].append(N[3:6])
        self.kinkout.add(t)
        self.touchdown.add(t)
        self._pending += 1
        if self._pending >= self.FLUSH_ROWS:
            self.flush()

    def flush(self) -> None:
        """Compute the moment columns of the pending rows (vectorised per anchor) and
        write them to anchors.csv as one block."""
        self.kinkout.flush()
        self.touchdown.flush()
        n = self._pending
        if n == 0:
            return
        times = np.array(self.times[-n:])
        N = np.array([self.forces[name][-n:] for name in self._names])  # (anchor, time, 3)
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
                self.reasons.setdefault(anc.name, []).extend(res["invalid_reason"].tolist())
                for k in MOMENT_COLUMNS:
                    self.columns[anc.name][k].extend(res[k].tolist())
                    cols[k][:, self._index[anc.name]] = res[k]
                self._last[anc.name] = res
            table.update({k: v.ravel() for k, v in cols.items()})
        self._last_time = self.times[-1]
        self.csv.write(table)
        self._pending = 0

    def fields(self, t: float, forces: np.ndarray) -> None:
        """Write the string fields and the composite moment field at ``t`` (collective)."""
        m = self.model
        self.string.write(t)
        self.last_fields_time = t
        if self.moments is None:  # nothing clamped or kinked; a beam's is in string.xdmf
            return
        if self._pending and self.times[-1] == t:
            self.flush()  # this time's row: its layers are those of the field
        idx = self._index
        if self._last_time == t and self._last:
            layers = {c.name: {k: v[-1:] for k, v in self._last[c.name].items()}
                      for c in self.clamped}
        else:  # a time without a row (a failed step's state)
            layers = {c.name: self._moments(c, np.array([t]), forces[idx[c.name]][None, :])
                      for c in self.clamped}
        if self.network:
            pos, kap, mom = self._segments(t, forces, layers)
            self.moments.write(t, pos, kap, mom, self.stations)
            return
        s_a = [m.geometry.stations[c.node] for c in self.clamped]
        r = self._nodal_positions()
        a = m.gather_nodal(m.a)
        kinks = self._kink_layers(t)
        pos = kap = None
        if m.comm.rank == 0:
            get = lambda k: np.array([layers[c.name][k][0] for c in self.clamped])  # noqa
            deltas = np.where(get("slack"), np.nan, get("delta"))
            normals = np.nan_to_num(get("normal")).reshape(-1, 3)
            pos, kap = composite_field(m.geometry.stations, r, a, self.EA, self.EI, self.m,
                                       self.load_at(t), self.stations, s_a, deltas,
                                       get("layer_length"), normals, m.tension_only,
                                       kinks=kinks)
        self.moments.write(t, pos, kap, None if kap is None else self.EI * kap,
                           self.stations)

    def _kink_layers(self, t: float) -> tuple | None:
        """The interior kinks' ``(s, delta, ell, normal)`` in the current state, time
        ``t``, for :func:`composite_field` (collective; None without kinks). A kink
        without a layer (slack: no tension, no length) adds nothing (NaN angle)."""
        if not self.kinked:
            return None
        c = self.kinkout.moments.measure(t)
        ell = c["layer_length"]
        ok = np.isfinite(ell) & (ell > 0) & np.isfinite(c["delta"])
        return (np.array([k.s for k in self.kinkout.kinks]), np.where(ok, c["delta"], np.nan),
                np.where(ok, ell, 1.0), c["normal"])

    def _nodal_positions(self) -> np.ndarray | None:
        u = self.model.gather_nodal(self.model.u)
        return None if u is None else self.model.geometry.points + u

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
            self.string.close()
            self.csv.close()
            if self.moments is not None:
                self.moments.close()
