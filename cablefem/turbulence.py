"""A turbulent wind field along a cable (``[fluid.turbulence]``, ``docs/fluid.md``): the
longitudinal fluctuation ``u'(x, t)`` of a Kaimal or von Kármán spectrum with Davenport's
exponential coherence between points, generated reproducibly from a seed.

Pure NumPy (no dolfinx): :class:`cablefem.fluid.FluidMotion` evaluates the field at the
nodes and adds ``u' e_U`` (``e_U`` the mean wind's direction) to the fluid's velocity.

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

__all__ = ["SPECTRA", "Turbulence", "TurbulentField", "spectrum", "davenport",
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

    def ramp_time(self, speed: float) -> float:
        """The build-up time (s): ``ramp``, or three integral time scales ``3 L/U``."""
        return 3.0 * self.length_scale / speed if self.ramp is None else float(self.ramp)

    def describe(self) -> dict:
        return {"spectrum": self.spectrum, "intensity": self.intensity,
                "length_scale": self.length_scale, "coherence_decay": self.coherence_decay,
                "seed": self.seed, "spacing": self.spacing, "f_max": self.f_max,
                "duration": self.duration, "ramp": self.ramp}


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


def synthesise(spec: Turbulence, stations: np.ndarray, speed: float):
    """The field's time series at ``stations`` (n, 3) for mean speed ``speed`` (m/s).

    Returns:
        ``(times, u, du)``: (N_t,) times over one period, (N_t, n) fluctuation (m/s) and its
        time derivative (m/s²) at the stations.
    """
    stations = np.asarray(stations, float).reshape(-1, 3)
    n = stations.shape[0]
    df = 1.0 / spec.duration
    nf = max(1, int(math.floor(spec.f_max / df + 1e-9)))
    f = df * np.arange(1, nf + 1)
    amp = np.sqrt(2.0 * spectrum(spec.spectrum, f, spec.intensity * speed, speed,
                                 spec.length_scale) * df)
    rng = np.random.default_rng(spec.seed)
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

    def at_stations(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Fluctuation and its derivative at the stations at time ``t`` (periodic)."""
        s = (t % self.spec.duration) / self.dt
        i = int(math.floor(s))
        r = s - i
        j = (i + 1) % self.times.size
        i %= self.times.size
        return ((1 - r) * self.u[i] + r * self.u[j], (1 - r) * self.du[i] + r * self.du[j])

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`at_stations` built up from rest over the ramp
        (:func:`cablefem.motion.ramp_factors`: ``r u'`` and ``r u̇' + ṙ u'``): the cable
        starts from its static state in the mean wind, which statics solves."""
        r, dr, _ = ramp_factors(t, self.spec.ramp_time(self.speed))
        if r == 0.0 and dr == 0.0:
            return np.zeros(self.stations.shape[0]), np.zeros(self.stations.shape[0])
        u, du = self.at_stations(t)
        return r * u, r * du + dr * u
