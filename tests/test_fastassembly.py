"""The time integrator's assembly without dolfinx's per-call Python dispatch
(:class:`cablefem.petsc_utils.RowsAssembler`, the anchor reactions' residual) gives the same
numbers as dolfinx's wrappers, bit for bit: the same kernels with the same packed constants
and coefficients add the same terms in the same order."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import level_case
from dolfinx import cpp as dcpp
from dolfinx.fem import IntegralType
from dolfinx.fem import petsc as fpetsc
from mpi4py import MPI
from petsc4py import PETSc

from cablefem.cable import CableModel
from cablefem.case import parse_case
from cablefem.dynamics import bc_row_scale
from cablefem.petsc_utils import (
    RowsAssembler,
    assemble_jacobian_rows,
    assemble_residual_rows,
    jacobian_columns,
    state_gather,
)
from cablefem.reactions import AnchorReactions
from cablefem.statics import solve_static

MOTION = {"type": "harmonic", "amplitude": [2e-4, 1e-4, 0], "omega": 32.814}
DAMPING = {"ratio": 0.005, "frequencies": [16.407, 32.814]}


def _moved_model(**solver):
    """A sagging cable off its static state, moving, at a time its anchor has moved: every
    term of the residual (stiffness, damping, inertia, weight) and the Dirichlet rows
    ``x - g`` non-zero."""
    model = CableModel(MPI.COMM_WORLD, parse_case(level_case(elements=8, motion=MOTION,
                                                             damping=DAMPING,
                                                             solver=solver)))
    solve_static(model)
    return _moved(model, 3, (1e-4, 1e-2, 1.0), 0.0123, (412.0, 8.1e4))


def _moved(model, seed: int, scales, t: float, shifts):
    """``model`` off its state by random ``u``, ``v``, ``a`` of ``scales`` (a seed per
    rank), at time ``t``, with the time integrator's ``shifts`` (v, a)."""
    rng = np.random.default_rng(seed + model.comm.rank)
    for f, scale in zip((model.u, model.v, model.a), scales):
        f.x.array[:] += scale * rng.standard_normal(f.x.array.size)
        f.x.scatter_forward()
    model.set_time(t)
    model.shift_v.value, model.shift_a.value = shifts
    return model


def _assemblers(model):
    """The time integrator's assembler (the state gathered into the packing) and one that
    packs the form whole at every call."""
    n_owned = model.V.dofmap.index_map.size_local
    rows = np.concatenate([a.flat_dofs for a in model.anchors]).astype(np.int32)
    rows = rows[rows < model.bs * n_owned]
    args = (model.f_dynamic, model.j_dynamic, model.bcs, rows, bc_row_scale(model),
            model.comm)
    return RowsAssembler(*args, state=(model.u, model.v, model.a)), RowsAssembler(*args)


def _count_packs(monkeypatch) -> list:
    """The forms dolfinx packs from now on, in order."""
    packs = []
    real = dcpp.fem.pack_coefficients
    monkeypatch.setattr(dcpp.fem, "pack_coefficients", lambda F: packs.append(F) or real(F))
    return packs


def test_rows_assembler_is_bit_identical_to_the_wrappers():
    """Residual and Jacobian of the fast path equal dolfinx's wrapper route exactly
    (difference 0, not a tolerance: the same floating-point operations)."""
    model = _moved_model()
    n_owned = model.V.dofmap.index_map.size_local
    rows = np.concatenate([a.flat_dofs for a in model.anchors]).astype(np.int32)
    rows = rows[rows < model.bs * n_owned]
    kappa = bc_row_scale(model)
    fast = RowsAssembler(model.f_dynamic, model.j_dynamic, model.bcs, rows, kappa, model.comm)
    if model.mesh.topology.index_map(1).size_local:  # a rank with cells: the fast route
        assert fast.cols is not None  # the Jacobian's coefficients taken from the residual's
    x = model.u.vector
    b_ref, b_fast = fpetsc.create_vector(model.f_dynamic), fpetsc.create_vector(model.f_dynamic)
    b_fast.set(7.0)  # stale content must not leak into the result
    assemble_residual_rows(b_ref, model.f_dynamic, model.bcs, x)
    with b_ref.localForm() as loc:
        loc.array[rows] *= kappa
    fast.residual(b_fast, x)
    assert b_ref.norm() > 0
    assert np.array_equal(b_ref.array_r, b_fast.array_r)

    A_ref = fpetsc.create_matrix(model.j_dynamic)
    A_fast = fpetsc.create_matrix(model.j_dynamic)
    A_fast.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
    assemble_jacobian_rows(A_ref, model.j_dynamic, rows, diag=kappa)
    fast.jacobian(A_fast)
    fast.jacobian(A_fast)  # a second assembly into the same matrix: zeroed first
    A_fast.axpy(-1.0, A_ref)
    assert A_ref.norm() > 0
    assert A_fast.norm() == 0.0
    for obj in (b_ref, b_fast, A_ref, A_fast):
        obj.destroy()


def test_reactions_residual_is_bit_identical_to_the_wrapper():
    """The anchor reactions' unconstrained residual, assembled directly, equals
    ``dolfinx.fem.petsc.assemble_vector`` plus the ghost accumulation exactly."""
    model = _moved_model()
    with AnchorReactions(model) as reactions:
        reactions.R.set(3.0)
        reactions._assemble()
        ref = fpetsc.create_vector(model.f_dynamic)
        with ref.localForm() as loc:
            loc.set(0.0)
        fpetsc.assemble_vector(ref, model.f_dynamic)
        ref.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        assert ref.norm() > 0
        assert np.array_equal(ref.array_r, reactions.R.array_r)
        ref.destroy()


def test_reactions_mass_matrices_in_blocks_are_the_wrappers():
    """The anchor reactions' mass matrices are block matrices of the node's unknowns
    (BAIJ: assembled in half the time) holding exactly what dolfinx's wrapper assembles
    as an AIJ matrix at the same state: the unconstrained one, assembled again in place,
    and the constrained one (anchor rows and columns zeroed, 1 on the diagonal)."""
    model = _moved_model()
    with AnchorReactions(model) as reactions:
        reactions._assemble_mass()  # at the moved state, in place
        for mat, bcs in ((reactions.M_full, []), (reactions.M, model.bcs)):
            assert mat.getType().endswith("baij") and mat.getBlockSize() == model.bs
            ref = fpetsc.assemble_matrix(model.m_form, bcs, diagonal=1.0)
            ref.assemble()
            diff = mat.convert("aij")
            diff.axpy(-1.0, ref)
            assert ref.norm() > 0
            assert diff.norm() == 0.0
            for obj in (ref, diff):
                obj.destroy()


def test_jacobian_columns_refuses_a_coefficient_the_residual_lacks():
    """The residual's form packs the acceleration, the Jacobian's does not: the Jacobian's
    coefficients are columns of the residual's, not the other way round (None: pack anew);
    and the coefficients' values are left as they were."""
    model = _moved_model()
    before = [f.x.array.copy() for f in (model.u, model.v, model.a)]
    assert jacobian_columns(model.j_dynamic, model.f_dynamic) is None
    for f, b in zip((model.u, model.v, model.a), before):
        assert np.array_equal(f.x.array, b)


def test_a_second_residual_at_the_same_time_repacks_only_the_state():
    """Newton's next residual in a step: only ``u``, ``v``, ``a`` are copied into the
    packed coefficients, and the residual and Jacobian are bit-identical to a whole
    packing; a coefficient outside the state changed at the same time is not seen until
    :meth:`forget` (what a new step calls)."""
    model = _moved_model(outer_correction="hinge")  # the hinges' law: Functions of cells
    assert len(model.f_dynamic.coefficients) > 3  # more than u, v, a
    part, whole = _assemblers(model)
    if model.mesh.topology.index_map(1).size_local:
        assert part.gather is not None
    x = model.u.vector
    b1, b2 = fpetsc.create_vector(model.f_dynamic), fpetsc.create_vector(model.f_dynamic)
    part.residual(b1, x, 0.0123)  # packs everything
    rng = np.random.default_rng(11 + model.comm.rank)
    for f, scale in ((model.u, 1e-4), (model.v, 1e-2), (model.a, 1.0)):  # Newton's update
        f.x.array[:] += scale * rng.standard_normal(f.x.array.size)
        f.x.scatter_forward()
    part.residual(b1, x, 0.0123)  # the state copied in
    whole.residual(b2, x)
    assert np.array_equal(b1.array_r, b2.array_r)
    A1, A2 = (fpetsc.create_matrix(model.j_dynamic) for _ in range(2))
    for A in (A1, A2):
        A.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
    part.jacobian(A1)
    whole.jacobian(A2)
    A1.axpy(-1.0, A2)
    assert A1.norm() == 0.0

    # the hinges' law, outside the state: seen after forget() only
    model.law_kb.x.array[:] *= 1.5
    part.residual(b1, x, 0.0123)
    whole.residual(b2, x)
    changed = model.comm.allreduce(not np.array_equal(b1.array_r, b2.array_r), MPI.LOR)
    assert changed
    part.forget()
    part.residual(b1, x, 0.0123)
    assert np.array_equal(b1.array_r, b2.array_r)
    for obj in (b1, b2, A1, A2):
        obj.destroy()


def test_a_new_time_copies_in_what_changed_without_a_whole_packing(monkeypatch):
    """At a new time (a new step, or after :meth:`forget`) the Functions outside the state
    are compared with the values they were packed with and copied in where they changed
    (the hinges' law here, as a time law's waves would be): the residual is bit-identical
    to a whole packing's, and dolfinx packs nothing (before: every new time packed the
    whole form, 160 µs of a 200-cell mooring line's 3 ms step)."""
    model = _moved_model(outer_correction="hinge")  # the hinges' law: Functions of cells
    part, whole = _assemblers(model)
    if not model.mesh.topology.index_map(1).size_local:
        return  # a rank without cells packs nothing either way
    assert part.others is not None and len(part.others) > 0
    x = model.u.vector
    b1, b2 = fpetsc.create_vector(model.f_dynamic), fpetsc.create_vector(model.f_dynamic)
    part.residual(b1, x, 0.0123)  # the first call packs everything
    packs = _count_packs(monkeypatch)
    rng = np.random.default_rng(5 + model.comm.rank)
    # a new time with the hinges' law changed; the same time after forget() (a new
    # step); a new time with only the state changed
    for time, law, new_step in ((0.0124, 1.5, False), (0.0124, 1.0, True),
                                (0.0125, 1.0, False)):
        model.law_kb.x.array[:] *= law
        model.u.x.array[:] += 1e-5 * rng.standard_normal(model.u.x.array.size)
        if new_step:
            part.forget()
        part.residual(b1, x, time)
        n_part = len(packs)
        whole.residual(b2, x)
        assert len(packs) == n_part + 1  # the whole one packed, the part did not
        assert np.array_equal(b1.array_r, b2.array_r)
    assert all(F is whole.F for F in packs)
    for obj in (b1, b2):
        obj.destroy()


def test_an_undamped_residual_gathers_its_state_without_the_velocity(monkeypatch):
    """A model without damping has no velocity in its residual. Asked to gather the state
    (u, v, a) as the time integrator does, the assembler gathers u and a and never packs
    the form whole at a new time (before: state_gather refused the velocity, and every
    residual packed every coefficient: 36 µs of a 200-cell line's residual); the residual
    is bit-identical to a whole packing's."""
    model = CableModel(MPI.COMM_WORLD, parse_case(level_case(elements=8, motion=MOTION)))
    solve_static(model)
    held = list(model.f_dynamic.coefficients)
    assert not any(model.v._cpp_object is c for c in held)  # undamped: no velocity
    _moved(model, 3, (1e-4, 1e-2, 1.0), 0.0123, (412.0, 8.1e4))
    part, whole = _assemblers(model)
    if not model.mesh.topology.index_map(1).size_local:
        return  # a rank without cells packs nothing either way
    assert part.gather is not None
    x = model.u.vector
    b1, b2 = fpetsc.create_vector(model.f_dynamic), fpetsc.create_vector(model.f_dynamic)
    part.residual(b1, x, 0.0123)  # the first call packs everything
    packs = _count_packs(monkeypatch)
    rng = np.random.default_rng(7 + model.comm.rank)
    for time in (0.0124, 0.0125):  # new times, the state moved
        for f in (model.u, model.a):
            f.x.array[:] += 1e-5 * rng.standard_normal(f.x.array.size)
        model.set_time(time)
        part.residual(b1, x, time)
        assert not packs  # gathered, not packed
        whole.residual(b2, x)
        packs.clear()
        assert np.array_equal(b1.array_r, b2.array_r)
    for obj in (b1, b2):
        obj.destroy()


def test_state_gather_refuses_a_function_the_form_lacks():
    model = _moved_model()
    from dolfinx import fem
    stranger = fem.Function(model.V)
    assert state_gather(model.f_dynamic, (model.u, stranger)) is None


@pytest.mark.parametrize("time_law", [False, True])
def test_reactions_on_the_steps_packing_are_bit_identical(time_law):
    """The anchor reactions take the integrator's packed coefficients with the output
    state copied in (a model whose Functions but the state do not change with time), or
    pack afresh at a new time (a term with a time law that sets a Function of its own):
    the forces equal those of reactions that pack everything themselves, to the last bit,
    at every output of a short run."""
    import ufl
    from dolfinx import fem

    from cablefem.dynamics import DynamicProblem
    from cablefem.terms import Term

    model = CableModel(MPI.COMM_WORLD, parse_case(level_case(elements=8, motion=MOTION,
                                                             damping=DAMPING)))
    if time_law:  # a vertical load along the cable whose Function follows the time
        q = fem.Function(model.V)

        def law(t):
            q.x.array[2::3] = -0.3 * np.sin(40.0 * t)

        model.forms.add(Term("gust", -ufl.inner(q, model.du) * ufl.dx, "dynamic", law))
        model.compile()
    solve_static(model)
    with DynamicProblem(model, 0.005) as problem, AnchorReactions(model) as own:
        assert problem._rows.timed == time_law
        for _ in range(6):
            problem.step()
            problem.anchor_forces()
            shared = problem.reactions.compute(problem.time)
            alone = own.compute(problem.time)
            assert np.array_equal(shared, alone)


def _wet_moved_model():
    """demos/mooring.toml on 20 elements (current, swell, seabed with friction) with the
    span's bending (an interior-facet integral), off its static state and moving, at a
    time within the waves' ramp."""
    import tomllib
    from pathlib import Path

    from cablefem.create import model_from_case

    demos = Path(__file__).resolve().parents[1] / "demos"
    data = tomllib.loads((demos / "mooring.toml").read_text())
    data["mesh"]["elements"] = 20
    data.setdefault("solver", {})["span_bending"] = True
    model = model_from_case(MPI.COMM_WORLD, parse_case(data, base_dir=demos))
    solve_static(model)
    return _moved(model, 5, (1e-2, 0.3, 1.0), 3.1, (105.3, 1.1e4))


def test_a_split_jacobian_is_the_whole_one_and_keeps_its_slow_part():
    """The dynamic Jacobian assembled in two parts (the fluid's terms, ``slow_jacobian``,
    and the others: ``RowsAssembler(parts=...)``) is the whole one to round-off; with its
    slow part kept (``slow=False``) after the state moved, it differs from the whole one
    at the new state by exactly the change of the fluid's part (its kernels summed in
    another order: 1e-13 of the matrix's norm, round-off of ~10 terms per entry). Both
    parts take their coefficients from the residual's packing, the interior facets' too
    (two rows of dolfinx's array per facet; the fast part packed its own at every
    assembly before)."""
    model = _wet_moved_model()
    assert model.forms.J_dynamic_part(slow=True) is not None
    n_owned = model.V.dofmap.index_map.size_local
    rows = np.concatenate([a.flat_dofs for a in model.anchors]).astype(np.int32)
    rows = rows[rows < model.bs * n_owned]
    kappa = bc_row_scale(model)
    state = (model.u, model.v, model.a)
    whole = RowsAssembler(model.f_dynamic, model.j_dynamic, model.bcs, rows, kappa,
                          model.comm, state=state)
    split = RowsAssembler(model.f_dynamic, model.j_dynamic, model.bcs, rows, kappa,
                          model.comm, state=state,
                          parts=(model.j_dynamic_fast, model.j_dynamic_slow))
    if model.mesh.topology.index_map(1).size_local:  # a rank with cells: the fast route
        assert any(key[0] == IntegralType.interior_facet
                   for key in dcpp.fem.pack_coefficients(model.f_dynamic))
        assert all(cols is not None for _, cols in split.parts)
    b = fpetsc.create_vector(model.f_dynamic)
    A, A_split = (fpetsc.create_matrix(model.j_dynamic, "baij") for _ in range(2))

    def slow_part():  # the fluid's part, its anchor rows zeroed as the Jacobian's are
        S = fpetsc.assemble_matrix(model.j_dynamic_slow)
        S.assemble()
        S.zeroRowsLocal(rows, diag=0.0)
        return S

    for asm in (whole, split):
        asm.residual(b, model.u.vector, 3.1)
    whole.jacobian(A)
    split.jacobian(A_split, slow=True)
    S_old = slow_part()
    same = PETSc.Mat.Structure.SAME_NONZERO_PATTERN  # both made from j_dynamic's pattern
    D = A_split.copy()
    D.axpy(-1.0, A, structure=same)
    scale = A.norm()
    assert D.norm() <= 1e-13 * scale, D.norm() / scale

    model.u.x.array[:] += 0.05 * np.random.default_rng(9).standard_normal(model.u.x.array.size)
    model.u.x.scatter_forward()
    for asm in (whole, split):
        asm.residual(b, model.u.vector, 3.1)
    whole.jacobian(A)
    split.jacobian(A_split, slow=False)  # the fluid's part as assembled before the move
    S_new = slow_part()
    S_old.axpy(-1.0, S_new)  # what keeping it leaves out
    assert S_old.norm() > 1e-6 * scale  # the move changed the fluid's part: a real test
    A_split.axpy(-1.0, A, structure=same)
    A_split.axpy(-1.0, S_old)
    assert A_split.norm() <= 1e-13 * scale, A_split.norm() / scale
    split.destroy()
    for obj in (b, A, A_split, D, S_old, S_new):
        obj.destroy()


def test_a_new_times_anchor_rows_are_the_prescribed_ones_and_follow_invalidate_time():
    """``set_time`` writes a moving anchor's rows from the fixed part ``position -
    reference`` kept since its first call (or the last ``invalidate_time``): the numbers
    of ``AnchorBC.prescribed``, to the last bit, at any time; an offset changed with
    ``invalidate_time`` (as the virtual hinges do) is taken at the next time."""
    model = CableModel(MPI.COMM_WORLD, parse_case(level_case(elements=8, motion=MOTION)))
    anc = next(a for a in model.anchors if a.motion is not None)
    arr = model.u_bc.x.array
    for t in (0.013, 0.5, 1.7):
        model.set_time(t)
        assert np.array_equal(arr[anc.flat_dofs], anc.prescribed("displacement", t))
    before = arr[anc.flat_dofs].copy()
    anc.offset = anc.offset + np.array([1e-3, -2e-3, 5e-4])
    model.invalidate_time()
    model.set_time(1.7)
    assert np.array_equal(arr[anc.flat_dofs], anc.prescribed("displacement", 1.7))
    if anc.dofs.size:  # the rank that holds the anchor's node
        assert not np.array_equal(arr[anc.flat_dofs], before)


def test_an_anchor_given_another_motion_is_moved_by_it_at_the_next_time():
    """An anchor's ``motion`` replaced between two times, without ``invalidate_time``
    (the Python API): ``set_time`` sees the other object and writes the new motion's
    rows, ``AnchorBC.prescribed``'s to the last bit (not the kept ones of the old)."""
    from cablefem.motion import HarmonicMotion

    model = CableModel(MPI.COMM_WORLD, parse_case(level_case(elements=8, motion=MOTION)))
    anc = next(a for a in model.anchors if a.motion is not None)
    model.set_time(0.3)
    anc.motion = HarmonicMotion([0.0, 3e-4, 1e-4], 20.0)
    model.set_time(0.4)
    arr = model.u_bc.x.array
    assert np.array_equal(arr[anc.flat_dofs], anc.prescribed("displacement", 0.4))
    if anc.dofs.size:  # the old motion would give other rows
        assert np.abs(anc.motion.displacement(0.4)).max() > 1e-5
