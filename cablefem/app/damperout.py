"""``dampers.csv`` and the dampers' summary: a single cable's dampers' force, stroke and
velocity at every output time (``[[dampers]]``, docs/dampers.md), and their peak and RMS
over the statistics window. A damper is specified by its force and stroke.

The numbers are those the dynamic residual uses (:func:`cablefem.dampers.
damper_motion_forms`: the same UFL, the kink layer's offset of the rod's node included),
at the output times' state; a network's damper cells' from their nodes in closed form
(:func:`cablefem.dampers.link_work`'s law, exact for P1 elements)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from mpi4py import MPI

from cablefem.app.statistics import FRACTION, window_start
from cablefem.io import anchorcsv, dampercsv
from cablefem.io.dampercsv import DAMPER_COLUMNS, QUANTITIES, VECTOR_COLUMNS

__all__ = ["DamperOutput", "DamperHistory"]


class DamperOutput:
    """Records the dampers' columns at each output time (collective: :meth:`add`
    assembles the two motion forms, or gathers a network's nodes) and writes
    ``dampers.csv`` in blocks (rank 0). Nothing for a model without dampers."""

    FLUSH_ROWS = 256

    def __init__(self, model, outdir: Path | None, resume_after: float | None = None):
        self.model = model
        #: a network's damper cells: (its [[dampers]] entry, node a, node b)
        self.links = _links(model) if model.is_network else []
        if model.is_network:
            self.dampers = [model.case.dampers[i] for i, _, _ in self.links]
            self.names = _link_names(model.case.dampers, self.links)
        else:
            self.dampers = list(model.case.dampers)
            self.names = [dampercsv.name(i) for i in range(len(self.dampers))]
        self.times: list[float] = []
        self.rows: dict[str, dict[str, list]] = {
            n: {c: [] for c in DAMPER_COLUMNS[2:]} for n in self.names}
        self._pending: list[tuple[float, dict]] = []
        self.csv = None
        if not self.dampers:
            return
        if model.is_network:  # the static state, gathered once
            self._us = model.gather_nodal(model.u_static)
        else:
            self._forms, self._f = _compile(model)
            # each damper node's owned dof block on this rank (-1: another rank's)
            where = np.full(len(model.geometry.points), -1, np.int64)
            where[model.line.owned_nodes] = np.arange(model.line.owned_nodes.size)
            self._owner = where[np.asarray(model.damper_nodes, np.int64)]
            self._mine = self._owner >= 0
            self._local = np.zeros((2, len(model.damper_nodes), 3))
            self._both = np.zeros_like(self._local)
        if outdir is None:  # measure only
            return
        self.csv = anchorcsv.open_series(model.comm, outdir / "dampers.csv", DAMPER_COLUMNS,
                                         resume_after, self._load)

    def _load(self, path: Path) -> None:
        """The rows written before a restart (every rank reads them: small)."""
        for row in anchorcsv.read_rows(self.model.comm, path):
            name = row["damper"]
            if name not in self.rows:
                continue
            if name == self.names[0]:
                self.times.append(float(row["time"]))
            for c in DAMPER_COLUMNS[2:]:
                self.rows[name][c].append(float(row[c]) if row[c] else np.nan)

    def measure(self) -> dict[str, np.ndarray] | None:
        """The columns (but time and name) of every damper at the model's current state,
        (n_dampers,) each, on every rank (collective)."""
        from dolfinx import cpp as dcpp
        from dolfinx import la

        model = self.model
        if model.is_network:
            u, v = model.gather_nodal(model.u), model.gather_nodal(model.v)
            cols = (_link_columns(self.dampers, self.links, model.geometry.points, u, v,
                                  self._us) if model.comm.rank == 0 else None)
            return model.comm.bcast(cols, root=0)
        # the velocity, then the stroke, at the dampers' nodes: each form assembled into
        # the field's array (dolfinx's kernel, the sums of assemble_vector), its ghosts
        # added to their owners, and the owners' values of the dampers' nodes summed
        # over the ranks (one small all-reduce)
        f = self._f
        local, both = self._local, self._both
        local[:] = 0.0
        for j, form in enumerate(self._forms):
            f.x.array[:] = 0.0
            dcpp.fem.assemble_vector(f.x.array, form, dcpp.fem.pack_constants(form),
                                     dcpp.fem.pack_coefficients(form))
            f.x.scatter_reverse(la.ScatterMode.add)
            vals = f.x.array.reshape(-1, model.bs)[:, :3]
            local[j, self._mine] = vals[self._owner[self._mine]]
        if model.comm.size == 1:
            both[:] = local
        else:
            model.comm.Allreduce(local, both, op=MPI.SUM)
        return _columns(self.dampers, both[0].copy(), both[1].copy())

    def add(self, t: float) -> None:
        if not self.dampers:
            return
        cols = self.measure()
        self.times.append(t)
        for i, n in enumerate(self.names):
            for c in DAMPER_COLUMNS[2:]:
                self.rows[n][c].append(float(cols[c][i]))
        self._pending.append((t, cols))
        if len(self._pending) >= self.FLUSH_ROWS:
            self.flush()

    def flush(self) -> None:
        if not self._pending or self.csv is None:
            return
        self.csv.write(anchorcsv.stacked_rows(self._pending, {"damper": self.names},
                                              DAMPER_COLUMNS[2:]))
        self._pending = []

    def close(self) -> None:
        self.flush()
        if self.csv is not None:
            self.csv.close()

    def history(self) -> DamperHistory:
        """What was recorded (a resumed run's rows and this run's)."""
        return DamperHistory(list(self.names), list(self.dampers), np.array(self.times),
                             {n: {c: np.array(v, float) for c, v in r.items()}
                              for n, r in self.rows.items()})


def _compile(model):
    """The compiled velocity and stroke forms and a function of the model's space to read
    their nodal values."""
    from dolfinx import fem

    from cablefem.dampers import damper_motion_forms
    from cablefem.jit import quiet_compiler
    from cablefem.string_terms import kink_layer

    tr = model.translational
    u_t, v_t, us_t, du_t = tr(model.u), tr(model.v), tr(model.u_static), tr(model.du)
    forms = damper_motion_forms(model.mesh, model.case.dampers,
                                [model.line.node_tag[k] for k in model.damper_nodes],
                                u_t, v_t, us_t, du_t, model.t0, model.dS,
                                ell=kink_layer(model, us_t))
    with quiet_compiler():
        compiled = [fem.form(f) for f in forms]
    return compiled, fem.Function(model.V, name="damper_motion")


def _links(model) -> list[tuple[int, int, int]]:
    """A network's damper cells: ([[dampers]] index, first node, second node), in the
    mesh's order."""
    geo = model.geometry
    which = np.asarray(geo.cell_damper)
    cells = np.asarray(geo.cells)
    return [(int(which[e]), int(cells[e, 0]), int(cells[e, 1]))
            for e in np.nonzero(which >= 0)[0]]


def _link_names(dampers, links) -> list[str]:
    """A network damper cell's name: its group's, with ``:j`` (its ``j``-th cell) when
    the group has several."""
    count = {}
    for i, _, _ in links:
        count[i] = count.get(i, 0) + 1
    seen: dict[int, int] = {}
    out = []
    for i, _, _ in links:
        j = seen[i] = seen.get(i, -1) + 1
        out.append(dampers[i].group if count[i] == 1 else f"{dampers[i].group}:{j}")
    return out


def _link_columns(dampers, links, points, u, v, us) -> dict[str, np.ndarray]:
    """A network's damper cells' columns from the nodes' displacement ``u``, velocity
    ``v`` and static displacement ``us`` (:func:`cablefem.dampers.link_work`'s force, in
    closed form for P1: along the cell ``e = (x_b - x_a)/|x_b - x_a|`` the extension from
    the static state ``|x_b - x_a| - |xs_b - xs_a|`` and its rate ``e·(v_b - v_a)``; along
    a fixed ``direction`` n, ``n·Δ(u - u_s)`` and ``n·Δv``). The vectors are the force on
    the cell's second node and the stroke and velocity along the axis."""
    a = np.array([x[1] for x in links])
    b = np.array([x[2] for x in links])
    x, xs = points + u, points + us
    axes = np.empty((len(links), 3))
    stroke = np.empty(len(links))
    for r, d in enumerate(dampers):
        if d.direction is not None:
            axes[r] = np.asarray(d.direction, float)
            stroke[r] = axes[r] @ ((u[b[r]] - us[b[r]]) - (u[a[r]] - us[a[r]]))
        else:
            chord = x[b[r]] - x[a[r]]
            axes[r] = chord / np.linalg.norm(chord)
            stroke[r] = np.linalg.norm(chord) - np.linalg.norm(xs[b[r]] - xs[a[r]])
    rate = np.einsum("ij,ij->i", axes, v[b] - v[a])
    return _columns(dampers, rate[:, None] * axes, stroke[:, None] * axes, axes)


def _columns(dampers, vel: np.ndarray, stroke: np.ndarray,
             axes: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The columns from the velocity and stroke vectors at the nodes, (n_dampers, 3);
    the scalars signed along ``axes`` (per damper), else along a damper's direction, else
    the magnitudes."""
    c = np.array([d.coefficient for d in dampers])
    k = np.array([d.stiffness for d in dampers])
    F = -(c[:, None] * vel + k[:, None] * stroke)  # the damper's force on the cable
    out = {}
    for q, vec in (("force", F), ("stroke", stroke), ("velocity", vel)):
        for j, col in enumerate(VECTOR_COLUMNS[q]):
            out[col] = vec[:, j].copy()
        out[q] = np.linalg.norm(vec, axis=1)
    for i, d in enumerate(dampers):
        if axes is not None or d.direction is not None:  # signed along the damper's axis
            n = axes[i] if axes is not None else np.asarray(d.direction, float)
            out["stroke"][i] = float(n @ stroke[i])
            out["velocity"][i] = float(n @ vel[i])
            out["force"][i] = -float(n @ F[i])
    return out


@dataclass
class DamperHistory:
    """The dampers' recorded columns: their names, their case entries, the output times
    and per damper each column's rows (``DAMPER_COLUMNS[2:]``)."""

    names: list[str]
    dampers: list
    times: np.ndarray
    rows: dict[str, dict[str, np.ndarray]]

    def summary(self, start: float | None = None,
                fraction: float = FRACTION) -> dict | None:
        """Per damper: where it is and its law, and the peak (of the absolute value) and
        RMS of its force, stroke and velocity over the statistics window (from ``start``,
        or the last ``fraction`` of the run: the anchors' and kinks' window), the window
        and the whole run's peaks (``*_run_peak``). None without dampers or rows."""
        if not self.names or self.times.size == 0:
            return None
        t = self.times
        t0 = window_start(t, start, fraction) if t.size > 1 else float(t[0])
        sel = t >= t0
        out = {}
        for d, name in zip(self.dampers, self.names):
            rows = self.rows[name]
            where = ({"group": d.group} if hasattr(d, "group") else
                     {"anchor": d.anchor, "distance": d.distance})
            entry = {**where, "coefficient": d.coefficient, "stiffness": d.stiffness,
                     "direction": (None if d.direction is None
                                   else [float(x) for x in d.direction]),
                     "window": [float(t0), float(t[-1])]}
            for q in QUANTITIES:
                v = rows[q][sel]
                v = v[np.isfinite(v)]
                if v.size == 0:
                    continue  # a number that does not exist is absent
                entry[f"{q}_peak"] = float(np.max(np.abs(v)))
                entry[f"{q}_rms"] = float(np.sqrt(np.mean(v * v)))
                entry[f"{q}_run_peak"] = float(np.nanmax(np.abs(rows[q])))
            out[name] = entry
        return out
