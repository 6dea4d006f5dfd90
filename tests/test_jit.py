"""The JIT layer (cablefem.jit): a form FFCx has cached is loaded by its file name, without
listing the cache folder (which holds thousands of files once a few models were built)."""

import importlib._bootstrap_external as bootstrap

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI

from cablefem.jit import direct_cache_lookup, quiet_compiler

SCALE = 1.375  # a kernel of this test alone


def _ufl_form(domain, scale):
    V = fem.FunctionSpace(domain, ("Lagrange", 1))
    c = fem.Constant(domain, 2.5)
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    return c * ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx + scale * u * v * ufl.dx


@pytest.mark.skipif(not direct_cache_lookup(), reason="only FFCx 0.5's lookup is replaced")
def test_a_cached_form_loads_without_listing_the_cache(monkeypatch):
    a = _ufl_form(mesh.create_unit_interval(MPI.COMM_WORLD, 4), SCALE)
    with quiet_compiler():
        first = fem.form(a)  # compiled: a new kernel
    listed = []
    real = bootstrap._os.listdir

    def listdir(path=None):
        listed.append(path)
        return real(path) if path is not None else real()

    monkeypatch.setattr(bootstrap._os, "listdir", listdir)
    with quiet_compiler():
        again = fem.form(a)  # the same form: in the cache now
    monkeypatch.undo()
    assert listed == []  # FFCx's own lookup lists the cache folder at every form
    # the same kernel: the matrices agree to the last bit
    A1 = fem.petsc.assemble_matrix(first)
    A2 = fem.petsc.assemble_matrix(again)
    A1.assemble()
    A2.assemble()
    assert np.array_equal(A1.convert("dense").getDenseArray(),
                          A2.convert("dense").getDenseArray())


def test_a_forms_cache_key_does_not_depend_on_what_was_compiled_before():
    """FFCx 0.5 sets the point spacing of the mesh's coordinate element in place when it
    analyses a form ("equispaced" where none was given). On a mesh made without it, every
    form's signature (FFCx's cache key) changed once any form of the mesh had been
    compiled: a run whose first forms came from the cache compiled a later one again, under
    a new key, at every run until each variant was cached (1-1.5 s each for case B)."""
    from ffcx.analysis import _analyze_form
    from ffcx.parameters import get_parameters

    from cablefem.geometry import create_line_mesh

    points = np.array([[0.0, 0.0, 0.0], [0.5, 0.2, 0.0], [1.0, 0.0, 0.1]])
    cells = np.array([[0, 1], [1, 2]])
    domain = create_line_mesh(MPI.COMM_WORLD, points, cells)
    before = _ufl_form(domain, SCALE).signature()
    _analyze_form(_ufl_form(domain, 2 * SCALE), get_parameters())  # what compiling does first
    after = _ufl_form(domain, SCALE).signature()  # a new form object: no cached signature
    assert after == before


def test_forms_a_run_may_not_need_are_compiled_on_first_use():
    """The statics' twins with compression allowed, the energies and the modal analysis'
    forms are compiled when first asked for, not with the model: a run that never needs
    them (most) does not pay for their compilation (three energy forms and the two twins:
    2.2 s of case B's first run on an empty form cache)."""
    from conftest import level_case

    from cablefem.case import parse_case
    from cablefem.create import model_from_case
    from cablefem.statics import solve_static

    model = model_from_case(MPI.COMM_WORLD, parse_case(level_case()))
    solve_static(model)
    lazy = ("energy_forms", "f_static_bilateral", "j_static_bilateral", "k_dynamic", "c_form")
    assert not set(lazy) & set(model.forms._compiled)
    e = model.energies()  # compiled now
    assert "energy_forms" in model.forms._compiled
    assert e["kinetic"] == 0.0  # at rest: v = 0 exactly
    assert e["strain"] > 0.0  # taut
    # a tension-only string has its own law with compression allowed: the twin is a form of
    # its own, compiled when first read (without one it would be f_static itself)
    assert model.forms.internal_bilateral is not None
    assert model.f_static_bilateral is not model.f_static
    assert "f_static_bilateral" in model.forms._compiled
