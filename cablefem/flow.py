"""The fluid's own motion around a cable (``docs/fluid.md``): a current or mean wind that
varies with elevation, regular (Airy) waves and a uniform velocity history.

Pure NumPy (no dolfinx): :mod:`cablefem.fluid` turns these into the Morison forces.

* :class:`Profile` — the factor ``f(z)`` on the case's ``current`` at elevation ``z``
  (along −gravity): piecewise linear through a table (held beyond its ends), or the power
  law ``((z − ground)/reference)^exponent`` of a mean wind, held below 1 % of the reference
  height (:data:`POWER_FLOOR`).
* :class:`AiryWave` — one linear (Airy) wave component of height ``H`` (crest to trough),
  period ``T`` and horizontal direction ``d`` on water of depth ``h`` (None: deep)::

      θ = k d·x − ω t + φ,   ω² = g k tanh(k h)
      u = ½ H ω [cosh(k(ζ + h)) d cos θ + sinh(k(ζ + h)) e_z sin θ] / sinh(k h)
      u̇ = ½ H ω² [cosh(k(ζ + h)) d sin θ − sinh(k(ζ + h)) e_z cos θ] / sinh(k h)

  with ``ζ`` the elevation below the mean free surface (the deep-water limit ``e^{kζ}`` for
  both ratios). Above the mean surface the kinematics are those at ``ζ = 0`` (constant
  extrapolation; the cable's wetness is decided by the mean surface). Irregular seas are
  sums of components.
* :class:`VelocitySeries` — a uniform velocity history (turbulent wind, a measured orbital
  velocity): a C2 cubic spline through a table ``time,vx,vy,vz``; its derivative is the
  fluid's acceleration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from cablefem.motion import ramp_factors
from cablefem.timetables import Spline, check_table, read_csv

__all__ = ["Profile", "AiryWave", "VelocitySeries", "wave_number", "wave_kinematics",
           "WaveField",
           "read_velocity_csv", "flow_problems", "POWER_FLOOR", "jonswap", "jonswap_waves"]

#: the power-law profile is held below this fraction of its reference height (the law's
#: slope is infinite at the ground)
POWER_FLOOR = 0.01


@dataclass(frozen=True, eq=False)
class Profile:
    """The factor on the current (or mean wind) at elevation ``z`` (m, along −gravity).

    ``kind`` "table": piecewise linear through ``(elevations, factors)`` (>= 2 rows,
    elevations strictly increasing), held at the end values beyond the table. ``kind``
    "power": ``(max(z − ground, POWER_FLOOR reference)/reference)^exponent``.

    Args:
        kind: "table" or "power".
        elevations, factors: The table's rows (m, -), for "table".
        reference: Reference height (m), > 0, for "power".
        exponent: The power law's exponent, >= 0.
        ground: The ground's elevation (m), for "power".

    Raises:
        ValueError: Naming the argument out of range.
    """

    kind: str
    elevations: np.ndarray | None = None
    factors: np.ndarray | None = None
    reference: float = 10.0
    exponent: float = 0.0
    ground: float = 0.0

    def __post_init__(self) -> None:
        if self.kind == "table":
            z, f = check_table(self.elevations, self.factors, None)
            object.__setattr__(self, "elevations", z)
            object.__setattr__(self, "factors", f)
        elif self.kind == "power":
            if not (math.isfinite(self.reference) and self.reference > 0):
                raise ValueError(f"reference must be > 0 (m), got {self.reference!r}")
            if not (math.isfinite(self.exponent) and self.exponent >= 0):
                raise ValueError(f"exponent must be >= 0, got {self.exponent!r}")
        else:
            raise ValueError(f"kind must be 'table' or 'power', got {self.kind!r}")

    def segments(self):
        """Table: ``(z_i, z_{i+1}, slope_i)`` of each segment (the factor is
        ``factors[0] + Σ slope_i (clip(z, z_i, z_{i+1}) − z_i)``)."""
        z, f = self.elevations, self.factors
        return [(z[i], z[i + 1], (f[i + 1] - f[i]) / (z[i + 1] - z[i]))
                for i in range(z.size - 1)]

    def __call__(self, z) -> np.ndarray:
        """The factor at elevations ``z`` (array)."""
        z = np.asarray(z, dtype=float)
        if self.kind == "table":
            return np.interp(z, self.elevations, self.factors)
        height = np.maximum(z - self.ground, POWER_FLOOR * self.reference)
        return (height / self.reference) ** self.exponent

    def describe(self) -> dict:
        if self.kind == "table":
            return {"type": "table", "elevation": self.elevations.tolist(),
                    "factor": self.factors.tolist()}
        return {"type": "power", "reference": self.reference, "exponent": self.exponent,
                "ground": self.ground}


def wave_number(omega: float, g: float, depth: float | None) -> float:
    """The root ``k`` of the dispersion relation ``ω² = g k tanh(k h)`` (``h = depth``;
    None: deep water, ``k = ω²/g``), by Newton from the deep-water value.

    Args:
        omega: Circular frequency (rad/s).
        g: Gravitational acceleration (m/s²).
        depth: Water depth (m), or None.

    Returns:
        The wave number (1/m).
    """
    k = omega**2 / g
    if depth is None:
        return k
    k = max(k, omega / math.sqrt(g * depth))  # the larger of the deep and shallow limits
    for _ in range(100):
        th = math.tanh(k * depth)
        f = g * k * th - omega**2
        df = g * th + g * k * depth * (1.0 - th**2)
        step = f / df
        k -= step
        if abs(step) < 1e-14 * k:
            return k
    raise ArithmeticError(f"no wave number for omega = {omega!r}, depth = {depth!r}")


@dataclass(frozen=True, eq=False)
class AiryWave:
    """A linear wave component: ``height`` (m, crest to trough), ``period`` (s), unit
    horizontal ``direction`` of travel, ``phase`` φ (rad): the surface elevation is
    ``½ H cos(k d·x − ω t + φ)``.

    Args:
        height: Wave height (m).
        period: Period (s).
        direction: (3,) unit horizontal direction of travel.
        phase: Phase (rad).
        key: The case key it comes from when not its own ``[[fluid.waves]]`` entry.
    """

    height: float
    period: float
    direction: np.ndarray
    phase: float = 0.0
    #: the case key it comes from when not its own [[fluid.waves]] entry (a spectrum's)
    key: str | None = None

    @property
    def omega(self) -> float:
        return 2.0 * math.pi / self.period

    def describe(self) -> dict:
        return {"height": self.height, "period": self.period,
                "direction": np.asarray(self.direction, float).tolist(), "phase": self.phase}


def jonswap(omega, hs: float, tp: float, gamma: float = 3.3) -> np.ndarray:
    """The JONSWAP spectrum of the surface elevation S(ω) (m² s), one-sided, of significant
    height ``hs`` (m), peak period ``tp`` (s) and peak enhancement ``gamma`` (1: the
    Pierson-Moskowitz spectrum), in DNV's form (DNV-RP-C205)::

        S(ω) = A_γ (5/16) Hs² ωp⁴ ω⁻⁵ exp(−(5/4)(ωp/ω)⁴) γ^exp(−(ω−ωp)²/(2σ²ωp²))

    ``σ`` = 0.07 below the peak and 0.09 above, ``A_γ = 1 − 0.287 ln γ`` the normalisation
    that keeps ``∫ S dω`` at ``Hs²/16`` (to about 1 % for γ from 1 to 7).

    Args:
        omega: Circular frequencies (rad/s).
        hs: Significant wave height (m).
        tp: Peak period (s).
        gamma: Peak enhancement factor.

    Returns:
        S(ω) at ``omega`` (0 at ω <= 0).
    """
    w = np.asarray(omega, float)
    wp = 2.0 * math.pi / tp
    sigma = np.where(w <= wp, 0.07, 0.09)
    peak = gamma ** np.exp(-((w - wp) ** 2) / (2.0 * sigma**2 * wp**2))
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        pm = 5.0 / 16.0 * hs**2 * wp**4 * w**-5.0 * np.exp(-1.25 * (wp / w) ** 4)
    return np.where(w > 0, (1.0 - 0.287 * math.log(gamma)) * pm * peak, 0.0)


def jonswap_waves(hs: float, tp: float, direction, gamma: float = 3.3,
                  components: int = 60, seed: int = 1, low: float = 0.5,
                  high: float = 3.0) -> list[AiryWave]:
    """An irregular long-crested sea of the JONSWAP spectrum (:func:`jonswap`) as
    ``components`` Airy waves travelling along ``direction``: the band ``[low, high]``
    times the peak frequency in equal bins, one component per bin at a frequency drawn
    uniformly in it (the sea then does not repeat after 2π/Δω), of amplitude
    ``sqrt(2 S(ω_i) Δω)`` (its variance ``S Δω``) and a random phase, from a generator
    seeded with ``seed`` (the same sea on every rank and in every run).

    Args:
        hs: Significant wave height (m).
        tp: Peak period (s).
        direction: (3,) unit horizontal direction of travel.
        gamma: Peak enhancement factor.
        components: Number of components.
        seed: Seed of the random frequencies and phases.
        low, high: The band, in multiples of the peak frequency.

    Returns:
        The components of nonzero amplitude.
    """
    rng = np.random.default_rng(seed)
    wp = 2.0 * math.pi / tp
    edges = np.linspace(low * wp, high * wp, components + 1)
    dw = np.diff(edges)
    w = edges[:-1] + rng.uniform(0.0, 1.0, components) * dw
    amp = np.sqrt(2.0 * jonswap(w, hs, tp, gamma) * dw)
    phases = rng.uniform(0.0, 2.0 * math.pi, components)
    d = np.asarray(direction, float)
    return [AiryWave(float(2.0 * a), float(2.0 * math.pi / wi), d, float(ph), "fluid.spectrum")
            for a, wi, ph in zip(amp, w, phases) if a > 0]


class WaveField:
    """The sum of Airy ``waves`` (:class:`AiryWave`) on water of ``depth`` (None: deep),
    the mean surface at elevation ``surface`` along the unit vector ``up`` (against
    gravity), built up over ``ramp`` seconds (:func:`cablefem.motion.ramp_factors`). The
    wave numbers, amplitudes and directions are found once; :meth:`at` evaluates every
    component at once (arrays of points by components), what a time step needs once per
    new time."""

    def __init__(self, waves, up, surface: float, depth: float | None, g: float,
                 ramp: float = 0.0) -> None:
        self.up = np.asarray(up, dtype=float)
        self.surface, self.depth, self.ramp = surface, depth, float(ramp)
        waves = list(waves)
        self.omega = np.array([w.omega for w in waves], dtype=float)
        self.k = np.array([wave_number(w.omega, g, depth) for w in waves], dtype=float)
        self.amp = np.array([0.5 * w.height * w.omega for w in waves], dtype=float)
        self.phase = np.array([w.phase for w in waves], dtype=float)
        self.D = np.array([np.asarray(w.direction, dtype=float) for w in waves],
                          dtype=float).reshape(-1, 3)
        self.Dk = self.D.T * self.k  # (3, components): θ = x·D k − (ω t − φ)
        # cosh(k(ζ + h))/sinh(k h) and sinh(k(ζ + h))/sinh(k h) from exponentials of
        # non-positive arguments (no overflow in deep water, no loss of accuracy), the
        # amplitude ½ H ω folded in; in deep water (no depth) both e^{kζ}
        self.amp_den = self.amp
        self._at = None  # (the points' bytes, what depends on them alone): see at()
        if depth is not None:
            self.amp_den = self.amp / (1.0 - np.exp(-2.0 * self.k * depth))
            self.two_kh = 2.0 * self.k * depth

    def _depth_ratios(self, zeta: np.ndarray):
        """The two depth ratios at elevations ``zeta`` below the surface, times ½ H ω."""
        if self.depth is None:
            e = np.exp(np.multiply.outer(zeta, self.k)) * self.amp  # (points, components)
            return e, e
        kz = np.multiply.outer(np.maximum(zeta, -self.depth), self.k)  # below the seabed:
        a, b = np.exp(kz), np.exp(-kz - self.two_kh)  # the bottom's kinematics
        return (a + b) * self.amp_den, (a - b) * self.amp_den

    def at(self, points: np.ndarray, t: float):
        """``(velocity, acceleration)``, each (n, 3), at ``points`` (n, 3) at time ``t``.
        What depends on the points alone (the depth ratios, the phase's part ``x·D k``) is
        kept for the next call at the same points (a time step evaluates the waves at two
        times at the positions of the last converged state): the same numbers."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        r, dr, _ = ramp_factors(t, self.ramp)
        if (r == 0.0 and dr == 0.0) or self.k.size == 0:
            return np.zeros_like(points), np.zeros_like(points)
        key = points.tobytes()
        if self._at is None or self._at[0] != key:
            self._at = (key, *self._depth_ratios(np.minimum(points @ self.up - self.surface,
                                                            0.0)), points @ self.Dk)
        _, ach, ash, xk = self._at
        theta = xk - (self.omega * t - self.phase)
        c, s = np.cos(theta), np.sin(theta)
        hc, hs, vs, vc = ach * c, ach * s, ash * s, ash * c
        u = hc @ self.D + np.multiply.outer(vs.sum(axis=1), self.up)
        du = (hs * self.omega) @ self.D - np.multiply.outer(vc @ self.omega, self.up)
        if self.ramp == 0.0 or r == 1.0 and dr == 0.0:  # built up
            return u, du
        return r * u, r * du + dr * u


def wave_kinematics(waves, points: np.ndarray, t: float, up: np.ndarray, surface: float,
                    depth: float | None, g: float, ramp: float = 0.0):
    """Velocity and acceleration (each (n, 3)) of the sum of ``waves`` at ``points`` (n, 3)
    at time ``t``; ``up`` is the unit vector against gravity, ``surface`` the mean surface's
    elevation along it. ``ramp`` > 0 (s) builds the waves up smoothly from rest
    (:func:`cablefem.motion.ramp_factors`: ``r u`` and ``r u̇ + ṙ u``). A time stepper
    keeps a :class:`WaveField` instead (the wave numbers found once).

    Args:
        waves: The :class:`AiryWave` components.
        points: (n, 3) positions (m).
        t: Time (s).
        up: (3,) unit vector against gravity.
        surface: Elevation of the mean free surface along ``up`` (m).
        depth: Water depth (m), or None (deep water).
        g: Gravitational acceleration (m/s²).
        ramp: Build-up time (s), >= 0.

    Returns:
        ``(velocity, acceleration)``, each (n, 3).
    """
    return WaveField(waves, up, surface, depth, g, ramp).at(points, t)


@dataclass(frozen=True, eq=False)
class VelocitySeries:
    """A uniform fluid velocity history (m/s): C2 cubic spline (not-a-knot ends) through
    ``(times, values)``, held outside the table (acceleration zero there).

    Args:
        times: (n,) strictly increasing times (s), n >= 2.
        values: (n, 3) velocities (m/s).
        source: The file the table came from, or None.
        hold: The case accepts that the table ends before ``dynamics.t_end``.
    """

    times: np.ndarray
    values: np.ndarray
    source: str | None = None
    hold: bool = False
    _spline: Spline = field(init=False, repr=False)

    def __post_init__(self) -> None:
        times, values = check_table(self.times, self.values, 3)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "_spline", Spline(times, values))

    def velocity(self, t: float) -> np.ndarray:
        return self._spline(t)

    def acceleration(self, t: float) -> np.ndarray:
        return self._spline(t, 1)

    def describe(self) -> dict:
        out: dict = {"type": "table", "file": self.source, "rows": int(self.times.size),
                     "interpolation": "cubic spline, not-a-knot", "hold": self.hold}
        if self.source is None:
            out.update(times=self.times.tolist(), values=self.values.tolist())
        return out


def read_velocity_csv(path, key: str = "file") -> VelocitySeries:
    """A velocity history from a CSV file with the header ``time,vx,vy,vz`` (s, m/s); the
    rules and errors of :func:`cablefem.motion.read_motion_csv`.

    Args:
        path: The CSV file.
        key: Key path reported in errors.
    """
    times, values = read_csv(path, ("time", "vx", "vy", "vz"), key)
    return VelocitySeries(times, values, source=str(path))


def flow_problems(fluid, gravity) -> list[tuple[str, str]]:
    """``(key, message)`` of a fluid's motion that does not fit the case: waves without a
    free surface or without gravity, or not travelling horizontally.

    Args:
        fluid: The :class:`cablefem.description.Fluid`.
        gravity: The :class:`cablefem.description.Gravity`, or None.
    """
    out: list[tuple[str, str]] = []
    if not fluid.waves:
        return out
    if fluid.surface is None:
        out.append(("fluid.waves", "waves need the free surface: give fluid.surface"))
    if gravity is None:
        return out
    if not gravity.g > 0:
        out.append(("fluid.waves", "waves need gravity (gravity.g > 0)"))
    gdir = np.asarray(gravity.direction, dtype=float)
    gdir = gdir / np.linalg.norm(gdir)
    for i, w in enumerate(fluid.waves):
        c = float(np.dot(np.asarray(w.direction, float), gdir))
        key = f"{w.key or f'fluid.waves[{i}]'}.direction"
        if abs(c) > 1e-6 and key not in {k for k, _ in out}:
            out.append((key, f"must be horizontal (normal to gravity), its component along "
                        f"gravity is {c:.3g}"))
    return out
