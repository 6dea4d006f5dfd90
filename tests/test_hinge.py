"""The first-order outer correction (cablefem.hinge, asymptotics.virtual_hinge): the far
field of the layer's elastica, and the string pinned at the virtual hinge against the rod.

Runs serially and on 2 MPI ranks (every model is built on COMM_WORLD)."""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

import numpy as np
import pytest
from conftest import sagging_paper_case
from dolfinx.fem import petsc as fpetsc
from dyn_util import resume_round_trip
from mpi4py import MPI
from petsc4py import PETSc
from scipy.integrate import solve_ivp

from cablefem.cable import CableModel
from cablefem.case import CaseError, load_case, parse_case
from cablefem.farfield import far_field_offsets, virtual_hinge
from cablefem.modal import solve_modes
from cablefem.moments import anchor_moments
from cablefem.rod import BeamModel
from cablefem.statics import solve_static

DEMOS = Path(__file__).resolve().parents[1] / "demos"


def _hinged(name: str, correction: str = "hinge"):
    case = load_case(DEMOS / name)
    return dataclasses.replace(case, solver=dataclasses.replace(
        case.solver, outer_correction=correction))


# ----------------------------------------------------------------------------- far field
@pytest.mark.parametrize("delta", [1e-3, 0.02, 0.2, 1.0, 2.0])
@pytest.mark.parametrize("beta", [0.0, 1e-3, 1e-2])
def test_far_field_offsets_match_the_integrated_elastica(delta, beta):
    """Integrate the rod along sigma (phi' from the exact first integral, r' = lambda d3)
    far into the span and read the offset of its straight far field."""
    T, EI = 2.0, 3e-4
    EA = T / beta if beta else np.inf
    ell0 = np.sqrt(EI / T)

    def rhs(s, y):
        phi = y[0]
        lam = 1 + beta * np.cos(phi)
        return [-(2 / ell0) * np.sin(phi / 2) * np.sqrt(1 + beta * np.cos(phi / 2) ** 2),
                lam * np.cos(phi), lam * np.sin(phi)]

    S = 60 * ell0  # phi(S) ~ Delta exp(-60): the far field, to round-off
    sol = solve_ivp(rhs, [0, S], [delta, 0, 0], rtol=1e-12, atol=1e-16, method="DOP853")
    Dt_num, Dn_num = sol.y[1, -1] - (1 + beta) * S, sol.y[2, -1]
    Dt, Dn = far_field_offsets(delta, T, EI, EA)
    # ODE tolerance 1e-12 on coordinates of size S = 60 ell0: 1e-10 ell0 absolute
    assert Dt == pytest.approx(Dt_num, abs=1e-10 * ell0)
    assert Dn == pytest.approx(Dn_num, abs=1e-10 * ell0)
    # the hinge is where the far-field line crosses the clamp line: h c = D + lam sigma_h t
    h, sig = virtual_hinge(delta, T, EI, EA)
    t, n = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    c = np.cos(delta) * t + np.sin(delta) * n
    assert np.allclose(h * c, Dt * t + Dn * n + (1 + beta) * sig * t, atol=1e-12 * ell0)


def test_virtual_hinge_closed_forms_and_limits():
    T, EI = 3.0, 1e-4
    ell0 = np.sqrt(EI / T)
    d = np.array([1e-9, 1e-3, 0.3, 1.5])
    h, sig = virtual_hinge(d, T, EI, np.inf)
    # inextensible: h = ell0 / cos(Delta/2), sigma_h = ell0 (2 cos(Delta/2) - 1) / cos(Delta/2)
    # (16-point Gauss-Legendre of analytic integrands: round-off)
    assert np.allclose(h, ell0 / np.cos(d / 2), rtol=1e-13)
    assert np.allclose(sig, ell0 * (2 * np.cos(d / 2) - 1) / np.cos(d / 2), rtol=1e-13)
    # small Delta, extensible: h -> lambda_inf ell, sigma_h -> ell (ell = ell0/sqrt(1+beta));
    # the next term is O(Delta^2) = 1e-18
    beta = 0.01
    h, sig = virtual_hinge(1e-9, T, EI, T / beta)
    ell = ell0 / np.sqrt(1 + beta)
    assert h == pytest.approx((1 + beta) * ell, rel=1e-12)
    assert sig == pytest.approx(ell, rel=1e-12)
    # no layer: slack anchor, or Delta = pi
    assert np.all(np.isnan(virtual_hinge(np.array([0.1, np.pi]), np.array([0.0, T]), EI,
                                         np.inf)))


# ----------------------------------------------------------------------------- against the rod
@pytest.mark.parametrize("name", ["paper_inplane.toml", "paper_spatial.toml"])
def test_hinged_string_matches_the_rod_statics_and_first_frequency(name):
    """Static anchor tension, anchor moment and first frequency within 0.2 % of the rod
    (the issue's target); the leading-order string misses at least one of them."""
    rod = BeamModel(MPI.COMM_WORLD, load_case(DEMOS / name))
    F_rod = solve_static(rod).anchor_forces[0]
    w_rod = solve_modes(rod, 1).omegas[0]
    res = {}
    for corr in ("none", "hinge"):
        m = CableModel(MPI.COMM_WORLD, _hinged(name, corr))
        F = solve_static(m).anchor_forces[0]
        w = solve_modes(m, 1).omegas[0]
        anc = m.anchors[0]
        mom = anchor_moments(F[None, :3], anc.direction, anc.section.EI, anc.section.EA,
                             anc.section.mass, np.zeros((1, 3)),
                             anc.section.mass * m.g_vec, m.length, None, "exact")["moment"][0]
        res[corr] = (np.linalg.norm(F[:3]), mom, w)
    T_rod, M_rod = np.linalg.norm(F_rod[:3]), np.linalg.norm(F_rod[3:6])
    errors = {corr: np.abs(np.array(v) / np.array([T_rod, M_rod, w_rod]) - 1)
              for corr, v in res.items()}
    # measured with the hinge: <= 1.4e-3 (case B tension; the string's 20 elements and the
    # rod's mesh are both in it); 2e-3 is the 0.2 %
    assert np.all(errors["hinge"] < 2e-3), errors
    # leading order: case A's frequency is 0.7 % off, case B's tension 2.6 %
    assert np.any(errors["none"] > 5e-3), errors


def test_hinge_keeps_the_whole_weight_on_the_anchors():
    """The layer's mass is out of the string and its weight is added at the anchor: the
    vertical anchor forces still carry the cable's whole weight m g l."""
    m = CableModel(MPI.COMM_WORLD, _hinged("paper_spatial.toml"))
    F = solve_static(m).anchor_forces
    W = m.case.section.mass * m.case.gravity.g * m.length
    # the consistent reactions balance the assembled weight to Newton's tolerance (1e-10
    # relative to the force scale) and the layer weights are added exactly
    assert -np.sum(F[:, 2]) == pytest.approx(W, rel=1e-8)
    rep = m.hinges.report()
    for name, hg in rep.items():
        # about one layer length along the clamp (case B: Delta = 0.2, ell ~ 6.3e-3 m)
        assert 0.9 * hg["sigma_h"] < hg["h"] < 1.1 * hg["sigma_h"]
        anc = next(a for a in m.anchors if a.name == name)
        assert np.allclose(m.u_bc.x.array[anc.flat_dofs].reshape(-1, 3),
                           anc.displacement(0.0) + hg["offset"], atol=1e-14)
        # h along the clamp, plus the second order E ~ ell^2 w/T (theory.md §6.2): here
        # ell0^2 w/T ~ 4e-5 h... within 1e-2 h of it
        assert np.linalg.norm(np.asarray(hg["offset"]) - hg["h"] * anc.direction) \
            < 1e-2 * hg["h"]


def test_hinge_parallel_equals_serial():
    case = _hinged("paper_inplane.toml")
    F_world = solve_static(CableModel(MPI.COMM_WORLD, case)).anchor_forces
    F_self = solve_static(CableModel(MPI.COMM_SELF, case)).anchor_forces
    # Newton's tolerance 1e-10 of the force scale; the partition only reorders sums
    assert np.allclose(F_world, F_self, rtol=1e-9, atol=1e-9 * np.abs(F_self).max())


def _sagging(n: int, corr: str = "hinge", EI: float = 9e-4):
    """A 10 %-sag cable at eps = sqrt(EI/(w l^3)) = 0.03 (EI = 9e-4; 0.08: 6.4e-3), clamped
    horizontally (anchor angle ~0.4 rad, layer length ~0.027 l at eps = 0.03): the old
    one-element hinge took it up to 19 elements only (6 at eps = 0.08)."""
    data = tomllib.loads((DEMOS / "paper_inplane.toml").read_text())
    data.setdefault("solver", {})["outer_correction"] = corr
    data["mesh"]["elements"] = n
    data["section"]["EI"] = EI
    data["anchors"][1]["position"] = [0.974, 0, 0]
    return parse_case(data, DEMOS)


def _anchor_state(case):
    m = CableModel(MPI.COMM_WORLD, case)
    res = solve_static(m)
    F = res.anchor_forces[0]
    anc = m.anchors[0]
    mom = anchor_moments(F[None, :3], anc.direction, anc.section.EI, anc.section.EA,
                         anc.section.mass, np.zeros((1, 3)), anc.section.mass * m.g_vec,
                         m.length, None, "exact")["moment"][0]
    return np.array([mom, solve_modes(m, 1).omegas[0]]), m, res


@pytest.mark.parametrize("kind", ["A", "sag"])
def test_hinge_on_any_mesh_converges_with_the_mesh(kind):
    """The layer's length is taken from as many elements as it needs: meshes from 10
    elements to 4x finer than the old one-element limit (case A: 125, the sagging cable: 19)
    are accepted and the static anchor moment and first frequency converge at the linear
    elements' O(L^2). Measured (moment, frequency), relative differences to the finest mesh:
    case A 2.1e-4, 4.0e-3 at 10 elements, 2.5e-9, 4.8e-6 at 250; sagging 2.4e-3, 1.9e-3 at
    10, 7.3e-6, 5.5e-6 at 160 (so, by Richardson, the finest mesh's own error is a third of
    that, ~2e-6)."""
    meshes = {"A": (10, 20, 40, 125, 250, 500), "sag": (10, 20, 40, 80, 160, 320)}[kind]
    make = (lambda n: _hinged("paper_inplane.toml") if kind == "A" else _sagging(n))
    vals, regions = [], []
    for n in meshes:
        case = make(n)
        case = dataclasses.replace(case, mesh=dataclasses.replace(case.mesh, elements=n))
        v, m, _ = _anchor_state(case)
        vals.append(v)
        regions.append(m.hinges.report()["p"]["elements"])
    vals = np.array(vals)
    assert regions[0] <= 2 and regions[-1] >= 8  # one or two elements coarse, many fine
    diff = np.abs(vals[:-1] / vals[-1] - 1)  # against the finest mesh
    # O(L^2): each halving of L divides the difference to the finest mesh by ~4 (3 allows the
    # finest mesh's own error and the non-halving step 40 -> 125); the last pair within
    # 1e-5 (their O(L^2) difference, 3x the finest mesh's own error; measured <= 7.3e-6)
    for k in range(len(meshes) - 2):
        ratio = (meshes[k + 1] / meshes[k]) ** 2 / 1.5
        assert np.all(diff[k + 1] <= diff[k] / ratio + 1e-7), diff
    assert np.all(diff[-1] < 1e-5), diff


@pytest.mark.single_rank  # counts fixed-point iterations (13 s on 2 ranks); the hinge
# on 2 ranks: test_hinge_network and case B's 2 ranks = serial test
def test_hinge_fixed_point_is_accelerated_and_tight(monkeypatch):
    """The sagging cable at eps = 0.08 on 6 elements (the old limit): the plain fixed point
    contracts by ~0.52 per iteration there and was rejected after 30 iterations (measured
    with the plain iteration here: 29-30 to Newton's tolerance). Accelerated (Anderson), it
    stops within 12 (measured: 9), and gives the anchor moment of the plain iteration run
    to its noise floor (depth 0, up to 200 iterations) to 1e-8 (both stop where sigma_h
    changes by <= 1e-10; the moment ~ sqrt(T) and T is smooth in sigma_h)."""
    import functools
    import logging

    import cablefem.hinge as hinge
    import cablefem.statics as statics

    records = []

    class Keep(logging.Handler):
        def emit(self, record):
            records.append(record.getMessage())

    def solve(depth):
        records.clear()
        if depth == 0:
            monkeypatch.setattr(statics, "hinge_fixed_point", functools.partial(
                plain, depth=0, max_iterations=200, tol=0.0))
        v, m, _ = _anchor_state(_sagging(6, EI=6.4e-3))
        return v, m, [r for r in records if "anchor force change" in r]

    plain = hinge.hinge_fixed_point
    h = Keep()
    logger = logging.getLogger("cablefem.hinge")
    level = logger.level
    logger.addHandler(h)
    logger.setLevel(logging.INFO)
    try:
        v, m, its = solve(3)
        v_ref, _, its_ref = solve(0)
    finally:
        logger.removeHandler(h)
        logger.setLevel(level)
    assert 2 <= len(its) <= 12 < len(its_ref), (its, its_ref)
    assert v[0] == pytest.approx(v_ref[0], rel=1e-8)


def test_hinge_placement_shared_over_the_ranks_is_the_serial_one():
    """``VirtualHinges.place`` shares the hinges out over the ranks and gathers their rows:
    every rank gets the rows one rank computes, to the last bit, and a hinge that cannot
    be placed (a slack second anchor, placed by the second rank under ``mpirun -n 2``)
    raises the same error on every rank instead of leaving the others waiting."""
    from cablefem.hinge import HingeError

    case = _hinged("paper_inplane.toml")
    world = CableModel(MPI.COMM_WORLD, case)
    forces = np.array(solve_static(world).anchor_forces, float)
    alone = CableModel(MPI.COMM_SELF, case)
    assert len(world.hinges.items) == 2
    assert np.array_equal(world.hinges.place(forces), alone.hinges.place(forces))
    slack = forces.copy()
    slack[world.hinges.items[1].index] = 0.0
    name = world.hinges.items[1].anchor.name
    with pytest.raises(HingeError, match=f"anchor {name}: .*no layer"):
        world.hinges.place(slack)


def test_hinge_refusal_is_a_case_error():
    """A hinge that cannot be placed (here: a layer longer than a quarter of half the
    cable, EI raised 1e4-fold) is an input problem naming solver.outer_correction."""
    case = _hinged("paper_inplane.toml")
    case = dataclasses.replace(case, section=dataclasses.replace(case.section, EI=4.0))
    with pytest.raises(CaseError, match="outer_correction"):
        solve_static(CableModel(MPI.COMM_WORLD, case))


def test_outer_correction_key_is_validated():
    data = tomllib.loads((DEMOS / "paper_inplane.toml").read_text())
    data.setdefault("solver", {})["outer_correction"] = "hing"
    with pytest.raises(CaseError, match=r"outer_correction.*did you mean 'hinge'"):
        parse_case(data, DEMOS)


# ----------------------------------------------------------------------------- dynamics
def _static_hinged(name: str, comm=MPI.COMM_WORLD):
    m = CableModel(comm, _hinged(name))
    solve_static(m)
    m.hinges.start_dynamics(m.u_static.x.array)
    return m


def test_following_layer_is_the_static_layer_at_the_static_state():
    """At the static state the layer's law (module docs of cablefem.hinge) gives the static
    tension at the static length: nothing moves when dynamics starts; the region's mass is
    its stress-free length less the layer's (c s + sigma_h = s); the law is softer than the
    element (the layer's compliance in series) and continuous at the floor and ceiling."""
    m = _static_hinged("paper_spatial.toml")
    hg = m.hinges
    T0, d0 = hg._measure(m.u_static.x.array)
    for h, t_k in zip(hg.items, T0):
        assert h.T_static == pytest.approx(t_k, rel=1e-12)
        if h.cells[0] < 0:
            continue
        c = int(h.cells[0])
        assert h.n == 1  # one element on this mesh
        assert m.c.x.array[c] * h.s[0] + h.mass_length == pytest.approx(h.s[0], rel=1e-14)
        ka, kb = m.law_ka.x.array[c], m.law_kb.x.array[c]
        assert ka > kb > 0.0  # a compliance in series: softer
        # the three branches of forms.layer_law_tension meet at the floor and the ceiling
        a, tf, tc = m.law_a.x.array[c], m.law_tf.x.array[c], m.law_tc.x.array[c]
        for T in (tf, tc):
            lam = a + ka * T
            assert (lam - a - (ka - kb) * T) / kb == pytest.approx(T, rel=1e-12)
    # the static tension again: identities up to round-off of O(1) quantities
    T1, d1 = hg._measure(m.u_static.x.array)
    np.testing.assert_allclose(T1, T0, rtol=1e-10)
    np.testing.assert_allclose(d1, d0, rtol=0, atol=1e-14)


def test_following_layer_matches_the_rod_far_field_to_second_order():
    """Move the first element's far node (the angle and the tension change, by eps and 2
    eps): the element's stretch satisfies the rod's far-field condition, ``lambda = c0 (1 -
    sigma/s) (1 + T/EA)`` with sigma(T, Delta) = sigma_far(T, Delta) + (the static state's
    mismatch between element and anchor force), up to a residual of second order (the law
    is linear about the static state): doubling the change multiplies the residual by 4
    (3.5-4.5 allows the third-order terms), and it is small against the law's first-order
    terms (measured 5 %: the cross term of T^-1/2 and Delta^2 in D_t; 10 % allowed)."""
    m = _static_hinged("paper_spatial.toml")
    hg = m.hinges
    u0 = m.u_static.x.array.copy()
    T0, d0 = hg._measure(u0)

    def far(h, d, T):  # the string's stress-free length to the rod's far-field line
        sec = h.anchor.section
        return (h.h * np.cos(d) - far_field_offsets(d, T, sec.EI, sec.EA)[0]) / (1 + T / sec.EA)

    shift = [h.sigma - far(h, d, T) for h, d, T in zip(hg.items, d0, T0)]
    res, first = [], []
    for scale in (0.5, 1.0):
        u = u0.copy()
        x = u.reshape(-1, 3)
        for h in hg.items:  # push the element's far node in the bending plane and along it
            if h.nodes is not None:
                a, b, E = h.nodes
                e = E + x[b] - x[a]
                le = np.linalg.norm(e)
                perp = h.anchor.direction - np.dot(h.anchor.direction, e) / le**2 * e
                # 0.01 rad less angle, a strain of 2e-5 more (T/EA = 2.5e-4: T up ~20 %)
                x[b] += scale * (0.01 * le * perp / np.linalg.norm(perp) + 2e-5 * e)
        T, d = hg._measure(u)
        assert np.all(np.abs(d - d0) > 4e-3 * scale) and np.all(T / T0 - 1 > 0.1 * scale)
        r, f = [], []
        for h, dk, Tk, sh, d_s, T_s in zip(hg.items, d, T, shift, d0, T0):
            if h.nodes is None:
                continue
            a, b, E = h.nodes
            lam = np.linalg.norm(E + x[b] - x[a]) / np.linalg.norm(E)
            sig = far(h, dk, Tk) + sh
            r.append(abs(lam - h.c0[0] * (1 - sig / h.s[0]) * (1 + Tk / h.EA0)))
            f.append(h.c0[0] * (abs(h.sig_T * (Tk - T_s))
                                + abs(h.sig_C * (np.cos(dk) - np.cos(d_s)))) / h.s[0])
        res.append(np.array(r))
        first.append(np.array(f))
    assert np.all(res[0] < 0.1 * first[0])
    ratio = res[1] / res[0]
    assert np.all((3.5 < ratio) & (ratio < 4.5)), ratio


def test_following_hinge_dynamics_is_stable_and_partition_independent():
    """Case B's first 0.5 s (100 steps, the t = 0 velocity jump sends axial waves through
    the first elements): a layer updated after each step from its element's tension, without
    the series compliance, blew up within 15 steps (the element's EA/L times the layer's
    axial compliance is ~2.4). Runs to the end, stays finite, and gives the serial anchor
    forces on 2 ranks to Newton's tolerance (1e-9 of the force scale, amplified by 100
    steps: 1e-7)."""
    from cablefem.dynamics import integrate

    hist = {}
    for comm in (MPI.COMM_WORLD, MPI.COMM_SELF):
        m = CableModel(comm, _hinged("paper_spatial.toml"))
        solve_static(m)
        m.u.x.array[:] = m.u_static.x.array
        hist[comm.size] = np.array([f.copy() for _, f in integrate(m, 0.5, 0.005, 0.9, 10)])
        sig = [h.sigma for h in m.hinges.items]
        rep = m.hinges.report()
        # the layer moves, but stays near its static length (tension within +-30 %)
        assert all(0.8 < s / r["sigma_h"] < 1.2 for s, r in zip(sig, rep.values()))
    a, b = hist[MPI.COMM_WORLD.size], hist[1]
    assert np.all(np.isfinite(a)) and a.shape[0] == 11
    assert np.abs(a[:, :, :3]).max() < 10.0  # static tension 2.5 N
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-7 * np.abs(b).max())


@pytest.mark.slow
@pytest.mark.parametrize("name", ["paper_inplane.toml", "paper_spatial.toml"])
def test_hinged_string_steady_state_rms_against_the_rod(name, mpi_tmp_path):
    """The paper's cases over 30 s (the rod: 141 and 133 elements, converged to 0.12 % in
    RMS, benchmarks/bench_paper.py): the steady-state RMS anchor moment of the string with
    the following hinge within 1 % of the rod's (the issue's target; measured 0.08-0.76 %).
    The peaks are not asserted: they miss the 1 % target (2.5-4 %, README)."""
    from cablefem.app.run import run_case

    rms = {}
    for label, case, kw in (("rod", load_case(DEMOS / name), {"model": "beam"}),
                            ("hinge", _hinged(name), {})):
        res = run_case(case, mpi_tmp_path / label, MPI.COMM_WORLD, progress=False,
                       figures=False, **kw)
        rms[label] = np.array([a["steady_state_moment"]["rms"]
                               for a in res.summary["anchors"].values()
                               if a["kind"] == "clamped"])
    assert np.all(np.abs(rms["rod"] / rms["hinge"] - 1) < 1e-2), rms


def test_following_hinge_resumes_from_a_checkpoint_exactly(mpi_tmp_path):
    """A checkpoint keeps the tension and angle each layer's law was set from (the state
    alone does not give them back: the tension measured in it depends on the law it was
    solved with). Case B resumed from checkpoint.npz at step 20 of 40 gives the
    uninterrupted anchor forces exactly (measured: 0; without the laws: 5 % off)."""
    full, resumed, ck = resume_round_trip(
        lambda: CableModel(MPI.COMM_WORLD, _hinged("paper_spatial.toml")), mpi_tmp_path, 0.2,
        0.005, 40)
    # per hinge: the first element's T, Delta, mode and per region element T, cos, sigma
    # the same equations from the same state and laws: round-off of the 2.5 N force
    np.testing.assert_allclose(resumed, full, rtol=0, atol=1e-12 * np.abs(full).max())


@pytest.mark.serial
def test_refused_hinge_exits_2_from_the_cli(tmp_path):
    """The CLI: a hinge that cannot be placed is an input problem, exit 2 (not 1)."""
    from cablefem.app.cli import main

    text = (DEMOS / "paper_inplane.toml").read_text().replace("EI = 4.0e-4", "EI = 4.0")
    case = tmp_path / "case.toml"
    case.write_text(text)
    assert main(["run", str(case), "--output", str(tmp_path / "out"),
                 "--outer-correction", "hinge"]) == 2


def _slackening():
    """Case A with mass-proportional damping and anchor q driven 3e-3 l towards p (twice
    the static stretch T/EA = 1.4e-3): the tension drops to ~0.01 of its static 25 every
    cycle (first below the floor at t = 0.075 s)."""
    data = tomllib.loads((DEMOS / "paper_inplane.toml").read_text())
    data.setdefault("solver", {})["outer_correction"] = "hinge"
    data["anchors"][1]["motion"] = {"type": "harmonic", "amplitude": [-3e-3, 0, 0],
                                    "omega": 6.0, "ramp": 0.0}
    data["damping"] = {"alpha": 1.0, "beta": 0.0}
    # snap loads: with rho_inf = 0.9 the leading-order string itself blows up on 40 or 60
    # elements (peak anchor force 1.6e4 against 79); with 0.5 every mesh from 20 to 60
    # elements, with or without hinges, peaks at 79.0-79.4
    data["dynamics"]["rho_inf"] = 0.5
    return parse_case(data, DEMOS)


def test_hinge_falls_back_at_low_tension_and_the_run_goes_on():
    """The slackening case A (_slackening), 1.5 s. Before the fallback the layer's law broke
    at t = 1.145 s (sigma NaN, the first element in compression). Now: the run completes;
    the rows whose first element is outside a quarter to twice its static tension are
    flagged, the others not; the forces stay within the quasi-static envelope (the largest
    stretch (1.4e-3 + 3e-3) EA = 79 N; 100 allows the dynamics' overshoot); and the layer's
    length stays within what the law gives between the floor and the ceiling (sigma_h/2 to
    11/8 sigma_h for sigma ~ T^-1/2, 0.45-1.45 with the angle's term)."""
    from cablefem.dynamics import integrate

    m = CableModel(MPI.COMM_WORLD, _slackening())
    solve_static(m)
    m.u.x.array[:] = m.u_static.x.array
    h = m.hinges.items[0]
    rows = []
    for t, F in integrate(m, 1.5, 0.005, 0.5, 1):
        T1, d1 = m.hinges._measure(m.u.x.array)  # the first element's
        rows.append((t, np.linalg.norm(F[0, :3]), m.hinges.fallback(F)["p"],
                     m.hinges.layer_sigma(T1[0], d1[0], h)))
    r = np.array(rows, float)
    assert r[-1, 0] == pytest.approx(1.5) and np.all(np.isfinite(r[:, :3]))
    assert r[:, 1].min() < 0.1 * r[0, 1]  # the tension did drop below the floor (25 % of T)
    assert 0.05 < r[:, 2].mean() < 0.6  # flagged rows, not all
    T0 = h.T_static
    outside = (r[:, 1] < 0.25 * T0) | (r[:, 1] > 2.0 * T0)
    np.testing.assert_array_equal(r[:, 2] == 1, outside)  # the flag is the law's range
    assert r[:, 1].max() < 100.0
    if h.cells[0] >= 0:
        assert np.all((r[:, 3] > 0.45 * h.sigma) & (r[:, 3] < 1.45 * h.sigma))


def test_fallback_is_flagged_in_the_summary_and_resumes_exactly(mpi_tmp_path):
    """The slackening case A over 0.2 s (40 steps): run_case's summary gives the fallback's
    fraction of rows per anchor with a warning; a checkpoint at step 20 (t = 0.1 s, inside
    the first fallback phase, 0.075-0.185 s) keeps the fallback flag and the resumed run
    gives the uninterrupted anchor forces exactly."""
    from cablefem.app.run import run_case

    case = _slackening()
    case = dataclasses.replace(case, dynamics=dataclasses.replace(case.dynamics, t_end=0.2))
    res = run_case(case, mpi_tmp_path / "run", MPI.COMM_WORLD, progress=False, figures=False)
    for name in ("p", "q"):
        frac = res.summary["anchors"][name]["outer_fallback_fraction"]
        # rows 16..37 of 41 (t = 0.08 ... 0.185 s; the flag is the law the step was solved
        # with): ~0.5; the bounds allow the phase to shift by a few steps
        assert 0.3 < frac < 0.7, frac
    assert any("outside the tension range it follows" in w["message"]
               for w in res.summary["warnings"])

    full, resumed, ck = resume_round_trip(lambda: CableModel(MPI.COMM_WORLD, case),
                                          mpi_tmp_path, 0.2, 0.005, 40)
    # the same equations from the same state and laws: round-off of the forces (~25 N)
    np.testing.assert_allclose(resumed, full, rtol=0, atol=1e-12 * np.abs(full).max())


def test_sagging_cable_with_horizontal_clamps_runs_by_default():
    """A 10 %-sag cable clamped horizontally (anchor angles 0.44 rad, eps = 0.03), anchor q
    moving 0.01 out of plane at 2.5 rad/s, below the first frequency 3.5: the first 3.5 s by
    default. Before, the layer followed the angle one step late, which fed energy into the
    motion: the tension swung from 1.17 down to 0.04 and Newton cycled at t = 2.78 s (run
    stopped). Now it runs on, and the anchor tension stays within 1 % of the static one
    (a swing of the cable's plane by about 0.1 rad changes it by less; measured +0.05 %, as
    the leading order's +0.05 %), 2 ranks as serial to Newton's tolerance."""
    from cablefem.dynamics import integrate

    data = sagging_paper_case(0.03)
    hist = {}
    for comm in (MPI.COMM_WORLD, MPI.COMM_SELF):
        m = CableModel(comm, parse_case(data, DEMOS))
        assert m.hinges  # the default
        solve_static(m)
        m.u.x.array[:] = m.u_static.x.array
        hist[comm.size] = np.array([(t, *F[0, :3]) for t, F in integrate(m, 3.5, 0.005, 0.9,
                                                                           10)])
    h = hist[MPI.COMM_WORLD.size]
    assert h[-1, 0] == pytest.approx(3.5)
    T = np.linalg.norm(h[:, 1:], axis=1)
    assert np.all(np.abs(T / T[0] - 1) < 0.01)
    # 700 steps of Newton at 1e-9 of the force scale: 1e-7
    np.testing.assert_allclose(h, hist[1], rtol=0, atol=1e-7 * np.abs(hist[1]).max())


def test_slackening_run_warns_about_rho_inf(mpi_tmp_path):
    """A run whose anchor tension drops below 5 % of the static one with rho_inf = 0.9 warns
    (naming rho_inf; snap loads blew up the leading-order string itself at 0.9 on 40
    elements, docs/theory.md §6); at 0.5 it does not. The slackening case A, 0.2 s (the
    tension reaches ~0.01 of its static value at t = 0.1-0.15)."""
    from cablefem.app.run import run_case

    case = _slackening()
    for rho, warned in ((0.9, True), (0.5, False)):
        dyn = dataclasses.replace(case.dynamics, t_end=0.2, rho_inf=rho)
        res = run_case(dataclasses.replace(case, dynamics=dyn), mpi_tmp_path / f"r{rho}",
                       MPI.COMM_WORLD, progress=False, figures=False, modes=0)
        # the anchors' slack warning (the step-to-step alternation's, on dynamics.dt, also
        # names a snap as a cause, at either rho_inf)
        msgs = [w["message"] for w in res.summary["warnings"]
                if w["key"].startswith("anchors.") and "snaps taut" in w["message"]]
        assert bool(msgs) == warned and all("rho_inf" in m for m in msgs)



def _residual(model) -> np.ndarray:
    """The static residual at ``model.u`` on the free rows (owned entries)."""
    b = fpetsc.assemble_vector(model.f_static)
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    fpetsc.set_bc(b, model.bcs, scale=0.0)
    out = b.array.copy()
    b.destroy()
    return out


def test_modes_linearise_the_law_the_dynamics_solves():
    """The modal analysis of a hinged cable linearises the layers' law (what the dynamics
    solves, set by start_dynamics), not the statics' elastic law: for each of the first
    four modes, the residual's change along the mode, (R(u0 + h phi) - R(u0 - h phi))/(2h),
    equals omega^2 M phi. Central differences of a smooth residual: error O(h^2) (measured
    0.3-0.6 h^2 relative, the mode's largest amplitude being 1 = the span), h = 1e-6, plus
    round-off (about 1e-6 measured); 1e-5 of |omega^2 M phi| allowed. Linearising the
    statics' law instead fails by far more (measured 19 in mode 2) on this 10 %-sag cable
    clamped horizontally, whose anchor angle enters the layer's law."""
    model = CableModel(MPI.COMM_WORLD, _sagging(40))
    solve_static(model)
    res = solve_modes(model, 4)
    u0 = model.u.x.array.copy()
    model.hinges.start_dynamics(u0)  # the law as the dynamics sets it
    M = fpetsc.assemble_matrix(model.m_form, model.bcs, diagonal=0.0)
    M.assemble()
    h = 1e-6
    for w, phi in zip(res.omegas, res.shapes):
        diff = []
        for sign in (1.0, -1.0):
            model.u.x.array[:] = u0 + sign * h * phi.x.array
            diff.append(_residual(model))
        model.u.x.array[:] = u0
        Kphi = (diff[0] - diff[1]) / (2 * h)
        Mphi = M.createVecLeft()
        M.mult(phi.vector, Mphi)
        expected = w**2 * Mphi.array
        err = MPI.COMM_WORLD.allreduce(float(np.sum((Kphi - expected) ** 2)))
        ref = MPI.COMM_WORLD.allreduce(float(np.sum(expected ** 2)))
        assert np.sqrt(err / ref) < 1e-5, (w, np.sqrt(err / ref))


def test_the_layers_forces_are_each_hinges_mass_times_g_minus_a():
    """``VirtualHinges.layer_forces``: the layer's weight and inertia ``m sigma_h (g -
    a)`` at each anchor with a hinge (the same floating-point operations: to the last
    bit), exact zeros at an anchor without one."""
    case = sagging_paper_case(0.01)
    case["solver"] = {**case.get("solver", {}), "outer_correction": "hinge"}
    model = CableModel(MPI.COMM_WORLD, parse_case(case))
    solve_static(model)
    hinges = model.hinges
    assert hinges and all(hg.mass_length > 0 for hg in hinges.items)
    n = len(model.anchors)
    acc = np.random.default_rng(7).standard_normal((n, 3))
    anchors = np.arange(n)
    got = hinges.layer_forces(anchors, acc)
    held = {hg.index: hg for hg in hinges.items}
    for i in range(n):
        if i in held:
            hg = held[i]
            expected = hg.anchor.section.mass * hg.mass_length * (hinges.g_vec - acc[i])
            assert np.array_equal(got[i], expected)
        else:
            assert np.array_equal(got[i], np.zeros(3))
    assert np.array_equal(hinges.layer_forces(anchors[::-1], acc[::-1]), got[::-1])
