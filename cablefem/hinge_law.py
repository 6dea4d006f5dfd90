"""The virtual hinges' layer law in dynamics (:mod:`cablefem.hinge`, docs/hinge.md).

:func:`start_law` puts the layer's law into each hinge's region, linearised about the static
state: each region cell removes its share of ``sigma(T, C) = sigma_h + sigma_T (T - T0) +
sigma_C (C - C0)``, with ``T`` within :data:`FLOOR` to :data:`CEILING` times its static
tension and the change of ``C = cos Delta`` within :data:`DCOS`, and its force direction is
shifted by its share of the far field's normal offset (:func:`start_offset`). The law's
derivatives are central differences of the rod's far field (:func:`sigma_far`,
:func:`law_derivatives`, :func:`offset_derivatives`).
"""

from __future__ import annotations

import numpy as np

from cablefem.asymptotics import far_field_offsets
from cablefem.errors import HingeError

__all__ = ["FLOOR", "CEILING", "DCOS", "HCOS", "start_law", "cell_values", "local_cells",
           "sigma_far", "law_derivatives", "offset_derivatives", "start_offset"]

#: Below this fraction of its static tension, a layer no longer follows the tension.
FLOOR = 0.25
#: Above this multiple of its static tension, a layer no longer follows the tension (the
#: linear law removes sigma_h/2 there, the far field 0.71 sigma_h; at 3 T0 it would be 0).
CEILING = 2.0
#: Largest change of cos(Delta) the law follows.
DCOS = 0.25
#: Step in cos(Delta) of the derivative d sigma / d cos(Delta).
HCOS = 1e-5


def cell_values(hinges, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tension (with the law in force) and cos Delta of every local cell in the state
    ``u`` (a Function's array with its ghosts; ``model.u`` is left as it was; cos
    Delta: zero outside the regions)."""
    m = hinges.model
    keep = None
    if u is not m.u.x.array:
        keep = m.u.x.array.copy()
        m.u.x.array[:] = u
    if hinges._scratch is None:
        from dolfinx import fem

        from cablefem.jit import quiet_compiler

        with quiet_compiler():
            cos = fem.Expression(m.law.cos, m.W.element.interpolation_points())
        hinges._scratch = (fem.Function(m.W), fem.Function(m.W), cos)
    T, C, cos = hinges._scratch
    T.interpolate(m.tension_expr)
    C.interpolate(cos)
    if keep is not None:
        m.u.x.array[:] = keep
    return T.x.array, C.x.array


def local_cells(hg) -> tuple[np.ndarray, np.ndarray]:
    """The region elements (indices into ``hg.cells``) on this rank, and their cells."""
    c = hg.cells[:hg.n]
    k = np.flatnonzero(c >= 0)
    return k, c[k]


def sigma_far(hg, T, delta):
    """The stress-free length to remove for the string from the (fixed) node at A + h c
    to lie on the rod's far-field line at tension T and angle Delta: along the string,
    ``h cos(Delta) - lambda_inf sigma = D_t(T, Delta)`` (vectorised)."""
    sec = hg.anchor.section
    D_t, _ = far_field_offsets(delta, T, sec.EI, sec.EA)
    return (hg.h * np.cos(delta) - D_t) / (1.0 + np.asarray(T, float) / sec.EA)


def law_derivatives(hg, T: np.ndarray, delta: np.ndarray):
    """``d sigma/dT`` and ``d sigma / d cos(Delta)`` (finite at Delta = 0, where ``d
    sigma / d Delta`` vanishes) of :meth:`_sigma_far`, by central differences."""
    dT = 1e-4 * T
    sig_T = (sigma_far(hg, T + dT, delta) - sigma_far(hg, T - dT, delta)) \
        / (2 * dT)
    hi = np.minimum(np.cos(delta) + HCOS, 1.0)
    lo = hi - 2.0 * HCOS
    sig_C = (sigma_far(hg, T, np.arccos(hi))
             - sigma_far(hg, T, np.arccos(lo))) / (hi - lo)
    return sig_T, sig_C


def offset_derivatives(hg, T: float, delta: float, cell_delta):
    """The far field's normal offset from the fixed node, ``dn = D_n(T, Delta) - h
    sin(Delta)`` (zero at the static state), linearised about the first element's
    static tension ``T`` and angle ``Delta``, as each region cell sees it: its offset is
    ``q (c - (c.e) e)`` with ``|c - (c.e) e| = sin(Delta_k)`` at its own angle, and
    a rotation of the region turns every cell by the same angle, ``d cos(Delta_k) =
    -sin(Delta_k) dDelta``. Returns ``(dq/dT, dq/d cos(Delta_k))`` per cell; zero
    where ``sin(Delta_k) < 1e-3`` (the offset is O(Delta^2) there)."""
    sec = hg.anchor.section

    def dn(T_, d_):
        return float(far_field_offsets(d_, T_, sec.EI, sec.EA)[1]) - hg.h * np.sin(d_)

    dT, dD = 1e-4 * T, 1e-5
    n_T = (dn(T + dT, delta) - dn(T - dT, delta)) / (2 * dT)
    n_D = (dn(T, delta + dD) - dn(T, delta - dD)) / (2 * dD)
    sin = np.sin(np.asarray(cell_delta, float))
    ok = sin > 1e-3
    safe = np.where(ok, sin, 1.0)
    return np.where(ok, n_T / safe, 0.0), np.where(ok, -n_D / safe**2, 0.0)


def start_offset(hinges, hg, T: float, delta: float, Tc, Cc) -> None:
    """The far field's normal offset (module docs) on the hinge's region, each cell
    taking the share ``c0/K`` of it per mesh length, linearised about the first
    element's static tension ``T`` and angle ``delta`` (``Tc``, ``Cc``: the cells' static
    tension and cosine)."""
    m = hinges.model
    k, c = local_cells(hg)
    q_T, q_C = offset_derivatives(hg, T, delta,
                                        np.arccos(np.clip(Cc[c], -1.0, 1.0)))
    share = hg.c0[k] / hg.K
    m.law_tref.x.array[c] = Tc[c]
    m.law_qT.x.array[c] = q_T * share
    m.law_qC.x.array[c] = q_C * share


def start_law(hinges, u_static: np.ndarray) -> None:
    """Put the layer's law into each region (module docs): linearised about the static
    state ``u_static``, each cell about its own static tension T0 and cos Delta C0.
    The law then stays as it is for the whole run (nothing is updated between steps;
    a restart sets it again from the static state)."""
    m = hinges.model
    T, delta = hinges._measure(u_static)
    Tc, Cc = cell_values(hinges, u_static)
    for hg, t_k, delta_k in zip(hinges.items, T, delta):
        hg.T_static = float(t_k)
        k, c = local_cells(hg)
        T0, C0 = Tc[c], Cc[c]
        if np.any(T0 <= 0.0):
            raise HingeError(f"anchor {hg.anchor.name}: a slack element next to the "
                             "virtual hinge in the static state")
        sig_T, sig_C = law_derivatives(hg, T0, np.arccos(np.clip(C0, -1.0, 1.0)))
        # the layer shortens as the tension grows (sigma ~ T^-1/2): sig_T < 0 (kept so,
        # the min/max composition of the law needs the following law the softest)
        sig_T = np.minimum(sig_T, 0.0)
        p, sl, c0 = hg.p[k], hg.s[k], hg.c0[k]
        c_s = c0 * (1.0 - p * hg.sigma / sl)  # the static stress-free length per mesh
        m.law_a.x.array[c] = c0 * (1.0 - p * (hg.sigma - sig_T * T0) / sl)
        m.law_b.x.array[c] = c0 * p * sig_C / sl
        m.law_ka.x.array[c] = c_s / hg.EA0 - c0 * p * sig_T / sl
        m.law_kb.x.array[c] = c_s / hg.EA0
        m.law_tf.x.array[c] = FLOOR * T0
        m.law_tc.x.array[c] = CEILING * T0
        m.cos_ref.x.array[c] = C0
        if hg.cells[0] >= 0:
            hg.sig_T, hg.sig_C = float(sig_T[0]), float(sig_C[0])
        start_offset(hinges, hg, t_k, delta_k, Tc, Cc)
