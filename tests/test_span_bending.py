"""The span's own bending in the string (solver.span_bending, docs/theory.md §6.1): a taut
pinned beam exactly and in the limit, a sagging cable against the rod, and statics that
move by O(eps^2) only."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import level_case, observed_order, sagging_paper_case
from mpi4py import MPI

from cablefem.app.run import run_case
from cablefem.cable import CableModel
from cablefem.case import CaseError, load_case, parse_case
from cablefem.modal import solve_modes
from cablefem.moments import anchor_moments
from cablefem.rod import BeamModel
from cablefem.statics import solve_static

DEMOS = Path(__file__).resolve().parents[1] / "demos"


# ----------------------------------------------------------------------------- taut beam
def taut_beam(n: int, EI: float, EA=1e4, l0=1.0, L=1.0001, m=1.0, bending=True):
    d = level_case(EA=EA, EI=EI, mass=m, g=0.0, length=l0, chord=L, elements=n,
                   solver={"span_bending": bending})
    for anc in d["anchors"]:
        anc["type"] = "pinned"
        del anc["direction"]
    model = CableModel(MPI.COMM_WORLD, parse_case(d))
    solve_static(model)
    return model


def taut_beam_discrete(n_el, k, T, lam, EI, m, l0):
    """Transverse frequencies of the discrete pinned beam, exact: sin(k pi s_i / l) is a
    mode of the P1 string (stiffness (T/lam) x/h per node, consistent mass m h (2 + cos)/3,
    x = 2 - 2 cos theta, theta = k pi h/l) and of the turning-angle energy EI theta_i^2 /
    (2 h) with theta_i = (w_i+1 - 2 w_i + w_i-1)/(lam h), whose stiffness is EI x^2/(lam^2
    h^3); no term at the pinned ends (the vertex sum stops there, as the sine does)."""
    h = l0 / n_el
    th = k * np.pi * h / l0
    x = 2.0 - 2.0 * np.cos(th)
    K = T / lam * x / h + EI * x * x / (lam * lam * h ** 3)
    return np.sqrt(K / (m * h * (2.0 + np.cos(th)) / 3.0))


EPS = 0.05  # EI = eps^2 with T = w = l = 1: (4 pi)^2 EI/T = 0.39 in mode 4


def test_taut_pinned_beam_discrete_exact():
    """Modes 1..4 of the taut string with span bending equal the discrete closed form to
    1e-8 (eigen tolerance 1e-12; the static stretch is solved to ~1e-10)."""
    n, EA, l0, L, m, EI = 24, 1e4, 1.0, 1.0001, 1.0, EPS ** 2
    model = taut_beam(n, EI, EA, l0, L, m)
    res = solve_modes(model, 8)
    T, lam = EA * (L / l0 - 1), L / l0
    expected = np.repeat([taut_beam_discrete(n, k, T, lam, EI, m, l0) for k in (1, 2, 3, 4)],
                         2)
    np.testing.assert_allclose(res.omegas, expected, rtol=1e-8)


def test_taut_pinned_beam_converges_to_the_beam():
    """omega_n -> (n pi/L) sqrt(T/m) sqrt(1 + (n pi)^2 EI/(T L^2)) at second order in h.

    The discrete form above expands to omega_h/omega = 1 + (theta^2/24) T/(T + EI k^2)
    + O(theta^4) (k = n pi/l): the string's consistent-mass error, damped by the share of
    bending in the stiffness (the turning-angle energy is exact to O(theta^2) against the
    mass's error). The model's continuum limit is k sqrt((T/lam + EI k^2/lam^2)/m); it
    differs from the formula in L by O(lam - 1) = 1e-4 relative, and the tests below
    compare with the formula in L within the mesh's own error."""
    EA, l0, L, m, EI = 1e4, 1.0, 1.0001, 1.0, EPS ** 2
    T, lam = EA * (L / l0 - 1), L / l0
    ns = np.array([16, 32, 64])
    modes = np.arange(1, 5)
    k = modes * np.pi / l0
    exact = k * np.sqrt((T / lam + EI * k * k / lam ** 2) / m)
    errors = []
    for n in ns:
        om = solve_modes(taut_beam(int(n), EI, EA, l0, L, m), 8).omegas[::2]
        err = om / exact - 1.0
        th = modes * np.pi / n
        lead = th ** 2 / 24 * T / (T + EI * k * k / lam)
        np.testing.assert_allclose(err, lead, rtol=0.05)  # the O(theta^4) rest: < 2 %
        errors.append(err)
        # the brief's formula, in the current length L and mass per current length
        formula = modes * np.pi / L * np.sqrt(T / (m * l0 / L)) * np.sqrt(
            1 + (modes * np.pi) ** 2 * EI / (T * L * L))
        assert np.all(np.abs(om / formula - 1) < lead + 2e-4)
    errors = np.array(errors)
    for j in range(len(modes)):
        assert 1.9 < observed_order(1.0 / ns, errors[:, j]) < 2.1


# ----------------------------------------------------------------------------- vs the rod
def sagging(EI: float, kind: str, span_bending: bool = False, EA=1e4,
            elements=100) -> dict:
    """A level cable of 10 % sag (l = w = 1 scale: span 1, m = g = 1) with both anchors
    ``kind`` (a clamp along the chord, which is horizontal, with the virtual hinge)."""
    d = {"title": "sag", "section": {"EA": EA, "EI": EI, "mass": 1.0}, "gravity": {"g": 1.0},
         "geometry": {"sag_ratio": 0.1}, "mesh": {"elements": elements},
         "anchors": [{"name": "p", "position": [0.0, 0, 0], "type": kind},
                     {"name": "q", "position": [1.0, 0, 0], "type": kind}],
         "solver": {"span_bending": span_bending}}
    if kind == "clamped":
        d["anchors"][0]["direction"] = [1.0, 0, 0]
        d["anchors"][1]["direction"] = [-1.0, 0, 0]
        d["solver"]["outer_correction"] = "hinge"
    return d


LABELS = {"IP sym": ("in-plane", "symmetric"), "IP anti": ("in-plane", "antisymmetric"),
          "OOP sym": ("out-of-plane", "symmetric"), "OOP anti": ("out-of-plane", "antisymmetric")}


def first_modes(model) -> dict[str, float]:
    """The first frequency of each kind (cablefem.modal's labels)."""
    st = solve_static(model)
    res = solve_modes(model, 8)
    out = {}
    for w, lab in zip(res.omegas, res.labels):
        for name, key in LABELS.items():
            if (lab.get("plane"), lab.get("symmetry")) == key:
                out.setdefault(name, float(w))
    assert set(out) == set(LABELS), res.labels
    out["H"] = float(st.anchor_forces[0][0])
    return out


def rod_modes(EI: float, kind: str, refine: float = 2.0) -> dict[str, float]:
    return first_modes(BeamModel(MPI.COMM_WORLD, parse_case(sagging(EI, kind)), refine=refine))


@pytest.mark.parametrize("eps", [0.03, 0.05])
def test_sagging_pinned_cable_against_the_rod(eps):
    """A 10 %-sag cable pinned at both ends: the string with span bending gives the rod's
    first four frequencies (in-plane symmetric and antisymmetric, out of plane) within
    0.5 % (measured: <= 0.2 %; the rod at refine 2 moves by < 4e-4 from refine 1, the string
    of 100 elements by < 2e-4 from 200). Without span bending the in-plane symmetric one
    is 2.5 % (eps 0.03) to 7 % (eps 0.05) low: more than 2 %."""
    EI = eps ** 2
    rod = rod_modes(EI, "pinned")
    bent = first_modes(CableModel(MPI.COMM_WORLD, parse_case(sagging(EI, "pinned", True))))
    plain = first_modes(CableModel(MPI.COMM_WORLD, parse_case(sagging(EI, "pinned"))))
    for name in LABELS:
        assert abs(bent[name] / rod[name] - 1) < 5e-3, (name, bent, rod)
    assert plain["IP sym"] / rod["IP sym"] - 1 < -2e-2


@pytest.mark.parametrize("eps", [0.03, 0.05])
def test_sagging_clamped_cable_against_the_rod(eps):
    """The same cable clamped along the chord (horizontal), with the virtual hinge and
    span bending: the first in-plane and out-of-plane frequencies against the rod, within
    the aim of 0.5 %. Measured on 100 elements (50 to 400 elements in brackets): eps =
    0.03: in-plane symmetric -0.41 % (-0.31 to -0.43 %), antisymmetric +0.02 %, out of
    plane -0.02 % and +0.07 %; eps = 0.05: -0.04 % (-0.33 to +0.12 %), +0.13 %, -0.08 %
    and +0.34 %. History: +0.63 % in the in-plane symmetric one at 0.05 while the region's
    bending took the shortened stress-free length of the hinge's cells (too stiff by
    1/(1 - sigma_h/K)); -0.54/-0.18/-0.19/-0.09 % (0.03) and +0.23/-0.37/-0.65/-0.06 %
    (0.05) before the hinge's second order (theory.md §6.2); -2.0/-0.8 % and -1.2/-1.4 %
    in plane before the hinge's normal offset (forms.layer_stretch_vector)."""
    EI = eps ** 2
    rod = rod_modes(EI, "clamped")
    bent = first_modes(CableModel(MPI.COMM_WORLD, parse_case(sagging(EI, "clamped", True))))
    for name in LABELS:
        assert abs(bent[name] / rod[name] - 1) < 5e-3, (name, bent, rod)


def test_the_hinges_offset_runs_where_the_layers_are_long(mpi_tmp_path):
    """The validation matrix's sag08 (case A's section with EI = 0.08^2, chord 0.974: 10 %
    sag, horizontal clamps, q moving out of plane) runs its dynamics with the normal
    offset. A version that solved the offset for the turn it gives its own cell (a
    division by 1 - gamma, gamma = 0.81-0.86 here) stopped at t = 0.10 s (Newton cycling);
    the offset now reads the cell's chord like the law, with nothing to divide."""
    from cablefem.app.run import run_case

    d = sagging_paper_case(0.08)
    d["dynamics"].update({"t_end": 0.3, "dt": 0.005})
    s = run_case(parse_case(d), mpi_tmp_path / "sag08", figures=False,
                 progress=False).summary
    assert s["dynamics"]["t_end"] == pytest.approx(0.3)
    assert s["dynamics"]["steps"] >= 60


# ----------------------------------------------------------------------------- statics
@pytest.mark.parametrize("eps,tol_plain,tol_bent", [(0.03, 1.5e-3, 1e-3), (0.05, 1.5e-3, 4e-3)])
def test_the_hinges_second_order_gives_the_rods_tension(eps, tol_plain, tol_bent):
    """The clamped 10 %-sag cable (horizontal clamps, Delta = 0.44): the horizontal anchor
    force of the hinged string against the rod (refine 2; refine 4 moves it by 1e-5).
    The hinge's second order (asymptotics.far_field_second_order: the weight along the
    layer turns the far field and lowers its tension, a shift of ~0.1-0.2 ell0^2 w/T per
    clamp) took it from -0.29 % (eps 0.03) and -1.14 % (0.05) to +0.06 % and +0.08 %
    without span bending; with span bending from -0.42 % and -1.70 % to -0.06 % and -0.46 %,
    and to -0.04 % and -0.29 % once the region's bending took the mesh length (not the
    hinge's shortened one). Tolerances: the measured values with a margin of about 1.4-2;
    before, every case failed."""
    EI = eps ** 2

    def H(model):
        return float(solve_static(model).anchor_forces[0][0])

    rod = H(BeamModel(MPI.COMM_WORLD, parse_case(sagging(EI, "clamped")), refine=2.0))
    plain = H(CableModel(MPI.COMM_WORLD, parse_case(sagging(EI, "clamped"))))
    bent = H(CableModel(MPI.COMM_WORLD, parse_case(sagging(EI, "clamped", True))))
    assert abs(plain / rod - 1) < tol_plain, (plain, rod)
    assert abs(bent / rod - 1) < tol_bent, (bent, rod)


@pytest.mark.parametrize("eps", [0.03, 0.05])
def test_statics_of_a_clamped_sagging_cable_move_at_order_eps2(eps):
    """The anchor force of the clamped 10 %-sag cable (virtual hinge) changes by
    O(eps^2) with span bending: the layer's moment EI kappa_s handed to the span (the
    term end_moments) cancels the end element's shear, so what is left is the bending of
    the span itself, |dN| ~ EI kappa_s^2 l with kappa_s ~ w/H (measured 1.0 eps^2 at 0.03
    and 1.3 eps^2 at 0.05, relative): bounded by 3 eps^2."""
    EI = eps ** 2
    forces = []
    for bend in (False, True):
        model = CableModel(MPI.COMM_WORLD, parse_case(sagging(EI, "clamped", bend)))
        forces.append(solve_static(model).anchor_forces[:, :3])
    rel = np.linalg.norm(forces[1] - forces[0], axis=1) / np.linalg.norm(forces[0], axis=1)
    assert np.all(rel < 3 * eps ** 2), rel


def test_case_A_anchor_moment_changes_less_than_the_estimate():
    """Case A (eps = 0.02, sag 0.5 %): the static anchor force moves by O(eps^2 (w l/T)^2)
    relative; the anchor moment M ~ sqrt(EI T) Delta follows with dM/M = dN_perp/(T Delta)
    + dT/(2T). Estimate from the measured force change: the moment changes by less than
    twice that, and by less than 1e-3 (the issue's accuracy target for the moment is
    0.1 %)."""
    case = load_case(DEMOS / "paper_inplane.toml")
    out = []
    for bend in (False, True):
        case.solver.span_bending = bend
        model = CableModel(MPI.COMM_WORLD, case)
        assert ("span_bending" in model.forms.user) == bend
        F = solve_static(model).anchor_forces[0, :3]
        anc = model.anchors[0]
        sec = case.section
        mom = anchor_moments(F[None, :], anc.direction, sec.EI, sec.EA, sec.mass,
                             np.zeros((1, 3)), sec.mass * model.g_vec, model.length)
        out.append((F, float(mom["moment"][0]), float(mom["delta"][0])))
    (F0, M0, D0), (F1, M1, _) = out
    T = np.linalg.norm(F0)
    c = model.anchors[0].direction
    dN = F1 - F0
    perp = np.linalg.norm(dN - (dN @ c) * c)
    estimate = perp / (T * D0) + abs(dN @ F0) / T ** 2 / 2
    assert abs(M1 / M0 - 1) < max(2 * estimate, 1e-12)
    assert abs(M1 / M0 - 1) < 1e-3


# ----------------------------------------------------------------------------- the switch
def test_span_bending_is_a_term_of_the_forms_and_off_by_default():
    d = level_case(elements=10)
    model = CableModel(MPI.COMM_WORLD, parse_case(d))
    assert "span_bending" not in model.forms.user
    d["solver"] = {"span_bending": True}
    model = CableModel(MPI.COMM_WORLD, parse_case(d))
    assert model.forms.user["span_bending"][1] == "static"
    assert model.forms.user["end_moments"][1] == "static"  # both anchors clamped
    d["solver"] = {"span_bending": "yes"}
    with pytest.raises(CaseError, match="solver.span_bending"):
        parse_case(d)


@pytest.mark.parametrize("eps", [0.03, 0.05])
def test_the_clamped_anchor_feels_the_string_force_only(eps):
    """At a clamped anchor the span's bending hands its moment to the layer (end_moments):
    the anchor force stays the first element's string force T e plus half its weight, to
    the outer shear EI kappa_s'. On a catenary kappa_s = (w/H) cos^2 psi, so |kappa_s'| =
    2 (w/H)^2 cos^3 psi sin psi <= 0.65 (w/H)^2: the bound EI (w/H)^2 (measured 0.4 of
    it). The vertex next to the anchor alone (no end moment) would add the shear
    EI kappa_s / h_0, about 25 times that bound here."""
    EI = eps ** 2
    d = sagging(EI, "clamped", True, elements=40)
    d["solver"]["outer_correction"] = "none"  # c = 1: the first element is the plain string
    model = CableModel(MPI.COMM_WORLD, parse_case(d))
    N = solve_static(model).anchor_forces[:, :3]
    r = model.gather_nodal(model.u)
    if model.comm.rank == 0:
        x = model.geometry.points + r
        h0 = model.geometry.stations[1]
        for k, (a, b) in enumerate(((0, 1), (-1, -2))):
            chord = x[b] - x[a]
            e = chord / np.linalg.norm(chord)
            T = d["section"]["EA"] * (np.linalg.norm(chord) / h0 - 1)
            string = T * e + model.g_vec * h0 / 2  # N = -R: minus the half element's weight
            H = abs(N[k][0])
            assert np.linalg.norm(N[k] - string) < EI / H ** 2, (N[k] - string, EI / H ** 2)
            assert EI / (T * h0) > 20 * EI / H ** 2


# ----------------------------------------------------------------------------- networks
def arc_network(path, EI: float, n: int, load: float, span_bending: bool = True):
    """The cable of :func:`sagging` as a network: its mesh a circular arc of 10 % sag
    through p and q with ``n`` equal chords (so its stress-free elements, at zero
    pretension, are the single cable's uniform ones), in two cable groups that meet in
    line at mid-span (a node of two groups: it bends like any other, and a point load there
    kinks the cable, cablefem.kinks), and the single
    cable of the same stress-free length; both clamped along the chord with the hinges
    and span bending, with a point load ``load`` (N, downwards) at mid-span."""
    from test_network import write_mesh

    s, R = 0.1, (0.25 + 0.1 ** 2) / 0.2
    alpha = np.arcsin(0.5 / R)
    th = np.linspace(-alpha, alpha, n + 1)
    pts = np.column_stack([0.5 + R * np.sin(th), 0 * th, R - s - R * np.cos(th)])
    length = n * 2 * R * np.sin(alpha / n)
    cells = np.column_stack([np.arange(n), np.arange(1, n + 1)])
    mesh = write_mesh(str(path / "arc.msh"), pts, cells,
                      ["a"] * (n // 2) + ["b"] * (n - n // 2),
                      {"p": [0], "q": [n], "mid": [n // 2]})
    single = sagging(EI, "clamped", span_bending, elements=n)
    single["geometry"] = {"length": length}
    anchors = [{"name": a["name"], "direction": a["direction"]} for a in single["anchors"]]
    sec = {"name": "s", **single["section"]}
    net = {"title": "arc", "network": {"mesh": mesh}, "sections": [sec],
           "cables": [{"group": g, "section": "s", "pretension": 0.0} for g in "ab"],
           "gravity": single["gravity"], "anchors": anchors, "solver": single["solver"]}
    if load:
        single["point_loads"] = [{"s": 0.5 * length, "value": [0.0, 0.0, -load]}]
        net["point_loads"] = [{"group": "mid", "value": [0.0, 0.0, -load]}]
    return parse_case(single), parse_case(net)


@pytest.mark.parametrize("load", [0.0, 0.3])
def test_a_network_bends_like_the_single_cable(mpi_tmp_path, load, monkeypatch):
    """solver.span_bending on a network (cablefem.network.NetworkModel.add_span_bending)
    against the single cable's (string_terms.add_span_bending, written separately: energy on
    interior facets, hand-over on a kink's facet sides; the network's hand-over is
    integrated over the elements): the same cable, the same stress-free elements, 10 % sag
    at eps = 0.05, clamped with the hinges. The first four frequencies and the horizontal
    anchor force agree to 1e-9 (the statics' Newton and hinge tolerances and the
    eigensolver's; the two start from different shapes; measured 3e-12),
    also with a point load of 0.3 w l at mid-span (a kink: no energy there, the span's
    moment handed over on both sides), where the static anchor and kink moments agree too.
    The span bending matters here: without it the in-plane symmetric frequency is lower by
    more than 1 %. Before, a network refused solver.span_bending."""
    import cablefem.junctions
    from cablefem.kinks import KinkMoments
    from cablefem.network import NetworkModel

    # a network's kinks run each cable to its string corner (docs/theory.md §6.3), a single
    # cable's do not: the span's bending is compared without the corners
    monkeypatch.setattr(cablefem.junctions, "junction_terms", lambda model: ())
    EI, n = 0.05 ** 2, 40

    def state(model):  # statics (horizontal anchor force), then the first four modes
        H = float(solve_static(model).anchor_forces[0][0])
        return np.append(solve_modes(model, 4).omegas, H)

    single, net = arc_network(mpi_tmp_path, EI, n, load)
    models = CableModel(MPI.COMM_WORLD, single), NetworkModel(MPI.COMM_WORLD, net)
    a, b = (state(m) for m in models)
    np.testing.assert_allclose(b, a, rtol=1e-9)
    if load:  # the static kink moment (the models hold their static state after the modes)
        kinks = [KinkMoments(m).measure(0.0)["moment"] for m in models]
        assert kinks[0].size == kinks[1].size == 1
        assert kinks[1][0] == pytest.approx(kinks[0][0], rel=1e-9)
    _, plain = arc_network(mpi_tmp_path, EI, n, load, span_bending=False)
    assert np.max(np.abs(state(NetworkModel(MPI.COMM_WORLD, plain))[:4] / b[:4] - 1)) > 1e-2


# ----------------------------------------------------------------------------- "auto"
def test_frequency_shift_estimate_on_the_taut_beam():
    """cablefem.span_bending.frequency_shifts on the taut pinned string (24 elements) with
    span bending off, against the discrete closed form with and without it
    (taut_beam_discrete): a first-order estimate, so within (shift)^2 of the exact
    relative change (eps = 0.01: shifts 0.05-0.8 %), and 1e-3 of it at least."""
    from cablefem.span_bending import frequency_shifts

    n, EA, l0, L, m, EI = 24, 1e4, 1.0, 1.0001, 1.0, 0.01 ** 2
    model = taut_beam(n, EI, EA, l0, L, m, bending=False)
    res = solve_modes(model, 8)
    est = frequency_shifts(model, res)
    T, lam = EA * (L / l0 - 1), L / l0
    bent = np.repeat([taut_beam_discrete(n, k, T, lam, EI, m, l0) for k in (1, 2, 3, 4)], 2)
    plain = np.repeat([taut_beam_discrete(n, k, T, lam, 0.0, m, l0) for k in (1, 2, 3, 4)],
                      2)
    exact = bent / plain - 1
    assert np.all(exact > 4e-4)
    np.testing.assert_allclose(est, exact, rtol=0,
                               atol=max(np.max(exact) ** 2, 1e-3 * exact.min()))


@pytest.mark.parametrize("eps,on", [(0.01, False), (0.03, True)])
def test_auto_span_bending_where_it_matters(mpi_tmp_path, eps, on):
    """solver.span_bending = "auto" (the case files' default): the string without the
    span's bending estimates how far the bending would move each computed mode
    (summary.json modes[].span_bending_shift; first order, against the actual change
    with span bending on within 15 %: measured 1-13 %, the in-plane symmetric mode's the
    largest) and switches it on above 0.5 %: on the 10 %-sag clamped cable at eps = 0.03
    (largest shift 3.8 %, mode 4) the run is the one with span bending on; at eps = 0.01
    (0.37 %) it stays off and is the run without, to the last digit (its statics and
    modes are reused). Before, a sagging cable's in-plane symmetric frequency was 1.6-3.4 %
    low by default with no word."""
    def run(setting, name):
        d = sagging(eps ** 2, "clamped", setting)
        d["modal"] = {"modes": 4}
        return run_case(parse_case(d), mpi_tmp_path / name, MPI.COMM_WORLD, figures=False,
                        progress=False, dynamics=False).summary

    auto, off, bent = run("auto", "auto"), run(False, "off"), run(True, "on")
    rec = auto["span_bending_auto"]
    assert rec["decision"] == ("on" if on else "off") and auto["span_bending"] is on
    assert (rec["largest_shift"] > 0.005) is on
    same = bent if on else off
    # on: the statics start from the probe's equilibrium (before its virtual hinges), so
    # the same equilibrium to Newton's tolerance (rtol 1e-10 of the forces; measured
    # 2e-13 in the modes), in fewer Newton iterations
    tol = 1e-9 if on else 0.0
    for a, b in zip(auto["modes"], same["modes"]):
        assert a["omega"] == pytest.approx(b["omega"], rel=tol, abs=0)
    for name, F in auto["static"]["anchor_forces"].items():
        np.testing.assert_allclose(F, same["static"]["anchor_forces"][name], rtol=tol,
                                   atol=tol * np.abs(F).max())
    est = np.array([m["span_bending_shift"] for m in off["modes"]])
    actual = np.array([b["omega"] / a["omega"] - 1 for a, b in zip(off["modes"],
                                                                    bent["modes"])])
    np.testing.assert_allclose(est, actual, rtol=0.15)
    assert ("span_bending_shift" in auto["modes"][0]) is not on


def test_auto_on_starts_statics_from_the_probe(mpi_tmp_path):
    """"auto" deciding "on" (the mooring demo at 80 elements: the span's bending would move
    mode 6 by 0.72 %) solves the statics with the span's bending from the probe's
    equilibrium (before its virtual hinges): the same equilibrium as the run with it on
    from the catenary, to Newton's tolerance (rtol 1e-10 of the forces: 1e-9 here; the
    modes likewise), in fewer Newton iterations: measured 25 against 60 (before, 92 and
    92: the virtual hinges' steps now take full Newton steps first and cut a stalling
    line search to 10 iterations, their continuation then takes over)."""
    from dataclasses import replace

    def run(setting, name):
        case = load_case(Path(__file__).parent.parent / "demos" / "mooring.toml")
        case = replace(case, solver=replace(case.solver, span_bending=setting),
                       mesh=replace(case.mesh, elements=80))
        return run_case(case, mpi_tmp_path / name, MPI.COMM_WORLD, figures=False,
                        progress=False, dynamics=False).summary

    auto, bent = run("auto", "auto"), run(True, "on")
    assert auto["span_bending_auto"]["decision"] == "on"
    for name, F in auto["static"]["anchor_forces"].items():
        np.testing.assert_allclose(F, bent["static"]["anchor_forces"][name], rtol=0,
                                   atol=1e-9 * np.abs(F).max())
    np.testing.assert_allclose([m["omega"] for m in auto["modes"]],
                               [m["omega"] for m in bent["modes"]], rtol=1e-9)
    assert auto["static"]["newton_iterations"] <= 0.6 * bent["static"]["newton_iterations"]
    assert bent["static"]["newton_iterations"] <= 75
