"""Bending moments at interior kinks (``docs/kinks.md``).

Wherever a concentrated force acts on the span of a single cable (a point load, a point
mass's weight and inertia, a damper) the string's tangent turns across the node, from
``e-`` (the element before) to ``e+`` (the element after), by the kink angle ``Δ_k``. A
cable with bending stiffness rounds that corner over a boundary layer on each side: with
the same tension ``T`` on both sides its tangent at the node is the bisector
``b = (e- + e+)/|e- + e+|``, and each side is the clamped layer of the anchors
(:func:`cablefem.asymptotics.layer`) with the clamp along ``b`` and the angle ``Δ_k/2``::

    M_k = 2 sqrt(EI T) sin(Δ_k/4) sqrt(1 + (T/EA) cos²(Δ_k/4))

about the axis ``b × e+`` (the kink's normal), decaying away from the node over
``ℓ = sqrt(EI/(T (1 + T/EA)))``. For a small angle, ``Δ_k = P/T`` for a transverse force
``P`` and ``M_k = P ℓ/2``: the tensioned beam's moment under a point load. ``T`` is the mean
of the two sides' tensions (they differ by a tangential force component). The reported
moment adds, as at the anchors, the string's own curvature at the node, ``EI κ_s`` with
``κ_s = t × (m a - q)/T`` (``moment_layer``: the layer's alone).

Each row is ``valid`` when the layer fits: the slack and quasi-static checks of the
anchors, the nearest other kink or anchor at least :data:`MIN_SPACING` layer lengths away
(the layers would overlap), and neither element in a virtual hinge's region (whose
stress-free length the hinge changed).

The force on each side at the node is the element's ``T e`` (away from the node) plus the
load on the half element next to the node, ``(h/2) (q - m (2 a_node + a_other)/3)`` with
``q`` the distributed load (weight included) and ``a`` the nodes' accelerations: the force
the element transmits to the node in the finite element equations (consistent mass), so a
kink sees the same force as a clamp at that node would (the element's midpoint force would
be off by the half element's load, O(h)).

Supports a cable passes through (networks): a pinned anchor on a node with two elements of
a cable group is a kink of that group, its reaction the concentrated force. A clamped anchor
on a node with more than one cable element is no kink: it is split into one clamped anchor
per element (:func:`cablefem.network.split_clamps`), each with its own layer in anchors.csv.

The rod (``cablefem.rod``) resolves the kink: its moment at the node is extrapolated from
its element moments on each side (quadratic, from the three elements nearest the node;
the rod's mesh is graded towards kinks as towards clamps), the two sides averaged.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
from mpi4py import MPI

from cablefem import asymptotics
from cablefem.junctions import corners

__all__ = ["KINK_COLUMNS", "MIN_SPACING", "Kink", "KinkMoments", "kink_points", "network_kinks"]

#: the columns of ``kinks.csv``
KINK_COLUMNS = ["time", "kink", "s", "tension", "delta", "moment", "Mx", "My", "Mz",
                "layer_length", "valid"]
#: a kink's layer is valid when the nearest other kink or anchor is at least this many
#: layer lengths away (the layer's profile has decayed to e^-3 = 5 % there)
MIN_SPACING = 3.0


@dataclass
class Kink:
    """An interior node where a concentrated force acts or a cable passes through a
    junction: ``name`` (``point_load0``, ``point_mass1``, ``damper0``; in a network
    ``<where>/<cable group>``), the node, its stress-free arc length ``s`` (NaN in a
    network), the nodes before and after it along the cable (``nodes`` = (before, node,
    after)), the stress-free lengths of the two elements ``h``, the stress-free distance
    to the nearest other kink or anchor along the cable ``spacing``, the section's name
    (a network's; None for a single cable) and the two elements (``cells``, network cell
    indices; a single cable's element numbers)."""

    name: str
    node: int
    s: float
    nodes: tuple = ()
    h: tuple = ()
    spacing: float = np.inf
    section: str | None = None
    cells: tuple = ()
    #: the anchor of a pinned support's kink (its ``<group>:<i>``)
    anchor: str | None = None
    #: the stress-free distances along the cable (a network's: its group) to the next
    #: kink, anchor, junction or end on each side, and whether a damper acts at the node
    sides: tuple = ()
    damper: bool = False


def kink_points(model) -> list[Kink]:
    """The kinks of a single cable or of a network (:func:`network_kinks`)."""
    if model.is_network:
        return network_kinks(model)
    if model.string_alone:  # EI = 0: no layer, no kink moment
        return []
    case, geo = model.case, model.geometry
    st = geo.stations
    out, seen = [], set()
    items = ([(f"point_load{i}", pl.s) for i, pl in enumerate(case.point_loads)]
             + [(f"point_mass{i}", pm.s) for i, pm in enumerate(case.point_masses)]
             + [(f"damper{i}", s) for i, s in enumerate(model.damper_s)])
    for name, s in items:
        k = geo.node_at(s)
        if k in seen or k == 0 or k == len(st) - 1:
            continue  # one kink per node (a mass with a load: the first item names it)
        seen.add(k)
        out.append(Kink(name, k, float(st[k]), (k - 1, k, k + 1),
                        (float(st[k] - st[k - 1]), float(st[k + 1] - st[k])),
                        cells=(k - 1, k)))
    # the distance from each kink to its nearest other kink or anchor (each way)
    marks = np.array(sorted({0.0, float(st[-1])} | {k.s for k in out}))
    dampers = {geo.node_at(s) for s in model.damper_s}
    for k in out:
        k.spacing = float(np.min(np.abs(marks[marks != k.s] - k.s)))
        k.sides = (float(k.s - marks[marks < k.s].max()), float(marks[marks > k.s].min() - k.s))
        k.damper = k.node in dampers
    return out


def network_kinks(model, which: str | None = None, record: bool = True) -> list[Kink]:
    """The kinks of a network (:class:`cablefem.network.NetworkModel`): at every node that
    is not a clamped anchor, where a point load, a point mass, a damper or a pinned anchor
    acts or several cables meet (a junction), each cable group with exactly two elements
    at the node passes through it and kinks there. A group with one element there ends at
    the node (a pin: no moment); with more than two, its path through the node is
    ambiguous: not covered. Where a point term acts at a node of two cable groups in line
    (one group ends, the other begins), the cable kinks there too, named
    ``<where>/<group>+<group>``, if both have the same section (else not covered: the
    layer would straddle a change of section). A clamped node is an anchor (split into its
    sides).

    Named ``<vertex group>:<i>/<group>`` when the node is the i-th of a 0D group (a pinned
    anchor's, a load's, a mass's), ``<damper group>:<j>.<end>/<group>`` at an end (0 or 1,
    the cell's node order) of the j-th cell of a damper's group, else
    ``node<k>/<group>``; ``spacing`` runs along the group's elements to the nearest other
    kink of the group, anchor, junction or end. ``network.kinks`` of the case chooses:
    "all" (loaded nodes, supports and junctions), "loaded" (nodes with point loads, point
    masses, dampers or pinned anchors) or "none"; ``which`` overrides it. ``record``:
    keep the nodes left without a kink in ``model.kink_gaps``."""
    geo = model.geometry
    net, case = geo.net, model.case
    cells = np.asarray(geo.cells, np.int64)
    n = len(geo.points)
    h = geo.cell_lengths
    ends = cells.tolist()  # Python ints: the walks below index them one by one
    group_of = np.asarray(net.cell_group).tolist()
    at_node: list[list[int]] = [[] for _ in range(n)]
    for e, (a, b) in enumerate(ends):
        at_node[a].append(e)
        at_node[b].append(e)
    anchored = {int(k) for k in geo.anchor_nodes.values()}
    clamped = {int(a.node) for a in model.anchors if a.kind != "pinned"}
    label = {int(a.node): a.name for a in model.anchors if a.kind == "pinned"}
    for item in list(case.point_loads) + list(case.point_masses):
        for i, k in enumerate(net.vertex_groups[item.s]):
            label.setdefault(int(k), f"{item.s}:{i}")
    damper_cell = ~geo.is_cable
    damper_nodes = {int(k) for k in cells[damper_cell].ravel()}
    count: dict[int, int] = {}
    for e in np.nonzero(damper_cell)[0]:  # a damper cell's ends: <damper group>:<j>.<0|1>
        i = int(geo.cell_damper[e])
        j = count[i] = count.get(i, -1) + 1
        for end, k in enumerate(cells[e]):
            label.setdefault(int(k), f"{case.dampers[i].group}:{j}.{end}")
    junctions = {int(k) for k in net.junctions}
    which = getattr(case.network, "kinks", "all") if which is None else which
    out = []
    #: (node, where, why) of the nodes with no kink moment: where a group meets itself
    #: with more than two elements (its path through the node is ambiguous), or where a
    #: concentrated force acts at the meeting of two cable groups of different sections
    gaps = []
    if record:
        model.kink_gaps = gaps
    candidates = [] if which == "none" else sorted(
        (set(label) | (junctions if which == "all" else set())) - clamped)

    def add_kink(name, k, es):  # the cable through node k on its two elements es
        before, after = (int(cells[e][cells[e] != k][0]) for e in es)
        out.append(Kink(name, k, np.nan, (before, k, after), (float(h[es[0]]), float(h[es[1]])),
                        section=geo.cell_section[es[0]], cells=tuple(es),
                        anchor=label[k] if k in anchored else None, damper=k in damper_nodes))

    for k in candidates:
        # a damper's cells are no cable: a cable kinks where a damper pulls at it
        cab = [e for e in at_node[k] if not damper_cell[e]]
        in_line = len(cab) == 2 and group_of[cab[0]] != group_of[cab[1]]
        if in_line and k in label:  # a force where two cable groups meet in line
            where = "+".join(net.groups[group_of[e]] for e in cab)
            if geo.cell_section[cab[0]] != geo.cell_section[cab[1]]:
                gaps.append((k, where, "two cable groups of different sections "
                                                  "meet there in line (the layer straddles "
                                                  "a change of section)"))
                continue
            add_kink(f"{label[k]}/{where}", k, cab)
            continue
        for g in sorted({group_of[e] for e in cab}):
            es = [e for e in at_node[k] if group_of[e] == g]
            if len(es) > 2:
                gaps.append((k, net.groups[g], f"the group meets itself with "
                                                          f"{len(es)} elements there"))
            if len(es) == 2:
                add_kink(f"{label.get(k, f'node{k}')}/{net.groups[g]}", k, es)
    stops = anchored | junctions | {k.node for k in out}
    for kink in out:  # walk each way along the side's group until a stop or a branch
        dist = []
        for e, node in zip(kink.cells, (kink.nodes[0], kink.nodes[2])):
            g = group_of[e]
            d = h[e]
            while node not in stops:
                nxt = [c for c in at_node[node] if c != e and group_of[c] == g]
                if len(nxt) != 1:
                    break  # the cable's free end (or a branch)
                e = nxt[0]
                d += h[e]
                a, b = ends[e]
                node = b if a == node else a
            dist.append(d)
        kink.spacing = float(min(dist))
        kink.sides = tuple(float(d) for d in dist)
    return out


class KinkMoments:
    """The kinks' moment columns from the model's current state (collective):
    :meth:`measure` reads the positions and accelerations of each kink's node and its two
    neighbours (a small all-reduce) and returns the columns of :data:`KINK_COLUMNS` but
    time."""

    def __init__(self, model, omega: float | None = None):
        from cablefem.moments import AnchorMoments

        self.model = model
        self.kinks = kink_points(model)
        self.omega = omega
        n = len(self.kinks)
        if model.is_network:
            secs = [model.case.network.sections[k.section] for k in self.kinks]
        else:
            secs = [model.case.section] * n
        self.EI = np.array([sec.EI for sec in secs], float)
        self.EA = np.array([sec.EA for sec in secs], float)
        self.m = np.array([sec.mass for sec in secs], float)
        #: the fluid's and seabed's terms assembled (the kink nodes' share), None without
        self._medium = _medium_form(model) if n else None
        self._medium_out = None  # its vector and field (medium_forces)
        fluid = getattr(model.case, "fluid", None)
        #: the fluid's diameter at each kink (the buoyancy in the half elements' load when
        #: the fluid's terms are not assembled), None without a fluid
        self.D = [None if fluid is None or self._medium is not None else
                  fluid.diameter_on(sec) for sec in secs]
        self._kinds: dict = {}  # the distinct (mass, diameter): state() loads each once
        self._kind = np.array([self._kinds.setdefault(md, len(self._kinds)) for md in
                               zip(self.m.tolist(), self.D)], np.int64)
        self.nodes = np.array([k.nodes for k in self.kinks], dtype=np.int64).reshape(-1, 3)
        self.h = np.array([k.h for k in self.kinks], float).reshape(-1, 2)
        self.spacing = np.array([k.spacing for k in self.kinks], float)
        #: the distributed load at a time (weight, loads, buoyancy), as at the anchors
        self._loads = AnchorMoments.from_model(model, omega) if n else None
        self._local = None
        #: the model's damping (its model, alpha, beta): the elements' damping forces
        damp = model.case.damping
        self.damping = (damp.model, float(damp.alpha), float(damp.beta))
        self._static = None  # rayleigh_k0: the static state's positions (first use)
        #: the kinks whose elements run to the string corner (cablefem.junctions), or None
        names = model.corner_kinks
        self.corner = (np.array([k.name in names for k in self.kinks], bool)
                       if names else None)

    @property
    def names(self) -> list[str]:
        return [k.name for k in self.kinks]

    def _in_hinge_region(self) -> np.ndarray:
        """Kinks next to an element whose law a virtual hinge changed (its stress-free
        length is not the mesh's there, so the tension above would be off): invalid."""
        hinges = self.model.hinges
        if not hinges:
            return np.zeros(len(self.kinks), bool)
        cells = np.array([k.cells for k in self.kinks], np.int64).reshape(-1, 2)
        region = np.concatenate([np.zeros(0, np.int64)] + [  # every hinge's: one test
            np.asarray(hg.elements[:hg.touched], np.int64) for hg in hinges.items])
        return np.isin(cells, region).any(axis=1)

    def _nodal(self, f) -> np.ndarray:
        """(n_kinks, 3, 3) the translational part of the function ``f`` at each kink's
        three nodes, on every rank (an all-reduce)."""
        m = self.model
        bs = m.bs
        n_owned = m.V.dofmap.index_map.size_local
        vals = f.x.array[: bs * n_owned].reshape(-1, bs)[:, :3]
        if self._local is None:  # each kink node's owned dof block here (-1: elsewhere)
            where = np.full(len(m.geometry.points), -1, np.int64)
            where[m.line.owned_nodes] = np.arange(m.line.owned_nodes.size)
            self._local = where[self.nodes]
        out = np.zeros(self.nodes.shape + (3,))
        mine = self._local >= 0
        out[mine] = vals[self._local[mine]]
        if m.comm.size == 1:
            return out
        total = np.empty_like(out)
        m.comm.Allreduce(out, total, op=MPI.SUM)  # the owner's values, zeros elsewhere
        return total

    def positions(self) -> np.ndarray:
        """(n_kinks, 3, 3) current positions of each kink's three nodes, on every rank."""
        return self._nodal(self.model.u) + self.model.geometry.points[self.nodes]

    def measure(self, t: float = 0.0, r: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """The columns (one row per kink) at the model's current state, time ``t`` (for
        the loads), and ``normal`` (n_kinks, 3), the unit axis ``e- × e+`` of the turn
        (zero without one); ``r``: the nodes' positions when
        the caller has them (:meth:`positions`)."""
        if not self.kinks:
            return self.columns(np.zeros((0, 3, 3)))
        return self.columns(**self.state(t, r))

    def state(self, t: float = 0.0, r: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """What :meth:`columns` takes of the model's current state at time ``t``:
        ``r``, ``a``, ``v`` at each kink's three nodes, the distributed ``load`` and the
        ``medium`` forces (collective; the same on every rank)."""
        load = np.array([self._loads.load_at(t, m, d) for m, d in self._kinds]
                        ).reshape(-1, 3)[self._kind]
        r = self.positions() if r is None else r
        if self.damping[0] == "rayleigh_k0" and self._static is None:
            self._static = (self._nodal(self.model.u_static)  # collective, once: here
                            + self.model.geometry.points[self.nodes])
        return {"r": r, "a": self._nodal(self.model.a), "load": load,
                "v": self._nodal(self.model.v), "medium": self.medium_forces()}

    def columns_of(self, states: list[dict]) -> dict[str, np.ndarray]:
        """:meth:`columns` of several :meth:`state` at once, ``(len(states), n_kinks)``
        each: one vectorised evaluation of every kink at every time (the kinks' numbers
        repeated for each time), not one per time. Pure NumPy."""
        R, n = len(states), len(self.kinks)
        if R == 0 or n == 0:
            return {k: v.reshape(R, n) for k, v in self.columns(np.zeros((0, 3, 3))).items()}
        if self.corner is not None and self.corner.any():
            # a string corner's fixed point takes as many iterations as its sharpest
            # corner needs: one time at a time, so that a row does not depend on the block
            rows = [self.columns(**st) for st in states]
            return {k: np.stack([row[k] for row in rows]) for k in rows[0]}
        many = copy.copy(self)  # this object with its per-kink numbers repeated R times
        many.kinks = self.kinks * R
        for name in ("EI", "EA", "m", "spacing", "corner"):
            val = getattr(self, name)
            if val is not None:
                setattr(many, name, np.tile(val, R))
        many.h = np.tile(self.h, (R, 1))
        if self._static is not None:
            many._static = np.tile(self._static, (R, 1, 1))
        args = {}
        for key in ("r", "a", "load", "v", "medium"):
            vals = [st[key] for st in states]
            args[key] = None if vals[0] is None else np.concatenate(vals)
        cols = many.columns(**args)
        return {k: v.reshape((R, n) + v.shape[1:]) for k, v in cols.items()}

    def medium_forces(self) -> np.ndarray | None:
        """(n_kinks, 3) the force the fluid and the seabed put on each kink's two half
        elements, at the current state: their terms of the residual (``fluid_static``,
        ``fluid_dynamic``, ``seabed``, ``seabed_dynamic``: drag, buoyancy, added mass and
        fluid inertia, contact, its damping and friction) assembled, at the kink's node,
        with the sign of a force on the cable; None without a fluid or a seabed.
        Collective."""
        if self._medium is None:
            return None
        from dolfinx import fem
        from dolfinx.fem.petsc import assemble_vector, create_vector
        from petsc4py import PETSc

        m = self.model
        if self._medium_out is None:  # the vector and the field, made once
            self._medium_out = (create_vector(self._medium), fem.Function(m.V))
        vec, f = self._medium_out
        with vec.localForm() as loc:
            loc.set(0.0)
        assemble_vector(vec, self._medium)
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        n_owned = m.V.dofmap.index_map.size_local * m.V.dofmap.index_map_bs
        f.x.array[:n_owned] = -vec.array_r[:n_owned]
        return self._nodal(f)[:, 1]

    def side_forces(self, r: np.ndarray, a: np.ndarray | None = None,
                    load: np.ndarray | None = None, v: np.ndarray | None = None,
                    medium: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The force each of a kink's two elements transmits at its node, pointing away
        from the node into the element (n_kinks, 2, 3): ``T e`` plus the load on the half
        element next to the node, ``(h/2) (q - m (2 a_node + a_other)/3)`` (the element's
        share of the nodal equation, consistent mass); zero on a slack element. With the
        velocities ``v`` (same shape as ``r``), the element's share of the damping force
        too (:meth:`damping_forces`); with ``medium`` (n_kinks, 3: :meth:`medium_forces`,
        the fluid's and the seabed's force on both half elements together), each
        element's share of it in proportion to its length. Also the elements' unit
        vectors ``e`` (n_kinks, 2, 3), along the cable (before -> node -> after)."""
        h = self.h
        if self.corner is not None and self.corner.any():  # to the string corners
            c, hc = corners(r[self.corner], h[self.corner], self.EA[self.corner],
                            self.EI[self.corner])
            r, h = np.array(r, float, copy=True), h.copy()
            r[self.corner], h[self.corner] = c, hc
        d = np.diff(r, axis=1)  # (n, 2, 3): the two elements
        length = np.linalg.norm(d, axis=2)
        e = d / length[..., None]
        strain = length / h - 1.0
        T2 = self.EA[:, None] * (np.maximum(strain, 0.0) if self.model.tension_only else strain)
        away = np.stack([-e[:, 0], e[:, 1]], axis=1)
        F = T2[..., None] * away
        if a is not None or load is not None or v is not None:
            q = np.zeros((len(r), 3)) if load is None else np.asarray(load, float)
            acc = np.zeros_like(r) if a is None else np.asarray(a, float)
            near = (2.0 * acc[:, 1][:, None] + acc[:, [0, 2]]) / 3.0  # (n, 2, 3)
            half = 0.5 * self.h[..., None] * (q[:, None, :] - self.m[:, None, None] * near)
            if v is not None:
                half = half + self.damping_forces(r, np.asarray(v, float), T2)
            F = np.where((T2 > 0.0)[..., None], F + half, 0.0)
        if medium is not None:  # the sides' shares: exact for a force uniform along them
            share = self.h / self.h.sum(axis=1, keepdims=True)
            F = F + np.where((T2 > 0.0)[..., None],
                             share[..., None] * np.asarray(medium, float)[:, None, :], 0.0)
        return F, e

    def damping_forces(self, r: np.ndarray, v: np.ndarray, T: np.ndarray) -> np.ndarray:
        """(n_kinks, 2, 3) the damping force each element transmits at the kink's node
        (away from the node), its share of the model's damping residual ``C v``: Rayleigh's
        ``alpha M`` on the half element (consistent mass), ``-alpha m (h/2) (2 v_node +
        v_other)/3``; ``beta K_t v = beta d/dt f_int`` on the current tangent (model
        "rayleigh"), ``beta d(T e)/dt = beta [(EA/h) dL/dt e + T (dd - (e.dd) e)/L]`` with
        ``dd`` the other node's velocity relative to the node's; on the static tangent
        ("rayleigh_k0") the same with the static ``T``, ``e`` and ``L``; the axial
        strain-rate model ("axial") its axial part ``beta (EA/h) dL/dt e``. ``T``: the
        elements' tensions (n_kinks, 2). Collective (the first call on "rayleigh_k0" reads
        the static state)."""
        model, alpha, beta = self.damping
        out = np.zeros((len(r), 2, 3))
        if model == "none" or not (alpha > 0 or beta > 0):
            return out
        if model in ("rayleigh", "rayleigh_k0") and alpha > 0:
            near = (2.0 * v[:, 1][:, None] + v[:, [0, 2]]) / 3.0
            out -= alpha * 0.5 * self.h[..., None] * self.m[:, None, None] * near
        if beta > 0 and model in ("rayleigh", "rayleigh_k0", "axial"):
            if model == "rayleigh_k0" and self._static is None:  # collective, once
                self._static = (self._nodal(self.model.u_static)
                                + self.model.geometry.points[self.nodes])
            geo = r if model != "rayleigh_k0" else self._static
            d = np.stack([geo[:, 0] - geo[:, 1], geo[:, 2] - geo[:, 1]], axis=1)
            L = np.linalg.norm(d, axis=2)
            e = d / L[..., None]  # away from the node, in that state
            dd = np.stack([v[:, 0] - v[:, 1], v[:, 2] - v[:, 1]], axis=1)
            Ldot = np.einsum("ijk,ijk->ij", e, dd)
            rate = (self.EA[:, None] / self.h * Ldot)[..., None] * e
            if model != "axial":
                Tg = T if model == "rayleigh" else self.EA[:, None] * (L / self.h - 1.0)
                rate = rate + (Tg / L)[..., None] * (dd - Ldot[..., None] * e)
            out += beta * rate
        return out

    def columns(self, r: np.ndarray, a: np.ndarray | None = None,
                load: np.ndarray | None = None, v: np.ndarray | None = None,
                medium: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """The columns for positions ``r`` (n_kinks, 3, 3) of each kink's three nodes,
        their accelerations ``a`` and velocities ``v`` (same shape), the distributed
        load ``load`` (n_kinks, 3) and the fluid's and seabed's force on the half elements
        ``medium`` (all None: the elements' own forces, no half-element load, no
        damping)."""
        n = len(self.kinks)
        F, e = self.side_forces(r, a, load, v, medium)
        size = np.linalg.norm(F, axis=2)  # (n, 2) the tension at the node on each side
        away = np.stack([-e[:, 0], e[:, 1]], axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):  # slack: the element's
            f = np.where(size[..., None] > 0, F / size[..., None], away)
        # a kink: from e- = -f0 into the node to e+ = f1 out of it, with the mean tension,
        # the clamp along the bisector
        T = size.mean(axis=1)
        bis = f[:, 1] - f[:, 0]
        network = self.model.is_network
        lay = SimpleNamespace(**{k: np.full(n, np.nan) for k in (
            "delta", "moment", "layer_length", "tension")}, valid=np.zeros(n, bool),
            moment_vector=np.full((n, 3), np.nan), normal=np.zeros((n, 3)),
            tangent=np.full((n, 3), np.nan))
        # one call per section (a network's kinks may have several)
        for key in sorted(set(zip(self.EI, self.EA, self.m))):
            rows = (self.EI == key[0]) & (self.EA == key[1]) & (self.m == key[2])
            qs = (key[2], self.omega) if self.omega else None
            with np.errstate(invalid="ignore", divide="ignore"):
                part = asymptotics.layer(
                    T[rows, None] * f[rows, 1], bis[rows], key[0], key[1], quasi_static=qs,
                    length=None if network else self.model.length)
            for k in ("delta", "moment", "layer_length", "valid", "moment_vector",
                      "tension", "tangent"):
                getattr(lay, k)[rows] = getattr(part, k)
            lay.normal[rows] = np.nan_to_num(part.normal)
        with np.errstate(invalid="ignore"):
            valid = (lay.valid & (self.spacing >= MIN_SPACING * lay.layer_length)
                     & ~self._in_hinge_region())
        Mv = lay.moment_vector
        if a is not None or load is not None:  # the string's own curvature at the node
            # (as at the anchors: the composite moment there is the layer's plus EI kappa_s)
            q = np.zeros((n, 3)) if load is None else np.asarray(load, float)
            acc = np.zeros((n, 3)) if a is None else np.asarray(a, float)[:, 1]
            with np.errstate(invalid="ignore"):
                Mv = Mv + self.EI[:, None] * asymptotics.string_curvature(
                    lay.tangent, lay.tension, self.m, acc, q)
        moment = np.where(np.isfinite(lay.moment), np.linalg.norm(Mv, axis=1), np.nan)
        Mv = np.nan_to_num(Mv)
        turn = np.cross(-f[:, 0], f[:, 1])  # the axis the tangent turns about, e- × e+
        tsize = np.linalg.norm(turn, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            normal = np.where(tsize[:, None] > 1e-14, turn / tsize[:, None], 0.0)
        return {"tension": T, "delta": 2.0 * lay.delta,
                "moment": moment, "moment_layer": lay.moment,
                "Mx": Mv[:, 0], "My": Mv[:, 1], "Mz": Mv[:, 2],
                "layer_length": lay.layer_length, "valid": valid.astype(int),
                "normal": normal}


def _medium_form(model):
    """The compiled sum of the model's terms of the medium (``medium``: the fluid's and the
    seabed's forces on the cable; their cell integrals: the forces along the elements), or
    None when it has none."""
    parts = model.forms.medium_forms
    if not parts:
        return None
    integrals = [itg for form in parts for itg in form.integrals()
                 if itg.integral_type() == "cell"]
    if not integrals:
        return None
    import ufl
    from dolfinx import fem

    from cablefem.jit import quiet_compiler

    with quiet_compiler():
        return fem.form(ufl.Form(integrals))


def damper_offset_estimate(kink: Kink, layer_length: float, corrected: float = 0.0):
    """The relative error of a damper's effect (its damping ratios, its force and the
    kink's moment) from acting at the string's corner rather than at the rod's node, which
    lies ``(ℓ/2)|e₊ − e₋|`` inside it: the cable's local flexibility at the node is
    ``(d₁ d₂/(d₁ + d₂))/T`` with ``d₁``, ``d₂`` the spans to the next fixed points each way,
    and the offset changes ``ℓ/2`` of it: ``((ℓ − ℓ_c)/2)(1/d₁ + 1/d₂)``, ``ℓ_c`` the part
    of the offset the model applies (``corrected``: a single cable's damper on the default
    route, ``min(ℓ, h/2.5)``, docs/dampers.md; 0 in a network and at leading order). The
    nearest kink, anchor or junction stands for a fixed point: an upper bound. None if the
    kink is not at a damper."""
    if not kink.damper or len(kink.sides) != 2 or not np.isfinite(layer_length):
        return None
    missing = max(layer_length - corrected, 0.0)
    return 0.5 * missing * (1.0 / kink.sides[0] + 1.0 / kink.sides[1])
