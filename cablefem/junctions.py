"""The first-order correction at a network's interior kinks: each cable meets the others
at the rod's node, not at its string corner.

Where a cable of a network turns at a node (a junction of cables, a crossing, a loaded or
pinned node) by the angle ``Δ``, a cable with bending stiffness rounds the corner over a
boundary layer on each side, and its node (where the other cables, loads, masses and
dampers hold it) lies *inside* the corner of its straight outer parts by (docs/kinks.md)::

    o = N − C = (ℓ_r/2) (a + b),   ℓ_r = sqrt(EI/T) sqrt(1 + T/EA)

``a``, ``b`` the unit vectors from the node along the cable's two elements, ``T`` their
mean tension (``ℓ_r`` is the virtual hinge's distance ``λ∞ ℓ`` of a small angle). One
cable alone could put its corner at the node (a force at the node is the same force at the
corner for the outer string), but two cables crossing each have their own corner, on
opposite sides of the node for a saddle net's two families: a string net whose cables all
meet at one point moves each family's straight parts by ``|o|`` (a few millimetres), which
over a bay turns the clamp angles by a few percent. This term makes every cable's two
elements at such a node run to its corner ``C = N − o(x)``, with ``o`` computed from the
chords to the node (the chords to the corner differ by ``O(|o|/h)``: a second-order change
of ``o``), and the node's test function moved with it (``δC = δN − δo``): the elements'
forces act on the node through the layer, as a rigid link, and the node's equation is the
rod's. Exact at first order in ``ℓ`` for a small angle (the exact clamped layer's offset
differs by ``O(Δ²)`` relative: 0.1 % of the offset at ``Δ = 0.08``).

What is left out (second order): the elements' weight, inertia, fluid and damping forces
near the corner stay on the elements to the node (a share ``|o|/h`` of one element's);
``ℓ_r`` is capped at ``h/2.5`` (``h`` the shorter element) where the elements are shorter
than the layer (the correction is then partial and :func:`offset_estimate` says by how
much); a kink next to an element of a virtual hinge's region, or with a slack element,
is not corrected.

The term is assembled outside UFL (it couples a cable's two elements through the node,
which one cell integral cannot): :class:`JunctionCorners` adds its residual and Jacobian
(derived by complex-step differentiation of the residual, exact to round-off) to the
vectors and matrices the solvers assemble, on the lowest rank that holds its three
nodes, and its blocks
to the matrices' sparsity (:func:`create_matrix`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["JunctionCorners", "corners", "create_matrix", "add_residual",
           "add_jacobian", "junction_terms", "fixed_dofs", "junction_state", "kink_estimate",
           "set_active", "give_up",
           "CAP_RATIO",
           "REUSE"]

#: ``ℓ_r`` is at most the shorter element (stress-free) over this (as a damper's offset:
#: beyond it the offset feeds the mesh's zigzag)
CAP_RATIO = 2.0
#: fixed-point iterations for the corner (a fixed count: the complex step differentiates
#: through them; 0.4^14 = 3e-6 at the cap, 1e-14 at ℓ_r/h = 0.1)
_ITERATIONS = 16
#: the share of the estimated derivative the fixed point extrapolates with (the elements'
#: lengths lag an iteration: the full estimate overshoots on short elements); with 12
#: iterations (at most; fewer on long elements) the corner is converged to 1e-6 at
#: h = 2.3 ℓ_r, to 1e-8 at h = 10 ℓ_r
_EXTRAPOLATION = 0.5
#: where ``ℓ_r`` exceeds this many caps (a nearly slack cable) the offset fades with the
#: tension (``∝ T``) to none at zero tension
SLACK_RATIO = 10.0
#: the term's Jacobian is reused until a node moved by this share of the shortest element
REUSE = 1e-4
_STEP = 1e-30  # the complex step


def _dot(x, y):
    """Row-wise dot product without conjugation (complex-step safe)."""
    return np.sum(x * y, axis=-1)


def _tension(length, h, EA, tension_only: bool):
    """The string's law ``T = EA (L/h − 1)`` (``h`` stress-free), 0 in compression for a
    tension-only cable (decided on the real part)."""
    T = EA * (length / h - 1.0)
    return np.where(T.real > 0.0, T, 0.0) if tension_only else T


def _corner(r, h, EA, EI, cap):
    """``(o, δs)``: the rod node's offset from the string corner, ``o = N − C``, for the
    kinks' positions ``r`` (n, 3, 3: before, node, after; complex for the complex step),
    ``ℓ_r`` at most ``cap``, and the stress-free length each of the two elements gains
    when it runs to the corner instead of the layer's virtual hinge (its hinge removes
    ``σ_h``; the corner path is longer by ``h/cos φ``)."""
    # the chords from the corner itself and the tension of the lengthened elements: o and
    # δs from the node's chords, then from the corner and lengths they give, to a fixed
    # point. The node's chords alone make o low by a relative ℓ_r/h (10 % on the saddle
    # net), and the elements' own stress-free lengths raise T by EA δs/h (on fine meshes
    # as much as T itself)
    ends = r[:, 0::2]  # (n, 2, 3) the nodes before and after
    N = r[:, 1]
    o = np.zeros_like(N)
    ds = np.zeros(len(r), dtype=r.dtype)
    count = _ITERATIONS
    EAn = EA[:, None]
    for it in range(_ITERATIONS):
        if it == count:
            break
        d = ends - (N - o)[:, None, :]  # the chords from the corner
        L = np.sqrt(np.einsum("ijk,ijk->ij", d, d))
        T2 = EAn * (L / (h + ds[:, None]) - 1.0)  # the two elements' tensions
        T2 = np.where(T2.real > 0.0, T2, 0.0)
        T = 0.5 * (T2[:, 0] + T2[:, 1])  # (a sum over an axis of 2 costs 10 times more)
        taut = T.real > 0.0
        T = np.where(taut, T, 1.0)
        beta = T / EA
        ell = np.sqrt(EI / T * (1.0 + beta))
        # at most the cap; towards a slack cable (ℓ_r beyond SLACK_RATIO caps) it fades to
        # zero with the tension, so that the offset is continuous where the cable goes slack
        # (a jump from 0 to the cap there stalled statics' continuation from zero tension)
        fade = np.where(ell.real > SLACK_RATIO * cap, (SLACK_RATIO * cap / ell) ** 2, 1.0)
        ell = np.where(taut, np.where(ell.real > cap, cap * fade, ell), 0.0)
        inv = 1.0 / L
        s = np.einsum("ijk,ij->ik", d, inv)  # a + b, the unit chords' sum
        # extrapolated: across the chords the map's derivative is about +q, q = ℓ_r (1/L0
        # + 1/L1)/2 ≤ 1/CAP_RATIO (a corner further out is sharper), so (F − q o)/(1 − q),
        # with a share of q (the lengths lag an iteration), contracts faster
        q = 0.5 * ell * (inv[:, 0] + inv[:, 1])
        if it == 0 and len(q):  # as many as the largest q needs (1e-10; on the real part,
            # the same count for every complex step)
            rate = 0.7 * float(np.max(q.real))
            count = _ITERATIONS if not rate < 0.5 else int(  # (NaN: a wild iterate)
                np.clip(np.ceil(np.log(1e-10) / np.log(max(rate, 1e-3))), 2, _ITERATIONS))
        q = _EXTRAPOLATION * q
        o = ((0.5 * ell)[:, None] * s - q[:, None] * o) / (1.0 - q)[:, None]
        # per side (angle φ = Δ/2, |s|² = 4 sin² φ): (D_n tan φ + D_t)/λ∞ of the far
        # field (docs/theory.md §6) to O(φ²): ℓ0 φ² (3 + 2β)/(4 (1 + β)^(3/2)), with
        # ℓ0 = ℓ_r/sqrt(1 + β)
        ds = ell * np.einsum("ij,ij->i", s, s) * (3.0 + 2.0 * beta) / (16.0 * (1.0 + beta) ** 2)
    return o, ds


def corners(r, h, EA, EI):
    """The kinks' string corners and their elements' stress-free lengths: ``r`` (n, 3, 3)
    with the middle node moved to ``C = N − o``, and ``h + δs`` (n, 2) (``ℓ_r`` capped at
    ``min(h)/CAP_RATIO``, as the term does)."""
    o, ds = _corner(r, h, EA, EI, h.min(axis=1) / CAP_RATIO)
    out = np.array(r, float, copy=True)
    out[:, 1] -= o
    return out, h + ds[:, None]


def _residual(x, h, EA, EI, cap, tension_only, corrected: bool = True):
    """The two elements' internal forces on their three nodes (n, 9), ``[−f0, f0 − f1,
    f1]``: with ``corrected`` the elements run to the corner ``C = N − o(x)`` with their
    stress-free lengths lengthened by ``δs`` (:func:`_corner`), and the node
    takes the sum of their forces at the corner (the layer carries it to the rod's node:
    no moment, the node is free to turn); without, the plain string's (what the UFL
    forms assemble)."""
    P0, N, P1 = x[:, 0], x[:, 1], x[:, 2]
    if corrected:
        o, ds = _corner(x, h, EA, EI, cap)
        C, h = N - o, h + ds[:, None]
    else:
        C = N
    d0, d1 = C - P0, P1 - C
    L0, L1 = np.sqrt(_dot(d0, d0)), np.sqrt(_dot(d1, d1))
    f0 = _tension(L0, h[:, 0], EA, tension_only)[:, None] * d0 / L0[:, None]
    f1 = _tension(L1, h[:, 1], EA, tension_only)[:, None] * d1 / L1[:, None]
    return np.stack([-f0, f0 - f1, f1], axis=1).reshape(len(x), 9)


class JunctionCorners:
    """The corner term of a network's kinks (the module's docstring). ``items``: each
    kink's three local dof blocks (n, 3: before, node, after) on this rank, the kinks
    whose node this rank owns; ``X`` their reference positions (n, 3, 3); ``h``, ``EA``,
    ``EI``, ``cap`` as :func:`corner_offsets`; ``names`` the kinks' names."""

    def __init__(self, blocks, X, h, EA, EI, cap, names, tension_only: bool = True,
                 comm=None):
        self.blocks = np.asarray(blocks, np.int32).reshape(-1, 3)
        self.X = np.asarray(X, float).reshape(-1, 3, 3)
        self.h = np.asarray(h, float).reshape(-1, 2)
        self.EA, self.EI = np.asarray(EA, float), np.asarray(EI, float)
        self.EI0 = self.EI  # the section's (set_active scales EI for a continuation)
        self.cap = np.asarray(cap, float)
        self.names = list(names)
        self.tension_only = tension_only
        self.comm = comm
        #: off: the term adds nothing (statics finds the plain string's equilibrium first)
        self.active = True
        self._K = self._xK = None  # the last Jacobian and where it was made
        self._hmin = float(self.h.min()) if len(self.h) else 0.0
        self._flat = (3 * self.blocks[:, :, None] + np.arange(3, dtype=np.int32)
                      ).reshape(-1, 9).astype(np.int32)

    def __len__(self) -> int:
        return len(self.blocks)

    def positions(self, u_local: np.ndarray) -> np.ndarray:
        """(n, 3, 3) the current positions from the displacement's local array (owned and
        ghost entries, 3 per node)."""
        return self.X + u_local[self._flat].reshape(-1, 3, 3)

    def residual(self, u_local: np.ndarray) -> np.ndarray:
        """(n, 9) the correction of the three nodes' rows: the corner's forces less the
        plain string's, which the forms assemble."""
        x = self.positions(u_local)
        args = (self.h, self.EA, self.EI, self.cap, self.tension_only)
        return _residual(x, *args) - _residual(x, *args, corrected=False)

    def jacobian(self, u_local: np.ndarray) -> np.ndarray:
        """(n, 9, 9) the derivative of :meth:`residual` (complex step, in one batch:
        exact to round-off). The residual depends on the three nodes' differences only (a
        rigid translation of a kink moves nothing), so the node's three columns are minus
        the sum of its neighbours': six complex steps, not nine."""
        x = self.positions(u_local)
        n = len(x)
        if not n:
            return np.zeros((0, 9, 9))
        dirs = np.r_[0:3, 6:9]  # the neighbours' coordinates
        xs = np.repeat(x.reshape(n, 1, 9), 6, axis=1).astype(complex)  # (n, 6 dirs, 9)
        xs[:, np.arange(6), dirs] += 1j * _STEP
        xs = xs.reshape(6 * n, 3, 3)
        rep = (lambda a: np.repeat(a, 6, axis=0))
        args = (rep(self.h), rep(self.EA), rep(self.EI), rep(self.cap), self.tension_only)
        col = (_residual(xs, *args) - _residual(xs, *args, corrected=False)).imag / _STEP
        col = col.reshape(n, 6, 9)
        K = np.empty((n, 9, 9))
        K[:, :, dirs] = np.transpose(col, (0, 2, 1))
        K[:, :, 3:6] = -(K[:, :, 0:3] + K[:, :, 6:9])
        return K

    def add_residual(self, arr: np.ndarray, u_local: np.ndarray) -> None:
        """Add the correction into ``arr``, a vector's local form (owned and ghost entries,
        before the ghosts are added to their owners)."""
        if len(self) and self.active:  # kinks share nodes (a crossing): summed, as
            # np.add.at does, by one bincount (np.add.at: 3.4 ms for the roof's 3200 kinks)
            arr += np.bincount(self._flat.ravel(), self.residual(u_local).ravel(),
                               minlength=arr.size)[:arr.size]

    def add_jacobian(self, A, u_local: np.ndarray, fixed: np.ndarray | None = None) -> None:
        """Add the correction's Jacobian into ``A`` (local indices, ADD; flushed before).
        ``fixed``: unrolled local dofs whose rows and columns are left alone (Dirichlet rows
        and columns a matrix assembled with its conditions has zeroed)."""
        from petsc4py import PETSc

        A.assemblyBegin(PETSc.Mat.AssemblyType.FLUSH)
        A.assemblyEnd(PETSc.Mat.AssemblyType.FLUSH)
        if not self.active:  # zeros: an assembled matrix drops the entries never set
            if len(self):
                A.setValuesBlockedLocalRCV(self.blocks, self.blocks,
                                           np.zeros((len(self), 81)),
                                           addv=PETSc.InsertMode.ADD)
            return
        x = self.positions(u_local)
        # the term's Jacobian is a small part of the whole (~ℓ/h of the two elements'):
        # made again only when a node moved by more than REUSE of the shortest element
        # since (then its change, ~1e-3 of it, slows Newton by ~1e-6 per iteration);
        # decided on all ranks alike, so that serial and parallel runs iterate alike
        moved = self._K is None or (len(self) and bool(
            np.max(np.abs(x - self._xK)) > REUSE * self._hmin))
        if self.comm is not None and self.comm.size > 1:
            from mpi4py import MPI
            moved = self.comm.allreduce(moved, op=MPI.LOR)
        if moved:
            self._K, self._xK = self.jacobian(u_local), x
        if not len(self):
            return
        K = self._K
        if fixed is not None and fixed.size:
            keep = ~np.isin(self._flat, fixed)
            K = K * keep[:, :, None] * keep[:, None, :]
        # blocked (AIJ and BAIJ alike), every kink's 9 x 9 block in one call: the same
        # additions in the same order as one call per kink (3 200 calls, 8 ms, on the
        # 94 000-dof roof)
        A.setValuesBlockedLocalRCV(self.blocks, self.blocks,
                                   np.ascontiguousarray(K).reshape(len(K), 81),
                                   addv=PETSc.InsertMode.ADD)

    def element_tensions(self, u_local: np.ndarray) -> np.ndarray:
        """(n, 2) the tensions of each kink's two elements, run to the corner with their
        lengthened stress-free lengths (the forces :meth:`residual` applies)."""
        x = self.positions(u_local)
        if not len(x):
            return np.zeros((0, 2))
        o, ds = _corner(x, self.h, self.EA, self.EI, self.cap)
        d = x[:, 0::2] - (x[:, 1] - o)[:, None, :]
        L = np.linalg.norm(d, axis=2)
        T = self.EA[:, None] * (L / (self.h + ds[:, None]) - 1.0)
        return np.maximum(T, 0.0) if self.tension_only else T

    def insert_pattern(self, pattern) -> None:
        """Every item's 3 x 3 dof blocks into a sparsity pattern (blocked local indices)."""
        for b in self.blocks:
            pattern.insert(b, b)



def create_matrix(model, form, mat_type: str | None = None):
    """``form``'s matrix, with the blocks of the model's node terms in its sparsity
    pattern (dolfinx's own matrix when it has none)."""
    from dolfinx import cpp as dcpp
    from dolfinx.fem import petsc as fpetsc

    terms = model.node_terms
    if not terms:
        return fpetsc.create_matrix(form, mat_type) if mat_type else fpetsc.create_matrix(form)
    V = form.function_spaces[0]
    mesh = V.mesh
    pattern = dcpp.fem.create_sparsity_pattern(
        mesh.topology, [form.function_spaces[0].dofmap, form.function_spaces[1].dofmap],
        set(form.integral_types))
    for t in terms:
        t.insert_pattern(pattern)
    pattern.assemble()
    return dcpp.la.petsc.create_matrix(mesh.comm, pattern, mat_type or "")


def set_active(model, on: bool, share: float = 1.0) -> None:
    """Switch the model's node terms on or off (statics solves the plain string first);
    ``share``: the corners' layers at that share of their length (``EI`` times its
    square), for a continuation."""
    for t in model.node_terms:
        t.active = on
        t.EI = t.EI0 * share ** 2
        t._K = None


def give_up(model, why: str) -> None:
    """Leave every kink at the node (the node terms off for the run), with a warning and
    the kinks in ``model.junction_gaps`` (their offsets then count in full in the
    estimates)."""
    set_active(model, False)
    names = sorted(model.corner_kinks)
    model.junction_gaps = list(model.junction_gaps) + [(n, why) for n in names]
    model.corner_kinks = frozenset()
    model.warnings.append(("kinks", f"the {len(names)} kink(s) of the network are left at "
                           f"the string's corner, not the rod's node: {why}; a first-order "
                           "error, in the anchors' and kinks' estimates (docs/theory.md "
                           "§6.3)"))


def _local_array(model) -> np.ndarray:
    return model.u.x.array


def fixed_dofs(model) -> np.ndarray:
    """The anchors' prescribed unrolled local dofs (the rows and columns a matrix
    assembled with the model's conditions has zeroed)."""
    parts = [np.asarray(a.flat_dofs, np.int64) for a in model.anchors]
    return np.concatenate(parts) if parts else np.zeros(0, np.int64)


def add_residual(model, arr: np.ndarray) -> None:
    """Add the model's node terms to a residual's local form ``arr`` at ``model.u``."""
    for t in model.node_terms:
        t.add_residual(arr, _local_array(model))


def add_jacobian(model, A, fixed: np.ndarray | None = None) -> None:
    """Add the model's node terms' Jacobian at ``model.u`` into ``A`` (``fixed``: rows and
    columns left alone, :meth:`JunctionCorners.add_jacobian`)."""
    for t in model.node_terms:
        t.add_jacobian(A, _local_array(model), fixed)


def junction_terms(model) -> tuple:
    """The network's corner term (:class:`JunctionCorners`) at every kink
    (:func:`cablefem.kinks.network_kinks` with ``"all"``, whatever ``network.kinks``
    reports) whose node this rank owns, on the default route (``solver.outer_correction
    = "hinge"``); () at leading order, for a model without bending stiffness or one that
    resolves its layers (``kink_offsets`` false: the rod), or when no kink is corrected on
    any rank. Kinks next to a virtual hinge's region are left out
    (``model.junction_gaps`` names them)."""
    model.junction_gaps = []
    if (model.case.solver.outer_correction != "hinge" or model.string_alone
            or not model.kink_offsets):  # a rod resolves its kinks' layers
        return ()
    kinks = _all_kinks(model)
    region = set()
    for hg in (model.hinges.items if model.hinges else ()):
        region |= {int(e) for e in hg.elements[:hg.touched]}
    line, geo = model.line, model.geometry
    block = _blocks(model)
    model.corner_kinks = set()
    corrected = []
    for k in kinks:
        if region & set(k.cells):
            model.junction_gaps.append((k.name, "next to a virtual hinge's region"))
            continue
        model.corner_kinks.add(k.name)
        corrected.append(k)
    keep = _mine(model, corrected, block)
    if model.comm.allreduce(len(keep), op=_sum()) == 0:
        return ()
    term = _term(model, keep, block)
    # every kink whose three nodes are here, owned or not: the cells' own tensions
    # (:meth:`JunctionCorners.element_tensions`, the network's tension field)
    seen = [k for k in kinks if k.name in model.corner_kinks and np.all(block[list(k.nodes)] >= 0)]
    cell_of = np.full(len(geo.cells), -1, np.int64)
    ref = line.reference_cells()
    cell_of[ref] = np.arange(ref.size)
    model.corner_report = (_term(model, seen, block),
                           np.array([cell_of[list(k.cells)] for k in seen],
                                    np.int64).reshape(-1, 2))
    return (term,)


def _all_kinks(model) -> list:
    """:func:`cablefem.kinks.network_kinks` with ``"all"``, found once per model (the
    mesh and the anchors do not change; a walk over every cell, 0.4 s on a 33 000-cell
    roof): the list is shared, not to be changed."""
    kinks = getattr(model, "_all_kinks", None)
    if kinks is None:
        from cablefem.kinks import network_kinks

        kinks = model._all_kinks = network_kinks(model, which="all", record=False)
    return kinks


def _blocks(model) -> np.ndarray:
    """The local dof block of every reference node (-1: not on this rank)."""
    nodes = model.line.dof_nodes(model.V)
    block = np.full(len(model.geometry.points), -1, np.int64)
    block[nodes] = np.arange(nodes.size)
    return block


def _mine(model, kinks, block) -> list:
    """The kinks this rank computes (collective): each on the lowest rank that holds its
    three nodes (owned or ghosts; the node's owner need not: dolfinx ghosts the cells
    next to a rank's own cells, not to its own vertices). RuntimeError on every rank when
    none does."""
    here = np.array([bool(np.all(block[list(k.nodes)] >= 0)) for k in kinks], bool)
    every = np.array(model.comm.allgather(here)).reshape(model.comm.size, len(kinks))
    if len(kinks) and not every.any(axis=0).all():
        k = kinks[int(np.argmin(every.any(axis=0)))]
        raise RuntimeError(f"kink {k.name}: no rank holds its node and both neighbours")
    first = np.argmax(every, axis=0) if len(kinks) else np.zeros(0, int)
    return [k for k, r in zip(kinks, first) if r == model.comm.rank]


def _term(model, kinks, block) -> JunctionCorners:
    secs = model.case.network.sections
    pts = np.asarray(model.geometry.points, float)
    h = np.array([k.h for k in kinks], float).reshape(-1, 2)
    return JunctionCorners(
        [block[list(k.nodes)] for k in kinks], [pts[list(k.nodes)] for k in kinks], h,
        [secs[k.section].EA for k in kinks], [secs[k.section].EI for k in kinks],
        h.min(axis=1) / CAP_RATIO, [k.name for k in kinks], model.tension_only, model.comm)


def junction_state(model) -> None:
    """Each kink's string-corner offset at the model's current state (collective), as
    ``model.junction_offsets``: ``{node: [(kink, |o|, applied, Δ), ...]}`` on every rank,
    ``|o| = ℓ_r sin(Δ/2)`` the whole offset, ``applied`` the share the corner term applies
    (0 where it does not: leading order, next to a hinge's region), ``Δ`` the kink's angle
    (for the anchors' error estimate, :meth:`cablefem.network.NetworkModel.
    anchor_junction_offset`)."""
    if model.string_alone:
        model.junction_offsets = {}
        return
    kinks = _all_kinks(model)
    block = _blocks(model)
    mine = _mine(model, kinks, block)
    out = []
    if mine:
        t = _term(model, mine, block)
        x = t.positions(model.u.x.array)
        o, _ = _corner(x, t.h, t.EA, t.EI, np.full(len(x), np.inf))  # the whole offset
        C = x[:, 1] - o
        a = x[:, 0] - C
        b = x[:, 2] - C
        cos = np.sum(a * b, axis=1) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
        delta = np.pi - np.arccos(np.clip(cos, -1.0, 1.0))
        size = np.linalg.norm(o, axis=1)
        for k, so, d, cap in zip(mine, size, delta, t.cap):
            ell = so / max(np.sin(0.5 * d), 1e-300)
            applied = (min(1.0, cap / ell) if ell > 0 else 1.0) \
                if k.name in model.corner_kinks and model.node_terms else 0.0
            out.append((k.node, k.name, float(so), float(applied), float(d)))
    state: dict[int, list] = {}
    for part in model.comm.allgather(out):
        for node, name, so, applied, d in part:
            state.setdefault(int(node), []).append((name, so, applied, d))
    model.junction_offsets = state


def kink_estimate(model, kink, delta: float, ell: float) -> float:
    """The static moment's estimated relative error at ``kink`` (a
    :class:`cablefem.kinks.Kink` of angle ``delta`` and layer length ``ell``): the outer
    problem's next order, ``(ℓ (1/d₁ + 1/d₂))²`` over the spans ``d`` to the next kink,
    anchor, junction or end each way (the sides' first order is the corner's), plus what
    the string leaves of the rod node offsets at the kink's node (all the cables there:
    the node moves with each), ``δ = Σ |o| [(1 − applied) + applied Δ²/4]``, which turns
    the sides by ``δ/d`` and the angle by ``δ (1/d₁ + 1/d₂)``; NaN without the sides or
    the angle."""
    sides = [d for d in getattr(kink, "sides", ()) if d and np.isfinite(d)]
    if len(sides) < 2 or not (delta > 0) or not (ell > 0):
        return float("nan")
    inv = 1.0 / sides[0] + 1.0 / sides[1]
    left = sum(so * ((1.0 - ap) + ap * d * d / 4.0)
               for _, so, ap, d in model.junction_offsets.get(int(kink.node), ()))
    return float((ell * inv) ** 2 + left * inv / delta)


def _sum():
    from mpi4py import MPI
    return MPI.SUM


def set_corner_cells(model, f, values) -> None:
    """Set the cell field ``f`` (one value per cell, on ``model.W``) on the corrected
    kinks' two elements to ``values(term)`` (per kink, its two elements) of the corner
    term (``model.corner_report``), on every rank that holds those cells (collective). The
    term lives on the rank that holds a kink's three nodes; a cell of its another rank
    owns gets its value through the cells' ghost exchange (before, the owner kept the
    chord's value)."""
    from dolfinx import fem, la

    W = f.function_space
    n_owned = W.dofmap.index_map.size_local
    sent, count = fem.Function(W), fem.Function(W)
    report = model.corner_report
    if report is not None and len(report[0]):
        term, cells = report
        idx = W.dofmap.list.array[cells.ravel()]
        vals = np.asarray(values(term), float).ravel()
        own = idx < n_owned
        f.x.array[idx[own]] = vals[own]
        sent.x.array[idx[~own]] = vals[~own]
        count.x.array[idx[~own]] = 1.0
    for g in (sent, count):  # each ghost's value to the cell's owner
        g.x.scatter_reverse(la.ScatterMode.add)
    got = np.flatnonzero(count.x.array[:n_owned] > 0)
    f.x.array[got] = sent.x.array[got] / count.x.array[got]
    f.x.scatter_forward()
