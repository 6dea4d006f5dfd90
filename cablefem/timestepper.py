"""The time integrator's PETSc ``TS`` (``alpha2``) with its options, callbacks and Newton
(:class:`cablefem.stepnewton.StepNewton`), for :class:`cablefem.dynamics.DynamicProblem`.

The residual and Jacobian come from :class:`cablefem.petsc_utils.RowsAssembler` (the
anchors' rows ``x - g`` weighted by :func:`bc_row_scale`). On one rank, where
:func:`cablefem.native_rows.native_rows` applies, the TS calls the C side directly
(:meth:`cablefem.native_rows.NativeRows.drive`): Python is then called only at a new time
and for the Jacobian's decision (:class:`~cablefem.stepnewton.StepNewton`'s reuse); the
same numbers to the last bit.
"""

from __future__ import annotations

import numpy as np
from dolfinx.fem import petsc as fpetsc
from mpi4py import MPI
from petsc4py import PETSc

from cablefem import junctions
from cablefem.native_rows import native_rows
from cablefem.petsc_utils import (
    RowsAssembler,
    SNESHistory,
    case_options,
    copy_in,
    default_options,
    keeps_factorisation,
    linear_solver_options,
    model_dofs,
)
from cablefem.stepnewton import StepNewton

__all__ = ["bc_row_scale", "make_ts"]


def bc_row_scale(model) -> float:
    """The weight of the anchors' rows ``x − g`` in the time integrator's residual, N/m:
    the largest force per metre of the cable, its force scale over its shortest element.
    The rows hold a length; Newton's tolerance is a force. Unweighted, a prescribed motion
    smaller than ``snes_atol`` (in metres) per step was not applied at all: Newton stopped
    at its predictor, the anchor lagged until the gap exceeded the tolerance, then caught
    up in one step, a jolt (a 192 m stay on 2000 elements, its deck starting a slow
    harmonic motion: held still for 0.41 s, then a jump of 0.17 mm that Newton's divergence
    test refused, and the run failed). Weighted, a gap of ``snes_atol/κ`` (1e-11 m there)
    is seen."""
    geo = model.mesh.geometry  # 1D cells of two nodes: their lengths
    ends = geo.x[geo.dofmap.array.reshape(-1, 2)]
    h = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)
    h_min = model.comm.allreduce(float(np.min(h, initial=np.inf)), op=MPI.MIN)
    return float(model.force_scale / h_min)


def make_ts(model, dt: float, rho_inf: float, history: SNESHistory,
            prefix: str | None = None, petsc_options: dict | None = None):
    """``model``'s time integrator: ``(ts, (F, J, newton), rows)``, the TS (options prefix
    ``prefix``, default the model's; ``petsc_options`` over the case file's, over the
    defaults), its residual vector and Jacobian matrix (alive as long as the TS), its
    :class:`~cablefem.stepnewton.StepNewton` (which records every residual norm in
    ``history``) and its :class:`~cablefem.petsc_utils.RowsAssembler` (``rows.native``:
    the C route, or None)."""
    prefix = model.prefix if prefix is None else prefix
    scale = model.force_scale
    n_dofs = model_dofs(model)
    defaults = {"ts_type": "alpha2", "ts_alpha_radius": rho_inf, "ts_max_reject": 0,
                "ts_max_snes_failures": -1, "snes_type": "newtonls",
                "snes_linesearch_type": "basic", "snes_rtol": 1e-9,
                "snes_atol": max(1e-11 * scale, 10.0 * model.residual_floor()),
                "snes_max_it": 25,
                # large networks: the residual's round-off floor (stiffness x position
                # round-off, summed over the dofs) can exceed atol; a relative update of
                # 1e-13 is converged
                "snes_stol": 1e-13,
                **linear_solver_options(n_dofs, model.comm.size, reuse=not model.is_beam)}

    n_owned = model.V.dofmap.index_map.size_local
    bc_rows = np.concatenate([a.flat_dofs for a in model.anchors]).astype(np.int32)
    bc_rows = bc_rows[bc_rows < model.bs * n_owned]  # owned rows; each rank zeroes its own
    F_vec = fpetsc.create_vector(model.f_dynamic)
    kappa = bc_row_scale(model)

    # the residual and Jacobian of assemble_residual_rows / assemble_jacobian_rows, the
    # anchors' rows x - g weighted by kappa (bc_row_scale), without per-call dispatch
    extra = None
    if model.node_terms:  # terms outside UFL (a network's kink corners), at model.u
        extra = (lambda arr: junctions.add_residual(model, arr),
                 lambda A: junctions.add_jacobian(model, A))
    F = model.f_dynamic
    # a term's time law may set its Functions (not only Constants) at a new time
    timed = (any(model.forms.term(n).set_time is not None for n in model.forms.user)
             or any(model.u_bc._cpp_object is c for c in F.coefficients))
    # the Jacobian in a fast and a slow part (a fluid's: Term.slow_jacobian), the slow one
    # kept longer; j_dynamic_slow is None without a slow term: the Jacobian whole
    slow = model.j_dynamic_slow
    parts = None if slow is None else (model.j_dynamic_fast, slow)
    rows = RowsAssembler(F, model.j_dynamic, model.bcs, bc_rows, kappa, model.comm, extra,
                         (model.u, model.v, model.a), timed, parts)
    serial, (u, v, a) = model.comm.size == 1, (model.u, model.v, model.a)

    # the Python route's callbacks (with the C route, cablefem.native_rows, the TS calls
    # the C side, which calls decide for the Jacobian and the model's time when it is new)
    def I2Function(ts, t, U, V, A, F):
        model.set_time(t)
        for X, f in ((U, u), (V, v), (A, a)):
            copy_in(X, f, serial)
        rows.residual(F, U, t)

    shifts = [None, None]  # the shifts the Constants hold (set here only)

    def decide(shift_v: float, shift_a: float, J: PETSc.Mat) -> int:
        """The Jacobian into ``J`` at the state of the residual just before (SNES): 0
        when done here (kept with its factorisation, or assembled), 1 when the C side is
        to assemble it whole (its constants packed)."""
        if newton.keep_jacobian(shift_v, shift_a):  # J and its factorisation kept
            return 0
        changed = shifts[0] != shift_v or shifts[1] != shift_a  # equal steps: the same
        if changed:
            model.shift_v.value = shifts[0] = shift_v
            model.shift_a.value = shifts[1] = shift_a
        native = rows.native
        if native is None:
            rows.jacobian(J, slow=newton.slow)
        elif rows.parts is None:
            if changed:
                native.constants()
            return 1
        else:  # its fast and slow parts
            native.jacobian(J, changed, newton.slow)
        return 0

    def I2Jacobian(ts, t, U, V, A, shift_v, shift_a, J, P):
        decide(shift_v, shift_a, J)

    newton = None  # the StepNewton, made once the options are read
    ts = PETSc.TS().create(model.comm)
    ts.setOptionsPrefix(prefix)
    ts.setType(PETSc.TS.Type.ALPHA2)
    ts.setI2Function(I2Function, F_vec)
    ts.setTimeStep(dt)
    ts.setExactFinalTime(PETSc.TS.ExactFinalTime.MATCHSTEP)
    user = {**case_options(model, ""), **(petsc_options or {})}
    with default_options(prefix, defaults, user):
        # -cable_mat_type (default baij: bs x bs blocks, assembly and triangular solves
        # faster than aij) is read here: the matrix must exist before the TS is configured
        J_mat = junctions.create_matrix(model, model.j_dynamic,
                                        PETSc.Options().getString(prefix + "mat_type"))
        # zeroing the anchor rows must keep the sparsity pattern: otherwise every assembly
        # changes it and every factorisation redoes its symbolic phase (and allocates)
        J_mat.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
        ts.setI2Jacobian(I2Jacobian, J_mat)
        ts.setFromOptions()
        # predictor, stopping test and Jacobian reuse (a fluid's, a seabed's Jacobian is
        # dear, and so is the kink corners' complex-step one: docs/benchmarks.md, "Networks
        # on 2 ranks"), and so is a large model's factorisation (linear_solver_options)
        costly = bool(model.forms.medium_forms or model.node_terms) or keeps_factorisation(
            n_dofs, reuse=not model.is_beam)
        newton = StepNewton(ts, prefix, costly, history)  # its test keeps the norms
        newton.split = rows.parts is not None
        rows.native = native_rows(model, rows, prefix)  # None: the Python route
        if rows.native is not None:  # without reuse or a split Jacobian, the C side
            # assembles at unchanged shifts without asking (the same decision every time)
            rows.native.drive(ts, F_vec, J_mat, lambda sv, sa: decide(sv, sa, J_mat),
                              same=newton.reuse == 0 and not newton.split)
            newton.elsewhere = lambda: rows.native.assembled
    return ts, (F_vec, J_mat, newton), rows
