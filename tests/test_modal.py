"""Natural frequencies against closed forms (docs/theory.md §8): the taut string, exactly
in its discrete form and in the limit, and Irvine & Caughey's sagging cable."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import level_case, observed_order
from mpi4py import MPI

from cablefem.cable import CableModel
from cablefem.case import parse_case
from cablefem.catenary import irvine_symmetric_frequency
from cablefem.modal import solve_modes
from cablefem.statics import solve_static


def taut_model(n: int, EA=100.0, l=1.0, L=1.01, m=1.0):
    d = level_case(EA=EA, EI=1e-6, mass=m, g=0.0, length=l, chord=L, elements=n)
    model = CableModel(MPI.COMM_WORLD, parse_case(d))
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
    model = CableModel(MPI.COMM_WORLD, parse_case(d))
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


def test_inclined_cable_modes_labelled():
    """An inclined cable (chord at 30 deg, small sag) has no exact mirror symmetry, but its
    out-of-plane modes are those of a taut string to O(sag): sin(n pi s/l), symmetric for
    n = 1 and antisymmetric for n = 2 about mid-span. The labels must say so (not "n/a"),
    with a mirror correlation of magnitude close to 1 (0.9: an O(sag ratio ~ 1e-2) defect
    leaves it far above that)."""
    d = level_case(EA=1e7, EI=1.0, mass=10.0, g=9.81, elements=40)
    d["geometry"] = {"horizontal_tension": 2e5}
    d["anchors"][1]["position"] = [100 * np.cos(np.pi / 6), 0.0, 100 * np.sin(np.pi / 6)]
    for a in d["anchors"]:
        a.pop("direction")
        a["type"] = "pinned"
    model = CableModel(MPI.COMM_WORLD, parse_case(d))
    solve_static(model)
    res = solve_modes(model, 6)
    oop = [lab for lab in res.labels if lab.get("plane") == "out-of-plane"]
    assert [lab["symmetry"] for lab in oop[:2]] == ["symmetric", "antisymmetric"]
    assert abs(oop[0]["symmetry_correlation"]) > 0.9 and abs(oop[1]["symmetry_correlation"]) > 0.9
    assert all(lab.get("symmetry") in ("symmetric", "antisymmetric", "mixed")
               for lab in res.labels)


def test_network_mode_plane():
    """Nodes in the plane z = 0: a shape along z is all normal (share 1), one along x all
    in-plane (share 0), to round-off; nodes on a line have no plane (no label)."""
    from cablefem.modal import classify_network_mode

    rng = np.random.default_rng(1)
    pts = np.column_stack([rng.random(20), rng.random(20), np.zeros(20)])
    normal = classify_network_mode(pts, np.column_stack([0 * pts[:, :2], rng.random(20)]))
    assert normal["plane"] == "normal" and abs(normal["normal_share"] - 1) < 1e-12
    inplane = classify_network_mode(pts, np.column_stack([rng.random(20), 0 * pts[:, 1:]]))
    assert inplane["plane"] == "in-plane" and inplane["normal_share"] < 1e-12
    line = np.column_stack([np.arange(5.0), 0 * np.arange(5.0), 0 * np.arange(5.0)])
    assert classify_network_mode(line, np.ones((5, 3))) == {}


def test_modal_modes_0_skips_the_modal_analysis(mpi_tmp_path):
    """docs/case-file.md: without a [modal] table a run computes modal.modes = 6 modes;
    modal.modes = 0 (which the README's "a run without modes" needs; it was refused,
    "must be >= 1") computes none and leaves the "auto" span bending off."""
    from conftest import level_case

    from cablefem.app.run import run_case
    from cablefem.case import parse_case

    d = level_case(elements=20)
    res = run_case(parse_case(d), mpi_tmp_path / "a", figures=False, progress=False)
    assert len(res.summary["modes"]) == 6
    d["modal"] = {"modes": 0}
    res = run_case(parse_case(d), mpi_tmp_path / "b", figures=False, progress=False)
    assert "modes" not in res.summary
    assert res.summary["span_bending_auto"]["reason"] == "no mode computed"


@pytest.mark.parametrize("share, plane", [(0.0, "in-plane"), (0.05, "in-plane"),
                                          (0.53, "mixed"), (0.3, "mixed"),
                                          (0.95, "out-of-plane"), (1.0, "out-of-plane")])
def test_a_mode_in_both_planes_is_labelled_mixed(share, plane):
    """A shape with the share ``share`` of its squared amplitude out of the plane of the
    chord (x) and gravity (-z): the second sine of a level cable in z and in y, weighted
    sqrt(1 - share) and sqrt(share). The share is recovered to round-off (the two parts
    are orthogonal); a mode with more than 10 % on either side (MIXED_SHARE) is 'mixed'.
    Before, 0.53 was labelled 'out-of-plane' (share > 0.5), and the in-plane mode of a
    cable in wind it stood for was missing from the table."""
    from cablefem.modal import classify_mode

    s = np.linspace(0.0, 1.0, 41)
    wave = np.sin(2 * np.pi * s)
    shape = np.column_stack([0 * s, np.sqrt(share) * wave, np.sqrt(1 - share) * wave])
    lab = classify_mode(s, shape, np.array([1.0, 0, 0]), np.array([0, 0, -1.0]), True)
    assert lab["out_of_plane_share"] == pytest.approx(share, abs=1e-12)
    assert lab["plane"] == plane
    assert lab["symmetry"] == "antisymmetric"
