"""The time integrator's residual and Jacobian assembled in C (``native_rows.c``), for a
model on one rank whose residual is its UFL forms alone.

:class:`cablefem.petsc_utils.RowsAssembler` calls dolfinx's compiled kernels through its
Python wrappers: on paper case B (63 unknowns) a residual costs 65 µs and a Jacobian 87 µs,
of which the kernels and their sums are about 7 µs and 19 µs (docs/benchmarks.md). Here
the cell loops, the copy of the state (u, v, a) into the packed coefficients and the
anchors' rows ``kappa (x - g)`` are one C call each, with the same kernels (FFCx's
``tabulate_tensor``), the same sums in the same order, so the same numbers to the last
bit. Python still sets the model's time, the constants and the other coefficients (once
per time: :meth:`NativeRows.at`). PETSc's TS calls the C side directly
(:meth:`NativeRows.drive`): Python only at a new time and for the Jacobian's decision.
The anchor forces are one C call too (:meth:`NativeRows.anchor_forces`).

The C file is compiled once with the system's C compiler into the FFCx cache folder, next
to the forms' kernels, and linked against the PETSc library petsc4py uses. Where it
cannot be (no compiler), or the model is outside what it does (several ranks, terms
outside UFL, integrals over exterior facets, more than :data:`MAX_PARTS` integrals,
elements with dof transformations), :func:`native_rows` returns None and the caller keeps
:class:`~cablefem.petsc_utils.RowsAssembler`. ``-<prefix>native_assembly false`` (or
``solver.petsc_options``) asks for the Python route.
"""

from __future__ import annotations

import ctypes
import logging
import math

import numpy as np
from dolfinx import cpp as dcpp
from petsc4py import PETSc

from cablefem.native_lib import (
    AT_CALL,
    DECIDE_CALL,
    MAX_PARTS,
    PYTHON_ERROR,
    Anchors,
    Ctx,
    Part,
    Watched,
    library,
)

__all__ = ["Anchors", "NativeRows", "Watched", "native_rows", "library"]

log = logging.getLogger(__name__)

def _address(cdata) -> int:
    """A cffi function pointer's address, through cffi's compiled backend (``cffi.FFI()``
    would import its C parser, pycparser: 0.1 s at every run's start)."""
    import _cffi_backend

    return int(_cffi_backend.FFI().cast("uintptr_t", cdata))


def _integrals(F, jacobians) -> list[tuple] | None:
    """The integrals of the residual ``F`` in dolfinx's order (over cells, then interior
    facets, each by its id), with its Jacobians' (the whole one, and its fast and slow
    parts or None): [(key, F's kernel's address, [each Jacobian's kernel's address there,
    or None])]; None when ``F`` has no integral over the cells, one over exterior facets,
    more than :data:`MAX_PARTS`, or a Jacobian has an integral ``F`` has not."""
    types = dcpp.fem.IntegralType
    kinds = ((types.cell, 0), (types.interior_facet, 2), (types.exterior_facet, 1))
    ids = {kind: list(F.integral_ids(kind)) for kind, _ in kinds}
    if (not ids[types.cell] or ids[types.exterior_facet]
            or len(ids[types.cell]) + len(ids[types.interior_facet]) > MAX_PARTS):
        return None
    forms = [F, *jacobians]
    for form in forms:
        if form is None:
            continue
        for kind, cls in kinds:
            own = list(form.integral_ids(kind))
            if not set(own) <= set(ids[kind]) or form.ufcx_form.num_integrals(cls) != len(own):
                return None
    out = []
    for kind, cls in kinds[:2]:
        for i in ids[kind]:
            addr = []
            for form in forms:
                uf = None if form is None else form.ufcx_form
                own = [] if uf is None else [uf.integral_ids(cls)[k]
                                             for k in range(uf.num_integrals(cls))]
                addr.append(_address(uf.integrals(cls)[own.index(i)].tabulate_tensor_float64)
                            if i in own else None)
            out.append(((kind, i), addr[0], addr[1:]))
    return out


def native_rows(model, rows, options_prefix: str) -> NativeRows | None:
    """A :class:`NativeRows` for ``rows`` (a :class:`~cablefem.petsc_utils.RowsAssembler`
    of ``model``), or None: the model is outside what it does (see the module), the
    option ``-<options_prefix>native_assembly`` is false, or it cannot be compiled."""
    if not PETSc.Options().getBool(options_prefix + "native_assembly", True):
        return None
    parts = rows.parts or [(None, None), (None, None)]  # the Jacobian's fast, slow part
    if (model.comm.size != 1 or rows.extra is not None or rows.gather is None
            or rows.others is None or rows.cols is None
            or any(form is not None and cols is None for form, cols in parts)
            or model.V.element.needs_dof_transformations
            or model.V.dofmap.index_map.local_range[0] != 0):  # local numbers: global
        return None
    integrals = _integrals(rows.F, [rows.J, parts[0][0], parts[1][0]])
    if integrals is None:
        return None
    if any(not np.shares_memory(bc.g.x.array, model.u_bc.x.array) for bc in rows.bcs):
        return None  # the prescribed values: model.u_bc's
    lib = library()
    if lib is None:
        return None
    return NativeRows(lib, model, rows, integrals)


class NativeRows:
    """The residual and Jacobian of ``rows`` (a :class:`~cablefem.petsc_utils.
    RowsAssembler`) by one C call each (made by :func:`native_rows`; ``rows.native`` is
    then this object, so that ``rows.forget()`` also reaches it). The state comes from the
    vectors given; :meth:`at` brings the time, the constants and the other coefficients up
    to date."""

    def __init__(self, lib, model, rows, integrals) -> None:
        self.lib, self.model, self.rows = lib, model, rows
        self._keep = []  # every array the C side points into
        ptr = self._ptr
        packed = rows.coefficients(None)  # the packing's shapes
        rows.forget()  # packed now, before the caller sets its time and state
        bs = model.V.dofmap.bs
        c = self.ctx = Ctx()
        c.bs, c.n_parts = bs, len(integrals)
        #: (key, the C side's copy of the residual's packing there), per integral
        self.packs = []
        widest = [1, 1]  # an element vector's nodes, the Jacobian's coefficients
        #: the Jacobian's forms and their columns of the residual's packing: the whole
        #: one, its fast and its slow part (None without a split)
        self.jacobians = [(rows.J, rows.cols), *(rows.parts or [(None, None)] * 2)]
        for part, (key, kf, kj) in zip(c.parts, integrals):
            w = np.array(packed[key], np.float64, order="C")
            self.packs.append((key, w))
            self._part(part, key, w, kf, kj)
            widest = [max(widest[0], part.nodes), max(widest[1], *part.stride_j)]
        #: the other Functions (a time law's, a hinge's law), copied into this side's
        #: packing where they changed, compared with what was packed here (their own notes:
        #: the Python route's packing keeps its own)
        self.others = [(arr, items) for arr, _, items in rows.others]
        self.wpacks = dict(self.packs)
        self._others_seen = Watched(lib, [arr for arr, _ in self.others])
        #: the packed constants of the residual and of each Jacobian (never empty)
        forms = [rows.F, *(f for f, _ in self.jacobians if f is not None)]
        self.consts = [np.zeros(dcpp.fem.pack_constants(form).size + 1) for form in forms]
        #: every form's Constants' values (views) where the forms name them and their
        #: packing is theirs in that order (None: packed afresh at every new time), and
        #: their bytes as last packed
        self.constant_values = _constant_values(forms)
        self._constants_seen = (None if self.constant_values is None
                                else Watched(lib, self.constant_values))
        self._constants_packed = False
        c.const_f = ptr(self.consts[0])
        for k, arr in enumerate(self.consts[1:]):
            c.const_j[k] = ptr(arr)
        bc_dofs = np.concatenate([bc.dof_indices()[0] for bc in rows.bcs]
                                 ).astype(np.int32) if rows.bcs else np.zeros(0, np.int32)
        c.n_bc, c.bc_dofs = bc_dofs.size, ptr(bc_dofs)
        c.g = ptr(model.u_bc.x.array)
        anchor_rows = np.ascontiguousarray(rows.rows, PETSc.IntType)
        c.n_rows, c.rows, c.kappa = anchor_rows.size, ptr(anchor_rows), rows.kappa
        c.n_local = model.u.x.array.size
        nd = widest[0] * bs
        c.be, c.ae, c.wj = ptr(np.zeros(nd)), ptr(np.zeros(nd * nd)), ptr(np.zeros(widest[1]))
        c.block_dofs = ptr(np.zeros(widest[0], PETSc.IntType))
        self._ref = ctypes.byref(c)
        #: the time of the last :meth:`at` (None: :meth:`RowsAssembler.forget` since)
        self.time: float | None = None
        #: the model's u, v, a as PETSc vectors (the residual's state is copied into them)
        self.state = [f.vector for f in (model.u, model.v, model.a)]
        for k, vec in enumerate(self.state):
            c.state[k] = vec.handle
        c.time = math.nan
        #: an exception raised in a call from the C side, raised again by :meth:`reraise`
        self.error: BaseException | None = None
        self._calls = None  # drive's callbacks (kept alive while the C side holds them)

    def _ptr(self, a: np.ndarray) -> int:
        self._keep.append(a)
        return a.ctypes.data

    def _part(self, part: Part, key, w: np.ndarray, kf: int, kj: list) -> None:
        """``part`` filled for the integral ``key``: its entities (cells, or interior
        facets: both cells), their nodes, coordinates and coefficients ``w``, as
        dolfinx's assemblers lay them out."""
        model, rows, ptr = self.model, self.rows, self._ptr
        dofmap = model.V.dofmap.list.array.reshape(-1, model.V.dofmap.dof_layout.num_dofs)
        geo = model.mesh.geometry
        gdofs = geo.dofmap.array.reshape(len(geo.dofmap), -1)
        where = np.asarray(rows.F.domains(*key), np.int32)
        part.facets = int(key[0] == dcpp.fem.IntegralType.interior_facet)
        if part.facets:  # (facet, side, (cell, local facet)): both cells' nodes in turn
            cells, local = where[:, :, 0], np.ascontiguousarray(where[:, :, 1])
            part.local = ptr(local)
            topology = model.mesh.topology
            topology.create_entity_permutations()
            per_cell = dcpp.mesh.cell_num_entities(topology.cell_type, topology.dim - 1)
            perms = topology.get_facet_permutations()[cells * per_cell + local]
            part.perms = ptr(np.ascontiguousarray(perms, np.uint8))
        else:
            cells = where.reshape(-1, 1)
        part.n = cells.shape[0]
        part.nodes = cells.shape[1] * dofmap.shape[1]
        part.dofs = ptr(np.ascontiguousarray(dofmap[cells].reshape(part.n, -1), np.int32))
        coords = np.ascontiguousarray(geo.x[gdofs[cells]].reshape(part.n, -1), np.float64)
        part.coords, part.coord_stride = ptr(coords), coords.shape[1]
        part.kernel_f = kf
        part.w_f = ptr(w)
        part.stride_f = w.size // part.n if part.n else 0
        for k, ((_, cols), kernel) in enumerate(zip(self.jacobians, kj)):
            if kernel is not None:
                cols = np.ascontiguousarray(cols[key], np.int32)
                part.kernel_j[k], part.stride_j[k], part.cols_j[k] = kernel, cols.size, ptr(cols)
        arrays = [f.x.array for f in (model.u, model.v, model.a)]
        for pos, arr, src in rows.gather.get(key, []):
            s = next(i for i, a in enumerate(arrays) if np.shares_memory(a, arr))
            part.n_state[s] = pos.size
            part.pos[s] = ptr(np.ascontiguousarray(pos, np.int64))
            part.src[s] = ptr(np.ascontiguousarray(src, np.int32))

    def at(self, t: float) -> None:
        """The model's time ``t``, and the packed constants and other coefficients at it
        (nothing at the time of the last call, without :meth:`RowsAssembler.forget`
        since)."""
        if t == self.time:
            return
        self.model.set_time(t)
        # the other Functions where they changed (the state: copied in by the C side)
        seen = self._others_seen
        if seen.changed():
            for i in np.flatnonzero(seen.flags).tolist():
                arr, items = self.others[i]
                for key, pos, src in items:
                    self.wpacks[key].reshape(-1)[pos] = arr[src]
        if (self._constants_seen is None or not self._constants_packed
                or self._constants_seen.changed()):
            self.constants()
        self.time = self.ctx.time = t

    def forget(self) -> None:
        """The next :meth:`at` brings everything up to date, even at the same time."""
        self.time, self.ctx.time = None, math.nan

    def drive(self, ts: PETSc.TS, F: PETSc.Vec, J: PETSc.Mat, decide,
              same: bool = False) -> None:
        """Have ``ts`` call the C side for its residual (into ``F``) and Jacobian (into
        ``J``) without Python between them: Python is called at a new time (:meth:`at`)
        and for the Jacobian's ``decide(shift_v, shift_a)``, which returns 0 when ``J``
        is done (kept, or assembled by the caller) and 1 when the whole Jacobian is to be
        assembled by the C side (its constants packed). ``same``: ``decide`` returns 1
        and changes nothing else whenever the shifts are those of its last 1 (no reuse,
        no split): the C side then assembles without asking, and counts those
        assemblies (:attr:`assembled`). The same numbers as :meth:`residual` and
        :meth:`jacobian` called from Python. An exception in those calls fails the step
        with a PETSc error: :meth:`reraise` raises it instead."""
        def at(t: float) -> int:
            try:
                self.at(t)
                return 0
            except BaseException as err:  # noqa: BLE001 - handed back by reraise
                self.error = err
                return PYTHON_ERROR

        def decision(shift_v: float, shift_a: float) -> int:
            try:
                return int(decide(shift_v, shift_a))
            except BaseException as err:  # noqa: BLE001 - handed back by reraise
                self.error = err
                return -PYTHON_ERROR

        self._calls = (AT_CALL(at), DECIDE_CALL(decision))
        c = self.ctx
        c.same, c.shift_v, c.shift_a = int(same), math.nan, math.nan
        c.at, c.decide = (ctypes.cast(f, ctypes.c_void_p).value for f in self._calls)
        _check(self.lib.cablefem_drive(self._ref, ts.handle, F.handle, J.handle))

    @property
    def assembled(self) -> int:
        """Whole Jacobians the C side assembled without asking (:meth:`drive`'s
        ``same``)."""
        return self.ctx.assembled

    def reraise(self) -> None:
        """Raise the exception of a call from the C side, if one failed (once)."""
        err, self.error = self.error, None
        if err is not None:
            raise err

    def constants(self) -> None:
        """The forms' constants packed again (the Jacobian's shifts, a time law's)."""
        forms = [self.rows.F, *(f for f, _ in self.jacobians if f is not None)]
        for form, arr in zip(forms, self.consts):
            packed = dcpp.fem.pack_constants(form)
            arr[:packed.size] = packed
        if self._constants_seen is not None:
            self._constants_seen.changed()  # the values packed: those seen now
            self._constants_packed = True

    def residual(self, t: float, U: PETSc.Vec, V: PETSc.Vec, A: PETSc.Vec,
                 F: PETSc.Vec) -> None:
        """The time integrator's residual at ``t`` and the state ``U``, ``V``, ``A`` into
        ``F``: :meth:`RowsAssembler.residual`'s numbers. The state is also copied into
        the model's Functions after the time is set, as the Python route does: a time law
        that reads them (a wave's kinematics where the cable is) sees the state of the last
        residual, also between outputs and in the integrator's start-up steps."""
        self.at(t)
        for X, y in zip((U, V, A), self.state):
            X.copy(y)  # one rank: no ghosts
        _check(self.lib.cablefem_residual(self._ref, U.handle, V.handle, A.handle,
                                          F.handle))

    def cells(self, t: float, U: PETSc.Vec, V: PETSc.Vec, A: PETSc.Vec,
              F: PETSc.Vec) -> None:
        """The residual's cells alone (no anchor rows) at ``t`` and ``U``, ``V``, ``A``
        into ``F``: the anchor forces' assembly (:mod:`cablefem.reactions`)."""
        self.at(t)
        _check(self.lib.cablefem_cells(self._ref, U.handle, V.handle, A.handle, F.handle))

    def forces(self, t: float, ksp: PETSc.KSP, M_full: PETSc.Mat, R: PETSc.Vec,
               work: tuple, zero: np.ndarray) -> int:
        """The dynamic part of :meth:`cablefem.reactions.AnchorReactions.compute` in one
        call, the same operations: with ``model.a`` holding the anchors' prescribed
        accelerations and zeros elsewhere, ``R = F(u, v, a_b)``, the mass solve ``M da =
        -R`` (rows ``zero`` of the right-hand side zeroed) with ``ksp``, ``a += da`` and
        ``R += M_full da``. ``work``: the vectors ``(rhs, da, M da)``. Returns the KSP's
        converged reason."""
        self.at(t)
        m, reason = self.model, ctypes.c_int(0)
        rhs, da, Mda = work
        _check(self.lib.cablefem_forces(
            self._ref, ksp.handle, M_full.handle, m.u.vector.handle, m.v.vector.handle,
            m.a.vector.handle, R.handle, rhs.handle, da.handle, Mda.handle, zero.size,
            zero.ctypes.data, ctypes.byref(reason)))
        return reason.value

    def anchor_forces(self, anchors: Anchors, acc: np.ndarray, out: np.ndarray,
                      ksp: PETSc.KSP, M_full: PETSc.Mat, R: PETSc.Vec, work: tuple,
                      zero: np.ndarray):
        """A call ``f(t)`` (returning the KSP's reason) that does :meth:`forces` with
        ``model.a`` first set to the anchors' accelerations ``acc`` (n, 3) at their rows
        and zero elsewhere, and then reads the anchor forces into ``out`` (n, 3): ``-R``
        at each anchor's rows, plus a virtual hinge's layer force (:class:`Anchors`; the
        operations of :meth:`cablefem.reactions.AnchorReactions.compute`). Its arguments
        are converted once: keep them (and their buffers) alive while ``f`` is used."""
        m, reason = self.model, ctypes.c_int(0)
        rhs, da, Mda = work
        ptr = ctypes.c_void_p
        args = (self._ref, ctypes.byref(anchors), *(ptr(a.ctypes.data) for a in (acc, out)),
                *(ptr(obj.handle) for obj in (ksp, M_full, m.u.vector, m.v.vector,
                                              m.a.vector, R, rhs, da, Mda)),
                ctypes.c_int32(zero.size), ptr(zero.ctypes.data), ctypes.byref(reason))
        call, at = self.lib.cablefem_anchor_forces, self.at

        def forces(t: float) -> int:
            at(t)
            _check(call(*args))
            return reason.value

        return forces

    def jacobian(self, J: PETSc.Mat, constants: bool = False, slow: bool = True) -> None:
        """The Jacobian at the state of the last :meth:`residual` into ``J``:
        :meth:`RowsAssembler.jacobian`'s numbers and steps (with a split Jacobian: its
        fast part, and its slow part as last assembled unless ``slow``). ``constants``:
        pack the constants again first (the time integrator's shifts changed)."""
        if constants:
            self.constants()
        lib, rows = self.lib, self.rows
        if rows.parts is None:
            return _check(lib.cablefem_jacobian(self._ref, J.handle, 0, 1))
        _check(lib.cablefem_jacobian(self._ref, J.handle, 1, 0))
        if slow or rows.A_slow is None:
            if rows.A_slow is None:  # J's pattern (assembled: it can be duplicated)
                rows.A_slow = J.duplicate()
            _check(lib.cablefem_jacobian(self._ref, rows.A_slow.handle, 2, 0))
        J.axpy(1.0, rows.A_slow, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        J.zeroRowsLocal(rows.rows, diag=rows.kappa)


def _constant_values(forms: list) -> list[np.ndarray] | None:
    """The values (views) of every Constant of ``forms``, in order, when each form names
    its Constants (``cablefem_constants``: :func:`cablefem.forms._form`) and their values
    side by side are its packing; None otherwise."""
    out = []
    for form in forms:
        held = getattr(form, "cablefem_constants", None)
        if held is None:
            return None
        values = [c.value for c in held]
        packed = dcpp.fem.pack_constants(form)
        mine = np.concatenate([v.ravel() for v in values]) if values else np.zeros(0)
        if mine.tobytes() != packed.tobytes() or any(v.base is None and v.flags.owndata
                                                      for v in values):
            return None
        out += values
    return out


def _check(err: int) -> None:
    """A PETSc error code of a C call raised (PETSc has printed where it arose)."""
    if err:
        raise PETSc.Error(err)
