"""How much the span's own bending would move a string's natural frequencies, and the
``solver.span_bending = "auto"`` decision it drives (docs/theory.md §6.1).

The string leaves the span's ``EI`` out (``solver.span_bending = false``); the term that
puts it in is a bending energy on the turning angle at the vertices
(:func:`cablefem.bending_forms.span_bending_energy`). To first order in that energy, mode ``i``
(circular frequency ``omega_i``, shape ``phi_i`` about the static state) moves by

    d omega_i / omega_i = (phi_i' K_b phi_i) / (2 omega_i^2 phi_i' M phi_i),

``K_b`` the energy's Hessian at the static state and ``M`` the model's mass matrix (point
masses, added mass and the hinges' regions included). :func:`frequency_shifts` evaluates
``phi' K_b phi`` as the second difference of the same vertex sum, in NumPy, at the same
vertices as the finite-element term (:meth:`cablefem.cable.CableModel.bending_vertices`),
and ``phi' M phi`` with the assembled mass matrix.

``"auto"`` (the case files' default) takes the span's bending into the outer problem where
it matters: when a computed mode would move by more than :data:`AUTO_THRESHOLD` (the
accuracy aimed at for the frequencies against the rod). It is resolved by
:func:`cablefem.app.run.run_case` from the string without it; a model built directly
(:class:`cablefem.cable.CableModel`) takes ``"auto"`` as off.
"""

from __future__ import annotations

import numpy as np
from dolfinx.fem import petsc as fpetsc

__all__ = ["AUTO_THRESHOLD", "vertex_energy", "frequency_shifts", "is_on"]

#: ``"auto"`` switches the span's bending on when a computed mode would move by more than
#: this (relative)
AUTO_THRESHOLD = 0.005
#: the second difference's step: this fraction of the cable's length at the mode's
#: largest nodal amplitude
STEP = 1e-4


def is_on(setting) -> bool:
    """Whether a ``solver.span_bending`` setting puts the span's bending in (``"auto"``
    still unresolved counts as off)."""
    return setting is True


def vertex_energy(points: np.ndarray, vertices: np.ndarray, EI: np.ndarray,
                  hbar: np.ndarray) -> float:
    """``sum EI (1 - cos theta) / hbar`` over the ``vertices`` (n, 3) (node before, node,
    node after) of a chain of nodes at ``points``: the span-bending energy of
    :func:`cablefem.bending_forms.span_bending_energy`, J."""
    if not len(vertices):
        return 0.0
    a, k, b = (points[vertices[:, j]] for j in range(3))
    e1, e2 = k - a, b - k
    cos = np.einsum("ij,ij->i", e1, e2) / (np.linalg.norm(e1, axis=1)
                                           * np.linalg.norm(e2, axis=1))
    return float(np.sum(EI * (1.0 - cos) / hbar))


def frequency_shifts(model, modal) -> np.ndarray:
    """The relative change of each mode's frequency that the span's bending would make
    (first order, module docs), about the model's static state ``model.u_static``
    (collective; the same array on every rank)."""
    vertices, EI, hbar = model.bending_vertices()
    M = fpetsc.assemble_matrix(model.m_form, model.bcs, diagonal=0.0)
    M.assemble()
    y = M.createVecLeft()
    base = model.gather_nodal(model.u_static)
    out = []
    for w, shape in zip(modal.omegas, modal.shapes):
        M.mult(shape.vector, y)
        mass = shape.vector.dot(y)
        phi = model.gather_nodal(shape)
        val = None
        if model.comm.rank == 0:
            pts = model.geometry.points + base
            t = STEP * model.length / max(float(np.max(np.abs(phi))), 1e-300)
            e = [vertex_energy(pts + s * t * phi, vertices, EI, hbar) for s in (-1, 0, 1)]
            stiff = (e[0] - 2.0 * e[1] + e[2]) / (t * t)
            val = stiff / (2.0 * w * w * mass) if w > 0 and mass > 0 else np.nan
        out.append(model.comm.bcast(val, root=0))
    y.destroy()
    M.destroy()
    return np.asarray(out, float)
