"""The far field of a clamped anchor's boundary layer, and its corrections of higher order.

Pure NumPy, no dolfinx (docs/theory.md §3 step 6 and §6.2, docs/hinge.md). Away from the
clamp the rod of :func:`cablefem.asymptotics.layer` is a straight line offset from the anchor
(:func:`far_field_offsets`); the string that continues it starts at a virtual hinge on the
clamp line (:func:`virtual_hinge`, the first-order outer correction). Under a distributed load
the far field curves and the tension grows along the layer: the layer's second-order
integrals (:func:`gradient_integrals`) give the shift of the far field
(:func:`far_field_second_order`) and the factor on the clamp's moment
(:func:`gradient_moment_factor`). Units: any consistent set.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["far_field_offsets", "virtual_hinge", "gradient_integrals", "far_field_second_order",
           "gradient_moment_factor"]

#: Gauss-Legendre nodes and weights on [0, 1] for the far-field integrals over the angle.
#: Their integrands are analytic in phi on [0, pi]: 16 points give round-off (checked in
#: tests/test_hinge.py against an integration of the elastica along sigma).
_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)
_GL_X, _GL_W = 0.5 * (_GL_X + 1.0), 0.5 * _GL_W


def far_field_offsets(delta: ArrayLike, T: ArrayLike, EI: ArrayLike,
                      EA: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Where the rod's far field lies relative to the anchor (the layer's far field).

    The rod leaves the anchor along c and turns to the string tangent t over the layer;
    its centre line is ``r(sigma) = A + int_0^sigma lambda d3``, with ``d3 = cos(phi) t +
    sin(phi) n`` (``n`` normal to t in the bending plane, on the side of c) and the
    stretch ``lambda = 1 + (T/EA) cos(phi)`` of an unshearable rod whose internal force is
    the constant N = T t (docs/theory.md §3, step 6). Far from the anchor it is the straight line
    ``A + D + lambda_inf sigma t``, ``lambda_inf = 1 + T/EA``, with the offset
    ``D = D_t t + D_n n = int_0^inf (lambda d3 - lambda_inf t) dsigma``. Changing the
    variable to phi with the exact first integral (Eq. 35),
    ``dphi/dsigma = -(2/ell0) sin(phi/2) sqrt(1 + beta cos^2(phi/2))``, ell0 = sqrt(EI/T),
    beta = T/EA::

        D_n = ell0 int_0^Delta (1 + beta cos phi) cos(phi/2) / sqrt(1 + beta cos^2(phi/2)) dphi
        D_t = -ell0 int_0^Delta sin(phi/2) (1 + 2 beta cos^2(phi/2))
              / sqrt(1 + beta cos^2(phi/2)) dphi

    (beta = 0: D_n = 2 ell0 sin(Delta/2), D_t = -2 ell0 (1 - cos(Delta/2))). Returns
    ``(D_t, D_n)`` [m], broadcast over the arguments; NaN where T <= 0.

    Args:
        delta: Anchor angle Delta [rad].
        T: Tension [N].
        EI, EA: Bending [N m^2] and axial [N] stiffness (``EA = inf``: inextensible).
    """
    d = np.asarray(delta, float)
    T = np.asarray(T, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        Tp = np.where(T > 0, T, np.nan)
        beta = Tp / np.asarray(EA, float)
        ell0 = np.sqrt(np.asarray(EI, float) / Tp)
        phi = d[..., None] * _GL_X
        ch = np.cos(phi / 2)
        root = np.sqrt(1 + beta[..., None] * ch**2)
        i_n = (1 + beta[..., None] * np.cos(phi)) * ch / root
        i_t = np.sin(phi / 2) * (1 + 2 * beta[..., None] * ch**2) / root
        D_n = ell0 * d * (i_n @ _GL_W)
        D_t = -ell0 * d * (i_t @ _GL_W)
    return D_t, D_n


def virtual_hinge(delta: ArrayLike, T: ArrayLike, EI: ArrayLike,
                  EA: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """The virtual hinge of the first-order outer problem at a clamped anchor.

    Away from the clamp the rod is a string that starts at the hinge ``H = A + h c`` on
    the clamp line, with ``sigma_h`` of stress-free length less: H is the point where the
    far-field line ``A + D + lambda_inf sigma t`` (:func:`far_field_offsets`) crosses the
    clamp line, ``h c = D + lambda_inf sigma_h t``, i.e.::

        h = D_n / sin(Delta),   sigma_h = (h cos(Delta) - D_t) / lambda_inf

    Small Delta: h -> lambda_inf ell and sigma_h -> ell (ell = ell0/sqrt(1 + beta), the
    layer length): the hinge is one layer length into the cable, and the rod's stretch in
    the layer is kept. At finite Delta the hinge moves out (h = ell0/cos(Delta/2) for an
    inextensible rod) and less length is removed (sigma_h = ell0 (2 cos(Delta/2) - 1) /
    cos(Delta/2)). At small Delta, H moves only at second order in a change of Delta, so
    that the string turns about it as the rod's far field does; at a finite angle it moves
    at first order (:mod:`cablefem.hinge`: the normal offset). Returns ``(h, sigma_h)``
    [m]; NaN where T <= 0 or Delta >= pi.

    Args:
        delta: Anchor angle Delta [rad].
        T: Tension [N].
        EI, EA: Bending [N m^2] and axial [N] stiffness (``EA = inf``: inextensible).
    """
    d = np.asarray(delta, float)
    D_t, D_n = far_field_offsets(d, T, EI, EA)
    with np.errstate(invalid="ignore", divide="ignore"):
        T = np.asarray(T, float)
        beta = np.where(T > 0, T, np.nan) / np.asarray(EA, float)
        ell0 = np.sqrt(np.asarray(EI, float) / np.where(T > 0, T, np.nan))
        small = np.abs(d) < 1e-6  # D_n / sin(Delta) -> its limit, to O(Delta^2)
        h = np.where(small, ell0 * np.sqrt(1 + beta),
                     D_n / np.where(small, 1.0, np.sin(d)))
        h = np.where(d < np.pi, h, np.nan)
        sigma_h = (h * np.cos(d) - D_t) / (1 + beta)
    return h, sigma_h


def gradient_integrals(delta: ArrayLike) -> dict[str, np.ndarray]:
    """Closed forms of the layer's second-order integrals (docs/theory.md §6.2).

    In units of ell0 = sqrt(EI/T0), with the inextensible elastica of the layer
    ``phi(s) = 4 atan(a exp(-s))``, ``a = tan(Delta/4)`` (the angle from the far-field
    tangent t towards the clamp direction, decaying from Delta), and ``phi1`` its response
    to a tension that grows linearly along the layer, ``T = T0 (1 + tau s)``, at first order
    in tau: ``phi1'' - cos(phi) phi1 = s sin(phi)``, ``phi1(0) = phi1(inf) = 0``, whose
    solution is ``phi1 = phi' (s^2 + s + (a^2 - a^2 exp(-2 s))/2)/4``. Returns::

        I_t = int s (cos phi - 1) ds = 4 ln cos(Delta/4)
        I_n = int s sin phi ds      = Delta
        J_t = -int sin(phi) phi1 ds = -4 ln cos(Delta/4)
        J_n = int cos(phi) phi1 ds  = tan(Delta/4) - Delta
        m1  = phi1'(0) / phi'(0)    = 1 / (4 cos^2(Delta/4))

    I_* are the first moments of the layer's departure from its far-field line (what a
    rotation of the far field along the layer does to it), J_* what the tension gradient
    does to the line, m1 what it does to the clamp's curvature (the moment). Checked
    against a finite-difference solution of the boundary value problem in the tests.

    Args:
        delta: Anchor angle Delta [rad].
    """
    d = np.asarray(delta, float)
    c4 = np.cos(d / 4)
    return {"I_t": 4 * np.log(c4), "I_n": d, "J_t": -4 * np.log(c4),
            "J_n": np.tan(d / 4) - d, "m1": 1.0 / (4 * c4 * c4)}


def far_field_second_order(N: ArrayLike, c: ArrayLike, q: ArrayLike, EI: float,
                           sigma_h: float) -> np.ndarray:
    """The O(ell^2) shift of the rod's far field from the virtual hinge's string (a vector,
    m; docs/theory.md §6.2).

    :func:`virtual_hinge` takes the far field of a layer under a constant force. Along the
    layer the force changes by the distributed load: the outer string curves
    (``dt/ds = q_perp/T``) and its tension grows (``dT/ds = q.t``), with ``q = m a - f``
    per stress-free length (``-f`` in statics: minus the weight and the distributed loads).
    At first order in both, the rod at a far station lies off the string that starts at the
    hinge by::

        E = ell0^2 [ (sh^2/2) kappa + Omega x (I_t t + I_n n) + (T'/T0) (J_t t + J_n n) ]

    with ``kappa = dt/ds``, ``Omega = t x kappa`` (the far field's rotation rate), ``n`` the
    unit normal to t towards c, ``sh = sigma_h/ell0`` (the string's first ``sigma_h`` of
    length is curved too) and the integrals of :func:`gradient_integrals`. ``N``: (3,) force
    at the anchor into the span, N; ``c``: clamp direction; ``q``: (3,) N/m. Zero for a
    straight, uniformly tensioned far field; ``I_n n`` and ``J_n n`` are written with
    ``c - (c.t) t`` and their limits at Delta = 0 (1 and -3/4 of it over sin Delta).

    Args:
        N: (3,) force at the anchor into the span [N].
        c: (3,) clamp direction (normalised here).
        q: (3,) ``m a - f`` per stress-free length [N/m].
        EI: Bending stiffness [N m^2].
        sigma_h: Stress-free length [m] the hinge removes (:func:`virtual_hinge`).

    Returns:
        The (3,) shift ``E`` [m].
    """
    N, c, q = (np.asarray(v, float) for v in (N, c, q))
    T0 = float(np.linalg.norm(N))
    t = N / T0
    c = c / np.linalg.norm(c)
    nvec = c - float(c @ t) * t  # |nvec| = sin(Delta), towards c
    sin_d = float(np.linalg.norm(nvec))
    d = float(np.arctan2(sin_d, float(c @ t)))
    g = gradient_integrals(d)
    if sin_d > 1e-8:
        r_i, r_j = float(g["I_n"]) / sin_d, float(g["J_n"]) / sin_d
    else:
        r_i, r_j = 1.0, -0.75
    kappa = (q - float(q @ t) * t) / T0
    Tp = float(q @ t)
    ell2 = EI / T0
    sh = sigma_h / np.sqrt(ell2)
    omega = np.cross(t, kappa)
    return ell2 * (0.5 * sh * sh * kappa
                   + np.cross(omega, float(g["I_t"]) * t + r_i * nvec)
                   + (Tp / T0) * (float(g["J_t"]) * t + r_j * nvec))


def gradient_moment_factor(delta: ArrayLike, tension: ArrayLike, tangent: ArrayLike,
                           q: ArrayLike, EI: float) -> np.ndarray:
    """``1 + m1 ell0 T'/T0``: the layer's moment at the clamp under a tension that grows
    along the layer by ``T' = q.t`` per stress-free length (docs/theory.md §6.2; ``m1`` of
    :func:`gradient_integrals`; 1/4 at small Delta, where M ~ sqrt(T): the moment of the
    tension half a layer into the span). ``tangent`` (..., 3) into the span, ``q`` (..., 3)
    = m a - f, N/m; NaN where T <= 0.

    Args:
        delta: Anchor angle Delta [rad].
        tension: Tension T0 [N].
        tangent: (..., 3) string tangent into the span.
        q: (..., 3) ``m a - f`` [N/m].
        EI: Bending stiffness [N m^2].
    """
    T = np.asarray(tension, float)
    t = np.asarray(tangent, float)
    Tp = np.sum(t * np.asarray(q, float), axis=-1) / np.linalg.norm(t, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        Tpos = np.where(T > 0, T, np.nan)
        return 1.0 + gradient_integrals(delta)["m1"] * np.sqrt(EI / Tpos) * Tp / Tpos
