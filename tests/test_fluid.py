"""Water and wind ([fluid], cablefem.fluid): added mass, drag in a steady current, a
quadratic-drag free decay, buoyancy, Newton's iterations, bad input (serially and under
mpirun -n 2)."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from cablefem.cable import CableModel
from cablefem.case import CaseError, parse_case
from cablefem.dynamics import DynamicsStats, integrate
from cablefem.modal import solve_modes
from cablefem.statics import solve_static

comm = MPI.COMM_WORLD
T0, M, L, D, RHO = 1.0e4, 50.0, 10.0, 0.1, 1025.0  # N, kg/m, m, m, kg/m^3
A = np.pi * D**2 / 4


def taut(EA: float = 1.0e8, fluid: dict | None = None, elements: int = 60, **extra) -> dict:
    """A taut weightless cable between pinned anchors (tension T0), in water."""
    d = {"title": "taut", "section": {"EA": EA, "EI": 1e-6, "mass": M},
         "gravity": {"g": 0.0}, "geometry": {"length": L / (1 + T0 / EA)},
         "mesh": {"elements": elements},
         "anchors": [{"name": "p", "position": [0.0, 0, 0], "type": "pinned"},
                     {"name": "q", "position": [L, 0, 0], "type": "pinned"}],
         "solver": {"outer_correction": "none"}}
    if fluid is not None:
        d["fluid"] = {"density": RHO, "diameter": D, **fluid}
    d.update(extra)
    return d


def modes(d: dict, n: int = 4):
    model = CableModel(comm, parse_case(d))
    solve_static(model)
    return solve_modes(model, n)


def test_added_mass_scales_the_frequencies():
    """Submerged at the same tension, a taut cable's frequencies scale by
    sqrt(m/(m + C_a rho A)) (the transverse modes: the added mass acts normal to the
    cable); the mass per stress-free length and the added mass per current length differ
    by the stretch T/EA = 1e-4, which bounds the difference: 2e-4 allowed. The drag's
    regularisation damps at small amplitude by a negligible ratio (< 1e-4)."""
    dry, wet = modes(taut()), modes(taut(fluid={}))
    np.testing.assert_allclose(wet.omegas / dry.omegas, np.sqrt(M / (M + RHO * A)),
                               rtol=2e-4)
    assert np.all(wet.damping_ratios < 1e-4)


def test_string_in_a_uniform_normal_flow_is_a_parabola():
    """A current U = 1 m/s across the cable: the load q = rho C_dn D U^2/2 per length
    deflects it as a parabola of sag q L^2/(8 T), T the cable's tension in the flow (it
    stretches); the flow stays normal to first order in the slope (4 sag/L = 2 %, whose
    square bounds the error with the node's position): 5e-4 relative allowed."""
    model = CableModel(comm, parse_case(taut(fluid={"current": [0.0, 0, 1.0]})))
    st = solve_static(model)
    q = 0.5 * RHO * 1.2 * D * 1.0**2
    nodal = model.gather_nodal(model.u)
    if comm.rank == 0:
        H = abs(st.anchor_forces[0][0])
        x = model.geometry.points[:, 0]
        np.testing.assert_allclose(nodal[:, 2], q * x * (L - x) / (2 * H),
                                   rtol=0, atol=5e-4 * q * L**2 / (8 * H))


def release(d: dict, amplitude: float, t_end: float, dt: float, rho_inf: float = 1.0):
    """Release the cable from amplitude * sin(pi x/L) along z; (times, mid-span z, stats,
    first circular frequency)."""
    model = CableModel(comm, parse_case(d))
    solve_static(model)
    w = solve_modes(model, 1).omegas[0]
    model.u.interpolate(lambda x: np.vstack([0 * x[0], 0 * x[0],
                                             amplitude * np.sin(np.pi * x[0] / L)]))
    model.u.x.array[:] += model.u_static.x.array
    mid = model.geometry.node_at(model.length / 2)
    stats = DynamicsStats()
    ts, zs = [], []
    for t, _ in integrate(model, t_end, dt, rho_inf, 1, stats):
        nodal = model.gather_nodal(model.u)
        ts.append(t)
        zs.append(None if nodal is None else nodal[mid, 2])
    return np.array(ts), np.array(zs), stats, w


@pytest.mark.single_rank  # a long free decay (25 s on 2 ranks); the drag's parallel
# assembly: test_newton_iterations_with_drag_no_more_than_with_rayleigh and the others
def test_quadratic_drag_free_decay_follows_equivalent_linearisation():
    """Released from 2 cm in its first mode in still water, the amplitude decays as the
    equivalent linearisation of the quadratic drag says: 1/A = 1/A0 + k t with
    k = 4 c_q omega/(3 pi m_g), c_q = rho C_dn D L (4/(3 pi))/2 and m_g = (m + m_a) L/2
    (the mode sin(pi x/L); the averages of |sin|^3 in space and |cos|^3 in time). Over
    five periods: the measured k within 5 % (the method's slowly-varying-amplitude
    assumption, k A T/2pi = 1 %, the other modes of the release and the tension's rise)."""
    t, z, stats, w = release(taut(EA=1.0e6, fluid={}), 0.02, 8.0, 0.005)
    if comm.rank == 0:
        period = 2 * np.pi / w
        peaks = []
        for i in range(5):
            sel = (t >= i * period) & (t < (i + 1) * period)
            j = np.argmax(np.abs(z[sel]))
            peaks.append((t[sel][j], abs(z[sel][j])))
        (t0, a0), (t1, a1) = peaks[0], peaks[-1]
        k = (1 / a1 - 1 / a0) / (t1 - t0)
        m_g = (M + RHO * A) * L / 2
        c_q = 0.5 * RHO * 1.2 * D * L * 4 / (3 * np.pi)
        assert k == pytest.approx(4 * c_q * w / (3 * np.pi * m_g), rel=0.05)


def test_newton_iterations_with_drag_no_more_than_with_rayleigh():
    """The drag's Jacobian is derived (with the regularised |v|): Newton stays quadratic,
    so a step takes no more iterations than with Rayleigh damping alone (measured 2.8
    with drag against 2.8-3 with Rayleigh; 2.0 and 2.0 with the velocity predictor and
    the stopping test of cablefem.stepnewton; one iteration more allowed on average).
    The Jacobian is assembled at every iteration here (a fluid's is otherwise kept across
    steps: a cheaper modified Newton, more iterations, tests/test_stepnewton.py)."""
    fresh = {"outer_correction": "none", "petsc_options": {"newton_jacobian_reuse": 0}}
    _, _, with_drag, _ = release(taut(EA=1.0e6, fluid={}, solver=fresh), 0.02, 1.0, 0.005)
    _, _, rayleigh, _ = release(taut(EA=1.0e6, damping={"ratio": 0.02,
                                                         "frequencies": [4.0, 12.0]}),
                                0.02, 1.0, 0.005)
    per = [s.newton_iterations / s.steps for s in (with_drag, rayleigh)]
    assert per[0] <= per[1] + 1.0, per


def test_buoyancy_is_the_submerged_weight():
    """With gravity, the anchors of a level cable carry its weight m g per stress-free
    length less the buoyancy rho g A per current length (the stretched cable's length from
    its nodes: P1 is straight between them), to Newton's tolerance (1e-6 allowed); with a
    free surface above the cable nothing changes, below it the dry weight is back."""
    def weights(fluid):
        d = taut(fluid=fluid, gravity={"g": 9.81})
        model = CableModel(comm, parse_case(d))
        st = solve_static(model)
        r = model.gather_nodal(model.u)
        length = None
        if comm.rank == 0:
            r = r + model.geometry.points
            length = float(np.sum(np.linalg.norm(np.diff(r, axis=0), axis=1)))
        length = comm.bcast(length, root=0)
        carried = -(st.anchor_forces[0][2] + st.anchor_forces[1][2])
        return carried, M * 9.81 * model.length, RHO * 9.81 * A * length
    carried, dry, buoyancy = weights({})
    assert carried == pytest.approx(dry - buoyancy, rel=1e-6)
    carried, dry, buoyancy = weights({"surface": 5.0})
    assert carried == pytest.approx(dry - buoyancy, rel=1e-6)
    carried, dry, _ = weights({"surface": -5.0})
    assert carried == pytest.approx(dry, rel=1e-6)


@pytest.mark.parametrize("fluid,key", [
    ({"density": -1.0}, "fluid.density"),
    ({"diameter": 0.0}, "fluid.diameter"),
    ({"cd_normal": -1.0}, "fluid.cd_normal"),
    ({"cd_tangential": -1.0}, "fluid.cd_tangential"),
    ({"ca_normal": -1.0}, "fluid.ca_normal"),
    ({"current": [1.0, 2.0]}, "fluid.current"),
    ({"buoyancy": 3}, "fluid.buoyancy"),
    ({"bogus": 1}, "fluid.bogus")])
def test_bad_fluid_is_rejected_with_its_key(fluid, key):
    d = taut(fluid={})
    d["fluid"].update(fluid)
    with pytest.raises(CaseError) as err:
        parse_case(d)
    assert key in str(err.value), str(err.value)


def test_fluid_needs_a_diameter():
    d = taut(fluid={})
    d["fluid"].pop("diameter")
    with pytest.raises(CaseError, match="fluid.diameter"):
        parse_case(d)


def test_python_api():
    """create_cable takes a Fluid; a bad one names its field."""
    from cablefem import Anchor, Fluid, Section, create_cable

    anchors = [Anchor("p", [0.0, 0, 0], "pinned"), Anchor("q", [L, 0, 0], "pinned")]
    sec = Section(EA=1e8, EI=1e-6, GJ=0.0, mass=M)
    model = create_cable(comm, anchors, sec, length=L / (1 + T0 / 1e8), elements=20,
                         outer_correction="none", fluid=Fluid(RHO, D))
    assert {"fluid_static", "fluid_dynamic"} <= set(model.forms.user)
    with pytest.raises(CaseError, match="fluid.density"):
        create_cable(comm, anchors, sec, length=L, fluid=Fluid(-1.0, D))


def _axial(res, model) -> float:
    """The frequency of the first mode whose shape is along the cable (x)."""
    for w, shape in zip(res.omegas, res.shapes):
        r = model.comm.bcast(model.gather_nodal(shape), root=0)
        if np.sum(r[:, 0] ** 2) > 0.99 * np.sum(r**2):
            return float(w)
    raise AssertionError("no axial mode")


def test_tangential_added_mass_scales_the_axial_frequencies():
    """fluid.ca_tangential (MoorDyn's Cat; it had no key): the added mass C rho A along the
    cable, per current length, scales the axial modes by sqrt(m/(m + C rho A lam)) (lam =
    1 + T/EA = 1.1, the stretch: the mass per stress-free length m) and leaves the
    transverse ones alone (C_an = 0 in both). Exact for the P1 masses (both scale alike):
    the eigen-solver's tolerance, 1e-8 allowed."""
    C, EA, n = 1.5, 1.0e5, 8
    out = []
    for ca_t in (0.0, C):
        model = CableModel(comm, parse_case(taut(EA=EA, elements=30, fluid={
            "ca_normal": 0.0, "ca_tangential": ca_t})))
        solve_static(model)
        res = solve_modes(model, n)
        out.append((_axial(res, model), res.omegas))
    lam = 1 + T0 / EA
    assert out[1][0] / out[0][0] == pytest.approx(np.sqrt(M / (M + C * RHO * A * lam)),
                                                  rel=1e-8)
    transverse = [w for w in out[0][1] if abs(w - out[0][0]) > 1e-6 * w][:4]
    for w in transverse:
        assert np.min(np.abs(out[1][1] - w)) <= 1e-8 * w
