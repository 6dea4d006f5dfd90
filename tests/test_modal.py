"""Natural frequencies against closed forms (physics.md section 6): the taut string, exactly
in its discrete form and in the limit, and Irvine & Caughey's sagging cable."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from cablefem.case import parse_case
from cablefem.catenary import irvine_symmetric_frequency
from cablefem.model import CableModel
from cablefem.modal import solve_modes
from cablefem.statics import solve_static

from conftest import level_case, observed_order


def taut_model(n: int, EA=100.0, l=1.0, L=1.01, m=1.0):
    d = level_case(EA=EA, EI=1e-6, mass=m, g=0.0, length=l, chord=L, elements=n)
    model = CableModel(parse_case(d), MPI.COMM_WORLD)
    solve_static(model)
    return model


def taut_discrete(n_el, k, T, lam, m, l):
    """Transverse frequencies of P1 elements with consistent mass on a taut string, exact:
    the discrete modes are sin(k pi s_i / l) and
    omega^2 = 6 (T/lam) / (m h^2) (1 - cos theta) / (2 + cos theta), theta = k pi h / l
    (the transverse stiffness per reference length is T/lam, lam the stretch)."""
    h = l / n_el
    th = k * np.pi * h / l
    return np.sqrt(6 * T / lam / (m * h * h) * (1 - np.cos(th)) / (2 + np.cos(th)))


def test_taut_string_discrete_exact():
    """The eigensolver reproduces the discrete closed form to 1e-9 (eigen tolerance 1e-12,
    assembled in double precision); modes come in degenerate (y, z) pairs."""
    n, EA, l, L, m = 20, 100.0, 1.0, 1.01, 1.0
    model = taut_model(n, EA, l, L, m)
    res = solve_modes(model, 6)
    T, lam = EA * (L / l - 1), L / l
    expected = np.repeat([taut_discrete(n, k, T, lam, m, l) for k in (1, 2, 3)], 2)
    np.testing.assert_allclose(res.omegas, expected, rtol=1e-9)
    # the pairs are the two transverse polarisations, both labelled n/a for a weightless cable
    # (no plane of gravity), symmetric / antisymmetric alternately
    assert [lab["symmetry"] for lab in res.labels] == ["symmetric"] * 2 + [
        "antisymmetric"] * 2 + ["symmetric"] * 2


def test_taut_string_converges_to_continuum():
    """omega_1 -> pi sqrt(T/m_c)/L (m_c mass per current length) at second order in h."""
    EA, l, L, m = 100.0, 1.0, 1.01, 1.0
    T = EA * (L / l - 1)
    exact = np.pi * np.sqrt(T / (m * l / L)) / L
    ns = np.array([8, 16, 32])
    err = np.array([abs(solve_modes(taut_model(int(n)), 1).omegas[0] / exact - 1) for n in ns])
    # the consistent mass over-estimates by theta^2/24 (theta = pi h/l): order 2
    assert 1.9 < observed_order(1.0 / ns, err) < 2.1
    np.testing.assert_allclose(err, (np.pi / ns) ** 2 / 24, rtol=0.02)


@pytest.mark.parametrize("lambda2", [1.0, 100.0])
def test_irvine_caughey(lambda2):
    """A level cable with 1 % sag, lambda^2 = 1 (< 4 pi^2) and 100 (> 4 pi^2): the first
    symmetric in-plane, antisymmetric in-plane and out-of-plane frequencies against
    tan(w/2) = w/2 - (4/lambda^2)(w/2)^3, 2 pi and pi (omega_bar = omega L / sqrt(H/m_I)).

    m_I is the mass per unit chord length (Irvine's m; ours is per stress-free length: they
    differ by the elastic stretch and the sag). Tolerance: the mesh error of the consistent
    mass (omega_bar h / L)^2 / 24 (4.3e-4 for the symmetric mode at lambda^2 = 100 with 80
    elements), plus 3e-4 for the neglected O((d/L)^2) = 1e-4 terms of the small-sag theory.
    """
    sag, n = 0.01, 80
    H0 = 1 / (8 * sag)
    EA = lambda2 * H0 * (1 + 8 * sag**2) * H0**2  # lambda^2 = (wL/H)^2 L EA / (H L_e)
    d = level_case(EA=EA, EI=1e-6, g=1.0, chord=1.0, elements=n,
                   geometry={"horizontal_tension": H0})
    model = CableModel(parse_case(d), MPI.COMM_WORLD)
    st = solve_static(model)
    H = st.anchor_forces[0][0]
    u = model.gather_nodal(model.u)
    dd = None
    if model.comm.rank == 0:
        r = model.geometry.points + u
        dd = -np.interp(0.5, r[:, 0], r[:, 2])
    dd = model.comm.bcast(dd, root=0)
    lam2 = (1 / H) ** 2 / (H * (1 + 8 * dd**2) / EA)
    res = solve_modes(model, 6)
    wbar = res.omegas / np.sqrt(H / model.length)

    def first(plane, sym=None):
        return next(w for w, lab in zip(wbar, res.labels) if lab["plane"] == plane
                    and (sym is None or lab["symmetry"] == sym))

    for value, exact in [(first("in-plane", "symmetric"), irvine_symmetric_frequency(lam2)),
                         (first("in-plane", "antisymmetric"), 2 * np.pi),
                         (first("out-of-plane"), np.pi)]:
        tol = (exact / n) ** 2 / 24 + 3e-4
        assert abs(value / exact - 1) < tol, (lam2, value / np.pi, exact / np.pi)
