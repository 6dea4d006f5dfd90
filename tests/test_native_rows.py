"""The time integrator's residual and Jacobian assembled in C (:mod:`cablefem.native_rows`)
are :class:`~cablefem.petsc_utils.RowsAssembler`'s numbers bit for bit: the same compiled
kernels with the same packed constants and coefficients, their terms added in the same
order. So a whole run gives the same anchor forces to the last bit with it and without it,
and a model outside its range (several ranks, terms outside UFL, no compiler) keeps the
Python route."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import level_case
from dolfinx.fem import petsc as fpetsc
from mpi4py import MPI
from petsc4py import PETSc
from test_fastassembly import _assemblers, _moved, _moved_model
from test_fluid import taut

from cablefem import native_lib as nl
from cablefem import native_rows as nr
from cablefem.cable import CableModel
from cablefem.case import parse_case
from cablefem.dynamics import DynamicProblem
from cablefem.statics import solve_static

MOTION = {"type": "harmonic", "amplitude": [2e-4, 1e-4, 0], "omega": 32.814}
DAMPING = {"ratio": 0.005, "frequencies": [16.407, 32.814]}
T = 0.0123  # the time _moved_model sets


def _damped_model(count: int = 1):
    """A taut cable with ``count`` dampers at interior nodes (an integral over each vertex,
    an interior facet: both elements' nodes, coordinates and coefficients), off its
    state."""
    case = {"title": "damper", "section": {"EA": 1e8, "EI": 1e-6, "mass": 1.0},
            "gravity": {"g": 9.81}, "geometry": {"length": 10.0},
            "mesh": {"elements": 10},
            "anchors": [{"name": "p", "position": [0.0, 0, 0], "type": "pinned"},
                        {"name": "q", "position": [10.001, 0, 0], "type": "pinned",
                         "motion": MOTION}],
            "dampers": [{"anchor": "p", "distance": 2.0 + 5.0 * k, "coefficient": 300.0,
                         "direction": [0.0, 0.6, 0.8]} for k in range(count)],
            "damping": DAMPING, "solver": {"outer_correction": "none"}}
    model = CableModel(MPI.COMM_WORLD, parse_case(case))
    solve_static(model)
    return _moved(model, 5, (1e-4, 1e-2, 1.0), T, (412.0, 8.1e4))


def _dense(A: PETSc.Mat) -> np.ndarray:
    return A.copy().convert("dense").getDenseArray()  # convert() alone works in place


def _two_dampers():
    return _damped_model(2)


@pytest.mark.parametrize("make", [_moved_model, _damped_model, _two_dampers],
                         ids=["cable", "damper", "two-dampers"])
def test_the_c_residual_and_jacobian_are_the_python_ones_bit_for_bit(make):
    """At a random state (every term of the residual non-zero, the anchors' rows ``x - g``
    too), residual and Jacobian equal RowsAssembler's exactly: difference 0, not a
    tolerance, since the floating-point operations are the same. With a damper, the
    integral over its vertex too."""
    model = make()
    rows, _ = _assemblers(model)
    native = nr.native_rows(model, rows, model.prefix)
    if model.comm.size > 1:  # one rank only: the Python route
        assert native is None
        return
    assert native is not None, "the C route should be available on one rank"
    # the cells, and each damper's vertex
    assert len(native.packs) == {_moved_model: 1, _damped_model: 2, _two_dampers: 3}[make]
    U, V, A = (f.vector.copy() for f in (model.u, model.v, model.a))
    F_py, F_c = U.duplicate(), U.duplicate()
    rows.residual(F_py, model.u.vector, T)
    J_py = fpetsc.create_matrix(model.j_dynamic)
    rows.jacobian(J_py)
    F_c.set(np.nan)  # every entry must be written
    native.residual(T, U, V, A, F_c)
    J_c = fpetsc.create_matrix(model.j_dynamic)
    native.jacobian(J_c, constants=True)
    assert np.abs(F_py.array).min() < np.abs(F_py.array).max()  # not a trivial vector
    assert np.array_equal(F_c.array, F_py.array)
    assert np.array_equal(_dense(J_c), _dense(J_py))
    # the state comes from the vectors given, not from the model's Functions
    V.scale(2.0)
    native.residual(T, U, V, A, F_c)
    assert not np.array_equal(F_c.array, F_py.array)


def test_a_petsc_error_in_the_c_call_is_raised():
    """A matrix of the wrong size: PETSc's error code from the C side is raised, not
    ignored."""
    model = _moved_model()
    rows, _ = _assemblers(model)
    native = nr.native_rows(model, rows, model.prefix)
    if native is None:  # several ranks: the Python route
        return
    U = model.u.vector.copy()
    native.residual(T, U, U, U, U.duplicate())
    small = PETSc.Mat().createAIJ([3, 3], bsize=3, comm=MPI.COMM_SELF)
    small.setUp()
    with pytest.raises(PETSc.Error):
        native.jacobian(small)
    small.destroy()


def _forces(native: bool, steps: int = 40, **solver) -> np.ndarray:
    model = CableModel(MPI.COMM_WORLD, parse_case(level_case(elements=8, motion=MOTION,
                                                             damping=DAMPING, solver=solver)))
    solve_static(model)
    with DynamicProblem(model, 2e-3, petsc_options={"native_assembly": native}) as problem:
        assert (problem._rows.native is not None) == (native and model.comm.size == 1)
        return np.array([f for _, f in problem.run(steps * 2e-3)])


def test_a_run_gives_the_same_anchor_forces_with_the_c_route_and_without(monkeypatch):
    """40 steps of a moving, damped cable, the anchor forces at every step (on the C route
    their residual, mass solve, sums and the anchors' rows are one C call too): equal to
    the last bit."""
    calls = []
    real = nr.NativeRows.anchor_forces  # prepares the call; each row makes it

    def counted(*args):
        call = real(*args)
        return lambda t: calls.append(1) or call(t)

    monkeypatch.setattr(nr.NativeRows, "anchor_forces", counted)
    c = _forces(True)
    assert len(calls) == (41 if MPI.COMM_WORLD.size == 1 else 0)
    py = _forces(False)
    assert len(calls) == (41 if MPI.COMM_WORLD.size == 1 else 0)
    assert c.shape == py.shape == (41, 2, 3)
    assert np.array_equal(c, py)


def _clamped_forces(native: bool, change=None) -> np.ndarray:
    """60 steps of a clamped cable with virtual hinges (each anchor's force then holds its
    layer's weight and inertia), one anchor moving: the anchor forces at every step;
    ``change(model)`` called after the 30th."""
    case = level_case(elements=12, motion=MOTION, damping=DAMPING,
                      solver={"outer_correction": "hinge"})
    model = CableModel(MPI.COMM_WORLD, parse_case(case))
    solve_static(model)
    assert model.hinges, "the clamps should have virtual hinges"
    out = []
    with DynamicProblem(model, 2e-3, petsc_options={"native_assembly": native}) as problem:
        for k in range(60):
            if k == 30 and change is not None:
                change(model)
            problem.step()
            out.append(problem.anchor_forces())
    return np.array(out)


def test_virtual_hinges_layer_forces_are_the_same_on_the_c_route():
    """The layers' weight and inertia, added to the anchor forces in C on the C route:
    the same forces to the last bit as the Python route's."""
    c, py = _clamped_forces(True), _clamped_forces(False)
    assert c.shape == py.shape == (60, 2, 3)
    assert np.array_equal(c, py)


def test_a_constant_changed_between_steps_is_seen_by_the_c_route():
    """The C route packs the forms' constants again only when one of them changed (their
    bytes compared at each new time): gravity changed by the caller between two steps
    (Python API) moves the forces as on the Python route, to the last bit; without the
    comparison the old gravity would stay packed."""
    def heavier(model):
        model.gravity.value = 1.5 * model.gravity.value

    c, py = _clamped_forces(True, heavier), _clamped_forces(False, heavier)
    same = _clamped_forces(True)
    assert np.array_equal(c, py)
    assert not np.array_equal(c[-1], same[-1])  # the change does move the forces


def test_an_exception_in_a_time_law_on_the_c_route_is_raised_as_itself(monkeypatch):
    """On the C route the time integrator calls the C side, which calls Python at a new
    time: an exception there fails the step and is raised as itself, as an exception in
    a Python callback is on the Python route (not as a PETSc error, and never lost)."""
    model = CableModel(MPI.COMM_WORLD, parse_case(level_case(elements=8, motion=MOTION)))
    solve_static(model)

    class Stop(Exception):
        pass

    real = CableModel.set_time

    def set_time(self, t):
        if t > 0.005:
            raise Stop(t)
        real(self, t)

    with DynamicProblem(model, 2e-3) as problem:
        monkeypatch.setattr(CableModel, "set_time", set_time)
        with pytest.raises(Stop):
            for _ in range(5):
                problem.step()
        assert problem._rows.native is None or problem._rows.native.error is None


def test_a_mass_solve_through_python_from_c_is_the_same():
    """The anchor forces' mass solve with a preconditioner of type python (PETSc calls
    back into Python from the C call): the same forces as on the Python route."""
    from cablefem.gathered_lu import PYTHON_TYPE
    opts = {"petsc_options": {"mass_pc_type": "python", "mass_pc_python_type": PYTHON_TYPE}}
    c, py = _forces(True, 10, **opts), _forces(False, 10, **opts)
    assert np.array_equal(c, py)


def test_terms_outside_ufl_keep_the_python_route():
    model = _moved_model()
    rows, _ = _assemblers(model)
    rows.extra = (lambda arr: None, lambda A: None)  # a network's kink corners
    assert nr.native_rows(model, rows, model.prefix) is None


def _wet_forces(native: bool, every: int = 1) -> tuple[np.ndarray, int]:
    """40 steps of a taut cable in a current and waves (whose kinematics are taken where
    the cable is), one anchor moving: the anchor forces every ``every`` steps, and how many
    of its Jacobians' assemblies were whole ones (not the fast part alone)."""
    case = taut(fluid={"current": [0.0, 0.3, 0.5], "surface": 0.05, "wave_ramp": 0.0,
                       "waves": [{"height": 0.04, "period": 0.5, "direction": [1.0, 0, 0]}]},
                elements=12, gravity={"g": 9.81})
    case["anchors"][1]["motion"] = MOTION
    model = CableModel(MPI.COMM_WORLD, parse_case(case))
    solve_static(model)
    with DynamicProblem(model, 2e-3, petsc_options={"native_assembly": native}) as problem:
        assert problem._rows.parts is not None  # the fluid's Jacobian kept apart
        assert (problem._rows.native is not None) == (native and model.comm.size == 1)
        forces = np.array([f for _, f in problem.run(40 * 2e-3, every)])
        return forces, problem.newton.slow_assemblies


def test_a_wet_cable_whose_jacobian_is_kept_in_parts_is_the_same_bit_for_bit():
    """A fluid's drag and added mass: the Jacobian in a fast and a slow part, kept over
    steps (both assembled in C, summed and given the anchors' rows as the Python route
    does), the mass moving with the tangent (the anchor forces' mass assembled in Python):
    the same anchor forces to the last bit, and the same number of slow assemblies."""
    c, py = _wet_forces(True), _wet_forces(False)
    assert c[0].shape == py[0].shape == (41, 2, 3)
    assert np.array_equal(c[0], py[0])
    assert c[1] == py[1] and c[1] >= 1


def test_between_outputs_the_model_holds_the_state_the_python_route_leaves():
    """Output every 3rd step: between outputs the model's Functions hold the state of the
    last residual, as on the Python route (the waves' kinematics at a new time are taken
    at the positions they hold), so the forces are again the same to the last bit."""
    c, py = _wet_forces(True, 3), _wet_forces(False, 3)
    assert c[0].shape == py[0].shape == (15, 2, 3)
    assert np.array_equal(c[0], py[0])


def test_without_a_c_compiler_the_python_route(monkeypatch):
    """No compiler: no library, the Python route, the run the same."""
    monkeypatch.setenv("CC", "/nonexistent/cc")
    monkeypatch.setattr(nl, "_LIB", [])
    assert nr.library() is None
    model = _moved_model()
    rows, _ = _assemblers(model)
    assert nr.native_rows(model, rows, model.prefix) is None
    monkeypatch.setattr(nl, "_LIB", [])  # the next test loads it again


def test_a_compiler_given_with_a_wrapper_command_compiles(monkeypatch):
    """``CC="env cc"`` (a compiler behind a wrapper, as ``ccache gcc``): the command's
    words, not one program named "env cc" (which fell back to the Python route). On 2
    ranks both compile at once, each into a folder of its own, renamed into place."""
    monkeypatch.setenv("CC", "env cc")
    monkeypatch.setattr(nl, "_LIB", [])
    assert nr.library() is not None
    monkeypatch.setattr(nl, "_LIB", [])  # the next test loads the usual one


@pytest.mark.parametrize("value", ["false", "0"])
def test_the_option_asks_for_the_python_route(value):
    model = _moved_model()
    rows, _ = _assemblers(model)
    opts = PETSc.Options()
    opts[model.prefix + "native_assembly"] = value
    try:
        assert nr.native_rows(model, rows, model.prefix) is None
    finally:
        opts.delValue(model.prefix + "native_assembly")


@pytest.mark.parametrize("native", [True, False])
def test_summary_says_which_route_assembled(native, mpi_tmp_path):
    """``summary.json``'s ``dynamics.assembly``: "c" on one rank unless the case asks for
    the Python route; "python" on several ranks; the anchor forces the same either way
    (compared by the test above)."""
    from cablefem.app.run import run_case

    case = level_case(elements=8, motion=MOTION, damping=DAMPING,
                      dynamics={"t_end": 0.02, "dt": 2e-3},
                      solver={"petsc_options": {"native_assembly": native}})
    r = run_case(parse_case(case), mpi_tmp_path / f"r{native}", figures=False,
                 progress=False)
    expected = "c" if native and MPI.COMM_WORLD.size == 1 else "python"
    assert r.summary["dynamics"]["assembly"] == expected


def test_watched_arrays_flag_exactly_those_whose_bytes_changed():
    """``Watched.changed`` (one C call at each new time for the other coefficients and the
    constants): the arrays whose bytes differ from their copies as last seen, flagged and
    counted, their copies then updated (a second call finds nothing); a sign of zero is a
    change, as byte comparison makes it."""
    lib = nr.library()
    if lib is None:
        pytest.skip("no C compiler here")
    arrays = [np.arange(5.0), np.zeros(()), np.ones(3)]
    seen = nr.Watched(lib, arrays)
    assert seen.changed() == 0 and not seen.flags.any()
    arrays[0][3] = 7.5
    arrays[1][()] = -0.0
    assert seen.changed() == 2
    assert seen.flags.tolist() == [1, 1, 0]
    assert np.array_equal(seen.copies[0], arrays[0])
    assert seen.changed() == 0
    assert nr.Watched(lib, []).changed() == 0
