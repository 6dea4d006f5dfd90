"""A flat seabed under a cable or a network (``[seabed]``, ``docs/seabed.md``).

The seabed is the plane at elevation ``z`` (along −gravity). Where the cable's current
position is below it by the penetration ``p``, the seabed pushes back per unit stress-free
length with ``k s(p)``, ``s`` the penetration smoothed over ``PENETRATION_BLEND`` of the
lying cable's own static penetration ``e = w/k`` (``s = p²/(2 b)`` below ``b``, ``p − b/2``
above: continuous with its slope, so Newton converges), plus, in dynamics, a vertical
dashpot ``c`` while in contact and a regularised Coulomb friction ``μ k s`` against the
velocity along the seabed, ``−μ k s v_h / sqrt(|v_h|² + v0²)``. Jacobians by UFL.

Statics starts from the catenary with its grounded part (:class:`GroundedCatenary`):
an inextensible catenary of submerged weight ``w`` from the touchdown point, where its
tangent is horizontal, up to the fairlead, and straight along the seabed to the anchor.
With the fairlead ``h`` above the seabed and the horizontal tension ``H``: suspended length
``l_s = sqrt(h² + 2 h H/w)``, its horizontal span ``(H/w) asinh(l_s w/H)``, grounded length
``l − l_s``, fairlead tension ``H + w h``.

The touchdown is reported twice (:func:`touchdown`): where the penalty contact ends, and
the rigid seabed's equivalent from the suspended length ``V/w``; the contact ends
``1.048 sqrt(H/k)`` beyond it (:func:`penalty_offset_factor`), and an anchor on the plane
carries the weight of that length of line (:func:`anchor_penalty_force`).
"""

from __future__ import annotations

import contextlib
import math

import numpy as np
import ufl
from dolfinx import fem
from petsc4py import PETSc

from cablefem.fluid import medium_dx
from cablefem.roots import brent
from cablefem.terms import Term

__all__ = ["PENETRATION_BLEND", "GroundedCatenary", "add_seabed_terms", "network_contact",
           "touchdown", "without_friction", "penalty_offset_factor", "anchor_penalty_force",
           "rigid_touchdown", "touchdowns", "positions"]

#: the smoothing length of the contact law as a fraction of the static penetration w/k
PENETRATION_BLEND = 0.1
#: the Gauss rule of the seabed's terms (its degree; None: UFL's estimate, shared with
#: every term without a rule of its own): 7 points, docs/seabed.md
QUADRATURE_DEGREE: int | None = 12
#: the least strain of the statics' initial guess (GroundedCatenary.position)
GUESS_STRAIN = 1.0e-3


class GroundedCatenary:
    """The grounded inextensible catenary between an anchor on the seabed and a fairlead
    above it (both points given; ``anchor_first``: the anchor is the cable's first end,
    ``s = 0``). ValueError when the line is too short to lie on the seabed (or too long
    for a catenary at all)."""

    def __init__(self, anchor, fairlead, length: float, w: float, up, anchor_first: bool,
                 EA: float = math.inf):
        self.anchor, self.fairlead = np.asarray(anchor, float), np.asarray(fairlead, float)
        self.up = np.asarray(up, float) / np.linalg.norm(up)
        self.l, self.w, self.first, self.EA = float(length), float(w), anchor_first, EA
        self._guess = None
        d = self.fairlead - self.anchor
        self.h = float(d @ self.up)
        horiz = d - self.h * self.up
        self.X = float(np.linalg.norm(horiz))
        if not (self.h > 0 and self.X > 0 and w > 0):
            raise ValueError("a grounded catenary needs the fairlead above and away from "
                             "the anchor, and a weight")
        self.e_h = horiz / self.X
        if self.l <= math.hypot(self.X, self.h) or self.l >= self.X + self.h:
            raise ValueError("the line is too short or too long for a grounded catenary")

        def gap(H):
            ls = self.suspended_length(H)
            return (self.l - ls) + H / w * math.asinh(ls * w / H) - self.X

        hi = w * self.l
        while gap(hi) < 0 and hi < 1e12 * w * self.l:
            hi *= 10.0
        lo = 1e-12 * hi
        if gap(lo) * gap(hi) > 0 or self.suspended_length(hi) > self.l:
            raise ValueError("no grounded catenary through the anchors")
        self.H = brent(gap, lo, hi, xtol=1e-14 * hi, rtol=1e-14)
        self.ls = self.suspended_length(self.H)
        if self.ls >= self.l:
            raise ValueError("the line is not long enough to touch the seabed")

    def suspended_length(self, H: float) -> float:
        return math.sqrt(self.h**2 + 2.0 * self.h * H / self.w)

    @property
    def grounded_length(self) -> float:
        return self.l - self.ls

    @property
    def fairlead_tension(self) -> float:
        return self.H + self.w * self.h

    def _sigma(self, s):
        """Arc length from the anchor along the line."""
        s = np.asarray(s, float)
        return s if self.first else self.l - s

    def position(self, s) -> np.ndarray:
        """A guess for statics: the grounded catenary of the stretched length
        ``l (1 + e)``, ``e = max(H/EA, GUESS_STRAIN)``, at the stretched arc lengths, so
        that it reaches the fairlead and every element's chord is in tension (a tension-only
        element without it has no stiffness; the chord of a curved element is shorter than
        its arc by (kappa h)^2/24)."""
        e = max(self.H / self.EA, GUESS_STRAIN)
        if self._guess is None:
            self._guess = GroundedCatenary(self.anchor, self.fairlead, self.l * (1.0 + e),
                                           self.w, self.up, True)
        return self._guess.shape(self._sigma(s) * (1.0 + e))

    def shape(self, a) -> np.ndarray:
        """The inextensible shape at arc length ``a`` from the anchor."""
        a = np.asarray(a, float)
        g = self.grounded_length
        sig = np.maximum(a - g, 0.0)  # arc length from the touchdown point
        c = self.H / self.w
        x = np.where(a <= g, a, g + c * np.arcsinh(sig / c))
        z = np.where(a <= g, 0.0, c * (np.sqrt(1.0 + (sig / c) ** 2) - 1.0))
        return self.anchor + x[..., None] * self.e_h + z[..., None] * self.up

    def tension(self, s) -> np.ndarray:
        sig = np.maximum(self._sigma(s) - self.grounded_length, 0.0)
        return np.sqrt(self.H**2 + (self.w * sig) ** 2)


def add_seabed_terms(model, w: float) -> None:
    """Add the seabed's terms to ``model.forms``, both forces of the medium (``medium``):
    ``seabed`` (the contact force, static) and ``seabed_dynamic`` (dashpot and friction,
    linearised without the friction: :func:`without_friction`); ``w`` the submerged
    weight per length (N/m), which sets the smoothing of the contact law."""
    sb = model.case.seabed
    mesh, u, v, du = model.mesh, model.u, model.v, model.du

    def const(x):
        return fem.Constant(mesh, PETSc.ScalarType(x))

    dx = medium_dx(QUADRATURE_DEGREE)
    k, c, mu = const(sb.stiffness), const(sb.damping), const(sb.friction)
    b = const(PENETRATION_BLEND * max(w, 1e-300) / sb.stiffness)
    v0 = const(sb.friction_velocity)
    up = -model.gravity / ufl.sqrt(ufl.dot(model.gravity, model.gravity))
    x = ufl.SpatialCoordinate(mesh) + u
    p = sb.z - ufl.dot(up, x)  # penetration
    smooth = ufl.conditional(ufl.gt(p, b), p - b / 2,
                             ufl.conditional(ufl.gt(p, 0.0), p * p / (2 * b), 0.0))
    # per stress-free length of cable (a network's damper cells: none)
    cc = model.c * model.section_field("on_cable", lambda sec: 1.0)
    model.forms.add(Term("seabed", -k * smooth * ufl.dot(up, du) * cc * dx, "static",
                         medium=True))
    # the dashpot acts as the contact's stiffness does, ds/dp: from none at p = 0 to all of
    # it at p = b. A step (all of it at any p > 0) made the residual jump where a node in
    # vertical motion crossed the seabed: Newton cycled between the two sides (the mooring
    # demo at t = 26.72 s, |F| 11.25 <-> 12.10 N for 25 iterations), the step was cut and
    # the run went on at a sixteenth of its step
    share = ufl.conditional(ufl.gt(p, b), 1.0, ufl.conditional(ufl.gt(p, 0.0), p / b, 0.0))
    vn = ufl.dot(v, up)
    vh = v - vn * up
    f = -c * share * vn * up - mu * k * smooth * vh / ufl.sqrt(ufl.dot(vh, vh) + v0 * v0)
    model.forms.add(Term("seabed_dynamic", -ufl.inner(f, du) * cc * dx, "dynamic",
                         linearised=lambda: without_friction(mu), medium=True))


@contextlib.contextmanager
def without_friction(mu):
    """Within the block the seabed's friction coefficient (the Constant ``mu``) is zero:
    the ``seabed_dynamic`` term's linearisation. The modal analysis leaves it out:
    linearised at rest, the regularised Coulomb law is a dashpot ``μ k s/v0`` per length
    (``μ w/v0`` on the lying part, e.g. 12 kN s/m² for a 250 N/m line with ``v0`` = 1 cm/s),
    an artefact of the regularisation whose slow real roots would crowd out every
    oscillating mode of the damped eigenproblem. The frequencies (K, M) never include it."""
    saved = float(mu.value)
    mu.value = 0.0
    try:
        yield
    finally:
        mu.value = saved


def penalty_offset_factor(blend: float = PENETRATION_BLEND) -> float:
    """``c`` in the penalty seabed's offset ``c sqrt(H/k)``: how far beyond the rigid
    seabed's touchdown the contact ends (and the length of line whose weight an anchor on
    the seabed's plane carries). From the first integral of ``H p'' = k s(p) - w`` across
    the contact's edge (small slopes): ``(H/2) p'^2 = int_0^{p_r} (w - k s) dq =
    (w^2/2k) (1 + blend - blend^2/12)`` with ``p_r`` the lying line's penetration; the
    suspended catenary's vertex lies ``H |p'| / w`` back from the edge (docs/seabed.md)."""
    return math.sqrt(1.0 + blend - blend * blend / 12.0)


def anchor_penalty_force(H: float, w: float, k: float, p: float,
                         blend: float = PENETRATION_BLEND) -> float:
    """The vertical force that holds a line's anchor at the penetration ``p`` (< 0: above
    the plane) while the line beyond it lies on the penalty seabed under the horizontal
    tension ``H``: ``sqrt(2 H int_p^{p_r} (w - k s(q)) dq)``, ``p_r = w/k + b/2`` the lying
    line's penetration (small slopes; the weight of about ``penalty_offset_factor()
    sqrt(H/k)`` of line for an anchor on the plane, ``p = 0``). 0 at ``p >= p_r``."""
    b = blend * w / k
    p_r = w / k + b / 2

    def F(q):  # int_0^q k s(t) dt (q >= 0)
        return k * q**3 / (6 * b) if q <= b else k * (b * b / 6 + ((q - b / 2) ** 2
                                                                    - b * b / 4) / 2)

    if p >= p_r:
        return 0.0
    integral = w * (p_r - p) - (F(p_r) - F(max(p, 0.0)))
    return math.sqrt(max(2.0 * H * integral, 0.0))


def rigid_touchdown(case, r, st, forces, anchors, w: float, up) -> dict:
    """The rigid seabed's equivalent of the touchdown (rank 0): the suspended catenary
    carries its own weight only, so its stress-free length from the fairlead is ``V/w``
    (``V`` the vertical force at the fairlead, the higher end), its vertex (the rigid
    touchdown) at the station ``s_f -+ V/w``; with the penalty seabed it sits
    ``penalty_offset_factor() sqrt(H/k)`` short of the contact's end. Also the anchors
    near the seabed's plane and the vertical force the penalty contact puts on them
    (:func:`anchor_penalty_force`). Entries absent, with ``rigid_missing`` saying why,
    where the suspended part carries more than its weight."""
    sb = case.seabed
    out = {}
    ends = [r[0], r[-1]]
    F = {a.name: np.asarray(f[:3], float) for a, f in zip(anchors, forces)}
    at_end = {a.name: int(np.argmin([np.linalg.norm(np.asarray(a.position) - e)
                                     for e in ends])) for a in anchors}
    top = max(anchors, key=lambda a: float(np.asarray(a.position) @ up))
    Ff = F[top.name]
    V = abs(float(Ff @ up))
    H = float(np.linalg.norm(Ff - (Ff @ up) * up))
    out["horizontal_tension"] = H
    out["penalty_offset"] = penalty_offset_factor() * math.sqrt(H / sb.stiffness)
    extra = [name for name, present in (
        ("loads", case.loads), ("point_masses", case.point_masses),
        ("point_loads", case.point_loads), ("dampers", case.dampers),
        ("fluid.current", case.fluid is not None and (
            np.linalg.norm(case.fluid.current) > 0 or case.fluid.profile is not None)))
        if present]
    length = float(st[-1] - st[0])
    if extra:
        out["rigid_missing"] = (f"the suspended part carries more than its own weight "
                                f"({', '.join(extra)}): V/w is not its length")
    elif not V / w < length:
        out["rigid_missing"] = "V/w exceeds the line's length: the line is not grounded"
    else:
        s_r = float(st[-1] - V / w) if at_end[top.name] == 1 else float(st[0] + V / w)
        pos = [float(np.interp(s_r, st, r[:, i])) for i in range(r.shape[1])]
        out["rigid"] = {"s": s_r, "position": pos, "suspended_length": V / w,
                        "grounded_length": length - V / w}
    near = {}
    p_r = (1 + PENETRATION_BLEND / 2) * w / sb.stiffness
    for a in anchors:
        p = float(sb.z - np.asarray(a.position, float) @ up)
        if abs(p) <= p_r and a is not top:
            h = float(st[1] - st[0] if at_end[a.name] == 0 else st[-1] - st[-2])
            near[a.name] = {"penetration": p, "vertical_force": float(F[a.name] @ up),
                            "penalty_force": -anchor_penalty_force(H, w, sb.stiffness, p),
                            "layer_elements": math.sqrt(H / sb.stiffness) / h}
    if near:
        out["anchors_on_seabed"] = near
    return out


def touchdown(model, forces=None) -> dict | None:
    """The touchdown point at the model's current state (collective; every rank gets it):
    where the penetration crosses zero between the last node in contact and the suspended
    part (towards the higher end, the fairlead), its stress-free station ``s`` and
    position, and the grounded length (stress-free, from the nodes in contact; linear
    between a node in contact and one not): the penalty contact's end. With the static
    anchor ``forces`` (rows in the order of ``model.anchors``), also the rigid seabed's
    equivalent (:func:`rigid_touchdown`). None when nothing touches."""
    r = positions(model)
    out = None
    if model.comm.rank == 0:
        out = touchdowns(model, r[None])[0]
        if out is not None and forces is not None:
            out.update(rigid_touchdown(model.case, r, model.geometry.stations, forces,
                                       model.anchors, model.submerged_weight,
                                       _up(model)))
    return model.comm.bcast(out, root=0)


def positions(model) -> np.ndarray | None:
    """A single cable's node positions at its current state, in station order, on rank 0
    (None on the others; collective)."""
    r = model.gather_nodal(model.u)
    return r + model.geometry.points if model.comm.rank == 0 else None


def _up(model) -> np.ndarray:
    g = np.asarray(model.g_vec, float)
    return -g / np.linalg.norm(g)


def touchdowns(model, r: np.ndarray) -> list[dict | None]:
    """:func:`touchdown` (without the rigid equivalent) of a single cable at each of a
    block of states, the nodes' positions ``r`` (times, nodes, 3) in station order (no
    MPI: the caller has gathered them), evaluated at once: the same numbers as one state
    at a time (the same products and sums, row by row)."""
    up = _up(model)
    pen = model.case.seabed.z - r @ up  # (times, nodes)
    st = model.geometry.stations
    on = pen > 0.0
    touches = np.any(on, axis=1)
    if st.size > 1:  # each element's share in contact, summed in order
        grounded = np.cumsum(np.diff(st) * _grounded_shares(pen[:, :-1], pen[:, 1:]),
                             axis=1)[:, -1]
    else:
        grounded = np.zeros(len(r))
    # towards the fairlead (the higher end): the last node in contact, and where the
    # penetration crosses zero between it and the next node
    up_end = r[:, -1] @ up >= r[:, 0] @ up
    last = on.shape[1] - 1 - np.argmax(on[:, ::-1], axis=1)
    k = np.where(up_end, last, np.argmax(on, axis=1))
    out = []
    for j in range(len(r)):
        if not touches[j]:
            out.append(None)
            continue
        kj = int(k[j])
        n = kj + 1 if up_end[j] else kj - 1
        s_td, x_td = float(st[kj]), r[j, kj]
        if 0 <= n < st.size and pen[j, n] < 0:
            f = pen[j, kj] / (pen[j, kj] - pen[j, n])
            s_td = float(st[kj] + f * (st[n] - st[kj]))
            x_td = r[j, kj] + f * (r[j, n] - r[j, kj])
        out.append({"s": s_td, "position": np.asarray(x_td).tolist(), "node": kj,
                    "grounded_length": float(grounded[j])})
    return out


def _grounded_shares(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`_grounded_share` of every element at once (end penetrations ``a``, ``b``)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        part = np.maximum(a, b) / (np.abs(a) + np.abs(b))
    return np.where((a > 0) & (b > 0), 1.0, np.where((a > 0) | (b > 0), part, 0.0))


def _grounded_share(a: float, b: float) -> float:
    """The share of an element in contact, from its end penetrations (linear)."""
    if a > 0 and b > 0:
        return 1.0
    if a > 0 or b > 0:
        return max(a, b) / (abs(a) + abs(b))
    return 0.0


def network_contact(model) -> dict | None:
    """A network's contact with the seabed at the model's current state (collective;
    every rank gets it): per cable group that touches, its grounded stress-free length and
    its touchdown points, where the penetration crosses zero along an element (positions,
    linear between the element's nodes). None when nothing touches."""
    sb = model.case.seabed
    r = model.gather_nodal(model.u)
    out = None
    if model.comm.rank == 0:
        geo = model.geometry
        net = geo.net
        r = r + geo.points
        g = np.asarray(model.g_vec, float)
        pen = sb.z - r @ (-g / np.linalg.norm(g))
        cells = np.asarray(geo.cells, np.int64)
        h = geo.cell_lengths
        out = {}
        for e in np.nonzero(geo.is_cable)[0]:
            a, b = (int(k) for k in cells[e])
            share = _grounded_share(pen[a], pen[b])
            if share == 0.0:
                continue
            entry = out.setdefault(net.groups[int(net.cell_group[e])],
                                   {"grounded_length": 0.0, "touchdown": []})
            entry["grounded_length"] += float(h[e] * share)
            if (pen[a] >= 0) != (pen[b] >= 0):  # a node on the plane (an anchor) touches
                f = pen[a] / (pen[a] - pen[b])
                entry["touchdown"].append((r[a] + f * (r[b] - r[a])).tolist())
        out = out or None
    return model.comm.bcast(out, root=0)
