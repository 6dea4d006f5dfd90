"""The string's own discretisation error in a mode's frequency, in closed form
(docs/theory.md §5.2): linear (P1) elements with the consistent mass in space,
generalised-α (PETSc ``alpha2``) in time.

Near a resonance the response amplifies a relative frequency error by the resonance factor
(:func:`cablefem.moments.resonance`), the mesh's and the time step's as much as the
outer problem's. The error estimate adds the mesh's (the string's own, which a reference
run at the same step does not share); the time step's is reported beside it (any run at
that step, the reference included, has it: halving ``dynamics.dt`` measures it).
"""

from __future__ import annotations

import numpy as np

__all__ = ["p1_frequency_ratio", "alpha_frequency_ratio", "effective_element",
           "frequency_error", "model_frequency_error",
           "network_frequency_error", "mode_mesh_error", "mode_mesh_errors"]


def p1_frequency_ratio(theta) -> np.ndarray:
    """``omega_h / omega`` of a wave of ``theta = k h`` radians per element on a uniform mesh of
    linear elements with the consistent mass (a taut string's mode n on N elements:
    ``theta = n pi / N``): ``(2/theta) sin(theta/2) / sqrt(1 - (2/3) sin^2(theta/2))``,
    ``1 + theta^2/24 + O(theta^4)`` (above 1: the consistent mass stiffens)."""
    t = np.asarray(theta, float)
    s = np.sin(t / 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.where(t > 0, 2 * s / np.where(t > 0, t, 1.0), 1.0) / np.sqrt(1 - 2 * s * s / 3)
    return r


def _alpha2_parameters(rho_inf: float) -> tuple[float, float, float, float]:
    """alpha_m, alpha_f, gamma, beta of PETSc's ``alpha2`` at spectral radius ``rho_inf``
    (Jansen, Whiting and Hulbert's form of Chung and Hulbert's method)."""
    am = (2 - rho_inf) / (1 + rho_inf)
    af = 1 / (1 + rho_inf)
    gamma = 0.5 + am - af
    beta = 0.25 * (1 + am - af) ** 2
    return am, af, gamma, beta


def alpha_frequency_ratio(Omega: float, rho_inf: float) -> float:
    """``omega_bar / omega`` of generalised-α at ``Omega = omega dt`` and ``rho_inf``: the
    phase per step of the principal root of the amplification matrix of ``u'' + omega^2 u =
    0`` (state ``u, dt u', dt^2 u''``), over ``Omega``. ``rho_inf = 1`` is the trapezoidal
    rule, ``2 arctan(Omega/2) / Omega = 1 - Omega^2/12 + ...`` (below 1: the period
    lengthens)."""
    if not Omega > 0:
        return 1.0
    am, af, gamma, beta = _alpha2_parameters(rho_inf)
    W = Omega * Omega
    A = np.empty((3, 3))
    for j, x in enumerate(np.eye(3)):
        u0, v0, a0 = x
        a1 = -(W * u0 + W * af * v0 + ((1 - am) + W * af * (0.5 - beta)) * a0) / (am
                                                                                  + W * af * beta)
        A[:, j] = (u0 + v0 + (0.5 - beta) * a0 + beta * a1,
                   v0 + (1 - gamma) * a0 + gamma * a1, a1)
    lam = np.linalg.eigvals(A)
    pair = lam[np.abs(lam.imag) > 1e-14 * np.abs(lam)]  # the principal roots (the spurious
    if pair.size == 0:  # one is real); none: overdamped by the method, no period at all
        return 0.0
    return float(np.max(np.abs(np.angle(pair))) / Omega)


def effective_element(stations) -> float:
    """The element length that gives a graded mesh's P1 frequency error: the error is
    ``(k h)^2/24`` locally and a mode's energy is spread along the cable, so the
    length-weighted mean of ``h^2``, ``sqrt(sum h^3 / sum h)``."""
    h = np.diff(np.asarray(stations, float))
    return float(np.sqrt(np.sum(h**3) / np.sum(h)))


def frequency_error(omega: float, tension: float, mass: float, h: float | None,
                    dt: float | None = None, rho_inf: float = 0.9) -> float:
    """The relative frequency error of a string's mode at ``omega`` (rad/s) from the mesh,
    elements of (effective) length ``h``: ``p1_frequency_ratio(k h) - 1`` with the mode's
    wavenumber ``k = omega sqrt(mass / tension)`` (positive: the consistent mass stiffens);
    with ``dt``, the time step's ``alpha_frequency_ratio(omega dt, rho_inf) - 1``
    (negative: the period lengthens) instead. 0 for an unknown ``h`` or ``dt``."""
    if dt is not None:
        return alpha_frequency_ratio(omega * dt, rho_inf) - 1 if dt > 0 else 0.0
    if not (h and tension > 0 and mass > 0):
        return 0.0
    return float(p1_frequency_ratio(omega * np.sqrt(mass / tension) * h)) - 1


def model_frequency_error(model, static, omega: float, time_step: bool = False
                          ) -> float | None:
    """:func:`frequency_error` of a single string's mode at ``omega``: its mesh's
    (effective element, least static tension: the largest wavenumber along the cable, mass
    per length with a fluid's added mass ``fluid.ca_normal rho pi D^2/4``), or, with
    ``time_step``, the case's time step's; None for a network (several sections and
    meshes), a rod, or a time step without a [dynamics] table."""
    case = model.case
    if time_step:
        dyn = case.dynamics
        return None if dyn is None else frequency_error(omega, 0.0, 0.0, None, dyn.dt,
                                                        dyn.rho_inf)
    if model.is_network or getattr(case, "section", None) is None:
        return None
    stations = getattr(model.geometry, "stations", None)
    if stations is None or not static.min_tension > 0:
        return None
    mass = case.section.mass
    fluid = getattr(case, "fluid", None)
    if fluid is not None:
        D = fluid.diameter_on(case.section)
        mass = mass + fluid.ca_normal * fluid.density * np.pi * D * D / 4
    return frequency_error(omega, static.min_tension, mass, effective_element(stations))


def _network_elements(model):
    """What :func:`network_frequency_error` needs of a network's owned elements, whatever
    the mode: the cells' vertex dofs, mass per length (a fluid's added mass in), static
    tension, stress-free length and which carry a string's wave (a cable's, tensioned)."""
    n = model.mesh.topology.index_map(1).size_local
    cable = np.asarray(model.cable_cells(), bool)[:n]
    T = np.asarray(model.tension_field().x.array[:n], float)
    m = np.asarray(model.m.x.array[:n], float).copy()
    fluid = getattr(model.case, "fluid", None)
    if fluid is not None:  # the added mass normal to the cable moves with it
        D = model.section_field("D", fluid.diameter_on).x.array[:n]
        m = m + fluid.ca_normal * fluid.density * np.pi * D * D / 4
    x = model.mesh.geometry.x
    g = model.mesh.geometry.dofmap.array.reshape(-1, 2)[:n]
    h = np.asarray(model.c.x.array[:n], float) * np.linalg.norm(x[g[:, 1]] - x[g[:, 0]],
                                                                axis=1)
    dofs = model.V.dofmap.list.array.reshape(-1, 2)[:n]
    ok = cable & (T > 0) & (m > 0) & (h > 0)
    return dofs, m, T, h, ok


def network_frequency_error(model, static, omega: float, shape, elements=None
                            ) -> float | None:
    """The mesh's relative frequency error of a network's mode at ``omega`` with mode shape
    ``shape`` (a Function of the model's space): each cable element's
    ``p1_frequency_ratio(k h) - 1`` at its own wavenumber ``k = omega sqrt(m / T)`` (its
    static tension ``T``, its mass per length ``m`` with a fluid's added mass, ``h`` its
    stress-free length), weighted by the mode's kinetic energy in the element
    (``m h (|φ_a|² + |φ_b|² + φ_a·φ_b)/3``, the consistent mass): a Rayleigh quotient's
    error is the energy-weighted mean of the elements' (docs/theory.md §5.2). The
    damper's cells and slack elements carry no wave of the string and are left out.
    ``elements``: :func:`_network_elements` of the model, when the caller has them (they
    do not depend on the mode). Collective; None for a model that is not a network, or
    without a tensioned element."""
    if not getattr(model, "is_network", False) or static is None:
        return None
    dofs, m, T, h, ok = _network_elements(model) if elements is None else elements
    phi = np.asarray(shape.x.array, float).reshape(-1, model.bs)[:, :3]
    pa, pb = phi[dofs[:, 0]], phi[dofs[:, 1]]
    w = m * h * (np.sum(pa * pa, 1) + np.sum(pb * pb, 1) + np.sum(pa * pb, 1)) / 3
    err = np.zeros(m.size)
    err[ok] = p1_frequency_ratio(omega * np.sqrt(m[ok] / T[ok]) * h[ok]) - 1
    num, den = model.comm.allreduce(np.array([np.sum(w[ok] * err[ok]), np.sum(w[ok])]))
    return float(num / den) if den > 0 else None


def mode_mesh_errors(model, static, modal) -> list[float | None]:
    """:func:`mode_mesh_error` of every mode of ``modal``, a network's element data
    gathered once (collective for a network)."""
    elements = _network_elements(model) if getattr(model, "is_network", False) and \
        static is not None else None
    return [network_frequency_error(model, static, float(w), sh, elements)
            if elements is not None else model_frequency_error(model, static, float(w))
            for w, sh in zip(modal.omegas, modal.shapes)]


def mode_mesh_error(model, static, modal, i: int) -> float | None:
    """The mesh's relative frequency error of mode ``i`` of ``modal`` (a
    :class:`cablefem.modal.ModalResult`): :func:`model_frequency_error` for a single
    string, :func:`network_frequency_error` with the mode's shape for a network (collective
    there); None where neither applies (a rod)."""
    w = float(modal.omegas[i])
    if getattr(model, "is_network", False):
        return network_frequency_error(model, static, w, modal.shapes[i])
    return model_frequency_error(model, static, w)
