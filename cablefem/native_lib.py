"""The compiled ``native_rows.c``: its build (once, into the FFCx cache folder, with the
system's C compiler, linked against the PETSc library petsc4py uses), its loading, and the
ctypes mirrors of its structs; :class:`Watched`, arrays compared with their copies in C.
Used by :mod:`cablefem.native_rows`."""

from __future__ import annotations

import ctypes
import hashlib
import logging
import os
import shlex
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from petsc4py import PETSc

__all__ = ["AT_CALL", "Anchors", "Ctx", "DECIDE_CALL", "MAX_PARTS", "PYTHON_ERROR", "Part",
           "Watched", "library"]

log = logging.getLogger(__name__)

_SOURCE = Path(__file__).with_name("native_rows.c")
_LIB: list = []  # [the loaded library or None], once per process


_p = ctypes.c_void_p
#: integrals the C side takes (given to native_rows.c as ``-DMAX_PARTS``)
MAX_PARTS = 8


class Part(ctypes.Structure):
    """``part_t`` of native_rows.c, field for field."""

    _fields_ = [("n", ctypes.c_int32), ("facets", ctypes.c_int32), ("nodes", ctypes.c_int32),
                ("dofs", _p), ("coords", _p), ("coord_stride", ctypes.c_int32),
                ("local", _p), ("perms", _p), ("kernel_f", _p), ("kernel_j", _p * 3),
                ("w_f", _p), ("stride_f", ctypes.c_int32), ("stride_j", ctypes.c_int32 * 3),
                ("cols_j", _p * 3), ("n_state", ctypes.c_int32 * 3), ("pos", _p * 3),
                ("src", _p * 3)]


class Ctx(ctypes.Structure):
    """``rows_ctx`` of native_rows.c, field for field."""

    _fields_ = [("bs", ctypes.c_int32), ("n_parts", ctypes.c_int32),
                ("parts", Part * MAX_PARTS),
                ("const_f", _p), ("const_j", _p * 3), ("n_bc", ctypes.c_int32),
                ("bc_dofs", _p),
                ("g", _p), ("n_rows", ctypes.c_int32), ("rows", _p),
                ("kappa", ctypes.c_double), ("n_local", ctypes.c_int32), ("be", _p),
                ("ae", _p), ("wj", _p), ("block_dofs", _p), ("time", ctypes.c_double),
                ("at", _p), ("decide", _p), ("state", _p * 3), ("same", ctypes.c_int32),
                ("shift_v", ctypes.c_double), ("shift_a", ctypes.c_double),
                ("assembled", ctypes.c_int64)]


class Anchors(ctypes.Structure):
    """``anchors_t`` of native_rows.c: the anchors as
    :meth:`cablefem.reactions.AnchorReactions.compute` reads them (built there)."""

    _fields_ = [("n", ctypes.c_int32), ("n_a", ctypes.c_int32), ("hinges", ctypes.c_int32),
                ("a_rows", _p), ("a_src", _p), ("row", _p), ("has_hinge", _p),
                ("mass", _p), ("g", _p)]


class _Watch(ctypes.Structure):
    """``watch_t`` of native_rows.c."""

    _fields_ = [("now", _p), ("last", _p), ("nbytes", ctypes.c_int64)]


class Watched:
    """Arrays (C-contiguous; their memory kept) compared byte for byte with their copies
    as last seen, in one C call (``cablefem_changed``): :meth:`changed` returns how many
    differ, updates their copies and flags them in :attr:`flags`. The copies start as the
    values now."""

    def __init__(self, lib, arrays: list[np.ndarray]) -> None:
        self.arrays = [np.asarray(a) for a in arrays]
        if any(not a.flags.c_contiguous for a in self.arrays):
            raise ValueError("watched arrays must be C-contiguous")
        self.copies = [a.copy() for a in self.arrays]
        n = len(self.arrays)
        self.items = (_Watch * max(n, 1))(*(_Watch(a.ctypes.data, c.ctypes.data, a.nbytes)
                                           for a, c in zip(self.arrays, self.copies)))
        self.flags = np.zeros(n, np.int32)
        self._args = (ctypes.byref(self.items), ctypes.c_int32(n),
                      ctypes.c_void_p(self.flags.ctypes.data if n else None))
        self._call = lib.cablefem_changed

    def changed(self) -> int:
        return self._call(*self._args) if self.arrays else 0


#: the C side's calls into Python (:meth:`NativeRows.drive`): a new time; the Jacobian's
#: decision from its two shifts
AT_CALL = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_double)
DECIDE_CALL = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_double, ctypes.c_double)
#: the error code the C side returns for an exception in those calls (PETSC_ERR_USER)
PYTHON_ERROR = 83


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
    """The compiled ``native_rows.c`` (a :class:`ctypes.PyDLL`), or None when it cannot be
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
    cc = shlex.split(os.environ.get("CC", "cc")) or ["cc"]  # "ccache gcc" too
    if petsc is None or shutil.which(cc[0]) is None:
        raise OSError(f"no PETSc library found or no C compiler {cc[0]!r}")
    int_type = "int64_t" if np.dtype(PETSc.IntType).itemsize == 8 else "int32_t"
    source = _SOURCE.read_bytes()
    flags = ["-O2", "-fPIC", "-shared", f"-DPETSC_INT={int_type}", f"-DMAX_PARTS={MAX_PARTS}"]
    key = hashlib.sha256(source + repr((cc, flags, petsc)).encode()).hexdigest()[:16]
    from dolfinx import jit
    folder = Path(jit.get_parameters()["cache_dir"]).expanduser()
    target = folder / f"cablefem_native_rows_{key}.so"
    if not target.is_file():
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=folder) as tmp:  # then renamed: atomic
            out = Path(tmp) / target.name
            subprocess.run([*cc, *flags, os.fspath(_SOURCE), "-o", os.fspath(out), petsc],
                           check=True, capture_output=True, timeout=120)
            os.replace(out, target)
    # the interpreter's lock stays held during the calls (they are short); a callback
    # PETSc makes into Python from them (a preconditioner of type python in the mass
    # solve) takes it again as its own
    lib = ctypes.PyDLL(os.fspath(target))
    for name in ("cablefem_residual", "cablefem_cells"):
        getattr(lib, name).argtypes = [ctypes.c_void_p] * 5
        getattr(lib, name).restype = ctypes.c_int
    lib.cablefem_jacobian.argtypes = [ctypes.c_void_p] * 2 + [ctypes.c_int32] * 2
    lib.cablefem_jacobian.restype = ctypes.c_int
    lib.cablefem_forces.argtypes = [ctypes.c_void_p] * 10 + [ctypes.c_int32, ctypes.c_void_p,
                                                             ctypes.POINTER(ctypes.c_int)]
    lib.cablefem_forces.restype = ctypes.c_int
    lib.cablefem_anchor_forces.argtypes = [ctypes.c_void_p] * 13 + [
        ctypes.c_int32, ctypes.c_void_p, ctypes.POINTER(ctypes.c_int)]
    lib.cablefem_anchor_forces.restype = ctypes.c_int
    lib.cablefem_drive.argtypes = [ctypes.c_void_p] * 4
    lib.cablefem_drive.restype = ctypes.c_int
    lib.cablefem_changed.argtypes = [ctypes.c_void_p, ctypes.c_int32, ctypes.c_void_p]
    lib.cablefem_changed.restype = ctypes.c_int32
    return lib
