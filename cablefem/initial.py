"""The velocity a time integration starts from (:func:`initial_velocity`), used by
:class:`cablefem.dynamics.DynamicProblem` and re-exported by :mod:`cablefem.dynamics`."""

from __future__ import annotations

import logging

import numpy as np
from dolfinx.fem import petsc as fpetsc
from mpi4py import MPI
from petsc4py import PETSc

from cablefem.petsc_utils import case_options, default_options, lu_options, model_dofs

__all__ = ["initial_velocity"]

log = logging.getLogger("cablefem.dynamics")


def initial_velocity(model, V: PETSc.Vec, t: float = 0.0, quasi_static: bool = True) -> bool:
    """Fill ``V`` with the velocity the dynamics starts from at time ``t``.

    The anchors' rows get their prescribed velocity ``ġ(t)`` (a clamp's rotation rows 0: a
    clamp translates). With ``quasi_static`` the free rows get the velocity with which the
    cable follows that motion quasi-statically, the solution of the tangent problem at the
    current state ``model.u`` (normally the static equilibrium)::

        K_ff v_f = −K_fb ġ(t),        K = ∂f_int/∂u (the static Jacobian)

    so that no element is strained at a rate: the anchor does not tear away from a cable at
    rest (a velocity jump across the first element, whose strain rate ``|ġ|/h`` grows without
    bound as the element shrinks and which a stiffness-proportional damping turns into a
    reaction ``β EA |ġ|/h``; the rod, graded to ``ℓ/8`` at a clamp, has elements 10-100 times
    shorter than the string's). Without ``quasi_static``, or when every anchor is at rest,
    the free rows are 0 (the cable at rest). Returns whether a quasi-static field was
    solved for (False when nothing moves). Collective."""
    V.set(0.0)
    n_owned = model.V.dofmap.index_map.size_local
    rows, vals = [], []
    for anc in model.anchors:
        r = anc.flat_dofs
        keep = r < model.bs * n_owned
        rows.append(r[keep])
        vals.append(np.asarray(anc.prescribed("velocity", t), float)[keep])
    rows = np.concatenate(rows).astype(np.int32) if rows else np.zeros(0, np.int32)
    vals = np.concatenate(vals) if vals else np.zeros(0)
    V.array[rows] = vals
    moving = model.comm.allreduce(bool(np.any(vals != 0.0)), op=MPI.LOR)
    if not (quasi_static and moving):
        return False
    # K at model.u, unconstrained: b = -K v_b; the anchor rows of b hold v_b
    K = fpetsc.assemble_matrix(model.j_static)
    K.assemble()
    b = V.duplicate()
    K.mult(V, b)
    b.scale(-1.0)
    b.array[rows] = vals
    # the tangent with identity rows and zero columns at the anchors: K_ff v_f = -K_fb v_b
    K.zeroRowsColumnsLocal(rows, diag=1.0)
    ksp = PETSc.KSP().create(model.comm)
    prefix = model.prefix + "static_"
    ksp.setOptionsPrefix(prefix)
    ksp.setOperators(K)
    with default_options(prefix, lu_options(model.comm.size, model_dofs(model)),
                         case_options(model, "static")):
        ksp.setFromOptions()
    x = V.duplicate()
    ksp.solve(b, x)
    ok = ksp.getConvergedReason() > 0 and np.all(np.isfinite(x.array_r))
    ok = model.comm.allreduce(bool(ok), op=MPI.LAND)
    if ok:
        x.copy(V)
        V.array[rows] = vals  # exactly the prescribed values
    elif model.comm.rank == 0:
        log.warning("the quasi-static initial velocity could not be solved for (KSP reason "
                    "%d): the cable starts at rest, its anchors moving",
                    ksp.getConvergedReason())
    for obj in (ksp, K, b, x):
        obj.destroy()
    return ok
