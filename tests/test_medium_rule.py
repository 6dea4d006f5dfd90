"""The medium's own Gauss rule (cablefem.fluid.QUADRATURE_DEGREE, cablefem.seabed's,
cablefem.jit.mixed_rules; docs/fluid.md, "Quadrature"): a kernel of several rules equals
the sum of its integrals' own kernels, each term keeps its rule, and the drag's rule moves
a mooring line's statics by a small part of the mesh's own error (serially and under
mpirun -n 2)."""

from __future__ import annotations

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fpetsc
from mpi4py import MPI

from cablefem import fluid, seabed
from cablefem.cable import CableModel
from cablefem.case import parse_case
from cablefem.statics import solve_static

comm = MPI.COMM_WORLD
M, G, LINE, H_F, X_F = 50.0, 9.81, 150.0, 50.0, 120.0  # kg/m, m/s^2, m, m, m


def mooring(elements: int = 30) -> dict:
    """A 150 m line on a seabed (z = 0) to a fairlead 50 m above it, in a 1 m/s current
    along the line with a 1/7 power-law profile, a wave and contact friction."""
    return {"title": "mooring", "section": {"EA": 1e9, "EI": 1e3, "mass": M},
            "gravity": {"g": G}, "geometry": {"length": LINE},
            "mesh": {"elements": elements},
            "anchors": [{"name": "anchor", "position": [0.0, 0, 0], "type": "pinned"},
                        {"name": "fairlead", "position": [X_F, 0, H_F], "type": "pinned"}],
            "seabed": {"z": 0.0, "stiffness": 1e5, "damping": 1e3, "friction": 0.5},
            "fluid": {"density": 1025.0, "diameter": 0.1, "surface": 60.0,
                      "current": [1.0, 0.0, 0.0],
                      "profile": {"type": "power", "ground": 0.0, "reference": 60.0,
                                  "exponent": 1 / 7},
                      "waves": [{"height": 2.0, "period": 8.0, "direction": [1.0, 0, 0]}]},
            "solver": {"outer_correction": "none"}}


def _rules(form) -> set:
    return {itg.metadata().get("quadrature_degree") for itg in form.integrals()}


def test_each_term_keeps_its_rule_and_the_kernel_is_the_sum_of_its_parts():
    """The dynamic residual and its Jacobian, one kernel each with the drag on its rule
    (3 points), the seabed on its own (7 points) and the string's terms on theirs, equal the
    sums of every term's form compiled alone, at a state of random displacements,
    velocities and accelerations: to round-off (1e-13 of the largest entry: a different
    order of the same sums). FFCx 0.5 alone fails to compile the first kernel (its cell
    constants declared once per rule)."""
    model = CableModel(comm, parse_case(mooring(elements=12)))
    forms = model.forms
    assert _rules(forms.term("fluid_dynamic").form) == {fluid.QUADRATURE_DEGREE}
    assert _rules(forms.term("seabed").form) == {seabed.QUADRATURE_DEGREE}
    assert None in _rules(forms.inertia)  # the string's terms: UFL's estimate
    rng = np.random.default_rng(7)
    for f in (model.u, model.v, model.a):
        f.x.array[:] = rng.normal(scale=0.1, size=f.x.array.size)
    model.set_time(1.3)
    whole = fpetsc.assemble_vector(forms.f_dynamic)
    whole.ghostUpdate(addv=fpetsc.PETSc.InsertMode.ADD, mode=fpetsc.PETSc.ScatterMode.REVERSE)
    parts = whole.duplicate()
    parts.set(0.0)
    J = forms.J_dynamic
    Jw = fpetsc.assemble_matrix(forms.j_dynamic)
    Jw.assemble()
    Jp = Jw.duplicate()
    Jp.zeroEntries()
    for form, _ in forms.terms.values():
        b = fpetsc.assemble_vector(fem.form(form))
        b.ghostUpdate(addv=fpetsc.PETSc.InsertMode.ADD, mode=fpetsc.PETSc.ScatterMode.REVERSE)
        parts.axpy(1.0, b)
        dJ = ufl.derivative(form, model.u, forms.trial)
        for w, shift in ((model.v, forms.shift_v), (model.a, forms.shift_a)):
            if w in form.coefficients():
                dJ = dJ + shift * ufl.derivative(form, w, forms.trial)
        A = fpetsc.assemble_matrix(fem.form(dJ))
        A.assemble()
        Jp.axpy(1.0, A, structure=fpetsc.PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
    assert len(J.integrals()) > 1
    scale = whole.norm(fpetsc.PETSc.NormType.INFINITY)
    parts.axpy(-1.0, whole)
    assert parts.norm(fpetsc.PETSc.NormType.INFINITY) < 1e-13 * scale
    jscale = Jw.norm(fpetsc.PETSc.NormType.INFINITY)
    Jp.axpy(-1.0, Jw, structure=fpetsc.PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
    assert Jp.norm(fpetsc.PETSc.NormType.INFINITY) < 1e-13 * jscale


def _statics(elements: int, degree) -> tuple[float, float]:
    saved = fluid.QUADRATURE_DEGREE
    fluid.QUADRATURE_DEGREE = degree
    try:
        model = CableModel(comm, parse_case(mooring(elements)))
    finally:
        fluid.QUADRATURE_DEGREE = saved
    st = solve_static(model)
    from cablefem.seabed import touchdown
    return float(np.linalg.norm(st.anchor_forces[1][:3])), touchdown(model)["s"]


@pytest.mark.parametrize("elements", [30])
def test_the_drags_rule_moves_the_statics_by_little_of_the_mesh_error(elements):
    """The fairlead tension and the touchdown with the drag on 3 Gauss points against
    UFL's 7 (degree 12): the change is below a tenth of the mesh's own error, estimated as
    the change from h to h/2 (the O(h^2) string: 4/3 of it is the error at h; a tenth of
    the change leaves the answer's error within 1.1 times the mesh's)."""
    coarse = _statics(elements, fluid.QUADRATURE_DEGREE)
    seven = _statics(elements, None)
    fine = _statics(2 * elements, None)
    for rule, exact, half in zip(coarse, seven, fine):
        assert abs(rule - exact) < 0.1 * abs(half - exact), (rule, exact, half)
