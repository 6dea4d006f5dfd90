"""Anchor moments from the string (docs/theory.md §3-4): case A's static state against
the composite closed form, mesh convergence with and without the string-curvature
correction, rotation invariance, and anchor swapping."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import level_case, observed_order
from mpi4py import MPI

from cablefem.cable import CableModel
from cablefem.case import parse_case
from cablefem.catenary import catenary_between
from cablefem.dynamics import integrate
from cablefem.moments import anchor_moments
from cablefem.statics import solve_static

EA, EI, CHORD = 17857.14, 4e-4, 1.0013333
W = np.array([0.0, 0.0, -1.0])  # weight per length, case A units


def _static_moments(n: int) -> tuple[dict, dict]:
    model = CableModel(MPI.COMM_WORLD, parse_case(level_case(elements=n)))
    st = solve_static(model)
    args = (EI, EA, 1.0, np.zeros((1, 3)), W, 1.0)
    return (anchor_moments(st.anchor_forces[:1], [1, 0, 0], *args),
            anchor_moments(st.anchor_forces[1:], [-1, 0, 0], *args))


def _reference():
    """Composite anchor moment with the exact elastic catenary's anchor force: the layer's
    closed form (exact first integral) plus EI kappa_string(0) = -EI w cos(Delta)/T."""
    N = catenary_between([0, 0, 0], [CHORD, 0, 0], 1.0, 1.0, EA).force_at_p()
    return anchor_moments(N[None, :], [1, 0, 0], EI, EA, 1.0, np.zeros((1, 3)), W, 1.0)


def test_case_A_static_moment():
    """Case A on the paper's 30-element mesh: M_p = M_q (symmetry, to round-off) and both
    equal the composite closed form (~1.985e-3) to the accuracy of the reaction force, which
    is O(h^2): 5.4e-5 relative at 20 elements (measured), so 3e-5 at 30 (ratio (20/30)^2)."""
    p, q = _static_moments(30)
    ref = _reference()
    assert p["moment"][0] == pytest.approx(q["moment"][0], rel=1e-12)
    assert p["moment"][0] == pytest.approx(ref["moment"][0], rel=3e-5)
    # docs/theory.md §9: "M_p ~ 2.0e-3", Delta ~ 0.02 rad
    assert 1.95e-3 < p["moment"][0] < 2.05e-3 and abs(p["delta"][0] - 0.02) < 1e-3
    # the correction lowers the layer's value: the two moments are along +Y (bending down)
    assert p["My"][0] > 0 and p["moment"][0] < p["moment_layer"][0]


def test_moment_convergence_with_and_without_correction():
    """With the correction the FE anchor moment converges to the composite closed form at
    second order (the order of the consistent reaction); without it (the layer alone) it
    stays off by the correction, EI w cos(Delta) / (T M) ~ 0.8 %, at every mesh."""
    ref = _reference()
    ns = np.array([10, 20, 40, 80])
    with_c, without = [], []
    for n in ns:
        p, _ = _static_moments(int(n))
        with_c.append(abs(p["moment"][0] / ref["moment"][0] - 1))
        without.append(abs(p["moment_layer"][0] / ref["moment"][0] - 1))
    assert 1.9 < observed_order(1.0 / ns, np.array(with_c)) < 2.1
    corr = EI * 1.0 * np.cos(ref["delta"][0]) / (ref["tension"][0] * ref["moment"][0])
    # without the correction the error tends to the correction itself; the remaining
    # difference is the same O(h^2) reaction error as above (< 3e-4 at 10 elements)
    np.testing.assert_allclose(without, corr, atol=3e-4)
    assert 0.007 < corr < 0.009


def _rotation(seed=3):
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def test_rotation_invariance():
    """Rotating the whole problem (anchors, clamp directions, gravity) rotates the moment
    vector and leaves its magnitude: equal to 1e-9 relative (Newton tolerance 1e-10 on
    a problem whose coordinates are mixed by the rotation)."""
    R = _rotation()
    base = level_case(elements=20)
    rot = level_case(elements=20, gravity={"g": 1.0, "direction": list(R @ [0, 0, -1.0])})
    for a in rot["anchors"]:
        a["position"] = list(R @ np.array(a["position"]))
        a["direction"] = list(R @ np.array(a["direction"]))
    out = []
    for d in (base, rot):
        case = parse_case(d)
        model = CableModel(MPI.COMM_WORLD, case)
        st = solve_static(model)
        g = case.gravity.g * case.gravity.direction
        out.append([anchor_moments(st.anchor_forces[i:i + 1], a.direction, EI, EA, 1.0,
                                   np.zeros((1, 3)), g, 1.0)
                    for i, a in enumerate(model.anchors)])
    for m0, m1 in zip(*out):
        assert m1["moment"][0] == pytest.approx(m0["moment"][0], rel=1e-9)
        M0 = np.array([m0["Mx"][0], m0["My"][0], m0["Mz"][0]])
        M1 = np.array([m1["Mx"][0], m1["My"][0], m1["Mz"][0]])
        np.testing.assert_allclose(M1, R @ M0, atol=1e-9 * m0["moment"][0])


def _series(d):
    case = parse_case(d)
    model = CableModel(MPI.COMM_WORLD, case)
    solve_static(model)
    names = [a.name for a in model.anchors]
    hist = {n: [] for n in names}
    for t, forces in integrate(model, 0.5, 0.005, 0.9, 5):
        for a, N in zip(model.anchors, forces):
            acc = a.acceleration(t)[None, :]
            hist[a.name].append(anchor_moments(N[None, :], a.direction, EI, EA, 1.0, acc, W,
                                               1.0)["moment"][0])
    return {k: np.array(v) for k, v in hist.items()}


def test_swapping_anchors_swaps_series():
    """Case A mirrored about mid-span (q at the origin, moving along -X, p fixed at the far
    end, mesh numbered from q): each named anchor has the same moment history, to 1e-8
    relative (the two runs differ by the node numbering and round-off only)."""
    motion = {"type": "harmonic", "amplitude": [2e-4, 0, 0], "omega": 32.814}
    damping = {"ratio": 0.005, "frequencies": [16.407, 32.814]}
    a = level_case(elements=20, motion=motion, damping=damping)
    b = level_case(elements=20, damping=damping)
    b["anchors"] = [
        {"name": "q", "position": [0.0, 0, 0], "direction": [1.0, 0, 0],
         "motion": {**motion, "amplitude": [-2e-4, 0, 0]}},
        {"name": "p", "position": [CHORD, 0, 0], "direction": [-1.0, 0, 0]}]
    sa, sb = _series(a), _series(b)
    for name in ("p", "q"):
        np.testing.assert_allclose(sb[name], sa[name], rtol=1e-8)
    assert not np.allclose(sa["p"], sa["q"], rtol=1e-3)  # the two anchors do differ


def test_the_first_order_route_scales_the_layer_by_the_tension_gradient():
    """anchor_moments with the hinge (outer_order 1) multiplies the layer's moment by
    1 + ell0 T'/(4 T cos^2(Delta/4)) (docs/theory.md §6.2), T' = (m a - f).t; the leading
    order (outer_order 0) does not. A gradient that changes the moment by more than a
    quarter makes the row invalid, with its reason. Exact arithmetic: rtol 1e-12."""
    EI, EA, m, L = 4e-4, np.inf, 1.0, 1.0
    delta, T = 0.3, 25.0
    F = T * np.array([[np.cos(delta), 0.0, -np.sin(delta)]] * 3)
    c = np.array([1.0, 0.0, 0.0])
    t = F[0] / T
    # loads per length (N/m): the weight, a strong pull along -t, and one 100 times that
    loads = np.array([[0.0, 0.0, -1.0], -2000.0 * t, -2e5 * t])
    acc = np.zeros((3, 3))
    lead = anchor_moments(F, c, EI, EA, m, acc, loads, L, outer_order=0)
    first = anchor_moments(F, c, EI, EA, m, acc, loads, L, outer_order=1)
    ell0 = np.sqrt(EI / T)
    Tp = np.einsum("ij,j->i", -loads, t)  # (m a - f).t with a = 0
    factor = 1 + ell0 * Tp / (4 * T * np.cos(delta / 4) ** 2)
    np.testing.assert_allclose(first["moment_layer"], lead["moment_layer"] * factor,
                               rtol=1e-12)
    assert abs(factor[1] - 1) < 0.25 < abs(factor[2] - 1)
    assert list(first["valid"]) == [1, 1, 0] and list(lead["valid"]) == [1, 1, 1]
    assert first["invalid_reason"][2] == "tension varies along the layer"


def test_psi0_follows_a_bending_plane_that_swings_about_down(mpi_tmp_path):
    """Case B's static bending planes point down (psi0 = pi at the branch cut of the
    layer's (-pi, pi]); its spatial motion swings them about that. anchors.csv writes
    psi0 on the branch centred on each anchor's first row, so the column follows the
    plane: no step between rows larger than pi (the plane turns by about 1e-3 rad a step
    of 0.005; before, psi0 jumped by 2 pi at 208 of case B's 6001 rows, from t = 0.01
    on). The angle is the layer's (the same cosine and sine), and 'cablefem post' on the
    run's forces writes the same psi0 (same formula on the same branch)."""
    import csv
    import tomllib
    from pathlib import Path

    from cablefem import asymptotics
    from cablefem.app.post import run_post
    from cablefem.app.run import run_case

    demos = Path(__file__).resolve().parents[1] / "demos"
    data = tomllib.loads((demos / "paper_spatial.toml").read_text())
    data["dynamics"]["t_end"] = 1.0
    case = parse_case(data, demos)
    out = mpi_tmp_path / "run"
    run_case(case, out, MPI.COMM_WORLD, figures=False, progress=False, modes=0)
    run_post(case, out / "anchors.csv", mpi_tmp_path / "post")

    def rows(path):
        with open(path) as fh:
            return list(csv.DictReader(fh))
    ran, posted = rows(out / "anchors.csv"), rows(mpi_tmp_path / "post" / "anchors.csv")
    layers = {a.name: a for a in case.anchors}
    for name in ("p", "q"):
        mine = [r for r in ran if r["anchor"] == name]
        psi = np.array([float(r["psi0"]) for r in mine])
        # the first row is the quasi-static start: the static plane (down, pi) tilted by
        # the damping force of the anchor's out-of-plane velocity (measured 2e-3 rad at q)
        assert np.all(np.isfinite(psi)) and abs(psi[0] - np.pi) < 0.01
        # a step turns the plane by ~1e-3 rad (1.4e-3 at most here); a 2 pi jump fails
        assert np.max(np.abs(np.diff(psi))) < 0.05
        F = np.array([[float(r[c]) for c in ("Nx", "Ny", "Nz")] for r in mine])
        lay = asymptotics.layer(F, layers[name].direction, case.section.EI, case.section.EA)
        # the layer's own azimuth, moved by 2 pi at most: equal angles to round-off (the
        # CSV's repr round-trips; 2 pi added costs 1e-15)
        np.testing.assert_allclose(np.exp(1j * psi), np.exp(1j * lay.psi0), atol=1e-12)
        psi_post = np.array([float(r["psi0"]) for r in posted if r["anchor"] == name])
        np.testing.assert_array_equal(psi_post, psi)
