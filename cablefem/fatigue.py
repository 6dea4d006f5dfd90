"""Fatigue at clamped anchors: stresses, rainflow counting, S-N curve, Miner's sum.

Pure NumPy post-processing of ``anchors.csv`` (``docs/theory.md`` §7):
``sigma = T/A + M/W``, rainflow counting (ASTM E1049-85, by the ``rainflow`` package), an
EN 1993-1-9 style S-N curve, Miner's sum ``D = sum n_i / N_i``. Units are the user's,
consistently (N and m: stresses in Pa); times are in the series' time unit.

The ``moment`` column is ``|M|``: a plane bending that changes sign folds it (range halved,
frequency doubled), a turning bending plane hides the reversal at every fibre: ``|M|``
underestimates the damage. Pass the vector ``(Mx, My, Mz)``: the stress is then taken at
``fibres`` fibres around the section (``M . w / W``, ``w`` unit vectors in the plane of the
moment vectors) and the continuous worst direction (:mod:`cablefem.fibres`) is reported.
Invalid samples (``valid = 0``, empty/NaN moment: slack) are NaN, never zero stress; the
fatigue functions refuse them unless dropped (``invalid="drop"``: the remaining samples are
joined across the gaps into one history). The reports' files are written by
:func:`cablefem.io.fatiguereport.write_report`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
import rainflow
from numpy.typing import ArrayLike

from cablefem.fibres import fibre_plane, scan_angles, scan_bound, worst_angle

__all__ = ["StressSection", "SNCurve", "axial_stress", "bending_stress", "fibre_directions",
           "anchor_stress", "rainflow_cycles", "miner_damage", "equivalent_stress_range",
           "damage_equivalent_range", "time_to_failure", "YEAR_SECONDS", "fatigue_report"]


#: the year of ``damage_per_year``: 365.25 days of 86400 s [s]
YEAR_SECONDS = 365.25 * 86400.0


def _number(name: str, value: object, low: float = 0.0, inclusive: bool = False) -> float:
    """``value`` as a finite float ``> low`` (``>= low`` if inclusive), else ValueError."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    if not (math.isfinite(x) and (x >= low if inclusive else x > low)):
        rel = ">=" if inclusive else ">"
        raise ValueError(f"{name} must be a finite number {rel} {low:g} (got {value!r})")
    return x


def _finite(name: str, a: np.ndarray) -> None:
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise ValueError(f"{name}: {bad.size} non-finite (NaN/inf) values, first at index "
                         f"{bad[0]}: invalid samples (e.g. a slack anchor) must be dropped "
                         "explicitly (--invalid drop, or fatigue_report(..., invalid='drop'))")


@dataclass(frozen=True)
class StressSection:
    """Section for ``sigma = T/A + M/W``: ``area`` A [m^2] and (effective) elastic section
    modulus ``modulus`` W = I/c_o [m^3], both finite and > 0.

    Args:
        area: Area A [m^2].
        modulus: Elastic section modulus W [m^3].

    Raises:
        ValueError: A value not finite or not > 0.
    """

    area: float
    modulus: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "area", _number("area", self.area))
        object.__setattr__(self, "modulus", _number("modulus", self.modulus))

    @classmethod
    def solid_circle(cls, diameter: float) -> StressSection:
        """Solid circle: ``A = pi d^2/4``, ``W = I/c_o = (pi d^4/64)/(d/2) = pi d^3/32``."""
        d = _number("diameter", diameter)
        return cls(math.pi * d**2 / 4, math.pi * d**3 / 32)

    @classmethod
    def effective(cls, area: float, modulus: float) -> StressSection:
        """Strands and ropes: user-given metallic area and effective section modulus."""
        return cls(area, modulus)


@dataclass(frozen=True)
class SNCurve:
    """S-N curve in the style of EN 1993-1-9 (Figure 7.1; detail categories in its tables,
    e.g. Table 8.1 for plain members and mechanically fastened joints).

    ``N = N_C (ds_C/ds)^m1`` for ``ds >= ds_D``; ``N = N_knee (ds_D/ds)^m2`` for
    ``ds_L <= ds < ds_D``; ``N = inf`` below the cut-off ``ds_L``. Defaults: ``N_C = 2e6``,
    ``m1 = 3``, knee (constant-amplitude fatigue limit) at ``N_knee = 5e6`` so
    ``ds_D = (2/5)^(1/3) ds_C = 0.737 ds_C``, ``m2 = 5`` to the cut-off at
    ``N_cutoff = 1e8`` so ``ds_L = (5/100)^(1/5) ds_D = 0.549 ds_D``.
    ``knee=False``: a single slope ``m1`` with no fatigue limit and no cut-off (``m2``,
    ``N_knee``, ``N_cutoff`` unused). Stay cables: EN 1993-1-11 gives its own categories for
    tension components; a value often quoted for wires and strands is ``ds_C = 160 MPa``
    with ``m = 4`` (e.g. ``SNCurve(160e6, m1=4, knee=False)``) - check the category against
    the standard and the cable's approval tests. Partial factors (``gamma_Ff``,
    ``gamma_Mf``) are not applied, and the curve is mean-stress insensitive.

    Fields: ``detail_category`` ds_C [stress unit] > 0; slopes ``m1, m2`` >= 1; ``knee``
    bool; cycles ``N_C, N_knee, N_cutoff`` > 0 with ``N_knee < N_cutoff``.

    Args:
        detail_category: ds_C [stress unit], > 0.
        m1, m2: Slopes, >= 1.
        knee: Whether the curve has a knee and a cut-off.
        N_C, N_knee, N_cutoff: Cycles, > 0, ``N_knee < N_cutoff``.

    Raises:
        ValueError: A field out of its range.
    """

    detail_category: float
    m1: float = 3.0
    m2: float = 5.0
    knee: bool = True
    N_C: float = 2e6
    N_knee: float = 5e6
    N_cutoff: float = 1e8

    def __post_init__(self) -> None:
        for f in ("detail_category", "N_C", "N_knee", "N_cutoff"):
            object.__setattr__(self, f, _number(f, getattr(self, f)))
        for f in ("m1", "m2"):
            object.__setattr__(self, f, _number(f, getattr(self, f), 1.0, inclusive=True))
        if not isinstance(self.knee, (bool, np.bool_)):
            raise ValueError(f"knee must be True or False (got {self.knee!r})")
        if self.N_knee >= self.N_cutoff:
            raise ValueError(f"N_knee must be < N_cutoff (got {self.N_knee:g} >= "
                             f"{self.N_cutoff:g})")

    @property
    def delta_sigma_D(self) -> float | None:
        """Knee (constant-amplitude fatigue limit) ``ds_C (N_C/N_knee)^(1/m1)``, or None."""
        ds = self.detail_category * (self.N_C / self.N_knee) ** (1 / self.m1)
        return ds if self.knee else None

    @property
    def delta_sigma_L(self) -> float | None:
        """Cut-off limit ``ds_D (N_knee/N_cutoff)^(1/m2)``, or None without a knee."""
        return self.delta_sigma_D * (self.N_knee / self.N_cutoff) ** (1 / self.m2) \
            if self.knee else None

    def cycles_to_failure(self, delta_sigma: ArrayLike) -> np.ndarray | float:
        """Cycles to failure ``N`` at the stress ranges ``delta_sigma`` (>= 0, vectorised;
        inf below the cut-off and at a zero range)."""
        s = np.asarray(delta_sigma, float)
        _finite("delta_sigma", s)
        if np.any(s < 0):
            raise ValueError("delta_sigma: stress ranges must be >= 0")
        with np.errstate(divide="ignore"):
            N = self.N_C * (self.detail_category / s) ** self.m1
            if self.knee:
                sd, sl = self.delta_sigma_D, self.delta_sigma_L
                N = np.where(s < sd, self.N_knee * (sd / s) ** self.m2, N)
                N = np.where(s < sl, np.inf, N)
        return float(N) if N.ndim == 0 else N

    def stress_range_at(self, N: float) -> float | None:
        """The curve's inverse: the range of which ``N`` (> 0) cycles make ``D = 1``; None
        for ``N > N_cutoff`` with a knee (no range at or above the cut-off lasts so long)."""
        N = _number("N", N)
        if not self.knee or N <= self.N_knee:
            return self.detail_category * (self.N_C / N) ** (1 / self.m1)
        if N <= self.N_cutoff:
            return self.delta_sigma_D * (self.N_knee / N) ** (1 / self.m2)
        return None

    def as_dict(self) -> dict:
        return {**asdict(self), "knee": bool(self.knee), "delta_sigma_D": self.delta_sigma_D,
                "delta_sigma_L": self.delta_sigma_L}


def axial_stress(T: ArrayLike, section: StressSection) -> np.ndarray:
    """Axial stress ``T/A`` [Pa] from the tension ``T`` [N].

    Args:
        T: Tension [N].
        section: The stress section.
    """
    return np.asarray(T, float) / section.area


def bending_stress(M: ArrayLike, section: StressSection) -> np.ndarray:
    """Bending stress ``M/W`` [Pa] at the outer fibre from a signed moment ``M`` [N m].

    Args:
        M: Signed moment [N m].
        section: The stress section.
    """
    return np.asarray(M, float) / section.modulus


def fibre_directions(M: ArrayLike, valid: ArrayLike | None = None, fibres: int = 36
                     ) -> np.ndarray:
    """The scanned fibre directions ``w = cos(a) e1 + sin(a) e2`` (rows), ``a`` in
    :func:`cablefem.fibres.scan_angles` (``2 pi k/fibres`` and the opposites: ``fibres`` rows
    for an even count, ``2 fibres`` for an odd one), in the plane ``e1, e2`` of the moment
    vectors ``M`` (n, 3) over the valid samples (:func:`cablefem.fibres.fibre_plane`). The
    bending stress at direction ``w`` is ``M . w / W``.

    Args:
        M: (n, 3) moment vectors [N m].
        valid: (n,) 0/1, or None (all finite rows).
        fibres: Number of scanned directions, >= 1.

    Returns:
        The unit directions, one per row.
    """
    M = np.asarray(M, float).reshape(-1, 3)
    ok = np.all(np.isfinite(M), axis=1)
    if valid is not None:
        ok &= np.asarray(valid, float) > 0
    e1, e2 = fibre_plane(M, ok)
    a = scan_angles(fibres)
    return np.cos(a)[:, None] * e1 + np.sin(a)[:, None] * e2


def anchor_stress(T: ArrayLike, M: ArrayLike, valid: ArrayLike | None, section: StressSection,
                  *, fibres: int = 36) -> tuple[np.ndarray, np.ndarray]:
    """Stress ``T/A + M/W`` [Pa] at a clamped anchor and the mask of the valid samples.

    Args:
        T: (n,) tension [N].
        M: (n,) signed moment or (n, 3) moment vector [N m].
        valid: (n,) 0/1, or None.
        section: The stress section.
        fibres: Number of scanned directions (moment vectors).

    Returns:
        ``(sigma, ok)``: ``sigma`` (n,), or (n, k) at the k scanned directions of
        :func:`fibre_directions` for a moment vector, NaN (never zero) at invalid samples;
        ``ok`` (n,) bool: ``T`` and ``M`` finite and ``valid`` nonzero.
    """
    T, M = np.asarray(T, float), np.asarray(M, float)
    ok = np.isfinite(T) & (np.all(np.isfinite(M), axis=1) if M.ndim == 2 else np.isfinite(M))
    if valid is not None:
        ok &= np.nan_to_num(np.asarray(valid, float)) != 0  # NaN: invalid
    if M.ndim == 2:
        bend = bending_stress(M @ fibre_directions(M, ok, fibres).T, section)
        sigma = axial_stress(T, section)[:, None] + bend
        return np.where(ok[:, None], sigma, np.nan), ok
    return np.where(ok, axial_stress(T, section) + bending_stress(M, section), np.nan), ok


def rainflow_cycles(series: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rainflow cycles (ASTM E1049-85 5.4.4, ``rainflow.extract_cycles``): ``ranges``,
    ``means`` [stress unit], ``counts`` (1.0 full cycle, 0.5 half cycle: the residue's ranges
    are kept as half cycles). Zero ranges (constant series) are left out; a 2-sample series
    (for which rainflow 3.2.0 counts nothing) is one half cycle. NaN raises ValueError.

    Args:
        series: 1-D stress history.

    Returns:
        ``(ranges, means, counts)``.
    """
    x = np.asarray(series, float)
    if x.ndim != 1:
        raise ValueError(f"series must be 1-D (got shape {x.shape})")
    _finite("series", x)
    if x.size == 2:
        cyc = [(abs(x[1] - x[0]), 0.5 * (x[0] + x[1]), 0.5)]
    else:
        cyc = [c[:3] for c in rainflow.extract_cycles(x.tolist())]
    a = np.array([c for c in cyc if c[0] > 0], float).reshape(-1, 3)
    return a[:, 0], a[:, 1], a[:, 2]


def _cycles(ranges: ArrayLike, counts: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    r, n = np.asarray(ranges, float).ravel(), np.asarray(counts, float).ravel()
    if r.shape != n.shape:
        raise ValueError(f"ranges and counts differ in length ({r.size} vs {n.size})")
    _finite("ranges", r)
    _finite("counts", n)
    if np.any(r < 0) or np.any(n < 0):
        raise ValueError("ranges and counts must be >= 0")
    return r, n


def miner_damage(ranges: ArrayLike, counts: ArrayLike, curve: SNCurve) -> float:
    """Miner's sum ``D = sum n_i / N(ds_i)`` (ranges below the cut-off do no damage).

    Args:
        ranges: Stress ranges [stress unit], >= 0.
        counts: Their cycle counts, >= 0.
        curve: The S-N curve.

    Returns:
        The damage D [-].
    """
    r, n = _cycles(ranges, counts)
    return float(np.sum(n / curve.cycles_to_failure(r)))


def equivalent_stress_range(ranges: ArrayLike, counts: ArrayLike, m: float,
                            n_ref: float | None = None) -> float:
    """Damage-equivalent constant range ``(sum n_i ds_i^m / n_ref)^(1/m)`` [stress unit].
    ``n_ref=None``: the total number of cycles (same damage in as many cycles); ``n_ref=2e6``
    (``N_C``): the range to compare with the detail category (single slope: ``D =
    (ds_E/ds_C)^m``). The moment of a single slope ``m``: all ranges count, even below a
    cut-off, so with a knee it does not give the curve's damage (the reports use
    :func:`damage_equivalent_range` and ``ds_C D^(1/m1)``). 0 without cycles.

    Args:
        ranges: Stress ranges, >= 0.
        counts: Their cycle counts, >= 0.
        m: The slope.
        n_ref: Reference number of cycles (None: the total).
    """
    r, n = _cycles(ranges, counts)
    m, total = _number("m", m), float(np.sum(n))
    nref = total if n_ref is None else _number("n_ref", n_ref)
    return float((np.sum(n * r**m) / nref) ** (1 / m)) if total > 0 else 0.0


def damage_equivalent_range(ranges: ArrayLike, counts: ArrayLike, curve: SNCurve
                            ) -> tuple[float | None, float]:
    """``(ds_eq, n_d)``: ``n_d`` the number of damaging cycles (ranges with a finite ``N``:
    at or above the cut-off, and nonzero), ``ds_eq`` the constant range of which ``n_d``
    cycles give the spectrum's damage ``D`` under ``curve``: ``N(ds_eq) = n_d / D``, on the
    slope ``m2`` if ``n_d / D > N_knee``. None if D = 0. (``n_d / D <= N_cutoff`` since every
    damaging cycle has ``N <= N_cutoff``: the inverse exists; the clip is for rounding.)

    Args:
        ranges: Stress ranges, >= 0.
        counts: Their cycle counts, >= 0.
        curve: The S-N curve.
    """
    r, n = _cycles(ranges, counts)
    N = np.atleast_1d(curve.cycles_to_failure(r))
    hit = np.isfinite(N)
    nd, D = float(np.sum(n[hit])), float(np.sum(n[hit] / N[hit]))
    if not D > 0:
        return None, nd
    target = min(nd / D, curve.N_cutoff) if curve.knee else nd / D
    return curve.stress_range_at(target), nd


def time_to_failure(D: float, duration: float) -> float:
    """``duration / D``: the simulated loading repeated until ``D = 1`` (inf if D = 0).

    Args:
        D: Damage over the loading, >= 0.
        duration: The loading's duration [time unit], > 0.
    """
    D, duration = _number("D", D, 0.0, inclusive=True), _number("duration", duration)
    return math.inf if D == 0 else duration / D


def _window(t: np.ndarray, window: str | tuple[float, float] | None) -> np.ndarray:
    if window is None:
        return np.ones(t.size, bool)
    if isinstance(window, str):
        if window != "steady":
            raise ValueError(f"window must be None, 'steady' or (t0, t1) (got {window!r})")
        sel = t >= t[-1] - (t[-1] - t[0]) / 3
    else:
        t0, t1 = (float(w) for w in window)
        sel = (t >= t0) & (t <= t1)
    if np.count_nonzero(sel) < 2:
        raise ValueError(f"window {window!r} holds fewer than 2 samples of "
                         f"[{t[0]:g}, {t[-1]:g}]")
    return sel


def _stats(x: np.ndarray) -> dict:
    return {"min": float(x.min()), "max": float(x.max()), "mean": float(x.mean()),
            "range": float(np.ptp(x))}


def _direction_stress(T, M, ok, section, curve, fibres):
    """The stress history at the reported direction, over the valid samples: the fibre
    search of :mod:`cablefem.fibres` for a moment vector (and its description), else
    ``T/A + M/W``."""
    axial = axial_stress(T[ok], section)
    if M.ndim == 1:
        return axial + bending_stress(M[ok], section), None
    e1, e2 = fibre_plane(M, ok)
    X, Y = bending_stress(M[ok] @ e1, section), bending_stress(M[ok] @ e2, section)

    def damage(a: float) -> float:
        return miner_damage(*rainflow_cycles(axial + math.cos(a) * X
                                             + math.sin(a) * Y)[::2], curve)

    w = worst_angle(damage, fibres)
    slope = max(curve.m1, curve.m2) if curve.knee else curve.m1
    fib = {"angle_deg": math.degrees(w.angle), "direction": (math.cos(w.angle) * e1
                                                             + math.sin(w.angle) * e2).tolist(),
           "plane": [e1.tolist(), e2.tolist()], "fibres": int(fibres),
           "scanned": int(scan_angles(fibres).size),
           "damage_scan": w.scan_damage, "scan_angle_deg": math.degrees(w.scan_angle),
           "damage_min_over_fibres": w.scan_min,
           "scan_bound": scan_bound(fibres, slope), "evaluations": w.evaluations}
    return axial + math.cos(w.angle) * X + math.sin(w.angle) * Y, fib


def _window_mask(t, T, M, v, window, invalid, anchor):
    sel = _window(t, window)
    t, T, M, v = t[sel], T[sel], M[sel], v[sel]
    ok = np.isfinite(T) & (np.all(np.isfinite(M), axis=1) if M.ndim == 2 else np.isfinite(M))
    ok &= np.nan_to_num(v) != 0  # NaN: invalid
    n_bad = int(np.count_nonzero(~ok))
    if n_bad and invalid == "raise":
        raise ValueError(f"anchor {anchor!r}: {n_bad} of {ok.size} samples invalid (valid = 0 "
                         f"or empty/NaN tension or moment, e.g. slack), first at t = "
                         f"{t[~ok][0]:g}; drop them with --invalid drop (cablefem fatigue) "
                         "or invalid='drop' (fatigue_report)")
    if not ok.any():
        raise ValueError(f"anchor {anchor!r}: no valid sample in the window")
    return t, T, M, ok, n_bad


def fatigue_report(times: ArrayLike, T: ArrayLike, M: ArrayLike, valid: ArrayLike | None,
                   section: StressSection, curve: SNCurve, *, invalid: str = "raise",
                   window: str | tuple[float, float] | None = None, fibres: int = 36,
                   bins: int = 20, anchor: str = "anchor", year: float | None = None) -> dict:
    """Fatigue of one anchor: stresses, rainflow, Miner's damage, time to failure.

    Args:
        times: (n,) strictly increasing [time unit].
        T: (n,) tension [N].
        M: (n,) signed moment or (n, 3) moment vector [N m] (prefer the vector, see the module
            docstring: the damage is that of the continuous worst direction,
            :mod:`cablefem.fibres`, scanned first at ``fibres`` directions and their opposites).
        valid: (n,) 0/1, or None (all valid).
        section: The stress section.
        curve: The S-N curve.
        invalid: "raise" or "drop" (the valid samples are then joined across the gaps into
            one history).
        window: None (all), "steady" (``t >= t_end - (t_end - t_0)/3``) or (t0, t1)
            (``t0 <= t <= t1``).
        fibres: Number of scanned directions.
        bins: Bins of the range histogram.
        anchor: Name for the messages.
        year: A year's length in the time unit (None: no ``damage_per_year``).

    Returns:
        A JSON-ready dict whose fields ``docs/fatigue.md`` defines.

    Raises:
        ValueError: Inconsistent shapes, times not increasing, an invalid sample with
            ``invalid="raise"``, or no valid sample in the window.
    """
    t, T, M = (np.asarray(a, float) for a in (times, T, M))
    n = t.size
    v = np.ones(n) if valid is None else np.asarray(valid, float)
    if t.ndim != 1 or T.shape != (n,) or M.shape[:1] != (n,) or v.shape != (n,) \
            or M.ndim > 2 or (M.ndim == 2 and M.shape[1] != 3):
        raise ValueError(f"anchor {anchor!r}: times, T, valid (n,) and M (n,) or (n, 3) "
                         f"must agree (got {t.shape}, {T.shape}, {v.shape}, {M.shape})")
    _finite(f"anchor {anchor!r}: times", t)
    if n < 2 or np.any(np.diff(t) <= 0):
        raise ValueError(f"anchor {anchor!r}: times must be >= 2 strictly increasing values")
    if invalid not in ("raise", "drop"):
        raise ValueError(f"invalid must be 'raise' or 'drop' (got {invalid!r})")
    if year is not None:
        year = _number("year", year)
    t, T, M, ok, n_bad = _window_mask(t, T, M, v, window, invalid, anchor)
    sig, fib = _direction_stress(T, M, ok, section, curve, fibres)
    r, _, c = rainflow_cycles(sig)
    D = miner_damage(r, c, curve)
    axial = axial_stress(T[ok], section)
    bend = sig - axial
    duration = float(t[-1] - t[0])
    ttf = time_to_failure(D, duration)
    eq, n_dam = damage_equivalent_range(r, c, curve)
    hist, edges = np.histogram(r, bins=bins, range=(0.0, float(r.max()) if r.size else 1.0),
                               weights=c)
    return {"anchor": anchor, "window": [float(t[0]), float(t[-1])], "duration": duration,
            "samples": int(ok.size), "valid_samples": int(np.count_nonzero(ok)),
            "dropped_invalid_samples": n_bad,
            "section": {"area": section.area, "modulus": section.modulus},
            "stress": _stats(sig), "axial_stress": _stats(axial),
            "bending_stress": _stats(bend), "damage": D,
            "damage_axial_only": miner_damage(*rainflow_cycles(axial)[::2], curve),
            "damage_bending_only": miner_damage(*rainflow_cycles(bend)[::2], curve),
            "cycles": float(c.sum()), "damaging_cycles": n_dam,
            "full_cycles": int(np.count_nonzero(c == 1.0)),
            "half_cycles": int(np.count_nonzero(c == 0.5)),
            "max_range": float(r.max()) if r.size else 0.0,
            "equivalent_range": eq,
            "equivalent_range_N_C": curve.detail_category * D ** (1 / curve.m1),
            "time_to_failure": None if math.isinf(ttf) else ttf,
            "time_to_failure_infinite": math.isinf(ttf), "year": year,
            "damage_per_year": None if year is None else D * year / duration,
            "histogram": {"edges": edges.tolist(), "counts": hist.tolist()}, "fibre": fib}
