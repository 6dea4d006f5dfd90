"""The turbulent wind field along a cable (cablefem.turbulence, [fluid.turbulence]): the
spectra's variance, the generated field's one-point spectrum, variance and two-point
coherence against their targets within the estimators' statistical error, seeds, the
stations' interpolation, the keys' validation, and the drag a stiff cable feels from it
(serially and under mpirun -n 2)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from cablefem.case import CaseError, parse_case, startup_time
from cablefem.turbulence import (
    Turbulence,
    TurbulentField,
    davenport,
    select_stations,
    spectrum,
)

comm = MPI.COMM_WORLD
U, SIGMA, LU, C = 20.0, 3.0, 100.0, 10.0


def line(n, length, axis=1):
    pts = np.zeros((n, 3))
    pts[:, axis] = np.linspace(0.0, length, n)
    return pts


def periodogram(u, duration):
    """The one-sided estimate A_k^2/(2 df) of each FFT frequency k >= 1 of a series that
    is periodic over ``duration`` (exact frequencies: no leakage)."""
    X = np.fft.rfft(u, axis=0)
    amp2 = 4.0 * np.abs(X) ** 2 / u.shape[0] ** 2
    return amp2[1:] * duration / 2.0, X[1:]


@pytest.mark.parametrize("kind", ["kaimal", "von_karman"])
def test_spectra_integrate_to_the_variance(kind):
    """Both spectra integrate to sigma^2 (quad over 0 < f < inf: 1e-8)."""
    from scipy.integrate import quad

    var = quad(lambda f: spectrum(kind, f, SIGMA, U, LU), 0.0, np.inf, limit=500)[0]
    assert var == pytest.approx(SIGMA**2, rel=1e-8)


def test_variance_is_the_band_of_the_spectrum():
    """A Cholesky factor's first row is (1, 0, ...): the first station's amplitudes are
    exactly sqrt(2 S df), its variance over the period the sum S(f_k) df to round-off; that
    sum is Kaimal's closed form sigma^2 [(1 + 6 a L/U)^(-2/3) - (1 + 6 b L/U)^(-2/3)] over
    the band a = df/2 .. b = f_max + df/2 (midpoint rule: 1e-3 here), i.e. (I U)^2 less the
    tails, which the closed form gives (10 % above f_max = 1 Hz)."""
    spec = Turbulence("kaimal", SIGMA / U, LU, C, 3, 0.0, 1.0, 600.0)
    field = TurbulentField(spec, line(5, 40.0), U)
    df = 1.0 / spec.duration
    f = df * np.arange(1, 601)
    band = np.sum(spectrum("kaimal", f, SIGMA, U, LU)) * df
    assert np.var(field.u[:, 0]) == pytest.approx(band, rel=1e-12)

    def above(x):
        return (1.0 + 6.0 * x * LU / U) ** (-2.0 / 3.0)

    assert band == pytest.approx(SIGMA**2 * (above(df / 2) - above(1.0 + df / 2)), rel=1e-3)
    assert SIGMA**2 * above(1.0) == pytest.approx(0.10 * SIGMA**2, rel=0.02)


@pytest.mark.parametrize("kind", ["kaimal", "von_karman"])
def test_one_point_spectrum_of_every_station(kind):
    """The periodogram of a station other than the first, averaged over K = 40 adjacent
    frequencies and 8 seeds, is the target S averaged over the same frequencies. Each
    periodogram ordinate is |sum_m H_jm e^{i phi_m}|^2 2 S df: mean 2 S df, a spread at
    most the chi-squared's with 2 degrees of freedom (relative std 1), so the average of
    n = 320 has relative std at most 1/sqrt(n) = 0.056: 4 std allowed."""
    seeds, K = 8, 40
    est, target = 0.0, None
    for seed in range(seeds):
        spec = Turbulence(kind, SIGMA / U, LU, C, seed, 0.0, 1.0, 600.0)
        field = TurbulentField(spec, line(4, 30.0), U)
        P, _ = periodogram(field.u, spec.duration)
        est = est + P[:600, 2] / seeds
    f = np.arange(1, 601) / 600.0
    target = spectrum(kind, f, SIGMA, U, LU)
    ratio = est.reshape(-1, K).mean(axis=1) / target.reshape(-1, K).mean(axis=1)
    assert np.all(np.abs(ratio - 1.0) < 4.0 / math.sqrt(K * seeds)), ratio


def test_coherence_of_two_stations_is_davenports():
    """The co-coherence Re sum X_0 X_1* / sqrt(sum |X_0|^2 sum |X_1|^2) of two stations
    10 m apart over bands of K = 30 frequencies and 6 seeds is exp(-C f D/U) (weighted by
    S over the band, as the estimator weights it). The first station's amplitudes are
    fixed, the second's X_1 = a (g e^{i phi_0} + sqrt(1 - g^2) e^{i phi_1}): each term's
    real part has mean g and std sqrt((1 - g^2)/2), so the estimate over n = 180 terms
    has std about sqrt((1 - g^2)/(2 n)): 4 std + 0.01 (the normalisation's own spread)."""
    dist, seeds, K = 10.0, 6, 30
    pts = line(2, dist)
    cross = p0 = p1 = 0.0
    for seed in range(seeds):
        spec = Turbulence("kaimal", SIGMA / U, LU, C, seed, 0.0, 0.5, 600.0)
        field = TurbulentField(spec, pts, U)
        _, X = periodogram(field.u, spec.duration)
        X = X[:300]
        cross = cross + np.real(X[:, 0] * np.conj(X[:, 1]))
        p0, p1 = p0 + np.abs(X[:, 0]) ** 2, p1 + np.abs(X[:, 1]) ** 2
    f = np.arange(1, 301) / 600.0
    S = spectrum("kaimal", f, SIGMA, U, LU)
    g = davenport(f, dist, U, C)

    def band(x):
        return x.reshape(-1, K).sum(axis=1)

    coh = band(cross) / np.sqrt(band(p0) * band(p1))
    expected = band(S * g) / band(S)
    tol = 4.0 * np.sqrt((1.0 - expected**2) / (2.0 * K * seeds)) + 0.01
    assert np.all(np.abs(coh - expected) < tol), (coh, expected)
    assert expected[0] > 0.5 > expected[-1]  # the bands span the decay


def test_seeds_stations_and_ranks():
    """The same seed gives the same field whatever the order of the points and on every
    rank; another seed an independent one: the first station's series of two seeds have
    fixed amplitudes a_k and independent phases, their correlation sum a_k^2 cos(d_k) /
    sum a_k^2 has mean 0 and std sqrt(sum a_k^4/2)/sum a_k^2: 4 std allowed."""
    spec = Turbulence("von_karman", 0.1, 50.0, C, 7, 0.0, 1.0, 300.0)
    pts = line(11, 50.0)
    a = TurbulentField(spec, pts, U)
    b = TurbulentField(spec, pts[::-1].copy(), U)
    np.testing.assert_array_equal(a.u, b.u)
    digest = float(np.sum(a.u * np.arange(a.u.size).reshape(a.u.shape)))
    assert comm.allgather(digest) == [digest] * comm.size
    other = TurbulentField(Turbulence("von_karman", 0.1, 50.0, C, 8, 0.0, 1.0, 300.0),
                           pts, U)
    corr = np.corrcoef(a.u[:, 0], other.u[:, 0])[0, 1]
    f = np.arange(1, 301) / 300.0
    a2 = spectrum("von_karman", f, 0.1 * U, U, 50.0)
    assert abs(corr) < 4.0 * math.sqrt(np.sum(a2**2) / 2) / np.sum(a2)
    assert abs(corr) > 0.0


def test_stations_and_interpolation():
    """Stations at least `spacing` apart among the points; a point between two stations
    gets the linear interpolation of their values (weights exact for a linear field);
    the time interpolation is exact at the grid's times and periodic; more than
    MAX_STATIONS stations are refused naming the spacing."""
    pts = line(41, 20.0)
    st = select_stations(pts, 2.0)
    d = np.linalg.norm(st[:, None] - st[None], axis=2) + 1e9 * np.eye(len(st))
    assert d.min() >= 2.0 and len(st) == 11
    field = TurbulentField(Turbulence("kaimal", 0.1, 50.0, C, 1, 2.0, 0.5, 100.0), pts, U)
    idx, w = field.weights(pts)
    y = np.sum(w * field.stations[idx, 1], axis=1)
    np.testing.assert_allclose(y, pts[:, 1], atol=1e-12)
    u, du = field.at_stations(field.times[5])
    np.testing.assert_array_equal(u, field.u[5])
    u2, _ = field.at_stations(field.times[5] + 100.0)
    np.testing.assert_allclose(u2, u, atol=1e-12)
    with pytest.raises(CaseError, match="fluid.turbulence.spacing"):  # before generating
        TurbulentField(Turbulence("kaimal", 0.1, 50.0), line(1001, 100.0), U)
    ramp = field.spec.ramp_time(U)  # 3 L/U = 7.5 s: built up from rest
    assert ramp == 7.5 and not np.any(field.at(0.0)[0])
    np.testing.assert_array_equal(field.at(ramp + 0.3)[0][:, 0],
                                  field.at_stations(ramp + 0.3)[0])
    assert not np.any(field.at(ramp + 0.3)[0][:, 1:])  # no transverse components asked


def test_transverse_components():
    """Lateral and vertical components (IEC 61400-1's Kaimal ratios: sigma_v = 0.8,
    sigma_w = 0.5 sigma_u, L_v = L/3, L_w = 0.0815 L): each one's first station has the
    variance sum S_c(f_k) df of its own spectrum to round-off (fixed amplitudes, as for u);
    their phases are independent of u's (the longitudinal series is the same with or
    without them) and of each other's; the frame is (along the wind, horizontal across it, up) for a
    horizontal wind, and a wind along gravity is refused when they are asked for."""
    from cablefem.turbulence import wind_frame

    base = dict(spectrum="kaimal", intensity=0.15, length_scale=LU, seed=2, f_max=1.0)
    spec = Turbulence(**base, lateral_intensity=0.12, vertical_intensity=0.075)
    field = TurbulentField(spec, line(4, 30.0), U)
    f = np.arange(1, 601) / 600.0
    for c, (sigma, length) in enumerate([(0.15, LU), (0.12, LU / 3), (0.075, 0.0815 * LU)]):
        band = np.sum(spectrum("kaimal", f, sigma * U, U, spec.component(c)[1])) / 600.0
        assert np.var(field.series[c][0][:, 0]) == pytest.approx(band, rel=1e-12)
        assert spec.component(c)[1] == pytest.approx(length, rel=2e-3)
    plain = TurbulentField(Turbulence(**base), line(4, 30.0), U)
    np.testing.assert_array_equal(plain.u, field.u)
    # independent phases: the first stations' series have fixed amplitudes a_k, b_k, their
    # correlation sum a_k b_k cos(d_k)/sqrt(sum a^2 sum b^2) has mean 0 and std
    # sqrt(sum a^2 b^2/2)/sqrt(sum a^2 sum b^2): 4 std allowed
    a2, b2 = (spectrum("kaimal", f, spec.component(c)[0] * U, U, spec.component(c)[1])
              for c in (1, 2))
    corr = np.corrcoef(field.series[1][0][:, 0], field.series[2][0][:, 0])[0, 1]
    assert abs(corr) < 4.0 * math.sqrt(np.sum(a2 * b2) / 2 / (np.sum(a2) * np.sum(b2)))
    frame = wind_frame([3.0, 4.0, 0.0], [0.0, 0.0, 1.0])
    np.testing.assert_allclose(frame, [[0.6, 0.8, 0], [-0.8, 0.6, 0], [0, 0, 1]], atol=1e-15)
    with pytest.raises(CaseError, match="fluid.current"):
        wind_frame([0.0, 0.0, 2.0], [0.0, 0.0, 1.0], spec)
    with pytest.raises(CaseError, match="fluid.turbulence.lateral_intensity"):
        parse_case(level_cable({"spectrum": "von_karman", "intensity": 0.1,
                                "length_scale": 50.0, "lateral_intensity": 0.08}))


def level_cable(turbulence, current=(1.0, 0.0, 0.0), dynamics=None):
    """A taut stiff light cable of 10 m along y in water, pinned at both ends:
    T = 1e6 N, m = 1 kg/m (first mode 50 Hz, far above the field's 2 Hz)."""
    T, EA, L = 1.0e6, 1.0e10, 10.0
    d = {"title": "level", "section": {"EA": EA, "EI": 1e-6, "mass": 1.0},
         "gravity": {"g": 0.0}, "geometry": {"length": L / (1 + T / EA)},
         "mesh": {"elements": 20},
         "anchors": [{"name": "p", "position": [0.0, 0, 0], "type": "pinned"},
                     {"name": "q", "position": [0.0, L, 0], "type": "pinned"}],
         "solver": {"outer_correction": "none"},
         "fluid": {"density": 1025.0, "diameter": 0.1, "current": list(current),
                   "cd_tangential": 0.0, "turbulence": turbulence}}
    if dynamics:
        d["dynamics"] = dynamics
    return d


@pytest.mark.parametrize("key, value, where", [
    ("spectrum", "kolmogorov", "fluid.turbulence.spectrum"),
    ("intensity", 0.0, "fluid.turbulence.intensity"),
    ("seed", -1, "fluid.turbulence.seed"),
    ("spacing", -1.0, "fluid.turbulence.spacing"),
    ("sead", 3, "fluid.turbulence.sead"),
    ("f_max", 1000.0, "fluid.turbulence.f_max"),
])
def test_bad_keys_are_refused(key, value, where):
    turb = {"intensity": 0.1, "length_scale": 50.0, key: value}
    with pytest.raises(CaseError) as err:
        parse_case(level_cable(turb))
    assert where in str(err.value), str(err.value)


def test_turbulence_needs_a_mean_wind_and_a_long_enough_period():
    turb = {"intensity": 0.1, "length_scale": 50.0}
    with pytest.raises(CaseError, match="fluid.current"):
        parse_case(level_cable(turb, current=(0.0, 0.0, 0.0)))
    with pytest.raises(CaseError, match="fluid.turbulence.duration"):
        parse_case(level_cable({**turb, "duration": 100.0},
                               dynamics={"t_end": 200.0, "dt": 0.1}))
    case = parse_case(level_cable(turb, dynamics={"t_end": 10.0, "dt": 0.1}))
    assert [k for k, _ in case.warnings] == ["fluid.turbulence.f_max"]  # 5 steps a period
    case = parse_case(level_cable(turb))
    assert case.fluid.turbulence == Turbulence("kaimal", 0.1, 50.0, 10.0, 1, 0.0, 2.0, 600.0, None,
                                                 0.0, 0.0, None, None)
    assert case.fluid.turbulence.ramp_time(1.0) == 150.0
    assert startup_time(case)[0] == 150.0  # the statistics start after the build-up


@pytest.mark.parametrize("vertical", [0.0, 0.1])
def test_stiff_cable_feels_the_quasi_static_drag(vertical):
    """A stiff light cable (first mode 50 Hz) along y in a turbulent current U = 1 m/s
    along x, I = 0.2, L = 20 m, f_max = 2 Hz, and a vertical component (sigma_w = 0.1 U)
    or none: the anchors carry the drag 1/2 rho Cd D int |v| v dx, v = (U + u', 0, w'),
    of the field linear between the nodes (4-point Gauss on each element: exact without
    w', 1e-6 with it) plus the fluid inertia (1 + Ca) rho A int dv/dt dx, the field
    computed here from the same stations. Quasi-static: the cable's own velocity (its
    deflection ~1e-4 m moving at 2 Hz, 1e-3 of U), its inertia ((2/50)^2) and the linear
    time interpolation of the field at the integrator's intermediate times change the
    force: measured 0.7e-2 of its fluctuation along x over the run in x, 1.2e-2 in z (the
    vertical length scale, 1.6 m, puts more of w' near f_max, where the linear time
    interpolation errs most); the field is built up over 0.5 s from the static state,
    which carries the steady drag 1/2 rho Cd D L U^2 only; 2e-2 allowed."""
    from cablefem.cable import CableModel
    from cablefem.dynamics import integrate
    from cablefem.statics import solve_static

    spec = {"intensity": 0.2, "length_scale": 20.0, "f_max": 2.0, "seed": 4, "ramp": 0.5,
            "vertical_intensity": vertical}
    model = CableModel(comm, parse_case(level_cable(spec)))
    st = solve_static(model)
    steady = np.sum(st.anchor_forces, axis=0)
    X = np.concatenate(comm.allgather(model.V.tabulate_dof_coordinates()))
    field = TurbulentField(parse_case(level_cable(spec)).fluid.turbulence, X, 1.0)
    y = field.stations[:, 1]
    assert np.all(np.diff(y) > 0)
    h = np.diff(y) * 10.0 / (y[-1] - y[0])  # current lengths of the elements
    rho, D = 1025.0, 0.1
    xg, wg = np.polynomial.legendre.leggauss(4)
    s_g, w_g = (xg + 1) / 2, wg / 2
    times, measured, expected = [], [], []
    for t, forces in integrate(model, 3.0, 0.01, 0.9, 2):
        times.append(t)
        measured.append(np.sum(forces, axis=0)[[0, 2]])
        v, dv = field.at(t)
        v = v[:, [0, 2]] + [1.0, 0.0]  # (U + u', w') at the nodes
        at_g = v[:-1, None, :] + s_g[None, :, None] * (v[1:] - v[:-1])[:, None, :]
        speed = np.linalg.norm(at_g, axis=2, keepdims=True)
        drag = 0.5 * rho * 1.2 * D * np.einsum("g,egc,e->c", w_g, speed * at_g, h)
        inertia = 2.0 * rho * np.pi * D**2 / 4 * np.sum(
            (dv[:-1, [0, 2]] + dv[1:, [0, 2]]) / 2 * h[:, None], axis=0)
        expected.append(drag + inertia)
    times, measured, expected = map(np.array, (times, measured, expected))
    swing = np.max(np.abs(expected[:, 0] - steady[0]))
    err = np.max(np.abs(measured - expected), axis=0)
    assert np.all(err < 2e-2 * swing), (err, swing)
    if vertical:
        assert np.max(np.abs(expected[:, 1])) > 0.1 * swing  # the vertical drag is there
    assert steady[0] == pytest.approx(0.5 * rho * 1.2 * D * 10.0, rel=1e-3)


def test_a_network_takes_the_field_at_its_nodes_in_3d(mpi_tmp_path):
    """A mooring line meshed as an L-shaped network in a current (tests/test_network_water):
    its stations are its 41 mesh points in 3D (spacing 0), every rank's the same, and the
    field changes the anchor forces over 1 s against the same run without it (by more
    than 1e-4 of the largest: zero if the network ignored the field; sigma = 0.1 m/s on a
    0.5 m/s current changes the drag on the line by tens of percent locally)."""
    from test_network_water import mooring_network

    from cablefem.dynamics import integrate
    from cablefem.network import NetworkModel
    from cablefem.statics import solve_static

    runs = []
    for turb in (None, {"intensity": 0.2, "length_scale": 50.0, "seed": 5, "ramp": 0.2}):
        d = mooring_network(mpi_tmp_path)
        d["fluid"] = {**d["fluid"], "waves": []}
        if turb:
            d["fluid"]["turbulence"] = turb
        model = NetworkModel(comm, parse_case(d))
        solve_static(model)
        runs.append(np.array([f[:, :3] for _, f in integrate(model, 1.0, 0.05)]))
    X = np.concatenate(comm.allgather(model.V.tabulate_dof_coordinates()))
    stations = select_stations(X, 0.0)
    assert stations.shape == (41, 3) and np.ptp(stations[:, 2]) > 75.0
    assert comm.allgather(float(stations.sum())) == [float(stations.sum())] * comm.size
    diff = np.max(np.abs(runs[1] - runs[0]))
    assert diff > 1e-4 * np.max(np.abs(runs[0])), diff
