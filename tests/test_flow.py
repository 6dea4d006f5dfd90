"""The fluid's own motion (cablefem.flow, cablefem.fluid): a current that varies with
elevation, Airy waves, a uniform velocity history and the fluid inertia; checked against
the linear wave theory's own equations and closed forms of strings (serially and under
mpirun -n 2)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from cablefem.cable import CableModel
from cablefem.case import CaseError, parse_case, startup_time
from cablefem.dynamics import integrate
from cablefem.flow import (
    POWER_FLOOR,
    AiryWave,
    Profile,
    WaveField,
    jonswap,
    jonswap_waves,
    wave_kinematics,
    wave_number,
)
from cablefem.modal import solve_modes
from cablefem.motion import ramp_factors
from cablefem.statics import solve_static

comm = MPI.COMM_WORLD
G = 9.81
RHO, D = 1025.0, 0.1
A = np.pi * D**2 / 4
UP = np.array([0.0, 0.0, 1.0])
WAVE = AiryWave(1.0, 6.0, np.array([1.0, 0.0, 0.0]), 0.3)


# ------------------------------------------------------------------ linear wave theory
@pytest.mark.parametrize("depth", [None, 5.0, 30.0])
def test_wave_number_solves_the_dispersion_relation(depth):
    """omega^2 = g k tanh(k h) (deep water: k = omega^2/g) to round-off."""
    w = WAVE.omega
    k = wave_number(w, G, depth)
    assert G * k * (1.0 if depth is None else math.tanh(k * depth)) == pytest.approx(
        w**2, rel=1e-12)


@pytest.mark.parametrize("depth", [None, 5.0, 30.0])
def test_airy_kinematics_satisfy_the_field_equations(depth):
    """The velocity is divergence-free, the surface moves with it (u_z = d eta/dt at the
    mean surface), the seabed does not (u_z = 0 at -h), and the acceleration is the
    velocity's time derivative, ramp included. Central differences of step 1e-4 relative
    to the wave: truncation about 1e-8 of the amplitude; 1e-6 allowed."""
    h = 1e-4 * 2 * np.pi / wave_number(WAVE.omega, G, depth)
    ht = 1e-4 * WAVE.period
    ramp = 2.0 * WAVE.period
    pts = np.array([[3.0, 1.0, -0.5], [7.0, -2.0, -2.0], [-4.0, 0.0, -4.5]])

    def vel(p, t, ramp=0.0):
        return wave_kinematics([WAVE], p, t, UP, 0.0, depth, G, ramp)

    scale = 0.5 * WAVE.height * WAVE.omega
    ex, ez = np.array([h, 0, 0]), np.array([0, 0, h])
    div = ((vel(pts + ex, 1.0)[0][:, 0] - vel(pts - ex, 1.0)[0][:, 0])
           + (vel(pts + ez, 1.0)[0][:, 2] - vel(pts - ez, 1.0)[0][:, 2])) / (2 * h)
    assert np.max(np.abs(div)) < 1e-6 * scale * wave_number(WAVE.omega, G, depth)
    k = wave_number(WAVE.omega, G, depth)
    for t in (0.7, 2.1):
        surface = pts * [1, 1, 0]
        eta_dot = (0.5 * WAVE.height * WAVE.omega
                   * np.sin(k * surface[:, 0] - WAVE.omega * t + WAVE.phase))
        assert np.allclose(vel(surface, t)[0][:, 2], eta_dot, rtol=0, atol=1e-12 * scale)
        if depth is not None:
            bottom = surface - [0, 0, depth]
            assert np.allclose(vel(bottom, t)[0][:, 2], 0.0, atol=1e-12 * scale)
        for tt in (t, 0.3 * ramp):  # inside the ramp too
            fd = (vel(pts, tt + ht, ramp)[0] - vel(pts, tt - ht, ramp)[0]) / (2 * ht)
            assert np.allclose(vel(pts, tt, ramp)[1], fd, rtol=0,
                               atol=1e-6 * scale * WAVE.omega)


@pytest.mark.parametrize("gamma,tol", [(1.0, 1e-6), (2.0, 2e-2), (3.3, 2e-2), (7.0, 2e-2)])
def test_jonswap_spectrum_has_the_significant_height(gamma, tol):
    """The JONSWAP spectrum's variance is Hs^2/16: exactly for gamma = 1 (the
    Pierson-Moskowitz integral; quadrature 1e-6), to DNV's normalisation 1 - 0.287 ln gamma
    elsewhere (measured -0.2 %, +0.2 %, -1.8 % at gamma = 2, 3.3, 7; 2 % allowed); its peak
    is at 2 pi/Tp."""
    from scipy.integrate import quad

    hs, tp = 4.0, 10.0
    wp = 2 * np.pi / tp
    m0 = quad(lambda w: jonswap(w, hs, tp, gamma), 1e-3, 50.0, points=[wp], limit=500)[0]
    assert m0 == pytest.approx(hs**2 / 16, rel=tol)
    w = np.linspace(0.5 * wp, 2 * wp, 3001)
    assert w[np.argmax(jonswap(w, hs, tp, gamma))] == pytest.approx(wp, abs=w[1] - w[0])


def test_spectrum_as_airy_components(tmp_path):
    """[fluid.spectrum] expands into `components` Airy waves along its direction whose
    variance sum((H/2)^2/2) is the spectrum's over the band [low, high] wp (one component
    a bin, at a random frequency in it: measured +0.6 % at gamma = 3.3, 60 components;
    1.5 % allowed), inside the band; the same seed gives the same sea (on every rank) and
    another seed another one (other phases)."""
    from scipy.integrate import quad

    spec = {"hs": 4.0, "tp": 10.0, "direction": [0.0, 1.0, 0.0]}
    case = parse_case(level_cable({"surface": 0.0, "spectrum": spec}, gravity={"g": G}),
                      base_dir=tmp_path)
    waves = case.fluid.waves
    wp = 2 * np.pi / 10.0
    band = quad(lambda w: jonswap(w, 4.0, 10.0, 3.3), 0.5 * wp, 3 * wp, limit=500)[0]
    assert len(waves) == 60
    assert sum((w.height / 2) ** 2 / 2 for w in waves) == pytest.approx(band, rel=1.5e-2)
    assert all(0.5 * wp <= w.omega <= 3 * wp for w in waves)
    np.testing.assert_array_equal(waves[0].direction, [0.0, 1.0, 0.0])
    again = jonswap_waves(4.0, 10.0, [0.0, 1.0, 0.0])
    assert [(w.height, w.period, w.phase) for w in again] == \
        [(w.height, w.period, w.phase) for w in waves]
    assert comm.allgather(waves[7].phase) == [waves[7].phase] * comm.size
    other = jonswap_waves(4.0, 10.0, [0.0, 1.0, 0.0], seed=2)
    assert other[0].phase != waves[0].phase


def test_deep_water_is_the_limit_of_finite_depth():
    """Finite-depth formulas at h = 2000 m (k h = 220) equal the deep-water ones: their
    difference is exp(-2 k h), far below round-off."""
    pts = np.array([[1.0, 0.0, -3.0], [0.0, 2.0, -40.0]])
    deep = wave_kinematics([WAVE], pts, 1.3, UP, 0.0, None, G)
    finite = wave_kinematics([WAVE], pts, 1.3, UP, 0.0, 2000.0, G)
    for a, b in zip(deep, finite):
        assert np.allclose(a, b, rtol=1e-12, atol=1e-15)


def test_the_wave_field_at_the_same_points_again_is_a_fresh_fields():
    """WaveField keeps what depends on the points alone for the next call at the same
    points: at other times, and after the points changed in place (the same array, other
    values: the kept part is found by the values), every value is the one a fresh field
    gives, to the last bit."""
    waves = [AiryWave(0.5, 4.0, np.array([0.6, 0.8, 0.0]), 1.1), WAVE]
    rng = np.random.default_rng(5)
    pts = rng.uniform([-50.0, -20.0, -40.0], [50.0, 20.0, 0.0], (32, 3))
    field = WaveField(waves, UP, 0.0, 30.0, G, ramp=5.0)
    for t in (2.0, 2.5, 11.0):
        fresh = WaveField(waves, UP, 0.0, 30.0, G, ramp=5.0).at(pts, t)
        for a, b in zip(field.at(pts, t), fresh):
            assert a.tobytes() == b.tobytes()
        pts[:, 2] -= 0.25  # moved in place
        fresh = WaveField(waves, UP, 0.0, 30.0, G, ramp=5.0).at(pts, t + 0.1)
        for a, b in zip(field.at(pts, t + 0.1), fresh):
            assert a.tobytes() == b.tobytes()


@pytest.mark.parametrize("depth", [None, 30.0, 2000.0])
def test_the_wave_field_sums_its_components_at_once(depth):
    """WaveField (every component at once, its wave numbers found once) against the Airy
    formulas written out component by component with cosh and sinh, a JONSWAP sea of 60
    components and two crossing waves, at points below the seabed, in the water and above
    the surface (held at the surface), during and after the build-up: to round-off (1e-12
    of the largest value; cosh/sinh of k h <= 700 and the field's exponentials agree to a
    few units of the last place)."""
    waves = jonswap_waves(3.0, 8.0, [1.0, 0.0, 0.0]) + [
        AiryWave(0.5, 4.0, np.array([0.6, 0.8, 0.0]), 1.1), WAVE]
    rng = np.random.default_rng(3)
    pts = rng.uniform([-50.0, -20.0, -40.0], [50.0, 20.0, 2.0], (64, 3))
    field = WaveField(waves, UP, 0.0, depth, G, ramp=5.0)
    h = 1e300 if depth is None else depth
    for t in (2.0, 11.0):
        r, dr, _ = ramp_factors(t, 5.0)
        vel, acc = np.zeros_like(pts), np.zeros_like(pts)
        zeta = np.minimum(pts[:, 2], 0.0)
        for w in waves:
            k = wave_number(w.omega, G, depth)
            zc = np.maximum(zeta, -h)
            if depth is None or k * h > 700:
                ch = sh = np.exp(k * zeta)
            else:
                ch, sh = np.cosh(k * (zc + h)) / np.sinh(k * h), np.sinh(k * (zc + h)) / \
                    np.sinh(k * h)
            th = k * (pts @ w.direction) - w.omega * t + w.phase
            a = 0.5 * w.height * w.omega
            u = a * ((ch * np.cos(th))[:, None] * w.direction
                     + (sh * np.sin(th))[:, None] * UP)
            du = a * w.omega * ((ch * np.sin(th))[:, None] * w.direction
                                - (sh * np.cos(th))[:, None] * UP)
            vel += r * u
            acc += r * du + dr * u
        got = field.at(pts, t)
        for mine, ref in zip(got, (vel, acc)):
            np.testing.assert_allclose(mine, ref, rtol=0, atol=1e-12 * np.max(np.abs(ref)))
        for mine, ref in zip(got, wave_kinematics(waves, pts, t, UP, 0.0, depth, G, 5.0)):
            np.testing.assert_array_equal(mine, ref)


def test_profiles():
    """A table is piecewise linear and held beyond its ends; the power law is 1 at the
    reference height and held below POWER_FLOOR of it."""
    tab = Profile("table", elevations=[-10.0, -2.0, 0.0], factors=[0.2, 0.8, 1.0])
    assert np.allclose(tab([-20.0, -10.0, -6.0, -1.0, 5.0]), [0.2, 0.2, 0.5, 0.9, 1.0])
    power = Profile("power", reference=10.0, exponent=0.16, ground=2.0)
    assert np.allclose(power([12.0, 42.0, 2.0]),
                       [1.0, 4.0**0.16, POWER_FLOOR**0.16])


# ------------------------------------------------------------------ cables in the flow
def vertical_riser(profile: dict) -> dict:
    """A weightless taut cable from (0, 0, -L) up to the origin in a current along x."""
    T, L, EA = 1.0e4, 10.0, 1.0e9
    return {"title": "riser", "section": {"EA": EA, "EI": 1e-6, "mass": 50.0},
            "gravity": {"g": 0.0}, "geometry": {"length": L / (1 + T / EA)},
            "mesh": {"elements": 40},
            "anchors": [{"name": "p", "position": [0.0, 0, -L], "type": "pinned"},
                        {"name": "q", "position": [0.0, 0, 0.0], "type": "pinned"}],
            "solver": {"outer_correction": "none"},
            "fluid": {"density": RHO, "diameter": D, "current": [1.0, 0, 0],
                      "cd_tangential": 0.0, "profile": profile}}


@pytest.mark.parametrize("profile", [
    {"type": "table", "elevation": [-10.0, 0.0], "factor": [0.0, 1.0]},
    {"type": "power", "reference": 10.0, "exponent": 1.0, "ground": -10.0}])
def test_string_in_a_linearly_sheared_current(profile):
    """U = U0 s/L (s above the bottom anchor) loads the taut string with
    q = c s^2/L^2, c = rho C_dn D U0^2/2; T w'' = -q gives
    w = c (L^3 s - s^4)/(12 T L^2). The table and the power law of exponent 1 are the same
    profile. P1 nodal values of a 1D string are exact up to the load's quadrature and the
    slope's second-order effects (slope 0.01: 1e-4), and the power law's floor below
    0.1 m changes the load by 1e-4 c there: 2e-3 of the largest deflection allowed."""
    model = CableModel(comm, parse_case(vertical_riser(profile)))
    st = solve_static(model)
    nodal = model.gather_nodal(model.u)
    if comm.rank == 0:
        L = 10.0
        T = float(np.linalg.norm(st.anchor_forces[1]))
        c = 0.5 * RHO * 1.2 * D
        s = model.geometry.points[:, 2] + L
        exact = c * (L**3 * s - s**4) / (12 * T * L**2)
        assert np.max(exact) > 0.01
        np.testing.assert_allclose(nodal[:, 0], exact, rtol=0, atol=2e-3 * np.max(exact))


def level_cable(fluid: dict, T: float = 1.0e4, EA: float = 1.0e8, m: float = 50.0,
                elements: int = 20, z: float = 0.0, **extra) -> dict:
    """A weightless taut cable of 10 m along y at elevation z, pinned at both ends."""
    L = 10.0
    d = {"title": "level", "section": {"EA": EA, "EI": 1e-6, "mass": m},
         "gravity": {"g": 0.0}, "geometry": {"length": L / (1 + T / EA)},
         "mesh": {"elements": elements},
         "anchors": [{"name": "p", "position": [0.0, 0, z], "type": "pinned"},
                     {"name": "q", "position": [0.0, L, z], "type": "pinned"}],
         "solver": {"outer_correction": "none"},
         "fluid": {"density": RHO, "diameter": D, **fluid}}
    d.update(extra)
    return d


def test_no_drag_above_the_surface():
    """A cable above the free surface is in air: the water's current does not touch it
    (before this was fixed, the drag acted on the whole cable whatever the surface)."""
    model = CableModel(comm, parse_case(level_cable({"current": [1.0, 0, 0],
                                                     "surface": -1.0})))
    solve_static(model)
    across = model.u.x.array.reshape(-1, 3)[:, 0]  # along the current
    assert comm.allreduce(float(np.max(np.abs(across), initial=0.0)), op=MPI.MAX) < 1e-12


def test_a_neutrally_buoyant_cable_moves_with_a_uniform_flow(tmp_path):
    """A cable as dense as the water, whose anchors move with a uniform oscillating flow
    (the velocity history A w cos(w t)), translates with it: relative velocity zero (no
    drag), and the fluid inertia (1 + C_a) rho A a_f is exactly its mass and added mass
    times the flow's acceleration. Without the inertia term the span would lag by about
    8 % of the amplitude (q L^2/(8 T) with q = (m + m_a) A w^2). The history is a spline
    through 200 rows a period (its acceleration within 1e-4); 1e-3 of the amplitude
    allowed."""
    amp, w, T, EA = 0.01, 2.0, 1.0e4, 1.0e8
    t = np.linspace(0.0, 4.0, 401)
    rows = "\n".join(f"{ti!r},{amp * w * np.cos(w * ti)!r},0,0" for ti in t)
    csv = tmp_path / "flow.csv"  # every rank reads its own folder
    csv.write_text("time,vx,vy,vz\n" + rows + "\n")
    motion = {"type": "harmonic", "amplitude": [amp, 0, 0], "omega": w, "ramp": 0.0}
    d = level_cable({"velocity": {"file": csv.name}}, T=T, EA=EA,
                    m=RHO * A * (1 + T / EA), elements=20)
    for anchor in d["anchors"]:
        anchor["motion"] = motion
    d["dynamics"] = {"t_end": 3.0, "dt": 0.01}
    model = CableModel(comm, parse_case(d, base_dir=tmp_path))
    solve_static(model)
    worst = 0.0
    for ti, _ in integrate(model, 3.0, 0.01, 1.0, 10):
        nodal = model.gather_nodal(model.u)
        if comm.rank == 0:
            worst = max(worst, float(np.max(np.abs(nodal[:, 0] - amp * np.sin(w * ti)))))
    if comm.rank == 0:
        assert worst < 1e-3 * amp, worst


def test_waves_on_a_held_cable_give_the_morison_force():
    """A very taut cable along y, 5 m below the surface at x = 7 m, in a wave along x on
    30 m of water: it barely moves (sag 2e-4 m), so the anchors carry the Morison force of
    the undisturbed wave, L (rho C_d D |u_n| u_n/2 + (1 + C_a) rho A a_n), u_n the (x, z)
    velocity of linear theory written out here. The cable's own motion changes the drag's
    relative velocity by 4e-4 and adds its inertia (1e-3 of the force): 3e-3 of the largest
    force allowed, after the ramp."""
    H, period, depth, x0, z0, L = 1.0, 6.0, 30.0, 7.0, -5.0, 10.0
    d = level_cable({"surface": 0.0, "depth": depth, "cd_tangential": 0.0,
                     "waves": [{"height": H, "period": period, "direction": [1.0, 0, 0]}],
                     "wave_ramp": period}, T=1.0e6, EA=1.0e10, z=z0, gravity={"g": G})
    for anchor in d["anchors"]:
        anchor["position"][0] = x0
    model = CableModel(comm, parse_case(d))
    st = solve_static(model)
    static = np.sum(st.anchor_forces, axis=0)
    w = 2 * np.pi / period
    k = wave_number(w, G, depth)
    times, measured = [], []
    for t, forces in integrate(model, 2 * period, period / 100, 1.0, 5):
        times.append(t)
        measured.append(np.sum(forces, axis=0) - static)
    times, measured = np.array(times), np.array(measured)
    theta = k * x0 - w * times
    ux = 0.5 * H * w * np.cosh(k * (z0 + depth)) / np.sinh(k * depth) * np.cos(theta)
    uz = 0.5 * H * w * np.sinh(k * (z0 + depth)) / np.sinh(k * depth) * np.sin(theta)
    ax = 0.5 * H * w**2 * np.cosh(k * (z0 + depth)) / np.sinh(k * depth) * np.sin(theta)
    az = -0.5 * H * w**2 * np.sinh(k * (z0 + depth)) / np.sinh(k * depth) * np.cos(theta)
    speed = np.hypot(ux, uz)
    expected = L * (0.5 * RHO * 1.2 * D * speed[:, None] * np.stack([ux, 0 * ux, uz], 1)
                    + 2.0 * RHO * A * np.stack([ax, 0 * ax, az], 1))
    after = times >= period
    assert np.sum(after) > 15
    err = np.max(np.abs(measured[after] - expected[after]))
    assert err < 3e-3 * np.max(np.abs(expected)), err


@pytest.mark.single_rank  # 9 s on 2 ranks; the modal problem's parallel path:
# test_modal.py, test_dampers.py
def test_modal_analysis_is_about_the_steady_current():
    """The modes and their damping ratios are those of the cable at rest in the steady
    current, whatever the waves do at the time of the analysis (here waves without a ramp,
    non-zero at t = 0, which the static solve sets): the same as without waves to the
    eigensolver's tolerance."""
    base = {"current": [0.3, 0, 0], "surface": 20.0}
    waves = {**base, "wave_ramp": 0.0,
             "waves": [{"height": 2.0, "period": 5.0, "direction": [1.0, 0, 0]}]}
    out = []
    for fluid in (base, waves):
        model = CableModel(comm, parse_case(level_cable(fluid, gravity={"g": G})))
        solve_static(model)
        out.append(solve_modes(model, 3))
    np.testing.assert_allclose(out[1].omegas, out[0].omegas, rtol=1e-9)
    np.testing.assert_allclose(out[1].damping_ratios, out[0].damping_ratios, rtol=1e-6)


def test_the_wave_ramp_ends_the_start_up():
    d = level_cable({"surface": 0.0, "waves": [{"height": 1.0, "period": 7.0,
                                                "direction": [0.0, 1.0, 0]}]},
                    dynamics={"t_end": 30.0, "dt": 0.05}, gravity={"g": G})
    t, why = startup_time(parse_case(d))
    assert t == pytest.approx(21.0) and "wave_ramp" in why


@pytest.mark.parametrize("fluid,key", [
    ({"waves": [{"height": 1.0, "period": 5.0, "direction": [1.0, 0, 0]}]}, "fluid.waves"),
    ({"surface": 0.0, "waves": [{"height": 1.0, "period": 5.0, "direction": [1.0, 0, 1]}]},
     "fluid.waves[0].direction"),
    ({"surface": 0.0, "waves": [{"height": -1.0, "period": 5.0, "direction": [1.0, 0, 0]}]},
     "fluid.waves[0].height"),
    ({"surface": 0.0, "waves": [{"height": 1.0, "direction": [1.0, 0, 0]}]},
     "fluid.waves[0].period"),
    ({"depth": 0.0}, "fluid.depth"),
    ({"wave_ramp": -1.0}, "fluid.wave_ramp"),
    ({"profile": {"elevation": [0.0, 1.0], "factor": [1.0, 1.0]}}, "fluid.profile.type"),
    ({"profile": {"type": "table", "elevation": [0.0, 1.0], "factor": [1.0]}},
     "fluid.profile.factor"),
    ({"profile": {"type": "table", "elevation": [1.0, 0.0], "factor": [1.0, 2.0]}},
     "fluid.profile.elevation"),
    ({"profile": {"type": "power", "reference": 0.0, "exponent": 0.1}},
     "fluid.profile.reference"),
    ({"profile": {"type": "power", "reference": 10.0, "exponent": 0.1,
                  "elevation": [0.0, 1.0]}}, "fluid.profile.elevation"),
    ({"velocity": {"file": "missing.csv"}}, "fluid.velocity.file"),
    ({"velocity": {}}, "fluid.velocity.file"),
    ({"spectrum": {"hs": 2.0, "tp": 8.0, "direction": [1.0, 0, 0]}}, "fluid.spectrum"),
    ({"surface": 0.0, "spectrum": {"hs": 2.0, "tp": 8.0, "direction": [1.0, 0, 0],
                                   "low": 3.0, "high": 2.0}}, "fluid.spectrum.high"),
    ({"surface": 0.0, "spectrum": {"hs": 2.0, "tp": 8.0, "direction": [1.0, 0, 0],
                                   "gamma": 0.5}}, "fluid.spectrum.gamma"),
    ({"surface": 0.0, "spectrum": {"hs": 2.0, "tp": 8.0, "direction": [1.0, 0, 0],
                                   "components": 0}}, "fluid.spectrum.components"),
    ({"surface": 0.0, "spectrum": {"hs": 2.0, "tp": 8.0}}, "fluid.spectrum.direction"),
    ({"surface": 0.0, "spectrum": {"hs": 2.0, "tp": 8.0, "direction": [0, 0, 1.0]}},
     "fluid.spectrum.direction")])
def test_bad_flow_is_rejected_with_its_key(fluid, key, tmp_path):
    with pytest.raises(CaseError) as err:
        parse_case(level_cable(fluid, gravity={"g": G}), base_dir=tmp_path)
    assert key in str(err.value), str(err.value)


def test_a_velocity_history_must_reach_the_end(tmp_path):
    csv = tmp_path / "v.csv"  # every rank reads its own folder
    csv.write_text("time,vx,vy,vz\n0,0,0,0\n1,1,0,0\n")
    d = level_cable({"velocity": {"file": "v.csv"}}, dynamics={"t_end": 2.0, "dt": 0.1})
    with pytest.raises(CaseError, match="fluid.velocity"):
        parse_case(d, base_dir=tmp_path)
    d["fluid"]["velocity"]["hold"] = True
    assert parse_case(d, base_dir=tmp_path).fluid.velocity.hold


def test_python_api_checks_the_waves():
    from cablefem import Anchor, Fluid, Section, create_cable

    anchors = [Anchor("p", [0.0, 0, 0], "pinned"), Anchor("q", [0.0, 10.0, 0], "pinned")]
    sec = Section(EA=1e8, EI=1e-6, GJ=0.0, mass=50.0)
    with pytest.raises(CaseError, match="fluid.waves"):
        create_cable(comm, anchors, sec, length=9.999, fluid=Fluid(RHO, D, waves=(WAVE,)))
    with pytest.raises(CaseError, match="gravity"):
        parse_case(level_cable({"surface": 0.0, "waves": [{"height": 1.0, "period": 5.0,
                                                           "direction": [1.0, 0, 0]}]}))
    tilted = AiryWave(1.0, 6.0, np.array([0.6, 0.0, 0.8]))
    with pytest.raises(CaseError, match=r"fluid.waves\[0\].direction"):
        create_cable(comm, anchors, sec, length=9.999,
                     fluid=Fluid(RHO, D, surface=0.0, waves=(tilted,)))


def test_statics_ramps_the_current_of_a_stiff_cable():
    """A nearly inextensible taut cable (T/EA = 1e-5) across a current: Newton from the
    straight line fails (the deflection's stretch doubles the tension), so statics ramps
    the current's drag as it ramps loads (before: no extra load to ramp, an error). The
    anchors carry the drag q L, q = rho C_dn D U^2/2, up to the cable's slope
    (cos^2 of at most 4 sag/L = 1 %: 1e-4); 1e-3 allowed."""
    d = level_cable({"current": [0.0, 0, 1.0]}, EA=1.0e9, elements=40)
    model = CableModel(comm, parse_case(d))
    st = solve_static(model)
    q = 0.5 * RHO * 1.2 * D
    carried = st.anchor_forces[0][2] + st.anchor_forces[1][2]
    assert carried == pytest.approx(q * 10.0, rel=1e-3)
