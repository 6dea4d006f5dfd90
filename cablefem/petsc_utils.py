"""Small PETSc helpers shared by the solvers: default options under a prefix, assembly
callbacks, and a record of Newton iterations for error messages."""

from __future__ import annotations

from collections import deque

import numpy as np
from dolfinx import cpp as dcpp
from dolfinx import fem
from dolfinx.fem import petsc as fpetsc
from petsc4py import PETSc

from cablefem.gathered_lu import PYTHON_TYPE as GATHERED
from cablefem.packing import (
    copy_changed,
    jacobian_columns,
    other_functions,
    state_gather,
    take_columns,
)

__all__ = ["default_options", "case_options", "assemble_residual", "assemble_jacobian",
           "assemble_residual_rows", "assemble_jacobian_rows",
           "SNESHistory",
           "lu_options", "model_dofs", "linear_solver_options", "keeps_factorisation", "copy_in",
           "RowsAssembler",
           "jacobian_columns"]

INSERT, ADD = PETSc.InsertMode.INSERT, PETSc.InsertMode.ADD
FORWARD, REVERSE = PETSc.ScatterMode.FORWARD, PETSc.ScatterMode.REVERSE


#: above this many degrees of freedom the time integrator reuses its factorisations
LARGE_ABOVE = 20_000

#: on several ranks, above this many degrees of freedom a direct solve factors on rank 0
#: only (:mod:`cablefem.gathered_lu`); below it on every rank (``pc_type redundant``)
GATHER_ABOVE = LARGE_ABOVE

def linear_solver_options(n_dofs: int, comm_size: int = 1, reuse: bool = True
                          ) -> dict[str, object]:
    """The automatic linear solver of the time integrator's Newton steps: a direct solve
    (:func:`lu_options`) of a block matrix (``mat_type baij``, blocks of the node's 3 or 6
    unknowns: its assembly, factorisation and triangular solves are faster than with AIJ).

    Above :data:`LARGE_ABOVE` degrees of freedom the factorisation dominates a step, so
    the time integrator keeps the Jacobian and its factorisation over steps while Newton
    contracts (:func:`keeps_factorisation`, :mod:`cablefem.stepnewton`): modified Newton,
    one triangular solve per iteration. Until 2026-11-27 this route was GMRES (to a tenth
    of Newton's increment test) preconditioned by an LU refreshed every 10 Jacobians
    (``snes_lag_preconditioner``); on the 94 000-dof roof of
    ``benchmarks/bench_scaling.py`` (100 steps, the kink corners' Jacobian kept over steps
    either way) it took 2.46 Newton and 1.86 GMRES iterations a step, i.e. 7 to 8
    applications of the factorisation, against 2.46 Newton iterations and as many
    applications now: the dynamics 13.0-16.3 s -> 10.0-11.7 s on 1 rank, 8.7-9.9 s ->
    6.2-7.4 s on 2, where every application is made on rank 0 alone (docs/benchmarks.md,
    "The dynamic step's solve without GMRES").

    Rejected earlier on these axially stiff, anisotropic systems (seconds per step, 2-core
    machine): serial AIJ + LU lagged 20, 0.28 against 0.15 in BAIJ; algebraic multigrid
    (GAMG, BoomerAMG: 10-25 times slower); block Jacobi with an LU per rank (229 GMRES
    iterations per Newton iteration on 2 ranks) and additive Schwarz with LU sub-solves and
    an overlap of 4 (8) elements (47 (38)): the axial wave crosses the roof within a step
    (docs/networks.md); MUMPS (0.49 s of CPU a step against 0.32 s; with METIS or SCOTCH
    orderings 0.6-0.75 s); PCFIELDSPLIT with a Schur complement on the partition interface
    (0.28 s per step on 2 ranks: forming the Schur complement costs 300 triangular solves);
    BDDC on a MATIS with every interface node primal (1 GMRES iteration, but three
    half-size triangular solves per application and ~180 coarse-basis solves per
    factorisation: docs/benchmarks.md, "One factorisation on one rank"). Above
    :data:`GATHER_ABOVE` on several ranks the LU is gathered onto rank 0
    (:func:`lu_options`). Override with ``-cable_mat_type``, ``-cable_ksp_type``,
    ``-cable_pc_type``, ``-cable_snes_lag_preconditioner``, ``-cable_newton_jacobian_reuse``.

    ``reuse=False`` (the rod): a fresh factorisation at every Newton iteration at every
    size. The rod's nearly rigid shear (``GA`` = 1e5 T) makes a stale factorisation crawl:
    the 5 x 5 saddle net's rod (34 425 dofs) took more than 6 s a step with GMRES on the
    reused LU, 0.8 s with a fresh one.
    """
    return {"mat_type": "baij", **lu_options(comm_size, n_dofs)}


def keeps_factorisation(n_dofs: int, reuse: bool = True) -> bool:
    """Whether the time integrator keeps its Jacobian and factorisation over steps because
    the factorisation is dear (above :data:`LARGE_ABOVE` degrees of freedom, not the rod):
    :func:`linear_solver_options`."""
    return reuse and n_dofs > LARGE_ABOVE


def model_dofs(model) -> int:
    """The model's number of unknowns over all ranks (what :func:`lu_options` sizes by)."""
    return model.bs * model.V.dofmap.index_map.size_global


def lu_options(comm_size: int = 1, n_dofs: int | None = None) -> dict[str, str]:
    """A direct solver: PETSc's own LU, above :data:`LARGE_ABOVE` degrees of freedom
    (``n_dofs``) with the approximate minimum degree ordering (``amd``), below with PETSc's
    default (nested dissection). In parallel, above :data:`GATHER_ABOVE` degrees of freedom
    the whole system is gathered onto rank 0 and factored there only
    (:mod:`cablefem.gathered_lu`, ``pc_type python``; its sequential LU's options under
    ``<prefix>gathered_``); below, every rank factors the whole system (``pc_type
    redundant``). On the cable systems seen here (1D cells, little fill) a sequential LU is
    2.5 to 4 times faster on 2 ranks than MUMPS (measured from 6e3 to 1e5 dofs: MUMPS's
    factorisation ~100 ms and solve ~30 ms at 1e5 dofs against 40 and 4 ms), and BDDC with
    every interface node primal, exact in one GMRES iteration, costs 4-10 times the
    redundant LU's setup and solve (docs/benchmarks.md, "One factorisation on one rank").
    The redundant LU's copies compete for a 2-core machine's memory bus; one copy on rank 0
    does not. ``-cable_pc_type lu -cable_pc_factor_mat_solver_type mumps`` (and
    ``static_``/``modal_``/``mass_`` prefixes) selects MUMPS.

    The ordering, measured on the 94 000-dof roof's dynamic matrix (BAIJ, 2026-11-26,
    numeric factorisation / triangular solve, ms): nested dissection (PETSc's default) 144
    / 5.5, one-way dissection 168 / 7.1, quotient minimum degree 58 / 3.5, reverse
    Cuthill-McKee 1010 / 34, ``amd`` 33 / 3.0; its statics 10.0 s of CPU with nested
    dissection, 6.5 s with ``amd``, the same anchor forces to 1e-16. Not below: PETSc's LU
    does not pivot, and with ``amd`` a 30-element mooring line jerked onto its seabed
    (``tests/test_seabed.py``, the bouncing line) stalled Newton at |F| = 3e8 where nested
    dissection goes through; the small systems gain nothing measurable from it."""
    amd = n_dofs is not None and n_dofs > LARGE_ABOVE
    if comm_size == 1:
        opts = {"ksp_type": "preonly", "pc_type": "lu"}
        if amd:
            opts["pc_factor_mat_ordering_type"] = "amd"
        return opts
    if n_dofs is not None and n_dofs > GATHER_ABOVE:
        opts = {"ksp_type": "preonly", "pc_type": "python", "pc_python_type": GATHERED}
        if amd:
            opts["gathered_pc_factor_mat_ordering_type"] = "amd"
        return opts
    opts = {"ksp_type": "preonly", "pc_type": "redundant", "redundant_pc_type": "lu"}
    if amd:
        opts["redundant_pc_factor_mat_ordering_type"] = "amd"
    return opts


class default_options:
    """Context manager: put ``defaults`` (and the case file's ``user`` options) under
    ``prefix`` in PETSc's options database for one ``setFromOptions`` call, then take them
    out again, so that they do not leak into the next model built in the same process.
    Options already in the database (the command line) win over both.

    Use::

        with default_options(prefix, {"snes_rtol": 1e-10}, case_options):
            snes.setFromOptions()
    """

    def __init__(self, prefix: str, defaults: dict[str, object],
                 user: dict[str, object] | None = None) -> None:
        self.prefix = prefix
        self.values = {**defaults, **{k.lstrip("-"): v for k, v in (user or {}).items()}}
        self.inserted: list[str] = []

    def __enter__(self):
        opts = PETSc.Options()
        for key, val in self.values.items():
            k = self.prefix + key
            if not opts.hasName(k):
                opts.setValue(k, _fmt(val))
                self.inserted.append(k)
        return self

    def __exit__(self, *exc):
        opts = PETSc.Options()
        for k in self.inserted:
            opts.delValue(k)
        self.inserted.clear()


def case_options(model, solver: str = "") -> dict[str, object]:
    """The case file's ``solver.petsc_options`` meant for one solver: keys that start with
    ``static_`` / ``modal_`` / ``mass_`` go to that solver (without the word), the others to
    the time integrator (``solver=""``)."""
    out = {}
    special = ("static_", "modal_", "mass_")
    for key, val in model.case.solver.petsc_options.items():
        key = key.lstrip("-")
        if solver and key.startswith(solver + "_"):
            out[key[len(solver) + 1:]] = val
        elif not solver and not key.startswith(special):
            out[key] = val
    return out


def _fmt(val: object) -> str:
    """An option's value as PETSc reads it (``None``: a flag without a value, as
    ``-snes_monitor`` on the command line)."""
    if val is None:
        return ""
    if isinstance(val, bool):
        return "true" if val else "false"
    return str(val)


def copy_in(x: PETSc.Vec, f: fem.Function, serial: bool = False) -> None:
    """Copy a PETSc vector into a Function and update its ghosts (``serial``: the caller
    knows the communicator has one rank, so there are no ghosts to update)."""
    x.copy(f.vector)
    if not serial:
        f.vector.ghostUpdate(addv=INSERT, mode=FORWARD)


def assemble_residual(b: PETSc.Vec, F: fem.FormMetaClass, J: fem.FormMetaClass, bcs,
                      x: PETSc.Vec, extra=None) -> None:
    """Residual with Dirichlet rows ``x - g`` (so Newton drives ``x`` to ``g``);
    ``extra(array)`` adds terms assembled outside UFL to the local form."""
    with b.localForm() as loc:
        loc.set(0.0)
    fpetsc.assemble_vector(b, F)
    if extra is not None:
        with b.localForm() as loc:
            extra(loc.array_w)
    fpetsc.apply_lifting(b, [J], [bcs], x0=[x], scale=-1.0)
    b.ghostUpdate(addv=ADD, mode=REVERSE)
    fpetsc.set_bc(b, bcs, x, -1.0)


def assemble_residual_rows(b: PETSc.Vec, F: fem.FormMetaClass, bcs, x: PETSc.Vec) -> None:
    """Residual without lifting; Dirichlet rows hold ``x - g``. Pairs with
    :func:`assemble_jacobian_rows`: Newton is then exact whatever the state of the
    constrained dofs, with no dependence on the Jacobian's parameters (e.g. TS shifts)."""
    with b.localForm() as loc:
        loc.set(0.0)
    fpetsc.assemble_vector(b, F)
    b.ghostUpdate(addv=ADD, mode=REVERSE)
    fpetsc.set_bc(b, bcs, x, -1.0)


def assemble_jacobian_rows(A: PETSc.Mat, J: fem.FormMetaClass, rows: np.ndarray,
                           diag: float = 1.0) -> None:
    """Jacobian assembled without boundary conditions, then the constrained *rows* (local
    unrolled indices of owned dofs) replaced by ``diag`` times identity rows (the residual's
    rows scaled alike); their columns are kept."""
    A.zeroEntries()
    fpetsc.assemble_matrix(A, J)
    A.assemble()
    A.zeroRowsLocal(rows, diag=diag)


class RowsAssembler:
    """:func:`assemble_residual_rows` and :func:`assemble_jacobian_rows` for the calls of a
    time integrator, thousands a run: the same kernels and the same sums, called without
    dolfinx's Python dispatch (constants and coefficients packed once per call, the local
    array taken without a local-form vector in serial, no ghost update on one rank, the
    anchor rows' indices and weight fixed). The results are bit-identical to the two
    functions'.

    ``kappa``: the weight of the Dirichlet rows (``x - g`` times ``kappa`` in the residual,
    ``kappa`` on the Jacobian's diagonal)."""

    def __init__(self, F: fem.FormMetaClass, J: fem.FormMetaClass, bcs, rows: np.ndarray,
                 kappa: float, comm, extra=None, state=(), timed: bool = True,
                 parts=None) -> None:
        #: ``extra``: (residual(array), jacobian(A)) of terms assembled outside UFL, or None
        self.extra = extra
        self.F, self.J, self.bcs = F, J, list(bcs)
        self.rows, self.kappa = rows, kappa
        self.serial = comm.size == 1
        self.cols = jacobian_columns(F, J)
        #: ``J`` as two forms whose sum it is, (fast, slow) (``CableForms.J_dynamic_part``,
        #: compiled as ``j_dynamic_fast``, ``j_dynamic_slow``), each with its columns of the
        #: packing; None: ``J`` whole
        self.parts = None if parts is None else [(p, jacobian_columns(F, p)) for p in parts]
        self.A_slow: PETSc.Mat | None = None  # the slow part as last assembled
        self.packed: dict | None = None  # the residual's packed coefficients, last call
        # the state Functions the residual has (an undamped one has no velocity)
        state = tuple(f for f in state if any(getattr(f, "_cpp_object", f) is c
                                              for c in F.coefficients))
        #: where the ``state`` Functions' values sit in the packed coefficients
        #: (:func:`state_gather`; None: always packed whole)
        self.gather = state_gather(F, state) if state else None
        #: the other Functions of ``F``: [(their values (a view), their bytes last packed,
        #: where they sit)], compared at a new time and copied in where they changed
        #: (None: ``F`` is packed whole at a new time)
        self.others = other_functions(F, state) if self.gather is not None else None
        #: ``timed``: setting the model's time may change a Function of ``F`` besides the
        #: state (a term's time law): the packing is then kept for one time only
        self.timed = timed
        self._packed_at = None  # the time the packing was last brought up to date
        #: the same residual and Jacobian in C (:mod:`cablefem.native_rows`), or None
        self.native = None

    def forget(self) -> None:
        """The next :meth:`residual` brings every coefficient up to date, not only the
        state (a new step: anything may have changed since); :attr:`native` too."""
        self._packed_at = None
        if self.native is not None:
            self.native.forget()

    def coefficients(self, time):
        """``F``'s packed coefficients at the current state, the numbers a whole packing
        gives: :meth:`others_at`, and the state Functions' values copied in. ``time`` None,
        or Functions whose places in the packing are not known: all packed."""
        packed, whole = self.others_at(time)
        if not whole:
            for key, items in self.gather.items():
                flat = packed[key].reshape(-1)
                for pos, arr, src in items:
                    flat[pos] = arr[src]
        return packed

    def others_at(self, time) -> tuple[dict, bool]:
        """``F``'s packing with every coefficient but the state up to date, and whether it
        was packed whole (the state too). At the ``time`` of the last call (not None; any
        time when not :attr:`timed`) and no :meth:`forget` since, as it was. At a new time
        (or after :meth:`forget`) the other Functions are compared with the values they
        were packed with, and those that changed (a time law's waves, a hinge's law) are
        copied in."""
        if time is not None and not self.timed:
            time = 0.0  # the Functions but the state do not change with time
        if time is None or self.gather is None or self.packed is None or (
                time != self._packed_at and self.others is None):
            return self._pack_whole(time), True
        if time != self._packed_at:
            copy_changed(self.packed, self.others)
            self._packed_at = time
        return self.packed, False

    def _pack_whole(self, time):
        """Every coefficient packed by dolfinx (the others' values noted)."""
        self.packed = dcpp.fem.pack_coefficients(self.F)
        self._packed_at = time
        for arr, last, _ in self.others or ():
            last[0] = arr.tobytes()
        return self.packed

    def residual(self, b: PETSc.Vec, x: PETSc.Vec, time: float | None = None) -> None:
        """The residual into ``b`` at the state the form's coefficients hold; the Dirichlet
        rows ``kappa (x - g)``. ``time``: the caller's time; a second call at the same time
        (Newton's next iteration, after no :meth:`forget`) repacks only the state
        Functions (only they change between the iterations of a step)."""
        F = self.F
        consts, coeffs = dcpp.fem.pack_constants(F), self.coefficients(time)
        if self.serial:  # one rank: no ghosts, the vector's array is its local form
            arr = b.array_w
            arr[:] = 0.0
            dcpp.fem.assemble_vector(arr, F, consts, coeffs)
            if self.extra is not None:
                self.extra[0](arr)
        else:
            with b.localForm() as loc:
                loc.set(0.0)
                dcpp.fem.assemble_vector(loc.array_w, F, consts, coeffs)
                if self.extra is not None:
                    self.extra[0](loc.array_w)
            b.ghostUpdate(addv=ADD, mode=REVERSE)
            arr = b.array_w
        dcpp.fem.set_bc(arr, self.bcs, x.array_r, -1.0)
        arr[self.rows] *= self.kappa

    def jacobian(self, A: PETSc.Mat, slow: bool = True) -> None:
        """The Jacobian into ``A``, its Dirichlet rows ``kappa`` times identity rows, at
        the state of the last :meth:`residual` (SNES evaluates the residual at a state
        before its Jacobian; the coefficients have not changed since): the Jacobian's
        packed coefficients are columns of the residual's (:func:`jacobian_columns`).
        With :attr:`parts`, ``slow`` False adds the slow part as last assembled to the fast
        part assembled now (a Jacobian with a kept part)."""
        A.zeroEntries()
        self._assemble(A, *(self.parts[0] if self.parts else (self.J, self.cols)))
        A.assemblyBegin(PETSc.Mat.AssemblyType.FLUSH)  # as dolfinx's wrapper does
        A.assemblyEnd(PETSc.Mat.AssemblyType.FLUSH)
        if self.extra is not None:
            self.extra[1](A)
        A.assemble()
        if self.parts is not None:
            if slow or self.A_slow is None:
                if self.A_slow is None:  # A's pattern (assembled: it can be duplicated)
                    self.A_slow = A.duplicate()
                self.A_slow.zeroEntries()
                self._assemble(self.A_slow, *self.parts[1])
                self.A_slow.assemble()
            A.axpy(1.0, self.A_slow, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        A.zeroRowsLocal(self.rows, diag=self.kappa)

    def _assemble(self, A: PETSc.Mat, J: fem.FormMetaClass, cols: dict | None) -> None:
        """``J``'s kernels added into ``A`` (not assembled), its coefficients taken from
        the residual's packing where ``cols`` says they sit."""
        if cols is not None and self.packed is not None:
            coeffs = take_columns(self.packed, cols)
        else:
            coeffs = dcpp.fem.pack_coefficients(J)
        dcpp.fem.petsc.assemble_matrix(A, J, dcpp.fem.pack_constants(J), coeffs, [])

    def destroy(self) -> None:
        """Free the kept part's matrix."""
        if self.A_slow is not None:
            self.A_slow.destroy()
            self.A_slow = None


def assemble_jacobian(A: PETSc.Mat, J: fem.FormMetaClass, bcs, extra=None) -> None:
    """The Jacobian with the conditions' rows and columns identity; ``extra(A)`` adds
    terms assembled outside UFL before the final assembly."""
    A.zeroEntries()
    fpetsc.assemble_matrix(A, J, bcs)
    if extra is not None:
        extra(A)
    A.assemble()


class SNESHistory:
    """Keeps the last Newton residual norms, for a failure message that says what happened."""

    def __init__(self, maxlen: int = 12) -> None:
        self.norms: deque[tuple[int, float]] = deque(maxlen=maxlen)

    def __call__(self, snes: PETSc.SNES, its: int, norm: float) -> None:
        self.norms.append((its, float(norm)))

    def clear(self) -> None:
        self.norms.clear()

    def text(self) -> str:
        return ", ".join(f"it {i}: |F|={n:.3e}" for i, n in self.norms) or "no iteration"
