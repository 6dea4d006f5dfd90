"""The composite moment field of a model at a field time (``moments.xdmf``), beside the
moments at anchors (:mod:`cablefem.moments`) and kinks (:mod:`cablefem.kinks`).

A single string's field lies along the whole cable: the string's curvature plus the
clamped layers at its clamped anchors and interior kinks (:func:`cablefem.moments.
composite_field`) on stations graded towards the static layers. A network's field is one
short straight segment per clamped anchor and per kink, with the layer's curvature profile
(:func:`cablefem.asymptotics.curvature_profile`) along it. A rod resolves its layers: it has
no composite field (:func:`composite_for` gives None).
"""

from __future__ import annotations

import numpy as np

from cablefem import asymptotics
from cablefem.moments import AnchorMoments, composite_field

__all__ = ["StringComposite", "NetworkSegments", "composite_for", "section_load"]


def section_load(columns: AnchorMoments, case, t: float, section=None) -> np.ndarray:
    """Distributed load per stress-free length at ``t`` on a cable of ``section`` (the
    case's single cable's by default), weight and buoyancy included
    (:meth:`cablefem.moments.AnchorMoments.load_at`)."""
    section = case.section if section is None else section
    fluid = getattr(case, "fluid", None)
    D = None if fluid is None else fluid.diameter_on(section)
    return columns.load_at(t, section.mass, D)


def _static_ells(columns: AnchorMoments, model, clamped, static_forces) -> list[float]:
    """Each clamped anchor's layer length under its static anchor force."""
    idx = {a.name: i for i, a in enumerate(model.anchors)}
    return [columns.anchor(c.name, np.zeros(1), static_forces[idx[c.name]][None, :]
                           )["layer_length"][0] for c in clamped]


def _nodal_positions(model) -> np.ndarray | None:
    u = model.gather_nodal(model.u)
    return None if u is None else model.geometry.points + u


class StringComposite:
    """A single string's composite field: the string's curvature with the clamped layers of
    its clamped anchors and interior kinks, on stations fixed for the run (and its
    restarts) from the static layers: half the static layer length is resolved, as the
    tension can rise in the dynamics. Build it in the static state (collective)."""

    cells = None  #: one polyline along the whole cable

    def __init__(self, model, columns: AnchorMoments, clamped, static_forces,
                 kink_moments=None, kink_static=None):
        self.model, self.columns, self.clamped = model, columns, clamped
        #: the interior kinks' measure (cablefem.kinks.KinkMoments), None without kinks
        self.kink_moments = kink_moments
        sec = model.case.section
        self.EI, self.EA, self.m = sec.EI, sec.EA, sec.mass
        ells = [0.5 * e for e in _static_ells(columns, model, clamped, static_forces)]
        s_a = [model.geometry.stations[c.node] for c in clamped]
        if kink_moments is not None:
            s_a += [k.s for k in kink_moments.kinks]
            ells += list(0.5 * kink_static["layer_length"])
        self.stations = asymptotics.graded_stations(
            model.length, s_a, [e if np.isfinite(e) and e > 0 else np.nan for e in ells])
        r = _nodal_positions(model)
        pts = None
        if model.comm.rank == 0:
            pts = np.column_stack([np.interp(self.stations, model.geometry.stations, r[:, k])
                                   for k in range(3)])
        self.points0 = model.comm.bcast(pts, root=0)

    def kink_layers(self, t: float) -> tuple | None:
        """The interior kinks' ``(s, delta, ell, normal)`` in the current state, time
        ``t``, for :func:`composite_field` (collective; None without kinks). A kink
        without a layer (slack: no tension, no length) adds nothing (NaN angle)."""
        if self.kink_moments is None:
            return None
        c = self.kink_moments.measure(t)
        ell = c["layer_length"]
        ok = np.isfinite(ell) & (ell > 0) & np.isfinite(c["delta"])
        return (np.array([k.s for k in self.kink_moments.kinks]),
                np.where(ok, c["delta"], np.nan), np.where(ok, ell, 1.0), c["normal"])

    def at(self, t: float, forces: np.ndarray, layers: dict) -> tuple:
        """Points, curvature and moment of the field at ``t`` in the current state
        (collective; None on ranks other than 0); ``layers``: each clamped anchor's moment
        columns at ``t`` (one row)."""
        return self.finish(self.state(t, forces), layers)

    def state(self, t: float, forces: np.ndarray) -> dict:
        """What the field at ``t`` takes from the current state (collective; the nodal
        arrays on rank 0 only): :meth:`finish` makes the field from it and the clamped
        layers, later if need be (the output computes the layers in batches of rows)."""
        m = self.model
        return {"t": t, "r": _nodal_positions(m), "a": m.gather_nodal(m.a),
                "kinks": self.kink_layers(t)}

    def finish(self, state: dict, layers: dict) -> tuple:
        """The field of :meth:`state` with the clamped anchors' ``layers`` at its time (one
        row each); pure NumPy (None on ranks other than 0)."""
        m = self.model
        if m.comm.rank != 0:
            return None, None, None
        s_a = [m.geometry.stations[c.node] for c in self.clamped]
        get = lambda k: np.array([layers[c.name][k][0] for c in self.clamped])  # noqa
        deltas = np.where(get("slack"), np.nan, get("delta"))
        normals = np.nan_to_num(get("normal")).reshape(-1, 3)
        pos, kap = composite_field(m.geometry.stations, state["r"], state["a"], self.EA,
                                   self.EI, self.m,
                                   section_load(self.columns, m.case, state["t"]),
                                   self.stations, s_a, deltas, get("layer_length"), normals,
                                   m.tension_only, kinks=state["kinks"])
        return pos, kap, self.EI * kap


class NetworkSegments:
    """A network's field: one short line per clamped anchor (10 static layer lengths,
    graded towards the anchor) and per kink (10 static layer lengths each side of the node,
    signed: < 0 back along the element before), each with its layer's curvature profile.
    Build it in the static state (collective)."""

    def __init__(self, model, columns: AnchorMoments, clamped, static_forces,
                 kink_moments=None, kink_static=None):
        self.model, self.columns, self.clamped = model, columns, clamped
        self.kink_moments = kink_moments
        self.sigmas = []
        for ell in _static_ells(columns, model, clamped, static_forces):
            ell = ell if np.isfinite(ell) else 1e-3 * model.length
            self.sigmas.append(asymptotics.graded_stations(10 * ell, [0.0], [0.5 * ell],
                                                           n_span=5))
        if kink_moments is not None:
            for ell in kink_static["layer_length"]:
                ell = ell if np.isfinite(ell) and ell > 0 else 1e-3 * model.length
                half = asymptotics.graded_stations(10 * ell, [0.0], [0.5 * ell], n_span=5)
                self.sigmas.append(np.concatenate([-half[:0:-1], half]))
        self.points0 = self._segments(0.0, static_forces, None)[0]
        self.stations = np.concatenate(self.sigmas)
        offs = np.cumsum([0] + [s.size for s in self.sigmas[:-1]])
        #: one polyline per clamped anchor and per kink
        self.cells = np.concatenate([np.column_stack([np.arange(s.size - 1),
                                                      np.arange(1, s.size)]) + off
                                     for s, off in zip(self.sigmas, offs)])

    def at(self, t: float, forces: np.ndarray, layers: dict) -> tuple:
        """Points, curvature and moment along every segment at ``t`` (collective)."""
        return self.finish(self.state(t, forces), layers)

    def state(self, t: float, forces: np.ndarray) -> dict:
        """What the field at ``t`` takes from the current state (collective): the clamped
        anchors' forces and the kinks' segments (see :meth:`StringComposite.state`)."""
        pts, kap, mom = [], [], []
        if self.kink_moments is not None:
            self._kink_segments(t, pts, kap, mom, True)
        return {"t": t, "forces": np.array(forces, float), "kinks": (pts, kap, mom)}

    def finish(self, state: dict, layers: dict) -> tuple:
        """The segments of :meth:`state` with the clamped anchors' ``layers`` (pure NumPy)."""
        pts, kap, mom = self._anchor_segments(state["t"], state["forces"], layers)
        kpts, kkap, kmom = state["kinks"]
        return (np.concatenate(pts + kpts), np.concatenate(kap + kkap),
                np.concatenate(mom + kmom))

    def _segments(self, t: float, forces: np.ndarray, layers: dict | None):
        """Points (and with ``layers``, curvature and moment) along each segment at ``t``."""
        pts, kap, mom = self._anchor_segments(t, forces, layers)
        if self.kink_moments is not None:
            self._kink_segments(t, pts, kap, mom, layers is not None)
        out = [np.concatenate(pts)]
        if layers is not None:
            out += [np.concatenate(kap), np.concatenate(mom)]
        return out

    def _anchor_segments(self, t: float, forces: np.ndarray, layers: dict | None):
        """Each clamped anchor's segment: its points (and with ``layers`` its curvature and
        moment) at ``t``."""
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
        return pts, kap, mom

    def _kink_segments(self, t: float, pts: list, kap: list, mom: list,
                       fields: bool) -> None:
        """Append each kink's segment at time ``t``, the current state (collective): the
        polyline from the node back along the element before and on along the one after,
        with the clamped layer of half the kink angle on each side about e- x e+
        (docs/kinks.md)."""
        km = self.kink_moments
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


def composite_for(kind: str, model, columns: AnchorMoments, static_forces,
                  kink_moments=None, kink_static=None):
    """The composite field of a model of ``kind`` (``"string"``, ``"network"``,
    ``"beam"``) with the clamped anchors of ``columns`` and the kinks of ``kink_moments``
    (:class:`cablefem.kinks.KinkMoments`, None or without kinks: none; ``kink_static``
    their static columns), in the static state ``static_forces``: None where there is
    nothing clamped or kinked, and for the rod, which resolves its layers (collective)."""
    cls = {"string": StringComposite, "network": NetworkSegments}.get(kind)
    clamped = [a for a in model.anchors if a.kind == "clamped"]
    if kink_moments is not None and not kink_moments.kinks:
        kink_moments = None
    if cls is None or not (clamped or kink_moments is not None):
        return None
    return cls(model, columns, clamped, static_forces, kink_moments, kink_static)
