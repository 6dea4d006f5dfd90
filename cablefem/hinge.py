"""The first-order outer correction: the string pinned at a virtual hinge near each clamp.

At leading order the string is pinned at the clamped anchor A itself. The rod's far field
is a string too, but one that starts at the virtual hinge ``H = A + h c`` on the clamp line,
with ``sigma_h`` of stress-free length less (:func:`cablefem.asymptotics.virtual_hinge`:
the exact far field of the layer's elastica, at finite anchor angle and with the layer's
stretch kept). Leaving the hinge out makes the outer solution wrong at O(ell/l): the anchor
tension of a sagging cable (the far field is offset by O(ell Delta^2) along the string) and
the frequencies (the span turns about H, not about A).

:class:`VirtualHinges` puts that into the finite-element string:

* the anchor node is prescribed at H (the anchor's ``offset`` h c, added to its
  prescribed displacement, so an anchor motion moves the hinge with it), shifted by the far
  field's second order ``E`` (:func:`cablefem.asymptotics.far_field_second_order`: the load
  along the layer turns the far field and changes its tension; docs/theory.md §6.2);
* the stress-free length ``sigma_h`` is taken out of the *region* next to the anchor: the
  fewest whole elements whose stress-free length K is at least ``sigma_h / REGION_FRACTION``
  (one element on a coarse mesh, as many as needed on a fine one), each shortened by the same
  fraction ``sigma_h / K`` (its coefficient ``c``, stress-free length per mesh length). The
  region's nodes are free: under tension they lie on the far-field line between H and the
  region's end, which is all the outer problem needs (the layer's shape is the boundary
  layer's business). The region is kept across the statics iterations (it grows only past
  GROW x REGION_FRACTION). The anchor force and moment do not depend on how many elements
  share the cut beyond the elements' O(L^2) (a test checks it from 10 elements to many times
  finer than the layer);
* the layer's own weight and inertia, ``m sigma_h (g - a_A)``, are added to the hinge
  force, so that the anchor force is the force at the real anchor
  (:meth:`cablefem.reactions.AnchorReactions.compute`); the boundary layer (the anchor moment)
  and the hinge itself are computed from it;
* statics iterates hinge -> equilibrium -> anchor force -> hinge to a fixed point,
  accelerated (:func:`hinge_fixed_point`, which drives statics through its hooks).

In dynamics the node stays where statics put it (it moves with the anchor), and so does the
region: a prescribed node that jumps with the tension feeds velocity jumps into
generalised-alpha (tried: the run blew up). Where the far field moves off the node, the
string is shifted instead (below: the normal offset). The
layer itself follows the tension T and the angle Delta through the region's constitutive
law (:meth:`VirtualHinges.start_dynamics`, :func:`cablefem.forms.layer_law_tension`): sigma
is the stress-free length for which the string from the fixed node lies, along the string,
on the rod's far-field line at T and Delta, ``h cos(Delta) - lambda_inf sigma = D_t(T,
Delta)`` (plus the static state's small mismatch between element tension and anchor force,
kept constant), and each region cell removes its share p of

    sigma(T, C) = sigma_h + sigma_T (T - T0) + sigma_C (C - C0),   C = cos Delta,

linearised about the cell's own static tension T0 and cosine C0. T and C are the cell's own
(C from its current tangent, in the residual), so the law is implicit: Newton solves the
layer's response to its own tension and angle within each step, and its Jacobian is derived
like every other term's. Written for the cell's stretch lambda this is linear, ``lambda = rho
+ ka T`` with ``rho = a - b (C - C0)``; ``ka`` is the elastic compliance plus the layer's
(sigma_T < 0: the layer gets shorter as the tension grows, sigma ~ T^-1/2), so the region is
softer than the element, a compliance in series. The law is fixed for the whole run: nothing
is updated between steps, so a restart gets it back from the static state, and nothing jumps.

The two parts matter in different places. sigma_T is tiny, but the first element is stiff
(EA/L), and EA/L times that compliance is ~2.4 in case B: a sigma updated from the last
step's tension blew up within 15 steps. sigma_C is first order in the motion at a sagging
cable's clamps (Delta ~ 0.4 rad): a sigma updated after each step from the last angle there
fed energy into the motion (a 10 %-sag cable blew up within 3 s), and one re-linearised about
the first element's tension at every step kicked the other region cells (their tensions
differ by the region's weight). Round a small Delta sigma_C (C - C0) is second order, as it
should be.

The normal offset. The string's line through the fixed node along the force direction t
passes at ``h sin(Delta)`` from A, the rod's far field at ``D_n(T, Delta)``: statics makes
them equal, dynamics moves them apart at first order where the static angle is finite. Each
region cell's force direction is that of its stretch vector shifted by its share of ``dn =
D_n - h sin(Delta)`` normal to the string, ``g - q (c - (c.e) e)``
(:func:`cablefem.forms.layer_stretch_vector`), with q linearised about the static state in
the first element's T and Delta (:func:`cablefem.hinge_law.offset_derivatives`) and computed,
like the law, from the cell's own chord. Without it the hinged string's in-plane
frequencies of a 10 %-sag cable with horizontal clamps were 1-2 % low (docs/theory.md §6).

Out of range (the fallback). The linear law holds from ``FLOOR`` to ``CEILING`` times T0;
outside, the cell keeps the law at the nearer end with the element's own elastic slope
(``T = max(min(T_a, T_f), T_c)``, continuous, with kinks), and the change of C is clipped to
``DCOS``. Rows whose first element's tension is outside that range are the anchor's
*fallback* rows: :meth:`VirtualHinges.fallback` flags them (from the anchor force), the
summary counts them, and the run goes on. In the region the mass is the element's less the
layer's static sigma_h (the layer's weight and inertia go to the anchor force), fixed during
the run.

Only the string model has hinges (``solver.outer_correction = "hinge"``); the rod resolves
its layers itself. In a network (:class:`cablefem.network.NetworkModel`) a clamped anchor
is the end node of one chain of elements (a clamp a cable runs through is split into one
anchor per side, :func:`cablefem.network.split_clamps`): the region is taken from that
chain, from the anchor through nodes on two elements, up to a junction, a free end or
half-way to another anchor (:meth:`VirtualHinges._network`); the elements keep their
pretension's stress-free length per mesh length as their base (``c0``).

A hinge that cannot be placed in statics (slack anchor, anchor angle above ~120 deg, a layer
longer than REGION_FRACTION of half the cable or of its chain to a junction) raises
:class:`HingeError` (statics makes it an input error naming ``solver.outer_correction``).
"""

from __future__ import annotations

import logging

import numpy as np
from mpi4py import MPI

from cablefem.asymptotics import far_field_second_order, layer, virtual_hinge
from cablefem.errors import CaseError, HingeError, StaticError
from cablefem.hinge_law import CEILING, DCOS, FLOOR, cell_values, start_law

__all__ = ["VirtualHinges", "HingeError", "REGION_FRACTION", "FLOOR", "CEILING", "DCOS",
           "hinge_fixed_point"]

log = logging.getLogger(__name__)

#: In statics the region is chosen so that sigma_h is at most this fraction of it: room for
#: the layer to grow in dynamics (to 11/8 sigma_h at the FLOOR tension, plus the angle's
#: term) and to be spread over a few elements on a fine mesh.
REGION_FRACTION = 0.25
#: Statics keeps its region while sigma_h stays below GROW x REGION_FRACTION of it (a
#: region that changed with every iteration would make the fixed point hop).
GROW = 1.5


class _Hinge:
    """One clamped anchor's hinge: its region's cells, their base coefficients, h and
    sigma_h."""

    def __init__(self, index, anc, s, cells, nodes):
        self.index = index  # position in model.anchors
        self.anchor = anc
        self.s = s  # stress-free lengths of the elements from the anchor on (all ranks), m
        self.cells = cells  # local cell of each of those elements (-1: not on this rank)
        self.elements = np.zeros(0, np.int64)  # their numbers in the geometry (all ranks)
        self.nodes = nodes  # first element: (anchor node, other node, X_other - X_anchor)
        self.n = 0  # elements the layer's length is taken from
        self.K = 0.0  # their stress-free length without the hinge
        self.p = np.zeros(0)  # their shares of it
        self.touched = 0  # elements whose coefficients the hinge has changed
        self.h = 0.0  # the node is at A + h c
        self.sigma = 0.0  # the layer's stress-free length (taken from the region)
        self.mass_length = 0.0  # the layer's mass per m (statics' sigma_h, fixed in dynamics)
        self.EA0 = 0.0  # the elements' own EA
        self.T_static = 0.0  # dynamics: the first element's static tension, N
        self.sig_T = self.sig_C = 0.0  # dynamics: the first element's law (layer_sigma)
        self.c0 = np.ones(len(s))  # stress-free length per mesh length without the hinge
        self.second = np.zeros(3)  # the node's O(ell^2) shift off the clamp line, m


class VirtualHinges:
    """Virtual hinges at every clamped anchor of a string model (see the module docs)."""

    def __init__(self, model) -> None:
        self.model = model
        self._scratch = None  # dynamics: cell functions of :meth:`_cell_values`
        self._loads = None  # the distributed loads at the anchors (statics, first use)
        self.items: list[_Hinge] = []
        self.g_vec = np.asarray(model.g_vec, float)
        if model.is_network:
            self._network()
            return
        geo = model.geometry
        X = model.V.tabulate_dof_coordinates()
        pts = np.asarray(geo.points, float)
        n_el = len(pts) - 1
        # the element of every local cell, owned then ghosts (a single cable's element k:
        # its cell k)
        elem_of = model.line.reference_cells()
        cell_of = np.full(n_el, -1, np.int64)
        cell_of[elem_of] = np.arange(elem_of.size)
        s_all = np.abs(np.diff(np.asarray(geo.stations, float)))
        for i, anc in enumerate(model.anchors):
            if anc.kind != "clamped":
                continue
            k0 = geo.anchor_nodes.get(anc.name)
            if k0 not in (0, n_el):
                raise HingeError(f"anchor {anc.name}: the virtual hinge needs the anchor at "
                                 "the end of one cable")
            order = np.arange(n_el) if k0 == 0 else np.arange(n_el)[::-1]
            order = order[:max(1, n_el // 2)]  # a region never reaches past mid-cable
            self._add(i, anc, s_all[order], cell_of[order], X, order)
        self.g_vec = np.asarray(model.g_vec, float)

    def _add(self, i, anc, s, cells, X, elements) -> None:
        """A hinge at anchor ``i`` whose region may take the elements of stress-free lengths
        ``s`` (from the anchor on) on the local ``cells`` (-1: not on this rank);
        ``elements``: their numbers in the geometry (all ranks)."""
        model = self.model
        nodes = None
        if cells[0] >= 0:  # the first element's two nodes, the anchor's first
            dofs = model.V.dofmap.cell_dofs(int(cells[0]))
            at_anchor = np.linalg.norm(X[dofs] - anc.reference, axis=1)
            a, b = dofs[np.argmin(at_anchor)], dofs[np.argmax(at_anchor)]
            nodes = (a, b, X[b] - X[a])  # and the element in the reference geometry
        hg = _Hinge(i, anc, np.asarray(s, float), np.asarray(cells, np.int64), nodes)
        hg.elements = np.asarray(elements, np.int64)
        hg.EA0 = float(anc.section.EA)
        # stress-free length per mesh length without the hinge (1 on a single cable; a
        # network's mesh is the pretensioned geometry)
        c = hg.cells
        hg.c0[c >= 0] = model.c.x.array[c[c >= 0]]
        # each region cell's clamp direction, signed by the cell's orientation (its
        # reference tangent t0 = x1 - x0 points away from the anchor or towards it)
        x, gdofs = model.mesh.geometry.x, model.mesh.geometry.dofmap
        turn = model.turn_dir.x.array.reshape(-1, 3)
        for cell in c[c >= 0]:
            v0, v1 = (x[k] for k in gdofs.links(int(cell)))
            away = np.dot(v1 - v0, 0.5 * (v0 + v1) - anc.reference)
            turn[cell] = np.sign(away) * np.asarray(anc.direction, float)
        self.items.append(hg)

    def _network(self) -> None:
        """The hinges of a network (:class:`cablefem.network.NetworkModel`): a clamped
        anchor is the end node of one chain of elements; its region may take the elements
        of that chain from the anchor on through nodes of degree 2, up to a junction (degree
        > 2) or a free end, or up to half the chain when it ends at another anchor."""
        model = self.model
        geo = model.geometry
        X = model.V.tabulate_dof_coordinates()
        cells_g = np.asarray(geo.cells, np.int64)
        # the dampers' cells are no part of a chain
        degree = np.array([len(es) for es in model.cable_cells_at()])
        anchored = {int(k) for k in geo.anchor_nodes.values()}
        length = geo.cell_lengths
        idx = np.asarray(model.cell_index, np.int64)  # network cell of each local cell
        cell_of = np.full(len(cells_g), -1, np.int64)
        cell_of[idx] = np.arange(idx.size)
        for i, anc in enumerate(model.anchors):
            if anc.kind != "clamped":
                continue
            k = int(geo.anchor_nodes[anc.name])
            if degree[k] != 1:
                raise HingeError(f"anchor {anc.name}: the virtual hinge needs the anchor at "
                                 f"the end of one cable (its node {k} is on {degree[k]} "
                                 "elements)")
            chain, node = model.chain(k)
            chain = np.asarray(chain, np.int64)
            if node in anchored:  # the other anchor's layer takes the other half
                chain = chain[:max(1, chain.size // 2)]
            self._add(i, anc, length[chain], cell_of[chain], X, chain)

    def __bool__(self) -> bool:
        return bool(self.items)

    def layer_forces(self, anchors: np.ndarray, accelerations: np.ndarray) -> np.ndarray:
        """(n, 3) weight and inertia of the layers of ``anchors`` (n indices), ``m sigma_h
        (g - a)`` with their ``accelerations`` (n, 3), N (zero rows for anchors without
        hinge)."""
        out, masses, g = [[0.0] * 3 for _ in range(len(anchors))], self.masses(), self.g_vec
        # Python floats: the same operations as NumPy's on the arrays, a tenth of the time
        for k, (i, a) in enumerate(zip(anchors.tolist(), accelerations.tolist())):
            if i in masses:
                out[k] = [masses[i] * (gj - aj) for gj, aj in zip(g.tolist(), a)]
        return np.array(out, float).reshape(-1, 3)

    def masses(self) -> dict[int, float]:
        """Each hinged anchor's layer mass ``m sigma_h`` (kg), by the anchor's index."""
        return {hg.index: hg.anchor.section.mass * hg.mass_length for hg in self.items}

    # ------------------------------------------------------------------ statics
    def place(self, forces: np.ndarray) -> np.ndarray:
        """(n_hinges, 5): h, sigma_h and the second-order shift E (3) of every hinge from the
        anchor forces (n_anchors, >= 3) at the real anchors (the same on every rank).
        Raises :class:`HingeError` where a hinge cannot be placed (on every rank, the
        first such hinge's).

        Collective: the hinges are shared out over the ranks (every ``size``-th one) and
        their rows gathered, the same numbers as on one rank (a 160-clamp roof: 0.95 s of
        statics on every rank before)."""
        out = np.zeros((len(self.items), 5))
        if self._loads is None:
            from cablefem.moments import AnchorMoments
            self._loads = AnchorMoments.from_model(self.model)
        comm = self.model.comm
        rank, size = comm.rank, comm.size
        errors = {}  # hinge index -> the error of a hinge that could not be placed here
        for k, hg in enumerate(self.items):
            if k % size != rank:
                continue
            try:
                out[k] = self._place(hg, forces)
            except Exception as err:  # noqa: BLE001 - raised on every rank below
                errors[k] = err
        # every rank learns each failure as (index, a HingeError?, its text): an error need
        # not pickle, and a rank left out of the gather would wait for ever
        failed = [(k, isinstance(e, HingeError), str(e)) for k, e in errors.items()]
        if size > 1:
            parts = comm.allgather((out[rank::size], failed))
            for r, (rows, _) in enumerate(parts):
                out[r::size] = rows
            failed = [f for _, theirs in parts for f in theirs]
        if failed:
            k, hinge, text = min(failed)
            if k in errors:
                raise errors[k]
            raise HingeError(text) if hinge else RuntimeError(
                f"placing the virtual hinge of anchor {self.items[k].anchor.name} failed on "
                f"another rank: {text}")
        return out

    def _place(self, hg, forces: np.ndarray) -> np.ndarray:
        """(5,): :meth:`place`'s row of hinge ``hg``."""
        sec = hg.anchor.section
        N = np.asarray(forces[hg.index][:3], float)
        lay = layer(N, hg.anchor.direction, sec.EI, sec.EA)
        h, sig = (float(v) for v in virtual_hinge(lay.delta, lay.tension, sec.EI,
                                                  sec.EA))
        why = None
        if not (np.isfinite(h) and np.isfinite(sig)):
            why = "no layer (slack anchor or anchor angle near 180 deg)"
        elif sig <= 0.0:
            why = f"sigma_h = {sig:.3g} m <= 0 (anchor angle above ~120 deg)"
        elif sig > REGION_FRACTION * float(np.sum(hg.s)):
            why = (f"sigma_h = {sig:.3g} m: the layer is too long for the cable (more "
                   f"than {REGION_FRACTION:g} of the {float(np.sum(hg.s)):.3g} m it may "
                   "be taken from: half the cable, or up to the next junction)")
        if why is not None:
            raise HingeError(f"anchor {hg.anchor.name}: cannot place the virtual hinge: "
                             f"{why}. Use solver.outer_correction = \"none\" (or "
                             "--outer-correction none) for the leading order.")
        # the far field's second-order shift (the load along the layer, theory.md §6.2)
        q = -self._loads.anchor_load(hg.anchor.name, 0.0)
        return np.concatenate([[h, sig], far_field_second_order(N, hg.anchor.direction,
                                                                 q, sec.EI, sig)])

    def apply(self, z: np.ndarray) -> None:
        """Put hinges at ``z`` (n_hinges, 5: h, sigma_h, E) into the model (statics): the
        node offsets ``h c + E``, and sigma_h taken from the elements next to the anchor,
        each filled to REGION_FRACTION of its stress-free length in turn (a change of
        sigma_h changes only the last element it reaches: the fixed point's equilibria stay
        close)."""
        for hg, row in zip(self.items, np.asarray(z, float).reshape(-1, 5)):
            h, sig = float(row[0]), float(row[1])
            hg.second = row[2:].copy()
            if not (np.isfinite(h) and np.isfinite(sig) and 0.0 < sig):
                raise HingeError(f"anchor {hg.anchor.name}: cannot place the virtual hinge "
                                 f"(h = {h:.3g} m, sigma_h = {sig:.3g} m)")
            if hg.n == 0 or sig > GROW * REGION_FRACTION * float(np.sum(hg.s[:hg.n])):
                need = int(np.searchsorted(np.cumsum(hg.s), sig / REGION_FRACTION)) + 1
                if need > hg.s.size:
                    raise HingeError(f"anchor {hg.anchor.name}: sigma_h = {sig:.3g} m is more "
                                     f"than {REGION_FRACTION:g} of half the cable (or of "
                                     "its chain up to the next junction)")
                hg.n = max(hg.n, need)
            hg.K = float(np.sum(hg.s[:hg.n]))  # the region's stress-free length
            hg.p = hg.s[:hg.n] / hg.K  # the same fraction of each
            r = np.zeros(hg.s.size)
            r[:hg.n] = sig * hg.p
            hg.h, hg.sigma = float(h), float(sig)
            hg.mass_length = float(sig)
            hg.anchor.offset = h * hg.anchor.direction + hg.second
            touched = max(hg.n, hg.touched)  # cells changed before and now
            c = hg.cells[:touched]
            cs = (hg.c0[:touched] * (1.0 - r[:touched] / hg.s[:touched]))[c >= 0]
            m, on = self.model, c[c >= 0]
            m.c.x.array[on] = cs
            m.EA.x.array[on] = hg.EA0
            # statics: the elastic law of the shortened elements (the layer's law is put in
            # by start_dynamics)
            m.law_a.x.array[on] = cs
            m.law_ka.x.array[on] = m.law_kb.x.array[on] = cs / hg.EA0
            m.law_b.x.array[on] = m.law_tf.x.array[on] = m.law_tc.x.array[on] = 0.0
            hg.touched = touched
        self.model.invalidate_time()

    def current(self) -> np.ndarray:
        """(n_hinges, 5): the h, sigma_h and E in the model."""
        return np.array([(hg.h, hg.sigma, *hg.second) for hg in self.items],
                        float).reshape(-1, 5)

    def regions(self) -> dict[str, int]:
        """Per anchor: the number of elements the layer's length is taken from."""
        return {hg.anchor.name: hg.n for hg in self.items}

    # ------------------------------------------------------------------ dynamics
    def _measure(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tension and anchor angle Delta (between the clamp direction and the first
        element) of every hinge's first element in the displacement ``u`` (a Function's
        array, ghosts up to date); from the ranks that have the element, to all ranks."""
        Tc, Cc = cell_values(self, u)
        local = np.zeros((len(self.items), 3))
        for k, hg in enumerate(self.items):
            if hg.nodes is None:
                continue
            c = int(hg.cells[0])
            local[k] = (Tc[c], np.arccos(np.clip(Cc[c], -1.0, 1.0)), 1.0)
        tot = self.model.comm.allreduce(local, op=MPI.SUM)  # every holder has the same values
        return tot[:, 0] / tot[:, 2], tot[:, 1] / tot[:, 2]

    def start_dynamics(self, u_static: np.ndarray) -> None:
        """Put the layer's law into each region (module docs): linearised about the static
        state ``u_static``, each cell about its own static tension T0 and cos Delta C0
        (:func:`cablefem.hinge_law.start_law`). The law then stays as it is for the whole
        run (nothing is updated between steps; a restart sets it again from the static
        state)."""
        start_law(self, u_static)

    def layer_sigma(self, T: float, delta: float, hg: _Hinge) -> float:
        """The stress-free length the law removes from the first element's region at its
        tension T and angle Delta, sigma_h + sigma_T (T - T0) + sigma_C (cos Delta - C0) with
        T within the floor and ceiling and the cosine's change within DCOS (first element's
        rank only; NaN elsewhere)."""
        if hg.cells[0] < 0:
            return float("nan")
        c = int(hg.cells[0])
        T0 = self.model.law_tf.x.array[c] / FLOOR
        dC = np.clip(np.cos(delta) - self.model.cos_ref.x.array[c], -DCOS, DCOS)
        return hg.sigma + hg.sig_T * (np.clip(T, FLOOR * T0, CEILING * T0) - T0) \
            + hg.sig_C * dC

    def fallback(self, forces: np.ndarray) -> dict[str, np.ndarray]:
        """Per anchor: True when the anchor's tension in ``forces`` (n_anchors, >= 3: the
        forces at the real anchors; or (n_anchors, rows, >= 3): a block of rows, one flag
        a row) is outside FLOOR to CEILING times its first element's static tension: the
        layer's law no longer follows the tension there (module docs). (The anchor force
        and the first element's tension differ by the layer's weight, about 1e-3 of them:
        nothing next to the range's factors 4 and 2.)"""
        out, forces = {}, np.asarray(forces, float)
        for hg in self.items:
            f = forces[hg.index]
            T = np.sqrt(f[..., 0] ** 2 + f[..., 1] ** 2 + f[..., 2] ** 2)
            started = hg.T_static > 0.0  # before start_dynamics: the statics' own law
            out[hg.anchor.name] = started & ~((FLOOR * hg.T_static <= T)
                                              & (T <= CEILING * hg.T_static))
        return out

    def report(self) -> dict[str, dict]:
        """Per anchor: the hinge distance h along the clamp direction, the stress-free
        length sigma_h removed (m), the number of elements it is taken from, and the node's
        offset from the anchor, ``h c + E`` (m, E the second order of docs/theory.md
        §6.2)."""
        return {hg.anchor.name: {"h": hg.h, "sigma_h": hg.sigma, "elements": hg.n,
                                 "offset": [float(v) for v in hg.anchor.offset]}
                for hg in self.items}


# ---------------------------------------------------------------------- statics' fixed point
def _input_error(model):
    """``f(call, *args)``: ``call(*args)``, a :class:`HingeError` made an input error naming
    ``solver.outer_correction`` (:class:`cablefem.errors.CaseError`)."""
    def guarded(call, *args):
        try:
            return call(*args)
        except HingeError as err:
            raise CaseError([("solver.outer_correction", str(err))],
                            model.case.source) from None
    return guarded


def _reach(hinges, steps, apply, z, z_done, it: int) -> tuple[int, int]:
    """The equilibrium with the hinges at ``z``: at once, or by continuation from the last
    hinges with an equilibrium ``z_done`` towards ``z`` (steps halved on failure, grown by
    1.5 on success). Returns the Newton iterations, in all and of the last solve;
    StaticError when the step falls below 1/64."""
    apply(z)  # sets the region for z (kept by the partial steps below)
    ok, its = steps.solve(it)
    total, theta, step = its, 0.0, 0.5
    while not ok:
        if step < 1.0 / 64:
            raise StaticError(f"static equilibrium with the virtual hinges (iteration "
                              f"{it}) not found, also in steps towards them: Newton "
                              f"history {steps.history()}")
        steps.restore()
        apply(z_done + min(1.0, theta + step) * (z - z_done))
        ok, its = steps.solve(it)
        total += its
        if ok:
            steps.keep()
            theta = min(1.0, theta + step)
            step *= 1.5
            ok = theta >= 1.0
        else:
            step *= 0.5
    return total, its


def _anderson(Z: list, G: list, depth: int) -> np.ndarray:
    """The next iterate of Anderson mixing of depth ``depth`` from the iterates ``Z`` and
    their images ``G`` (trimmed in place to the last ``depth + 1``): the combination of the
    last images with least residual (the plain image with one pair)."""
    del Z[:-(depth + 1)], G[:-(depth + 1)]
    R = [gg - zz for gg, zz in zip(G, Z)]
    if len(R) < 2:
        return G[-1]
    dR = np.column_stack([R[k + 1] - R[k] for k in range(len(R) - 1)])
    dG = np.column_stack([G[k + 1] - G[k] for k in range(len(G) - 1)])
    gamma = np.linalg.lstsq(dR, R[-1], rcond=1e-12)[0]
    return G[-1] - dG @ gamma


def hinge_fixed_point(model, steps, forces: np.ndarray, tol: float | None = None,
                      max_iterations: int = 30, depth: int = 3) -> int:
    """Fixed point hinge -> equilibrium -> anchor forces -> hinge of ``model.hinges``,
    accelerated (Anderson mixing of depth ``depth`` on the hinges' (h, sigma_h, E)).

    Statics is driven through ``steps`` (:class:`cablefem.static_newton.HingeSteps`, the hooks
    of a static solve): ``solve(it)`` Newton at the current hinges -> (converged,
    iterations); ``keep()`` and ``restore()`` the state of the last equilibrium;
    ``anchor_forces()`` at the current equilibrium; ``rtol``, ``atol`` Newton's tolerances;
    ``history()`` its last history.

    The hinge depends on the anchor force only through ell ~ T^-1/2 and Delta; the plain
    iteration contracts by 1e-2 to 1e-3 per step on a taut cable but only by about a half on
    a sagging one with horizontal clamps (the hinge moves the sag, the sag the angle).
    Converged when the anchor forces change by less than ``tol`` (default: Newton's own
    force tolerance, ``max(atol, rtol |F|)`` of the SNES, times 10: the fixed point is then
    as exact as the equilibrium inside it) between two equilibria, or (h, sigma_h) by less
    than 1e-10 of sigma_h (the anchor force is exact to ~1e-10 and sigma_h ~ T^-1/2: the
    iteration's noise floor; near it the force changes by more than Newton's tolerance,
    the first element being stiff). ``forces`` is updated in place to the last
    equilibrium's; returns the Newton iterations. A hinge that cannot be placed is an input
    problem (:class:`cablefem.errors.CaseError` naming ``solver.outer_correction``)."""
    hinges, guarded = model.hinges, _input_error(model)

    def apply(z):
        guarded(hinges.apply, z)
        model.set_time(0.0)

    its_total = 0
    Z, G = [], []  # iterates and their images
    z = guarded(hinges.place, forces)
    scale = float(z[:, 1].max())  # lengths in units of the first sigma_h (fixed)
    change_F = change_z = np.inf
    z_done = hinges.current()  # the last hinges with an equilibrium
    steps.keep()
    for it in range(1, max_iterations + 1):
        total, its = _reach(hinges, steps, apply, z, z_done, it)
        its_total += total
        z_done = hinges.current()
        steps.keep()
        old = forces.copy()
        forces[:] = steps.anchor_forces()
        g = guarded(hinges.place, forces)
        change_F = float(np.abs(forces - old).max())
        change_z = float(np.abs(g - z).max() / scale)
        tol_F = tol if tol is not None else 10.0 * max(
            steps.atol, steps.rtol * float(np.abs(forces).max()))
        log.info("statics: virtual hinges, iteration %d: anchor force change %.2e (tolerance "
                 "%.2e), hinge change %.2e of sigma_h, %d Newton iterations", it, change_F,
                 tol_F, change_z, its)
        if it > 1 and (change_F <= tol_F or change_z < 1e-10):
            return its_total
        Z.append(z.ravel() / scale)
        G.append(g.ravel() / scale)
        z = _anderson(Z, G, depth).reshape(-1, 5) * scale
        if not (np.all(np.isfinite(z)) and np.all(z[:, 1] > 0)):
            z = g  # a wild extrapolation: the plain step
            Z, G = [], []
    raise StaticError(f"the virtual-hinge iteration did not converge in {max_iterations} "
                      f"iterations (last anchor force change {change_F:.2e} N, hinge change "
                      f"{change_z:.2e} of sigma_h)")
