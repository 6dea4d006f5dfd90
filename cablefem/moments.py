"""From anchor forces to anchor bending moments: the columns of ``anchors.csv``.

Pure NumPy (no dolfinx), so that ``cablefem post`` can apply it to anchor-force histories
from any string solver. For a clamped anchor at every time (``docs/theory.md``
§3-4):

* the layer's closed form from the anchor force ``N_a`` (:func:`cablefem.asymptotics.layer`),
* plus the string's own curvature at the anchor, ``EI κ_string(0)`` with
  ``κ_string = t × (m a − f) / T`` (``a`` the anchor's acceleration, ``f`` the distributed
  load at the anchor, weight included): ``M(0) = M_a(0) b_a + EI κ_string(0)``.

``moment`` is the magnitude of that vector and ``Mx, My, Mz`` its components (internal
moment in the anchor's direction of travel, into the span); ``moment_layer`` is the layer's
term alone. Slack anchors get ``valid = 0`` and empty moment fields, never a silent zero;
rows outside the method's range (layer too long, not quasi-static, or a force more than
90 degrees from the clamp direction, :data:`MAX_ANCHOR_ANGLE`) get ``valid = 0`` with their
numbers kept, and :func:`anchor_moments` says why in ``invalid_reason``.

Sign convention of the forces: ``N`` is the force of the span on the anchor, i.e. the
tension times the unit tangent from the anchor into the span (``docs/post.md``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cablefem import asymptotics
from cablefem.io.anchorcsv import ANCHOR_COLUMNS, MOMENT_COLUMNS, OPTIONAL_MOMENT_COLUMNS
from cablefem.motion import accelerations, factors

__all__ = ["ANCHOR_COLUMNS", "MOMENT_COLUMNS", "OPTIONAL_MOMENT_COLUMNS", "MAX_ANCHOR_ANGLE",
           "ERROR_THRESHOLD", "anchor_moments", "error_estimate",
           "resonance", "resonance_factor", "resonant_frequency_error"]

#: Estimated relative error of the anchor moment above which a run warns (docs/theory.md
#: §5): 2 %, the accuracy at which the leading order stops being better than the inputs
#: (EI of a stranded cable, tension) and below which a fatigue life (S-N slope 3 to 5)
#: moves by less than 10 %.
ERROR_THRESHOLD = 0.02
#: Clamped ends whose virtual hinges shorten the string (a cable clamped at both ends).
HINGED_ENDS = 2


def resonance_factor(omega: float | None, omegas, damping_ratio) -> float:
    """The factor of :func:`resonance` alone."""
    return resonance(omega, omegas, damping_ratio)[0]


def resonance(omega: float | None, omegas, damping_ratio) -> tuple[float, float | None]:
    """How much a relative error of the natural frequencies grows in the response to a
    harmonic excitation at ``omega`` (rad/s) (docs/theory.md §5):
    ``1 / sqrt(d**2 + zeta**2)`` with ``d = |omega / (k omega_n) - 1|`` the smallest relative
    detuning from a primary (k = 1) or parametric (k = 2) resonance of the modes
    ``omegas`` and ``zeta`` the damping ratio there: ``damping_ratio(omega_n)``, or, when
    ``damping_ratio`` is a sequence, each mode's own (the damped system's modal ratios,
    dampers included); at least 1 (far from resonance the response follows the load
    quasi-statically). Returns the factor and the circular frequency of the mode that
    gives it (None at factor 1)."""
    if not omega or omegas is None or len(omegas) == 0:
        return 1.0, None
    if callable(damping_ratio):
        ratios = [damping_ratio(w) for w in np.asarray(omegas, float)]
    else:
        ratios = np.asarray(damping_ratio, float)
    best, mode = 1.0, None
    for w, z in zip(np.asarray(omegas, float), ratios):
        if not w > 0:
            continue
        z = max(float(z), 0.0)
        for k in (1, 2):
            d = abs(omega / (k * w) - 1.0)
            f = 1.0 / max(np.hypot(d, z), 1e-12)
            if f > best:
                best, mode = f, float(w)
    return best, mode


def resonant_frequency_error(tension, EI: float, mass: float | None,
                             resonant_omega: float | None, resonant_shift: float | None,
                             discretisation: float | None):
    """The resonant mode's relative frequency error, string minus rod, with its sign
    (docs/theory.md §5.2): the mesh's ``discretisation`` (P1 with the consistent mass: the
    string's mode is too high, positive) minus the span's bending shift, which raises the
    rod's frequency and which the string lacks (``resonant_shift`` measured on the mode,
    positive; else the taut beam's ``EI m omega_n^2 / (2 T^2)`` at ``resonant_omega`` and
    the row's ``tension``; none when both are None: the outer problem bends). 0 when
    neither is known; per row where the formula is used."""
    net = float(discretisation) if discretisation else 0.0
    if resonant_shift is not None and np.isfinite(resonant_shift):
        return net - resonant_shift
    if resonant_omega and mass:
        T = np.asarray(tension, float)
        return net - EI * mass * resonant_omega**2 / (2.0 * T * T)
    return net


def error_estimate(delta: np.ndarray, tension: np.ndarray, EI: float, EA: float,
                   length: float | None, period_ratio: np.ndarray | None = None,
                   outer_order: int = 0, amplification: float = 1.0,
                   moment: np.ndarray | None = None, static_moment: float | None = None,
                   mass: float | None = None, resonant_omega: float | None = None,
                   resonant_shift: float | None = None,
                   discretisation: float | None = None, junction: float = 0.0) -> np.ndarray:
    """Estimated relative error of the anchor moment (docs/theory.md §5), per row.

    ``e_outer = HINGED_ENDS h / (lambda l)`` (``lambda = 1 + T/EA``: the stretched
    length, as ``h`` is a distance) is the size of the first-order outer correction: the
    virtual hinge (:func:`cablefem.asymptotics.virtual_hinge`) moves each clamped end of the
    string by ``h`` (one layer length at small Delta, ``ell0 / cos(Delta/2)`` at finite
    Delta), which changes the string's free length, hence its anchor angle and its
    frequencies, by that relative amount. The leading order (``outer_order = 0``) neglects
    it: estimate ``e_outer``; with the hinge (``outer_order = 1``) the next order,
    ``e_outer**2``. ``period_ratio**2`` (the layer's neglected inertia, which is also the
    span's bending frequency shift ``EI m omega^2 / T^2``, twice it) is added. NaN where
    the tension is not positive (slack rows) or the length unknown.

    Near a resonance the outer error is also a frequency error of the same relative size,
    which the response amplifies by ``amplification`` (:func:`resonance_factor`): with the
    row's ``moment`` and the ``static_moment``, the outer term becomes
    ``e_outer (M_s + amplification |M - M_s|) / max(M, M_s)`` (relative to the static
    moment where the moment passes through small values). With ``resonant_omega`` (the
    resonant mode's circular frequency, when the outer problem has no span bending) and the
    ``mass`` per length, that mode's own frequency error from the span's bending,
    ``EI m omega_n^2 / (2 T^2)`` (a taut beam's first correction), is amplified likewise and
    added to the dynamic part; ``resonant_shift``, when given, is that error measured on
    the mode itself (:func:`cablefem.span_bending.frequency_shifts`, any shape: a sagging
    cable's in-plane modes bend far more than a taut beam's) and replaces the formula.
    ``discretisation``: the resonant mode's signed frequency error from the string's own
    mesh (:func:`cablefem.discretisation.frequency_error`). The two are one frequency
    error of the mode, with signs (:func:`resonant_frequency_error`): its size is amplified,
    not the sum of their sizes. ``junction``: the normal offset (m) the string leaves at the
    span's far end (a network's kinks, :meth:`cablefem.network.NetworkModel.
    anchor_junction_offset`), which turns the anchor's angle by ``junction/l``: the
    moment's relative error ``junction / (2 l tan(Delta/2))``. The estimate is at most 1:
    an error of the size of the moment itself (a history whose phase is not determined).
    """
    h, _ = asymptotics.virtual_hinge(delta, tension, EI, EA)
    with np.errstate(invalid="ignore"):
        stretch = 1 + np.asarray(tension, float) / EA  # h is a distance, l stress-free
        e = HINGED_ENDS * h / (stretch * (length if length else np.nan))
        e = e if outer_order == 0 else e * e
        if amplification > 1 and moment is not None and static_moment is not None:
            M = np.asarray(moment, float)
            Ms = abs(static_moment)
            dyn = amplification * np.abs(M - static_moment) / np.maximum(M, Ms)
            e = e * (Ms / np.maximum(M, Ms) + dyn)
            e = e + np.abs(resonant_frequency_error(tension, EI, mass, resonant_omega,
                                                    resonant_shift, discretisation)) * dyn
        if period_ratio is not None:
            e = e + np.nan_to_num(np.asarray(period_ratio, float) ** 2, nan=0.0)
        if junction and length:
            e = e + junction / (2.0 * length * np.tan(0.5 * np.asarray(delta, float)))
    return np.minimum(e, 1.0)


#: Largest relative change of the layer's moment by the tension's gradient along it
#: (asymptotics.gradient_moment_factor, the first-order route): beyond, the row is invalid.
MAX_GRADIENT_CORRECTION = 0.25
#: Largest angle Delta between the clamp direction and the anchor force that the layer
#: describes. The clamp turns the cable by Delta within the layer; beyond 90 degrees the
#: cable would leave the clamp backwards, which no taut cable does: such a force has the
#: wrong sign (the anchor's reaction instead of the span's force) or comes from a
#: mis-oriented clamp.
MAX_ANCHOR_ANGLE = np.pi / 2


def anchor_moments(forces: np.ndarray, direction: np.ndarray, EI: float, EA: float,
                   mass: float, accel: np.ndarray, load: np.ndarray, length: float,
                   omega: float | None = None, form: str = "exact",
                   outer_order: int = 0, amplification: float = 1.0,
                   static_moment: float | None = None,
                   resonant_omega: float | None = None,
                   resonant_shift: float | None = None,
                   discretisation: float | None = None, junction: float = 0.0
                   ) -> dict[str, np.ndarray]:
    """Anchor moment columns for one clamped anchor over ``n`` times.

    Rows with ``delta`` above :data:`MAX_ANCHOR_ANGLE` are invalid; ``invalid_reason``
    (n,) says why a row is invalid ("" when valid).

    Parameters
    ----------
    forces : (n, 3) force the span transmits at the anchor, into the span, N.
    direction : (3,) clamp direction into the cable.
    EI, EA : N m², N. mass : kg/m. length : stress-free cable length, m.
    accel : (n, 3) acceleration of the anchor, m/s². load : (3,) or (n, 3) distributed
        load per stress-free length at the anchor, weight included, N/m.
    omega : highest excitation circular frequency (rad/s) for the quasi-static check.
    outer_order : 0 for the leading-order outer solution, 1 with the virtual hinge: the
        order of ``error_estimate`` (:func:`error_estimate`); ``amplification`` and
        ``static_moment`` (N m) its resonance factor and the static moment it applies to;
        ``resonant_omega`` the resonant mode's circular frequency (its span-bending
        frequency error is amplified too; None when the outer problem bends) and
        ``resonant_shift`` that error measured on the mode (None: the taut beam's);
        ``discretisation`` its frequency error from the mesh and the time step;
        ``junction`` the offset a network leaves at the span's far end, m.
    """
    N = np.atleast_2d(np.asarray(forces, float))
    qs = (mass, omega) if omega else None
    lay = asymptotics.layer(N, direction, EI, EA, form=form, length=length, quasi_static=qs)
    kap = asymptotics.string_curvature(lay.tangent, lay.tension, mass, accel, load)
    m_layer = lay.moment
    steep = np.zeros(N.shape[0], bool)
    with np.errstate(invalid="ignore"):
        M = lay.moment_vector
        if outer_order == 1:  # the tension's gradient along the layer (theory.md §6.2)
            q = mass * np.asarray(accel, float) - np.asarray(load, float)
            grad = asymptotics.gradient_moment_factor(lay.delta, lay.tension, lay.tangent,
                                                      q, EI)
            M, m_layer = M * grad[:, None], m_layer * grad
            # a first-order correction above a quarter is no correction: the tension
            # changes across the layer by its own size
            steep = np.abs(grad - 1.0) > MAX_GRADIENT_CORRECTION
        M = M + EI * kap
    M = np.where(lay.slack[:, None], np.nan, M)
    with np.errstate(invalid="ignore"):
        backwards = lay.delta > MAX_ANCHOR_ANGLE  # NaN (slack) compares False
        long_ = lay.length_ratio > asymptotics.MAX_LENGTH_RATIO
        dynamic = lay.period_ratio > asymptotics.MAX_PERIOD_RATIO
    valid = lay.valid & ~backwards & ~steep
    reason = np.select(
        [lay.slack, backwards, ~lay.valid & long_, ~lay.valid & dynamic, ~lay.valid, steep],
        ["slack", "force more than 90 deg from the clamp direction", "layer too long",
         "layer not quasi-static", "undefined layer", "tension varies along the layer"],
        default="")
    return {"delta": lay.delta, "moment": np.linalg.norm(M, axis=1), "Mx": M[:, 0],
            "My": M[:, 1], "Mz": M[:, 2], "psi0": lay.psi0, "layer_length": lay.layer_length,
            "moment_layer": m_layer, "valid": valid.astype(int),
            "error_estimate": error_estimate(lay.delta, lay.tension, EI, EA, length,
                                             lay.period_ratio, outer_order, amplification,
                                             np.linalg.norm(M, axis=1), static_moment,
                                             mass, resonant_omega, resonant_shift,
                                             discretisation, junction),
            "invalid_reason": reason, "tension": lay.tension, "normal": lay.normal,
            "slack": lay.slack}


def composite_field(node_s: np.ndarray, r: np.ndarray, a: np.ndarray, EA: float, EI: float,
                    mass: float, load: np.ndarray, stations: np.ndarray,
                    anchor_s: list[float], deltas: np.ndarray, ells: np.ndarray,
                    normals: np.ndarray, tension_only: bool = True,
                    kinks: tuple | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Composite curvature along the cable at one time (docs/theory.md §4, docs/kinks.md).

    ``node_s`` (n,), ``r`` (n, 3), ``a`` (n, 3): stations, positions and accelerations of
    the string's nodes; ``stations`` (P,): where to evaluate; ``anchor_s``, ``deltas``,
    ``ells``, ``normals``: the clamped anchors (at ``s = 0`` or ``s = l``) and their layers.
    ``kinks``: ``(s, delta, ell, normal)`` of the interior kinks (K,), (K,), (K,), (K, 3):
    station, whole kink angle ``Δ_k``, layer length and unit normal ``e- × e+`` of the
    turn; each adds the clamped layer of angle ``Δ_k/2`` on both sides, in ``|s − s_k|``
    (the string turns by ``Δ_k`` at the node, which its straight P1 elements do not
    show: the layers add that turn, spread over a few ``ℓ``). NaN ``delta``: nothing.
    Returns positions (P, 3) and the composite curvature (P, 3) in 1/m, as vectors in the
    direction of increasing ``s`` (multiply by EI for the moment).
    The string's curvature on each P1 element uses the element's tangent and tension and
    the interpolated acceleration: P1 elements are straight, so their tangent is not
    differentiated.
    """
    pos = np.column_stack([np.interp(stations, node_s, r[:, k]) for k in range(3)])
    acc = np.column_stack([np.interp(stations, node_s, a[:, k]) for k in range(3)])
    e = np.clip(np.searchsorted(node_s, stations, side="right") - 1, 0, node_s.size - 2)
    chord = r[1:] - r[:-1]
    lam = np.linalg.norm(chord, axis=1) / np.diff(node_s)
    T = EA * (lam - 1.0)
    if tension_only:
        T = np.maximum(T, 0.0)
    tang = chord / np.linalg.norm(chord, axis=1)[:, None]
    ks = asymptotics.string_curvature(tang[e], T[e], mass, acc, load)
    ks = np.nan_to_num(ks, nan=0.0)  # slack element: no string curvature from tension
    L = node_s[-1]
    sig = [stations - s0 if s0 < 0.5 * L else L - stations for s0 in anchor_s]
    orient = [1.0 if s0 < 0.5 * L else -1.0 for s0 in anchor_s]
    half = np.asarray(deltas, float).reshape(-1)
    ells = np.asarray(ells, float).reshape(-1)
    normals = np.asarray(normals, float).reshape(-1, 3)
    if kinks is not None and len(kinks[0]):
        s_k, d_k, l_k, n_k = (np.asarray(x, float) for x in kinks)
        # both sides turn the same way: the same sign in the direction of travel
        sig += [np.abs(stations - s0) for s0 in s_k]
        orient += [1.0] * s_k.size
        half = np.concatenate([half, 0.5 * d_k])
        ells = np.concatenate([ells, l_k])
        normals = np.concatenate([normals, n_k.reshape(-1, 3)])
    if not sig:
        return pos, ks
    kap = asymptotics.composite_curvature(ks, np.array(sig), half, ells, normals,
                                          orientation=np.array(orient))
    return pos, kap


@dataclass
class ClampedAnchor:
    """What the anchor moments need of one clamped anchor: plain numbers and its motion."""

    name: str
    index: int  #: the anchor's place in the model's anchor list (the rows of its forces)
    direction: np.ndarray  #: unit clamp direction into the cable
    EI: float
    EA: float
    mass: float  #: kg/m, of the cable's section at the anchor
    motion: object = None  #: a :class:`cablefem.motion.Motion` (``acceleration(t)``) or None
    diameter: float | None = None  #: m, the fluid's diameter there (buoyancy; None: none)
    #: m, the span its layer is measured against (None: the cable's length)
    length: float | None = None
    #: m, the rod node offsets the string leaves at the span's far end (a network's)
    junction: float = 0.0

    def acceleration(self, times: np.ndarray) -> np.ndarray:
        """(n, 3) acceleration of the anchor at ``times``, m/s²."""
        return accelerations(self.motion, times)


class AnchorMoments:
    """The bending moment columns of ``anchors.csv`` (:data:`MOMENT_COLUMNS`) at every
    clamped anchor of a model, from anchor-force histories: :func:`anchor_moments` with
    the anchor's section, clamp direction and acceleration, the distributed load at the
    anchor at each time (the weight plus the case's distributed loads, time-dependent ones
    included), the span (the cable's length; a network's anchor: its chain of elements,
    ``model.anchor_span``), the highest excitation frequency ``omega`` and the
    inner solution's ``form``. Pure NumPy: :meth:`from_model` reads what it needs from a
    model once; the object holds no dolfinx or PETSc object.

    Use::

        moments = AnchorMoments.from_model(model, omega=32.8)
        cols = moments.compute(times, forces)   # forces (n, n_anchors, 3)
        cols["p"]["moment"]                     # (n,) N m at clamped anchor "p"
    """

    def __init__(self, anchors: list[ClampedAnchor], gravity: np.ndarray, length: float,
                 loads: list[tuple[np.ndarray, object]] = (), omega: float | None = None,
                 form: str = "exact", outer_order: int = 0,
                 buoyancy: np.ndarray | None = None) -> None:
        """``gravity``: (3,) acceleration of gravity, m/s²; ``loads``: (value (3,) N/m,
        time function with ``value(t)``) of each distributed load; ``buoyancy``: (3,) the
        buoyancy per length and per m² of section, ``-rho g`` (None: none), times the area
        of the diameter :meth:`load_at` is given."""
        self.anchors = list(anchors)
        self.gravity = np.asarray(gravity, float)
        self.length = float(length)
        self.loads = [(np.asarray(v, float), tf) for v, tf in loads]
        self.buoyancy = None if buoyancy is None else np.asarray(buoyancy, float)
        self.omega, self.form, self.outer_order = omega, form, outer_order
        #: resonance factor of the error estimate and static moment per anchor
        #: (:meth:`set_resonance`)
        self.amplification, self.static_moments = 1.0, {}
        self.resonant_omega = self.resonant_shift = self.discretisation = None
        self._by_name = {a.name: a for a in self.anchors}

    @classmethod
    def from_model(cls, model, omega: float | None = None, form: str = "exact"
                   ) -> AnchorMoments:
        """The clamped anchors of a model (a string, a network or a rod)."""
        fluid = getattr(model.case, "fluid", None)
        buoyancy = None
        if fluid is not None and fluid.buoyancy:  # the submerged weight at the anchors
            # (anchors below the surface), on each anchor's section's diameter
            buoyancy = -fluid.density * np.asarray(model.g_vec, float)
        clamped = [ClampedAnchor(a.name, i, np.asarray(a.direction, float), a.section.EI,
                                 a.section.EA, a.section.mass, a.motion,
                                 None if fluid is None else fluid.diameter_on(a.section),
                                 model.anchor_span(a.name),
                                 model.anchor_junction_offset(a.name))
                   for i, a in enumerate(model.anchors) if a.kind == "clamped"]
        loads = [(np.asarray(ld.value, float), ld.time) for _, ld in model.loads]
        order = 1 if model.hinges else 0
        return cls(clamped, model.g_vec, model.length, loads, omega, form, order, buoyancy)

    def set_resonance(self, amplification: float, static_forces,
                      resonant_omega: float | None = None,
                      resonant_shift: float | None = None,
                      discretisation: float | None = None) -> None:
        """Let the error estimate of the dynamic part of the moments grow by
        ``amplification`` (:func:`resonance`) about the static moments of the anchor
        forces ``static_forces`` (n_anchors, 3+) in the model's anchor order;
        ``resonant_omega``: the resonant mode's circular frequency, whose span-bending
        frequency error is amplified too (None when the outer problem has span bending);
        ``resonant_shift``: that error measured on the mode (None: the taut beam's);
        ``discretisation``: the mode's frequency error from the mesh and the time step."""
        self.amplification, self.resonant_omega, self.resonant_shift = 1.0, None, None
        self.discretisation = None
        F = np.asarray(static_forces, float)
        self.static_moments = {a.name: float(self.anchor(a.name, [0.0], F[a.index, None, :3])[
            "moment"][0]) for a in self.anchors}
        self.amplification = float(amplification)
        self.resonant_omega, self.resonant_shift = resonant_omega, resonant_shift
        self.discretisation = discretisation

    @property
    def names(self) -> list[str]:
        return [a.name for a in self.anchors]

    def load_at(self, t: float, mass: float, diameter: float | None = None) -> np.ndarray:
        """(3,) distributed load per stress-free length at ``t`` on a cable of ``mass``
        (kg/m) and, in a fluid with buoyancy, of ``diameter`` (m), weight and buoyancy
        included, N/m."""
        f = mass * self.gravity
        for value, tf in self.loads:
            f = f + value * tf.value(t)
        if self.buoyancy is not None:
            if diameter is None:
                raise ValueError("load_at: the buoyancy needs the cable's diameter")
            f = f + self.buoyancy * (np.pi * diameter**2 / 4)
        return f

    def loads_at(self, times: np.ndarray, mass: float, diameter: float | None = None
                 ) -> np.ndarray:
        """(n, 3) :meth:`load_at` at each of ``times``, the same numbers."""
        times = np.asarray(times, float).reshape(-1)
        f = np.tile(mass * self.gravity, (times.size, 1))
        for value, tf in self.loads:
            f = f + np.asarray(value)[None, :] * factors(tf, times)[:, None]
        if self.buoyancy is not None:
            if diameter is None:
                raise ValueError("load_at: the buoyancy needs the cable's diameter")
            f = f + self.buoyancy * (np.pi * diameter**2 / 4)
        return f

    def anchor_load(self, name: str, t: float) -> np.ndarray:
        """(3,) :meth:`load_at` on clamped anchor ``name``'s section at ``t``, N/m."""
        a = self._by_name[name]
        return self.load_at(t, a.mass, a.diameter)

    def anchor(self, name: str, times: np.ndarray, forces: np.ndarray) -> dict:
        """The columns of clamped anchor ``name`` (:func:`anchor_moments`'s dict) for its
        forces (n, 3) at ``times`` (n,)."""
        a = self._by_name[name]
        times = np.atleast_1d(np.asarray(times, float))
        load = self.loads_at(times, a.mass, a.diameter)
        return anchor_moments(np.asarray(forces, float)[:, :3], a.direction, a.EI, a.EA,
                              a.mass, a.acceleration(times), load,
                              self.length if a.length is None else a.length, self.omega,
                              self.form, self.outer_order, self.amplification,
                              self.static_moments.get(name), self.resonant_omega,
                              self.resonant_shift, self.discretisation, a.junction)

    def compute(self, times: np.ndarray, forces) -> dict[str, dict[str, np.ndarray]]:
        """Columns of every clamped anchor: ``{name: {column: (n,) array}}``. ``forces``:
        (n, n_anchors, 3) in the model's anchor order (as :func:`cablefem.dynamics.
        integrate` yields them, stacked), or a dict ``{name: (n, 3)}``."""
        out = {}
        for a in self.anchors:
            N = (forces[a.name] if isinstance(forces, dict)
                 else np.asarray(forces, float)[:, a.index])
            out[a.name] = self.anchor(a.name, times, N)
        return out


__all__ += ["AnchorMoments", "ClampedAnchor"]
