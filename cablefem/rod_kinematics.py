"""The rod's kinematics: Cayley rotations in NumPy and UFL, the rod's strains, its energy
density and the one-point exact product of P1 fields (:mod:`cablefem.rod` describes the
formulation)."""

from __future__ import annotations

import numpy as np
import ufl

__all__ = ["rotation_matrix", "cayley_from_rotation", "virtual_rotation_map",
           "cayley_rotation", "split", "rod_strains", "p1_product", "energy_density"]


# ----------------------------------------------------------------------------- NumPy side
def _skew(a: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def rotation_matrix(q: np.ndarray) -> np.ndarray:
    """``Λ(q)`` for a Cayley vector ``q`` (NumPy)."""
    q = np.asarray(q, float)
    Q = _skew(q)
    return np.eye(3) + 4.0 / (4.0 + q @ q) * (Q + 0.5 * Q @ Q)


def cayley_from_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cayley vector of the smallest rotation taking unit vector ``a`` to unit vector ``b``:
    ``q = 2 (a × b)/(1 + a·b)``. Raises ValueError for opposite vectors (180°)."""
    a = np.asarray(a, float) / np.linalg.norm(a)
    b = np.asarray(b, float) / np.linalg.norm(b)
    d = 1.0 + float(a @ b)
    if d < 1e-8:
        raise ValueError("a rotation of 180 degrees has no Cayley vector")
    return 2.0 * np.cross(a, b) / d


def virtual_rotation_map(q: np.ndarray) -> np.ndarray:
    """``H(q)`` with ``δθ = H δq`` (spatial virtual rotation from a variation of ``q``)."""
    q = np.asarray(q, float)
    return 4.0 / (4.0 + q @ q) * (np.eye(3) + 0.5 * _skew(q))


# ----------------------------------------------------------------------------- UFL side
def _uskew(a):
    return ufl.as_matrix([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def cayley_rotation(q):
    """``Λ(q)`` as a UFL expression."""
    Q = _uskew(q)
    return ufl.Identity(3) + 4.0 / (4.0 + ufl.dot(q, q)) * (Q + 0.5 * Q * Q)


def split(w):
    """Displacement and Cayley vector of the six-component unknown ``w``."""
    return ufl.as_vector([w[0], w[1], w[2]]), ufl.as_vector([w[3], w[4], w[5]])


def rod_strains(w, t0, frame, c=1.0):
    """Material strains ``(Γ, K, directors)`` of the rod (module docstring)."""
    u, q = split(w)
    rs = (t0 + ufl.grad(u) * t0) / c
    qs = ufl.grad(q) * t0 / c
    L = cayley_rotation(q)
    d = [L * E for E in frame]
    omega = 4.0 / (4.0 + ufl.dot(q, q)) * (qs + 0.5 * ufl.cross(q, qs))
    G = ufl.as_vector([ufl.dot(d[0], rs), ufl.dot(d[1], rs), ufl.dot(d[2], rs) - 1.0])
    K = ufl.as_vector([ufl.dot(omega, d[0]), ufl.dot(omega, d[1]), ufl.dot(omega, d[2])])
    return G, K, d


def p1_product(a, b, t0, mesh):
    """Integrand whose one-point (midpoint) quadrature gives ``∫ a·b`` exactly for P1
    fields on an element of length ``h``: ``a·b + (h²/12) ∂a·∂b``.

    Every cell integral of the rod uses one point: FFCx 0.5 cannot compile a form that mixes
    two quadrature rules on cells (it declares the Jacobian twice), and the stiffness needs
    the one-point rule (no locking) while the mass must stay consistent."""
    h = ufl.CellVolume(mesh)
    if len(a.ufl_shape) == 0:
        return a * b + h * h / 12.0 * ufl.dot(ufl.grad(a), t0) * ufl.dot(ufl.grad(b), t0)
    return ufl.inner(a, b) + h * h / 12.0 * ufl.inner(ufl.grad(a) * t0, ufl.grad(b) * t0)


def energy_density(G, K, EA, GA, EI, GJ):
    """``Ψ`` per stress-free length."""
    return 0.5 * (EA * G[2] ** 2 + GA * (G[0] ** 2 + G[1] ** 2)
                  + EI * (K[0] ** 2 + K[1] ** 2) + GJ * K[2] ** 2)
