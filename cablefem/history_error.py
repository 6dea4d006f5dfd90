"""The error a moment history gets from the string's frequency errors (docs/theory.md §5.4).

The string's modes are off by a small relative error ``δ_k`` (its mesh, the outer
problem's neglected terms: the modal table's ``error_estimate``; the time step's, which
every run at that step shares, is left out as from the rows' estimate). A response that
follows the load quasi-statically hardly feels it; two parts of a history do:

* *a line near a resonance*. The response at a harmonic ``ν`` of the excitation (``Ω/2``
  to ``6Ω``: a cable's geometric nonlinearity puts them in) changes by
  ``H(ν; ω_k (1 + δ_k)) / H(ν; ω_k)`` with ``H = 1/(ω² - ν² + 2iζων)``: by
  ``δ/sqrt(δ² + ζ²)`` of itself at exact tuning. A harmonic ``2Ω`` next to a mode is a
  superharmonic resonance: the rows' estimate, which looks at ``Ω`` and ``Ω/2``, does not
  see it;
* *the free vibration*: what the response holds beside the lines (the start's transient,
  which decays as ``exp(-ζωt)``, or, under a random excitation, all of it). At frequency
  ``ω`` its phase drifts by ``δ(ω) ω τ``, ``τ`` the time since it started: the run's time
  for a transient, at most ``1/(2ζω)`` (the response's memory) under a random excitation.

:func:`history_error` works on the anchor force (the response): it fits the lines over the
statistics window by least squares, changes each by its ratio, turns the phase of the
rest's spectrum (frequencies next to a line go with the line: its build-up and beating are
locked to the excitation), and compares the moment of the changed force with the moment
(the moment's own nonlinear dependence on the force, harmonics included, taken exactly):
the estimated RMS error of the moment over the window, relative to its RMS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["HARMONICS", "MAX_LINES", "Spectrum", "excitation", "history_error"]

#: the excitation's harmonics fitted as lines, half of it included (a parametric response)
HARMONICS = (0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
#: the odd multiples of half the excitation's frequency (a parametric response's own
#: harmonics), fitted when the half line holds this much of the force's fluctuation
HALF_LINE = 0.05
#: the frequencies within this many resolutions ``2 pi/T`` of a line go with the line (its
#: amplitude's build-up or beating: locked to the excitation, not a free vibration)
LINE_BAND = 1.5
#: an excitation of more harmonic components than this (a sea of many Airy waves) is
#: treated as random: its lines would not be told apart over a window
MAX_LINES = 3
#: a line above the highest computed mode (times this) cannot be checked for a resonance
UNCHECKED_MARGIN = 1.1
#: a line whose RMS is below this fraction of the history's cannot add more than twice it
#: to the error (its phase off altogether): below half the warning threshold (5 %) it is
#: not worth a warning when it cannot be checked
MIN_LINE_SHARE = 0.025


@dataclass
class Spectrum:
    """What the estimate knows of the model's modes: their circular frequencies (rad/s,
    ascending), each one's relative frequency error (its size) and damping ratio."""

    omegas: np.ndarray
    errors: np.ndarray
    zetas: np.ndarray

    def error_at(self, omega: np.ndarray) -> np.ndarray:
        """The relative frequency error at ``omega``: the modes' interpolated, the lowest
        mode's below it, and above the highest growing as ``omega²`` (the mesh's and the
        time step's errors both do, to leading order)."""
        w = np.asarray(omega, float)
        out = np.interp(w, self.omegas, self.errors)
        top = w > self.omegas[-1]
        out[top] = self.errors[-1] * (w[top] / self.omegas[-1]) ** 2
        return out

    def zeta_at(self, omega: np.ndarray) -> np.ndarray:
        """The damping ratio of the mode nearest each ``omega``."""
        w = np.asarray(omega, float)
        k = np.argmin(np.abs(w[:, None] - self.omegas[None, :]), axis=1)
        return self.zetas[k]


def excitation(case) -> tuple[list[float], bool]:
    """The circular frequencies (rad/s) of the case's harmonic excitations (anchor motions,
    loads' time laws, a few Airy waves) and whether anything else excites it (a table, a
    velocity history, turbulence, a sea of many waves): then the response is random."""
    lines, random = [], False

    def law(describe: dict) -> None:
        nonlocal random
        kind = describe.get("type", describe.get("kind"))
        if kind in (None, "constant"):
            return
        w = describe.get("omega")
        if kind in ("harmonic", "ellipse") and w is not None:
            amp = describe.get("amplitude")
            ws = np.broadcast_to(np.atleast_1d(np.asarray(w, float)), (3,)) \
                if amp is not None else np.atleast_1d(np.asarray(w, float))
            if amp is not None:
                ws = ws[np.asarray(amp, float) != 0]
            lines.extend(float(x) for x in ws if x > 0)
        else:
            random = True

    for a in case.anchors:
        if a.motion is not None:
            law(a.motion.describe())
    for ld in list(case.loads) + list(case.point_loads):
        law(ld.time.describe() if hasattr(ld.time, "describe") else {})
    fluid = getattr(case, "fluid", None)
    if fluid is not None:
        law(fluid.time.describe() if hasattr(fluid.time, "describe") else {})
        if fluid.velocity is not None or fluid.turbulence is not None:
            random = True
        if len(fluid.waves) > MAX_LINES:
            random = True
        else:
            lines.extend(float(w.omega) for w in fluid.waves)
    if len(set(lines)) > MAX_LINES:
        random = True
    return sorted(set(lines)), random


def _uniform(t: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rows ``F`` (per column) on a uniform grid of as many points (an output grid is
    uniform but for the last row of a run that stops between its steps)."""
    grid = np.linspace(t[0], t[-1], t.size)
    if np.allclose(np.diff(t), grid[1] - grid[0], rtol=1e-6, atol=0.0):
        return t, F
    return grid, np.column_stack([np.interp(grid, t, F[:, k]) for k in range(F.shape[1])])


def _lines(lines: list[float], span: float, nyquist: float, half: bool = False
           ) -> list[float]:
    """The frequencies fitted over a window of length ``span``: the excitations' harmonics
    (:data:`HARMONICS`), lower orders first, each kept when it holds a whole period in the
    window, lies below the Nyquist frequency and is half a resolution ``2 pi/span`` or more
    from every line kept before it (closer ones cannot be told apart over the window: the
    first stands for both)."""
    kept: list[float] = []
    gap = math.pi / span
    orders = HARMONICS + ((1.5, 2.5, 3.5, 4.5, 5.5) if half else ())
    for h in orders:
        for w in lines:
            nu = h * w
            if 2 * gap <= nu < nyquist and all(abs(nu - k) >= gap for k in kept):
                kept.append(nu)
    return sorted(kept)


def _ratio(spectrum: Spectrum, nu: float) -> tuple[complex, int]:
    """The change of a line's response at ``nu`` when a mode's frequency is off by its
    error: ``H(nu; omega_k (1 + delta_k)) / H(nu; omega_k)`` for a mode's
    ``H = 1/(omega² - nu² + 2 i zeta omega nu)``, of the mode it changes most, and that
    mode (0-based)."""
    best, mode = 1.0 + 0j, 0
    for k, (w, d, z) in enumerate(zip(spectrum.omegas, spectrum.errors, spectrum.zetas)):
        w2 = w * (1.0 + d)
        z = max(float(z), 0.0)
        r = (w * w - nu * nu + 2j * z * w * nu) / (w2 * w2 - nu * nu + 2j * z * w2 * nu)
        if abs(r - 1.0) > abs(best - 1.0):
            best, mode = r, k
    return best, mode


def _shift_lines(t, coef, nus, ratios) -> np.ndarray:
    """The change of the fitted lines (``coef``: mean, then cos and sin of each line, per
    column) when line ``i`` is multiplied by the complex ``ratios[i]``."""
    out = np.zeros((t.size, coef.shape[1]))
    for i, (nu, r) in enumerate(zip(nus, ratios)):
        c, s = coef[1 + 2 * i], coef[2 + 2 * i]  # line = Re[(c - i s) e^{i nu t}]
        z = complex(r) - 1.0
        out += np.outer(np.cos(nu * t), c * z.real + s * z.imag) \
            - np.outer(np.sin(nu * t), c * z.imag - s * z.real)
    return out


def _shift_free(t, rest, spectrum: Spectrum, random: bool, nus=(), ratios=()
                ) -> np.ndarray:
    """The change of the free vibration ``rest`` (per column) when each frequency's phase
    drifts by ``delta(omega) omega tau`` (module docs); the frequencies within
    :data:`LINE_BAND` resolutions of a line ``nus[i]`` change as that line does
    (``ratios[i]``)."""
    n = rest.shape[0]
    w = 2.0 * math.pi * np.fft.rfftfreq(n, d=(t[-1] - t[0]) / (n - 1))
    band = LINE_BAND * 2.0 * math.pi / (t[-1] - t[0])
    tau = np.full(w.size, math.sqrt(float(np.mean(t * t))))  # since the start, t = 0
    if random:  # the response's memory
        z = spectrum.zeta_at(w)
        with np.errstate(divide="ignore"):
            tau = np.where((z > 0) & (w > 0), np.minimum(tau, 1.0 / (2.0 * z * w)), tau)
    phi = np.minimum(spectrum.error_at(w) * w * tau, math.pi)
    change = np.exp(1j * phi) - 1.0
    for nu, r in zip(nus, ratios):
        change[np.abs(w - nu) <= band] = complex(r) - 1.0
    R = np.fft.rfft(rest, axis=0)
    return np.fft.irfft(R * change[:, None], n, axis=0)


def _fit(t, F, nus: list[float]) -> tuple[list[float], np.ndarray, np.ndarray]:
    """Least squares of the columns of ``F`` on a mean and the lines ``nus``: the lines,
    the coefficients (mean, then cos and sin of each line) and the rest."""
    X = np.column_stack([np.ones_like(t)] + [f(nu * t) for nu in nus for f in (np.cos,
                                                                              np.sin)])
    coef, *_ = np.linalg.lstsq(X, F, rcond=None)
    return nus, coef, F - X @ coef


def _share(coef: np.ndarray, i: int, fluct: float) -> float:
    """Line ``i``'s RMS (all columns) over ``fluct``."""
    amp = np.hypot(coef[1 + 2 * i], coef[2 + 2 * i])
    return float(np.sqrt(np.sum(amp * amp) / 2.0) / fluct)


def history_error(times, forces, moment_of, lines: list[float], random: bool,
                  spectrum: Spectrum, covered: tuple = ()) -> dict | None:
    """The estimated RMS error, over ``times`` (the statistics window; the run started at
    ``t = 0``), of the moment ``moment_of(times, forces)`` that the modes' frequency errors
    give the anchor force history ``forces`` (n, 3), relative to the moment's RMS (module
    docs). The force is the response: its lines (the excitation's harmonics, fitted) are
    changed as a mode off by its error changes them, its free vibration drifts in phase,
    and the moment of the changed force is compared with the moment (the moment's own
    dependence on the force, harmonics included, taken exactly).

    Returns ``{"estimate", "lines_error", "free_error", "free_share", "lines": [{"omega",
    "share", "mode", "change"}], "unchecked": [omega, ...]}``: ``lines_error`` and
    ``free_error`` the same with only the lines or only the free vibration changed;
    ``share`` a line's part of the force's fluctuation (RMS over RMS); ``change`` how much
    the mode changes it (``|ratio - 1|``); ``unchecked``: lines above the highest computed
    mode that would move the moment by more than :data:`MIN_LINE_SHARE` with their phase
    reversed. None with fewer than 16 finite rows, no moment, no mode or a window shorter
    than a period of the lowest mode. ``covered``: line frequencies whose change the rows'
    own estimate already holds (the primary and parametric resonance of the highest
    excitation frequency, :func:`cablefem.moments.error_estimate`): fitted, listed with
    ``"in_rows": True``, not changed."""
    t, F = np.asarray(times, float), np.asarray(forces, float)[:, :3]
    ok = np.all(np.isfinite(F), axis=1)
    t, F = t[ok], F[ok]
    if t.size < 16 or spectrum.omegas.size == 0 or not t[-1] > t[0]:
        return None
    if (t[-1] - t[0]) * spectrum.omegas[0] < 2.0 * math.pi:
        return None  # less than a period of the lowest mode: no spectrum to speak of
    t, F = _uniform(t, F)
    M = np.asarray(moment_of(t, F), float)
    rms = float(np.sqrt(np.nanmean(M * M)))
    if not rms > 0:
        return None

    def rel(dF: np.ndarray) -> float:
        dM = np.asarray(moment_of(t, F + dF), float) - M
        return float(np.sqrt(np.nanmean(dM * dM)) / rms)

    span, nyquist = t[-1] - t[0], math.pi * (t.size - 1) / (t[-1] - t[0])
    fluct = float(np.sqrt(np.mean(np.sum((F - F.mean(axis=0)) ** 2, axis=1))))
    nus, coef, rest = _fit(t, F, _lines(lines, span, nyquist))
    halves = [0.5 * w for w in lines]
    if any(fluct > 0 and _share(coef, nus.index(nu), fluct) > HALF_LINE
           for nu in nus if any(abs(nu - x) <= 1e-12 * x for x in halves)):
        nus, coef, rest = _fit(t, F, _lines(lines, span, nyquist, half=True))
    out: dict = {"lines": [], "unchecked": []}
    ratios, top = [], float(spectrum.omegas[-1])
    for i, nu in enumerate(nus):
        r, k = _ratio(spectrum, nu)
        entry = {"omega": float(nu), "share": _share(coef, i, fluct) if fluct > 0 else 0.0,
                 "mode": k + 1, "change": float(abs(r - 1.0))}
        if any(abs(nu - c) <= 1e-9 * c for c in covered):
            entry["in_rows"] = True
            r = 1.0
        ratios.append(r)
        out["lines"].append(entry)
        if nu > UNCHECKED_MARGIN * top:  # no mode known there: its phase reversed
            worst = [-1.0 if j == i else 1.0 for j in range(len(nus))]
            if rel(_shift_lines(t, coef, nus, worst)) > MIN_LINE_SHARE:
                out["unchecked"].append(float(nu))
    d_lines = _shift_lines(t, coef, nus, ratios)
    d_free = _shift_free(t, rest, spectrum, random, nus, ratios)
    out["lines_error"] = rel(d_lines)
    out["free_error"] = rel(d_free)
    out["free_share"] = float(np.sqrt(np.mean(np.sum(rest * rest, axis=1))) / fluct) \
        if fluct > 0 else 0.0
    out["estimate"] = min(rel(d_lines + d_free), 1.0)
    return out
