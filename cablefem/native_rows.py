"""The time integrator's residual and Jacobian assembled in C (``native_rows.c``), for a
model on one rank whose residual is its UFL forms alone.

:class:`cablefem.petsc_utils.RowsAssembler` calls dolfinx's compiled kernels through its
Python wrappers: on paper case B (63 unknowns) a residual costs 65 µs and a Jacobian 87 µs,
of which the kernels and their sums are about 7 µs and 19 µs (docs/benchmarks.md). Here
the cell loops, the copy of the state (u, v, a) into the packed coefficients and the
anchors' rows ``kappa (x - g)`` are one C call each, with the same kernels (FFCx's
``tabulate_tensor``), the same sums in the same order, so the same numbers to the last
bit. Python still sets the model's time, the constants and the other coefficients (once
per time: :meth:`NativeRows.at`), and PETSc's TS, SNES and KSP and their callbacks are the
same.

The C file is compiled once with the system's C compiler into the FFCx cache folder, next
to the forms' kernels, and linked against the PETSc library petsc4py uses. Where it
cannot be (no compiler), or the model is outside what it does (several ranks, terms
outside UFL, a Jacobian kept in parts, integrals other than one over the cells, elements
with dof transformations), :func:`native_rows` returns None and the caller keeps
:class:`~cablefem.petsc_utils.RowsAssembler`. ``-<prefix>native_assembly false`` (or
``solver.petsc_options``) asks for the Python route.
"""

from __future__ import annotations

import ctypes
import hashlib
import logging
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from dolfinx import cpp as dcpp
from petsc4py import PETSc

__all__ = ["NativeRows", "native_rows", "library"]

log = logging.getLogger(__name__)

_SOURCE = Path(__file__).with_name("native_rows.c")
_LIB: list = []  # [the loaded library or None], once per process


class _Ctx(ctypes.Structure):
    """``rows_ctx`` of native_rows.c, field for field."""

    _p = ctypes.c_void_p
    _fields_ = [("n_cells", ctypes.c_int32), ("nodes", ctypes.c_int32),
                ("bs", ctypes.c_int32), ("coord_stride", ctypes.c_int32),
                ("dofmap", _p), ("coords", _p), ("kernel_f", _p), ("kernel_j", _p),
                ("w_f", _p), ("stride_f", ctypes.c_int32), ("stride_j", ctypes.c_int32),
                ("cols_j", _p), ("const_f", _p), ("const_j", _p),
                ("n_state", ctypes.c_int32 * 3), ("pos", _p * 3), ("src", _p * 3),
                ("n_bc", ctypes.c_int32), ("bc_dofs", _p), ("g", _p),
                ("n_rows", ctypes.c_int32), ("rows", _p), ("kappa", ctypes.c_double),
                ("n_local", ctypes.c_int32), ("be", _p), ("ae", _p), ("wj", _p),
                ("cell_dofs", _p)]


def _petsc_library() -> str | None:
    """The PETSc shared library this process loaded (through petsc4py)."""
    try:
        with open("/proc/self/maps") as fh:
            for line in fh:
                path = line.split()[-1]
                if "/libpetsc" in path and ".so" in path:
                    return path
    except OSError:
        pass
    return None


def library():
    """The compiled ``native_rows.c`` (a :class:`ctypes.CDLL`), or None when it cannot be
    built here; built once into the FFCx cache folder and loaded once per process."""
    if _LIB:
        return _LIB[0]
    lib = None
    try:
        lib = _load()
    except (OSError, subprocess.SubprocessError) as err:
        log.info("the compiled residual is not available (%s): the Python route", err)
    _LIB.append(lib)
    return lib


def _load():
    petsc = _petsc_library()
    cc = os.environ.get("CC", "cc")
    if petsc is None or shutil.which(cc) is None:
        raise OSError(f"no PETSc library found or no C compiler {cc!r}")
    int_type = "int64_t" if np.dtype(PETSc.IntType).itemsize == 8 else "int32_t"
    source = _SOURCE.read_bytes()
    flags = ["-O2", "-fPIC", "-shared", f"-DPETSC_INT={int_type}"]
    key = hashlib.sha256(source + repr((cc, flags, petsc)).encode()).hexdigest()[:16]
    from dolfinx import jit
    folder = Path(jit.get_parameters()["cache_dir"]).expanduser()
    target = folder / f"cablefem_native_rows_{key}.so"
    if not target.is_file():
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=folder) as tmp:  # then renamed: atomic
            out = Path(tmp) / target.name
            subprocess.run([cc, *flags, os.fspath(_SOURCE), "-o", os.fspath(out), petsc],
                           check=True, capture_output=True, timeout=120)
            os.replace(out, target)
    lib = ctypes.CDLL(os.fspath(target))
    for name in ("cablefem_residual", "cablefem_cells"):
        getattr(lib, name).argtypes = [ctypes.c_void_p] * 5
        getattr(lib, name).restype = ctypes.c_int
    lib.cablefem_jacobian.argtypes = [ctypes.c_void_p] * 2
    lib.cablefem_jacobian.restype = ctypes.c_int
    lib.cablefem_forces.argtypes = [ctypes.c_void_p] * 10 + [ctypes.c_int32, ctypes.c_void_p,
                                                             ctypes.POINTER(ctypes.c_int)]
    lib.cablefem_forces.restype = ctypes.c_int
    return lib


def _address(cdata) -> int:
    import cffi
    return int(cffi.FFI().cast("uintptr_t", cdata))


def _cell_kernel(form) -> tuple[int, int] | None:
    """``form``'s one cell integral: (its id, its kernel's address); None when the form
    has other integrals too."""
    types = dcpp.fem.IntegralType
    ids = form.integral_ids(types.cell)
    if (len(ids) != 1 or form.integral_ids(types.exterior_facet)
            or form.integral_ids(types.interior_facet)):
        return None
    uf = form.ufcx_form
    if uf.num_integrals(0) != 1:
        return None
    return ids[0], _address(uf.integrals(0)[0].tabulate_tensor_float64)


def native_rows(model, rows, options_prefix: str) -> NativeRows | None:
    """A :class:`NativeRows` for ``rows`` (a :class:`~cablefem.petsc_utils.RowsAssembler`
    of ``model``), or None: the model is outside what it does (see the module), the
    option ``-<options_prefix>native_assembly`` is false, or it cannot be compiled."""
    if not PETSc.Options().getBool(options_prefix + "native_assembly", True):
        return None
    F, J = rows.F, rows.J
    if (model.comm.size != 1 or rows.extra is not None or rows.parts is not None
            or rows.gather is None or rows.others is None or rows.cols is None
            or model.V.element.needs_dof_transformations
            or model.V.dofmap.index_map.local_range[0] != 0):  # local numbers: global
        return None
    kf, kj = _cell_kernel(F), _cell_kernel(J)
    if kf is None or kj is None or kf[0] != kj[0]:
        return None
    if any(not np.shares_memory(bc.g.x.array, model.u_bc.x.array) for bc in rows.bcs):
        return None  # the prescribed values: model.u_bc's
    lib = library()
    if lib is None:
        return None
    return NativeRows(lib, model, rows, kf, kj)


class NativeRows:
    """The residual and Jacobian of ``rows`` (a :class:`~cablefem.petsc_utils.
    RowsAssembler`) by one C call each (made by :func:`native_rows`; ``rows.native`` is
    then this object, so that ``rows.forget()`` also reaches it). The state comes from the
    vectors given; :meth:`at` brings the time, the constants and the other coefficients up
    to date."""

    def __init__(self, lib, model, rows, kf, kj) -> None:
        self.lib, self.model, self.rows = lib, model, rows
        key = (dcpp.fem.IntegralType.cell, kf[0])
        F = rows.F
        cells = np.asarray(F.domains(key[0], key[1]), np.int32)
        dofmap = model.V.dofmap.list.array.reshape(-1, model.V.dofmap.dof_layout.num_dofs)
        geo = model.mesh.geometry
        gdofs = geo.dofmap.array.reshape(len(geo.dofmap), -1)
        keep = self._keep = []  # every array the C side points into

        def ptr(a):
            keep.append(a)
            return a.ctypes.data

        bs = model.V.dofmap.bs
        nodes = dofmap.shape[1]
        c = self.ctx = _Ctx()
        c.n_cells, c.nodes, c.bs = cells.size, nodes, bs
        c.dofmap = ptr(np.ascontiguousarray(dofmap[cells], np.int32))
        coords = np.ascontiguousarray(geo.x[gdofs[cells]], np.float64)
        c.coord_stride = coords[0].size if cells.size else 0
        c.coords = ptr(coords)
        c.kernel_f, c.kernel_j = kf[1], kj[1]
        self.key = key
        self.w_f = np.array(rows.coefficients(None)[key], np.float64, order="C")  # its shape
        rows.forget()  # packed now, before the caller sets its time and state
        c.w_f = ptr(self.w_f)
        c.stride_f = self.w_f.shape[1] if self.w_f.ndim == 2 else 0
        cols = np.ascontiguousarray(rows.cols[key], np.int32)
        c.stride_j, c.cols_j = cols.size, ptr(cols)
        self.const_f = np.zeros(dcpp.fem.pack_constants(F).size + 1)  # never empty
        self.const_j = np.zeros(dcpp.fem.pack_constants(rows.J).size + 1)
        c.const_f, c.const_j = ptr(self.const_f), ptr(self.const_j)
        arrays = [f.x.array for f in (model.u, model.v, model.a)]
        for pos, arr, src in rows.gather.get(key, []):
            s = next(i for i, a in enumerate(arrays) if a is arr
                     or np.shares_memory(a, arr))
            c.n_state[s] = pos.size
            c.pos[s] = ptr(np.ascontiguousarray(pos, np.int64))
            c.src[s] = ptr(np.ascontiguousarray(src, np.int32))
        bc_dofs = np.concatenate([bc.dof_indices()[0] for bc in rows.bcs]
                                 ).astype(np.int32) if rows.bcs else np.zeros(0, np.int32)
        c.n_bc, c.bc_dofs = bc_dofs.size, ptr(bc_dofs)
        c.g = ptr(model.u_bc.x.array)
        anchor_rows = np.ascontiguousarray(rows.rows, PETSc.IntType)
        c.n_rows, c.rows, c.kappa = anchor_rows.size, ptr(anchor_rows), rows.kappa
        c.n_local = model.u.x.array.size
        nd = nodes * bs
        c.be, c.ae = ptr(np.zeros(nd)), ptr(np.zeros(nd * nd))
        c.wj = ptr(np.zeros(max(cols.size, 1)))
        c.cell_dofs = ptr(np.zeros(nodes, PETSc.IntType))
        self._ref = ctypes.byref(c)
        #: the time of the last :meth:`at` (None: :meth:`RowsAssembler.forget` since)
        self.time: float | None = None

    def at(self, t: float) -> None:
        """The model's time ``t``, and the packed constants and other coefficients at it
        (nothing at the time of the last call, without :meth:`forget` since)."""
        if t == self.time:
            return
        self.model.set_time(t)
        packed, _ = self.rows.others_at(t)  # the state: copied in by the C side
        np.copyto(self.w_f, packed[self.key])
        self.constants()
        self.time = t

    def constants(self) -> None:
        """The forms' constants packed again (the Jacobian's shifts, a time law's)."""
        cf, cj = dcpp.fem.pack_constants(self.rows.F), dcpp.fem.pack_constants(self.rows.J)
        self.const_f[:cf.size] = cf
        self.const_j[:cj.size] = cj

    def residual(self, t: float, U: PETSc.Vec, V: PETSc.Vec, A: PETSc.Vec,
                 F: PETSc.Vec) -> None:
        """The time integrator's residual at ``t`` and the state ``U``, ``V``, ``A`` into
        ``F``: :meth:`RowsAssembler.residual`'s numbers."""
        self.at(t)
        err = self.lib.cablefem_residual(self._ref, U.handle, V.handle, A.handle, F.handle)
        if err:
            raise PETSc.Error(err)

    def cells(self, t: float, U: PETSc.Vec, V: PETSc.Vec, A: PETSc.Vec,
              F: PETSc.Vec) -> None:
        """The residual's cells alone (no anchor rows) at ``t`` and ``U``, ``V``, ``A``
        into ``F``: the anchor forces' assembly (:mod:`cablefem.reactions`)."""
        self.at(t)
        err = self.lib.cablefem_cells(self._ref, U.handle, V.handle, A.handle, F.handle)
        if err:
            raise PETSc.Error(err)

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
        err = self.lib.cablefem_forces(
            self._ref, ksp.handle, M_full.handle, m.u.vector.handle, m.v.vector.handle,
            m.a.vector.handle, R.handle, rhs.handle, da.handle, Mda.handle, zero.size,
            zero.ctypes.data, ctypes.byref(reason))
        if err:
            raise PETSc.Error(err)
        return reason.value

    def jacobian(self, J: PETSc.Mat, constants: bool = False) -> None:
        """The Jacobian at the state of the last :meth:`residual` into ``J``:
        :meth:`RowsAssembler.jacobian`'s numbers. ``constants``: pack the constants again
        first (the time integrator's shifts changed)."""
        if constants:
            self.constants()
        err = self.lib.cablefem_jacobian(self._ref, J.handle)
        if err:
            raise PETSc.Error(err)
