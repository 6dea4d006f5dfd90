"""A turbulent wind field along a cable (``[fluid.turbulence]``, ``docs/fluid.md``): the
longitudinal fluctuation ``u'(x, t)`` of a Kaimal or von Kármán spectrum (optionally the
lateral ``v'`` and vertical ``w'``, Kaimal, independent of it) with Davenport's exponential
coherence between points, generated reproducibly from a seed.

Pure NumPy (no dolfinx): :class:`cablefem.fluid.FluidMotion` evaluates the field at the
nodes and adds ``u' e_u + v' e_v + w' e_w`` (:func:`wind_frame`) to the fluid's velocity.

Method (spectral representation, Shinozuka and Deodatis; Veers): at ``n`` stations and
frequencies ``f_k = k Δf`` (``k = 1 .. N``, ``Δf = 1/duration``, ``N Δf <= f_max``), the
cross-spectral matrix ``S_ij(f) = S(f) coh(Δ_ij, f)`` with ``coh = exp(−C f Δ_ij / U)``
(``Δ_ij`` the distance between the stations) is factored as ``S(f) H Hᵀ`` (Cholesky; an
eigen-factor where Cholesky fails in round-off), and::

    u'_j(t) = Σ_k sqrt(2 S(f_k) Δf) Σ_m H_jm(f_k) cos(2π f_k t + φ_mk)

with independent phases ``φ_mk`` uniform in [0, 2π) from a generator seeded with ``seed``.
Each station's variance is ``Σ_k S(f_k) Δf`` (the spectrum's variance less its tails below
``Δf`` and above ``f_max``), the cross-spectrum of two stations is ``S coh`` exactly in
expectation. The sum is evaluated once by an inverse FFT on a grid of ``8 N`` times over the
period ``duration`` and interpolated linearly in time (the field repeats after
``duration``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cablefem.errors import CaseError
from cablefem.motion import ramp_factors

__all__ = ["wind_frame", "SPECTRA", "Turbulence", "TurbulentField", "spectrum", "davenport",
           "select_stations", "synthesise", "OVERSAMPLE", "VON_KARMAN", "MAX_STATIONS"]

#: the spectra known: their one-sided S(f) integrates to σ² over 0 < f < ∞
SPECTRA = ("kaimal", "von_karman")
#: time samples per period of the highest frequency on the synthesis grid (linear
#: interpolation between them: amplitude error at most (2π/8)²/8 = 8 % at f_max, below
#: 0.5 % at f_max/4)
OVERSAMPLE = 8
#: von Kármán's constant 70.8, exactly: (2 √π Γ(1/3) / Γ(5/6))² = 70.78, for which its
#: spectrum integrates to σ² (with 70.8: 1.4e-4 less)
#: most stations: one factorisation of an n x n matrix per frequency costs n^3/3 (1000
#: stations and 1200 frequencies: minutes); a larger spacing is asked for beyond
MAX_STATIONS = 1000
VON_KARMAN = (2.0 * math.sqrt(math.pi) * math.gamma(1 / 3) / math.gamma(5 / 6)) ** 2


def spectrum(kind: str, f, sigma: float, speed: float, length: float) -> np.ndarray:
    """One-sided spectrum ``S(f)`` (m²/s²/Hz) of the longitudinal fluctuation, of variance
    ``sigma²`` (``∫₀^∞ S df = σ²`` exactly for both)::

        kaimal      S = σ² (4 L/U) / (1 + 6 f L/U)^(5/3)
        von_karman  S = σ² (4 L/U) / (1 + 70.8 (f L/U)²)^(5/6)

    (70.8: :data:`VON_KARMAN`, to round-off).

    Args:
        kind: "kaimal" or "von_karman".
        f: Frequencies (Hz).
        sigma: Standard deviation σ (m/s).
        speed: Mean speed U (m/s), > 0.
        length: Integral length scale L (m), > 0.
    """
    n = np.asarray(f, float) * length / speed
    if kind == "kaimal":
        shape = (1.0 + 6.0 * n) ** (-5.0 / 3.0)
    elif kind == "von_karman":
        shape = (1.0 + VON_KARMAN * n**2) ** (-5.0 / 6.0)
    else:
        raise ValueError(f"kind must be one of {SPECTRA}, got {kind!r}")
    return sigma**2 * 4.0 * length / speed * shape


def davenport(f, distance, speed: float, decay: float) -> np.ndarray:
    """Davenport's coherence ``exp(−C f Δ / U)`` (the normalised cross-spectrum of two
    points ``Δ`` apart).

    Args:
        f: Frequencies (Hz).
        distance: Distances Δ (m).
        speed: Mean speed U (m/s).
        decay: Decay constant C.
    """
    return np.exp(-decay * np.asarray(f, float) * np.asarray(distance, float) / speed)


@dataclass(frozen=True)
class Turbulence:
    """The case's turbulence (``[fluid.turbulence]``): ``spectrum``, ``intensity``
    ``I = σ/U`` on the mean speed ``U = |fluid.current|``, ``length_scale`` L (m),
    ``coherence_decay`` C, ``seed``, station ``spacing`` (m; 0: every node a station),
    ``f_max`` (Hz), the field's period ``duration`` (s) and its build-up time ``ramp`` (s).

    Args:
        spectrum: One of :data:`SPECTRA`.
        intensity: Turbulence intensity, > 0.
        length_scale: Integral length scale (m), > 0.
        coherence_decay: Davenport's decay constant, >= 0.
        seed: Seed of the random phases, >= 0.
        spacing: Least distance between stations (m), >= 0.
        f_max: Highest frequency (Hz), > 0.
        duration: Period of the field (s), > 0.
        ramp: Build-up time from rest (s), >= 0, or None (3 L/U).
        lateral_intensity, vertical_intensity: σ_v/U and σ_w/U, >= 0 (0: none; Kaimal
            only).
        lateral_length_scale, vertical_length_scale: Their length scales (m), or None
            (IEC 61400-1's ratios to ``length_scale``).
    """

    spectrum: str
    intensity: float
    length_scale: float
    coherence_decay: float = 10.0
    seed: int = 1
    spacing: float = 0.0
    f_max: float = 2.0
    duration: float = 600.0
    ramp: float | None = None
    lateral_intensity: float = 0.0
    vertical_intensity: float = 0.0
    lateral_length_scale: float | None = None
    vertical_length_scale: float | None = None

    def component(self, c: int) -> tuple[float, float]:
        """``(intensity, length scale)`` of component ``c`` (0 longitudinal, 1 lateral,
        2 vertical); the transverse length scales default to IEC 61400-1's Kaimal ratios
        (2.7/8.1 and 0.66/8.1 of the longitudinal one)."""
        if c == 0:
            return self.intensity, self.length_scale
        if c == 1:
            return self.lateral_intensity, (self.lateral_length_scale or
                                            self.length_scale * 2.7 / 8.1)
        return self.vertical_intensity, (self.vertical_length_scale or
                                         self.length_scale * 0.66 / 8.1)

    def ramp_time(self, speed: float) -> float:
        """The build-up time (s): ``ramp``, or three integral time scales ``3 L/U``."""
        return 3.0 * self.length_scale / speed if self.ramp is None else float(self.ramp)

    def describe(self) -> dict:
        return {"spectrum": self.spectrum, "intensity": self.intensity,
                "length_scale": self.length_scale, "coherence_decay": self.coherence_decay,
                "seed": self.seed, "spacing": self.spacing, "f_max": self.f_max,
                "duration": self.duration, "ramp": self.ramp,
                "lateral_intensity": self.lateral_intensity,
                "vertical_intensity": self.vertical_intensity,
                "lateral_length_scale": self.component(1)[1],
                "vertical_length_scale": self.component(2)[1]}


def select_stations(points, spacing: float) -> np.ndarray:
    """The stations among ``points`` (m, 3): their distinct rows in lexicographic order,
    each kept when it is at least ``spacing`` from every station kept before (0: all). The
    same points in any order give the same stations (every rank, every run)."""
    pts = np.unique(np.round(np.asarray(points, float).reshape(-1, 3), 9), axis=0)
    if spacing <= 0:
        return pts
    keep = [pts[0]]
    for p in pts[1:]:
        if np.min(np.linalg.norm(np.asarray(keep) - p, axis=1)) >= spacing:
            keep.append(p)
    return np.asarray(keep)


def _factor(coh: np.ndarray) -> np.ndarray:
    """A factor H with H Hᵀ = coh: Cholesky, or the eigen-factor if round-off makes the
    (positive definite) exponential coherence matrix fail it."""
    try:
        return np.linalg.cholesky(coh)
    except np.linalg.LinAlgError:
        lam, vec = np.linalg.eigh(coh)
        return vec * np.sqrt(np.maximum(lam, 0.0))


def synthesise(spec: Turbulence, stations: np.ndarray, speed: float, component: int = 0):
    """The field's time series at ``stations`` (n, 3) for mean speed ``speed`` (m/s):
    ``component`` 0 (longitudinal, phases from ``default_rng(seed)``), 1 (lateral) or 2
    (vertical; phases from ``default_rng([seed, component])``: independent of the others).

    Returns:
        ``(times, u, du)``: (N_t,) times over one period, (N_t, n) fluctuation (m/s) and its
        time derivative (m/s²) at the stations.
    """
    stations = np.asarray(stations, float).reshape(-1, 3)
    n = stations.shape[0]
    df = 1.0 / spec.duration
    nf = max(1, int(math.floor(spec.f_max / df + 1e-9)))
    f = df * np.arange(1, nf + 1)
    intensity, length = spec.component(component)
    amp = np.sqrt(2.0 * spectrum(spec.spectrum, f, intensity * speed, speed, length) * df)
    rng = np.random.default_rng(spec.seed if component == 0 else [spec.seed, component])
    phases = np.exp(1j * rng.uniform(0.0, 2.0 * math.pi, (nf, n)))
    dist = np.linalg.norm(stations[:, None, :] - stations[None, :, :], axis=2)
    nt = 2 * ((OVERSAMPLE * (nf + 1) + 1) // 2)  # even, OVERSAMPLE samples a period of f_max
    coef = np.zeros((nt // 2 + 1, n), complex)
    for k in range(nf):
        H = _factor(davenport(f[k], dist, speed, spec.coherence_decay))
        coef[k + 1] = amp[k] * (H @ phases[k])
    coef *= nt / 2.0  # irfft: x_n = (2/N) Re Σ X_k e^{2πi k n/N} for 0 < k < N/2
    freq = np.zeros(nt // 2 + 1)
    freq[1:nf + 1] = f
    u = np.fft.irfft(coef, nt, axis=0)
    du = np.fft.irfft(coef * (2j * math.pi * freq)[:, None], nt, axis=0)
    return spec.duration / nt * np.arange(nt), u, du


def wind_frame(current, up, spec: Turbulence | None = None, source: str = "<dict>"):
    """The rows ``e_u`` (along ``current``), ``e_v = up × e_u / |up × e_u|`` (lateral,
    horizontal) and ``e_w = e_u × e_v`` (vertical for a horizontal wind) of the turbulence's
    components.

    Raises:
        CaseError: Transverse components asked for in a wind along ``up`` (``fluid.current``).
    """
    e_u = np.asarray(current, float) / np.linalg.norm(current)
    side = np.cross(np.asarray(up, float), e_u)
    if np.linalg.norm(side) < 1e-6:
        if spec is not None and (spec.lateral_intensity > 0 or spec.vertical_intensity > 0):
            raise CaseError([("fluid.current", "the lateral and vertical turbulence need a "
                              "mean wind that is not along gravity")], source)
        side = np.cross(e_u, np.eye(3)[int(np.argmin(np.abs(e_u)))])  # unused: no v, w
    e_v = side / np.linalg.norm(side)
    return np.vstack([e_u, e_v, np.cross(e_u, e_v)])


class TurbulentField:
    """The field at given points: synthesised at the stations chosen among ``points``
    (:func:`select_stations`), each point's value linear between its two nearest stations
    (weights inversely proportional to the distances: linear interpolation for a point on
    the segment between them).

    Args:
        spec: The :class:`Turbulence`.
        points: (m, 3) all points of the cable (every rank's: the stations come from them).
        speed: Mean speed U (m/s), > 0.
        source: The case file, named in the error of too many stations.

    Raises:
        CaseError: More than :data:`MAX_STATIONS` stations (``fluid.turbulence.spacing``).
    """

    def __init__(self, spec: Turbulence, points, speed: float,
                 source: str = "<dict>") -> None:
        self.spec, self.speed = spec, float(speed)
        self.stations = select_stations(points, spec.spacing)
        if self.stations.shape[0] > MAX_STATIONS:
            raise CaseError([("fluid.turbulence.spacing", f"{self.stations.shape[0]} stations "
                              f"at spacing {spec.spacing:g} m, above {MAX_STATIONS}: give a "
                              "larger spacing")], source)
        self.times, self.u, self.du = synthesise(spec, self.stations, self.speed)
        self.dt = self.times[1] - self.times[0]
        #: the (u, du) series of each component (None: not generated)
        self.series = [(self.u, self.du)] + [
            synthesise(spec, self.stations, self.speed, c)[1:]
            if spec.component(c)[0] > 0 else None for c in (1, 2)]

    def weights(self, points) -> tuple[np.ndarray, np.ndarray]:
        """``(index, weight)``, each (m, 2): the two nearest stations of each point and
        their weights."""
        pts = np.asarray(points, float).reshape(-1, 3)
        d = np.linalg.norm(pts[:, None, :] - self.stations[None, :, :], axis=2)
        if self.stations.shape[0] == 1:
            return np.zeros((pts.shape[0], 2), int), np.full((pts.shape[0], 2), 0.5)
        idx = np.argsort(d, axis=1, kind="stable")[:, :2]
        dd = np.take_along_axis(d, idx, axis=1)
        w = dd[:, ::-1].copy()  # w_1 ∝ d_2, w_2 ∝ d_1
        tot = w.sum(axis=1)
        w[tot == 0] = 0.5
        w /= np.where(tot == 0, 1.0, tot)[:, None]
        return idx, w

    def at_stations(self, t: float, component: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Fluctuation of ``component`` and its derivative at the stations at time ``t``
        (periodic; zero for a component not generated)."""
        if self.series[component] is None:
            return np.zeros(self.stations.shape[0]), np.zeros(self.stations.shape[0])
        u, du = self.series[component]
        s = (t % self.spec.duration) / self.dt
        i = int(math.floor(s))
        r = s - i
        j = (i + 1) % self.times.size
        i %= self.times.size
        return ((1 - r) * u[i] + r * u[j], (1 - r) * du[i] + r * du[j])

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The three components (n, 3: longitudinal, lateral, vertical) and their
        derivatives at the stations, built up from rest over the ramp
        (:func:`cablefem.motion.ramp_factors`: ``r u'`` and ``r u̇' + ṙ u'``): the cable
        starts from its static state in the mean wind, which statics solves."""
        n = self.stations.shape[0]
        r, dr, _ = ramp_factors(t, self.spec.ramp_time(self.speed))
        if r == 0.0 and dr == 0.0:
            return np.zeros((n, 3)), np.zeros((n, 3))
        parts = [self.at_stations(t, c) for c in range(3)]
        u = np.column_stack([p[0] for p in parts])
        du = np.column_stack([p[1] for p in parts])
        return r * u, r * du + dr * u
