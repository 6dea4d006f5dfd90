"""Anchor forces: the consistent reaction at every anchor, gathered across MPI ranks.

The force that the span transmits at anchor ``a`` (pointing into the span) is
``N_a = −R_a``, where ``R_a`` is the assembled residual of the *unconstrained* weak form at
the anchor's degrees of freedom (``docs/theory.md`` §3, step 1). It holds
the inertia, damping and weight of the half element next to the anchor, which makes it more
accurate than the first element's tension.

In dynamics the residual needs the acceleration at the output time. The generalised-α method
satisfies equilibrium at its intermediate stage, not at ``t_{n+1}``; so the acceleration is
recomputed from the semi-discrete equation of motion at ``t_{n+1}``: ``M_ff a_f = −r_f(u, v,
a_b)`` with the anchors' prescribed accelerations ``a_b``. The reaction is then the one that
balances the discrete equations exactly at that time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from dolfinx import cpp as dcpp
from dolfinx.fem import petsc as fpetsc
from mpi4py import MPI
from petsc4py import PETSc

from cablefem.junctions import add_residual
from cablefem.petsc_utils import (
    ADD,
    FORWARD,
    INSERT,
    REVERSE,
    case_options,
    default_options,
    lu_options,
    model_dofs,
)

__all__ = ["AnchorReactions"]


class AnchorReactions:
    """The force ``N_a`` the span transmits at every anchor of a model (a
    :class:`~cablefem.cable.CableModel`, a network or a rod), from the model's current state.

    Holds its PETSc objects (the residual vector, the mass matrices and the KSP of the mass
    solve, options prefix ``<model prefix>mass_``, e.g. ``-cable_mass_ksp_type``) and
    preallocated buffers: an evaluation (:meth:`compute`) assembles once, solves once with
    the mass matrix (dynamics) and sums the anchors' rows over the ranks with one
    ``Allreduce`` of a NumPy buffer. :meth:`destroy` (or a ``with`` block) frees the PETSc
    objects.

    Use::

        with AnchorReactions(model) as reactions:
            N = reactions.compute(t)            # (n_anchors, 3), same on every rank
            N0 = reactions.compute(0.0, dynamic=False)  # statics: v = a = 0
    """

    def __init__(self, model) -> None:
        self.model = model
        n_owned = model.V.dofmap.index_map.size_local
        #: (anchor index, first unrolled row) of the anchors whose node this rank owns
        self._own = [(i, model.bs * int(anc.dofs[anc.dofs < n_owned][0]))
                     for i, anc in enumerate(model.anchors)
                     if np.any(anc.dofs < n_owned)]
        #: the same as index arrays: the anchors, and their three force rows
        self._own_index = np.array([i for i, _ in self._own], np.int64)
        self._own_rows = np.array([[row, row + 1, row + 2] for _, row in self._own],
                                  np.int64).reshape(-1, 3)
        #: force (and a rod's moment) per anchor
        self._layout = None  # _native_forces' anchors (False: it does not apply)
        self._local = np.zeros((len(model.anchors), 6 if model.is_beam else model.bs))
        self._global = np.zeros_like(self._local)
        self.R = fpetsc.create_vector(model.f_dynamic)
        # blocks of the node's unknowns (BAIJ): assembled in half the time of AIJ, with
        # the same entries (docs/benchmarks.md, "The anchor reactions' mass in blocks")
        self.M = fpetsc.create_matrix(model.m_form, "baij")
        fpetsc.assemble_matrix(self.M, model.m_form, model.bcs, diagonal=1.0)
        self.M.assemble()
        self.M_full = fpetsc.create_matrix(model.m_form, "baij")  # anchor rows kept
        self._assemble_full()
        self.Mda = self.M_full.createVecLeft()
        prefix = model.prefix + "mass_"
        self.ksp = PETSc.KSP().create(model.comm)
        self.ksp.setOptionsPrefix(prefix)
        self.ksp.setOperators(self.M)
        with default_options(prefix, lu_options(model.comm.size, model_dofs(model)),
                             case_options(model, "mass")):
            self.ksp.setFromOptions()
        self.rhs = self.R.duplicate()
        self.da = model.a.vector.duplicate()  # ghosted, like the Function's vector
        #: a term's mass changes with the state or time (a fluid's added mass is normal to
        #: the cable; a term's time law): the mass matrices are assembled at each evaluation
        self._mass_moves = model.forms.mass_moves
        #: the anchors' owned rows: the constrained mass matrix is the unconstrained one
        #: with these rows and columns zeroed and 1 on the diagonal (one assembly a time)
        n_owned = model.V.dofmap.index_map.size_local
        rows = np.concatenate([a.flat_dofs for a in model.anchors] + [np.zeros(0)])
        self._bc_rows = rows[rows < model.bs * n_owned].astype(PETSc.IntType)
        self._derive = self._mass_moves and self._derived_is_assembled()
        self._zero_rows = self._zero_rows_is_set_bc()
        #: a :class:`cablefem.petsc_utils.RowsAssembler` of the same residual whose packed
        #: coefficients serve (``coefficients(t)``: the state copied in when they can);
        #: None: packed at every evaluation
        self.packer = None
        self._time = None  # the time of the evaluation (for the packer)

    def _derived_is_assembled(self) -> bool:
        """Whether :meth:`_derive_constrained` gives the constrained mass matrix assembled
        with the model's conditions exactly (checked once: the conditions are the anchors'
        rows); otherwise both are assembled at every evaluation (collective)."""
        M = self.M.duplicate(copy=True)
        self._derive_constrained()
        M.axpy(-1.0, self.M)
        same = M.norm(PETSc.NormType.NORM_INFINITY) == 0.0
        M.destroy()
        if not same:  # the assembled one again
            m = self.model
            self.M.zeroEntries()
            fpetsc.assemble_matrix(self.M, m.m_form, m.bcs, diagonal=1.0)
            self.M.assemble()
        return same

    def _derive_constrained(self) -> None:
        """``M`` from ``M_full``: the anchors' rows and columns zeroed, 1 on the diagonal
        (what the assembly with the conditions gives: the other entries are the same
        sums)."""
        self.M_full.copy(self.M, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        self.M.zeroRowsColumnsLocal(self._bc_rows, diag=1.0)

    def _assemble_mass(self) -> None:
        """The mass matrices at the current state (in place; the KSP refactors): the
        unconstrained one assembled, the constrained one derived from it where that was
        found exact, assembled too otherwise."""
        m = self.model
        self._assemble_full()
        if self._derive:
            self._derive_constrained()
            return
        self.M.zeroEntries()
        fpetsc.assemble_matrix(self.M, m.m_form, m.bcs, diagonal=1.0)
        self.M.assemble()

    def _assemble_full(self) -> None:
        """The unconstrained mass matrix at the current state, into ``M_full`` (dolfinx's
        assembler called directly, as ``fem.petsc.assemble_matrix`` does)."""
        form = self.model.m_form
        self.M_full.zeroEntries()
        dcpp.fem.petsc.assemble_matrix(self.M_full, form, dcpp.fem.pack_constants(form),
                                       dcpp.fem.pack_coefficients(form), [])
        self.M_full.assemble()

    def _assemble(self) -> None:
        """The unconstrained residual into ``self.R`` (dolfinx's kernel called directly, as
        :class:`~cablefem.petsc_utils.RowsAssembler` does: the same sums)."""
        F = self.model.f_dynamic
        packer = self.packer
        native = getattr(packer, "native", None)
        if native is not None and packer.F is F and self._time is not None:
            m = self.model  # the same sums in C (cablefem.native_rows), one rank
            return native.cells(self._time, m.u.vector, m.v.vector, m.a.vector, self.R)
        coeffs = (packer.coefficients(self._time) if packer is not None and packer.F is F
                  else dcpp.fem.pack_coefficients(F))
        consts = dcpp.fem.pack_constants(F)
        if self.model.comm.size == 1:  # no ghosts: the array is the local form
            arr = self.R.array_w
            arr[:] = 0.0
            dcpp.fem.assemble_vector(arr, F, consts, coeffs)
            add_residual(self.model, arr)
            return
        with self.R.localForm() as loc:
            loc.set(0.0)
            dcpp.fem.assemble_vector(loc.array_w, F, consts, coeffs)
            add_residual(self.model, loc.array_w)
        self.R.ghostUpdate(addv=ADD, mode=REVERSE)

    def _zero_rows_is_set_bc(self) -> bool:
        """Whether zeroing :attr:`_bc_rows` of an owned array is what ``set_bc(b, bcs,
        scale=0)`` does (checked once on a vector of ones: the conditions are the anchors'
        rows); otherwise dolfinx's ``set_bc`` is called at every evaluation."""
        with self.rhs.localForm() as loc:
            loc.set(1.0)
        fpetsc.set_bc(self.rhs, self.model.bcs, scale=0.0)
        zero = np.flatnonzero(self.rhs.array_r == 0.0)
        return zero.size == self._bc_rows.size and np.array_equal(zero,
                                                                 np.sort(self._bc_rows))

    def equilibrium_acceleration(self, t: float) -> None:
        """Set ``model.a`` to the acceleration that satisfies the equations of motion at
        ``t`` for the current ``model.u`` and ``model.v`` (anchors: prescribed)."""
        self._equilibrium(t, self._anchor_accelerations(t))
        self.R.scale(-1.0)  # what it left there before: -F(u, v, a_b)

    def _anchor_accelerations(self, t: float) -> list:
        """Each anchor's prescribed acceleration at ``t`` (None: without motion)."""
        return [anc.acceleration(t) if anc.motion is not None else None
                for anc in self.model.anchors]

    def _equilibrium(self, t: float, acc: list) -> None:
        """:meth:`equilibrium_acceleration` with the anchors' accelerations ``acc``,
        leaving ``F(u, v, a_b)`` in ``self.R`` and the correction ``δa`` in ``self.da``."""
        m = self.model
        self._time = t
        if self._mass_moves:
            self._assemble_mass()
        self._anchors_only(acc)
        self._assemble()
        rhs = self.rhs.array_w
        np.negative(self.R.array_r, out=rhs)
        if self._zero_rows:
            rhs[self._bc_rows] = 0.0  # zero rows: anchors keep a_b
        else:
            fpetsc.set_bc(self.rhs, m.bcs, scale=0.0)
        self.ksp.solve(self.rhs, self.da)
        _solved(t, self.ksp.getConvergedReason())
        if m.comm.size > 1:  # one rank: no ghosts to update
            self.da.ghostUpdate(addv=INSERT, mode=FORWARD)
        m.a.vector.axpy(1.0, self.da)
        if m.comm.size > 1:
            m.a.vector.ghostUpdate(addv=INSERT, mode=FORWARD)

    def _anchors_only(self, acc: list) -> None:
        """``model.a``: the anchors' accelerations ``acc``, zero elsewhere."""
        arr = self.model.a.x.array
        arr[:] = 0.0
        for anc, a in zip(self.model.anchors, acc):
            if anc.dofs.size and a is not None:  # the others: zero, set above
                arr[anc.flat_dofs] = anc.prescribed_from(a)

    def _native_applies(self) -> bool:
        """Whether the residual has a C route (:mod:`cablefem.native_rows`) that does the
        dynamic evaluation's operations: its own residual, a fixed mass, zeroed rows."""
        return not (getattr(self.packer, "native", None) is None or self._mass_moves
                    or not self._zero_rows or self.packer.F is not self.model.f_dynamic)

    def _native(self, t: float, acc: list) -> bool:
        """:meth:`compute`'s dynamic part in one C call where the residual has one
        (the same operations, the same numbers); False otherwise (nothing done)."""
        if not self._native_applies():
            return False
        self._time = t
        self._anchors_only(acc)
        _solved(t, self.packer.native.forces(t, self.ksp, self.M_full, self.R,
                                             (self.rhs, self.da, self.Mda), self._bc_rows))
        return True

    def _native_forces(self, t: float, acc: list) -> np.ndarray | None:
        """:meth:`compute`'s dynamic evaluation in one C call, where :meth:`_native`
        applies to a string whose every anchor is on this rank (the same operations and
        numbers); None otherwise (nothing done)."""
        if self._layout is False or not self._native_applies():
            return None
        if self._layout is None:
            self._layout = self._anchor_layout()
            if self._layout is False:
                return None
        lay = self._layout
        lay.acc[:] = _rows(acc, range(len(acc)))
        hinges = self.model.hinges
        lay.anchors.hinges = bool(hinges)
        if hinges:
            lay.mass[:], lay.has_hinge[:] = 0.0, 0
            for i, mass in hinges.masses().items():
                lay.mass[i], lay.has_hinge[i] = mass, 1
            lay.g[:] = hinges.g_vec
        self._time = t
        _solved(t, lay.call(t))
        return lay.out.copy()

    def _anchor_layout(self) -> _AnchorLayout | bool:
        """The :class:`_AnchorLayout` of :meth:`_native_forces`, or False: a rod, or an
        anchor off this rank."""
        from cablefem.native_rows import Anchors

        m = self.model
        n = len(m.anchors)
        if (m.is_beam or m.bs != 3 or [i for i, _ in self._own] != list(range(n))
                or any(anc.bs != 3 for anc in m.anchors)):
            return False
        rows = [anc.flat_dofs for anc in m.anchors if anc.dofs.size]
        src = [3 * i + anc._layout()[1] for i, anc in enumerate(m.anchors) if anc.dofs.size]
        lay = _AnchorLayout(np.ascontiguousarray(np.concatenate(rows), PETSc.IntType),
                            np.ascontiguousarray(np.concatenate(src), np.int32),
                            np.array([row for _, row in self._own], PETSc.IntType),
                            np.zeros(n, np.int32), np.zeros(n), np.zeros(3),
                            np.zeros((n, 3)), np.zeros((n, 3)))
        lay.anchors = Anchors(n=n, n_a=lay.a_rows.size, hinges=0,
                              **{k: getattr(lay, k).ctypes.data for k in
                                 ("a_rows", "a_src", "row", "has_hinge", "mass", "g")})
        lay.call = self.packer.native.anchor_forces(
            lay.anchors, lay.acc, lay.out, self.ksp, self.M_full, self.R,
            (self.rhs, self.da, self.Mda), self._bc_rows)
        return lay

    def compute(self, t: float, dynamic: bool = True) -> np.ndarray:
        """Anchor forces ``N_a`` (n_anchors, 3) in N, identical on every rank; for a beam
        (n_anchors, 6): force and moment (N m, the rod's internal moment at the anchor).

        With ``dynamic=False`` velocity and acceleration are taken as zero (statics).
        In dynamics the residual is linear in the acceleration, so the anchor rows of
        ``F(u, v, a_b + δa)`` are those of ``F(u, v, a_b)`` plus ``M δa``: one assembly.
        """
        m = self.model
        self._time = t
        if dynamic:
            acc = self._anchor_accelerations(t)
            forces = self._native_forces(t, acc)
            if forces is not None:  # the whole evaluation in one C call
                return forces
            if not self._native(t, acc):
                self._equilibrium(t, acc)  # leaves F(u, v, a_b) in self.R
                self.M_full.mult(self.da, self.Mda)
                self.R.axpy(1.0, self.Mda)  # R = F(u, v, a_b) + M da = F(u, v, a)
            arr = self.R.array_r
        else:
            m.a.x.array[:] = 0.0
            self._time = None  # statics: packed afresh
            self._assemble()
            arr = self.R.array_r
        local, own = self._local, self._own_index
        local[:] = 0.0
        local[own, :3] = -arr[self._own_rows]
        if m.hinges:  # the layers' weight and inertia: the forces at the real anchors
            a = _rows(acc, own) if dynamic else np.zeros((own.size, 3))
            local[own, :3] += m.hinges.layer_forces(own, a)
        if m.is_beam:  # a rod: its rotation rows' reaction -> the moment (rod.py)
            for i, row in self._own:
                anc = m.anchors[i]
                off = row + anc.rot_offset
                local[i, 3:] = -(anc.moment_map @ arr[off: off + 3])
        if m.comm.size == 1:
            return local.copy()
        m.comm.Allreduce(local, self._global, op=MPI.SUM)
        return self._global.copy()  # the caller may keep it: not the buffer itself

    def destroy(self) -> None:
        """Free the PETSc objects (the object cannot compute afterwards)."""
        for obj in (self.ksp, self.M, self.M_full, self.R, self.rhs, self.Mda, self.da):
            obj.destroy()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.destroy()


@dataclass
class _AnchorLayout:
    """The arrays :class:`cablefem.native_rows.Anchors` points into (kept alive here):
    the rows of ``model.a`` the accelerations go to and where from, each anchor's first
    residual row, the hinges' flags, masses and gravity, the accelerations and the
    forces; the Anchors and the prepared C call."""

    a_rows: np.ndarray
    a_src: np.ndarray
    row: np.ndarray
    has_hinge: np.ndarray
    mass: np.ndarray
    g: np.ndarray
    acc: np.ndarray
    out: np.ndarray
    anchors: object = None
    call: object = None


def _rows(acc: list, which) -> np.ndarray:
    """(len(which), 3): the accelerations ``acc[i]`` of the anchors ``which``, zero where
    one is None (an anchor without motion)."""
    out = np.zeros((len(which), 3))
    for k, i in enumerate(which):
        if acc[int(i)] is not None:
            out[k] = acc[int(i)]
    return out


def _solved(t: float, reason: int) -> None:
    """RuntimeError when the mass solve at ``t`` failed (its KSP's converged reason)."""
    if reason < 0:
        raise RuntimeError(f"mass-matrix solve failed at t={t:g} (KSP reason {reason})")
