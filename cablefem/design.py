"""A design from a load-case set: Miner's damage over the design life and the extremes.

A load-case set runs every load case with one or more seeds; each run is summarised by a
:class:`CaseRecord` (:func:`case_record` builds one from a finished case folder).
:func:`assemble_design` combines the records into the content of ``design.json``:

- ``fatigue``: per location (clamped anchor, ``kink:<name>``), the damage over the design
  life, the sum over the cases of the seeds' mean damage rate in their fatigue windows times
  the case's hours over the design life; the life in years and the governing case;
- ``extremes``: per location the largest moment and tension over every record with its case
  and seed, and per case the most probable maximum (MPM) over a stated duration from its
  seeds' window maxima (a Gumbel fit by the method of moments);
- ``cases``: per record its status, wall time, window and its share of the design damage per
  location (the design damage is exactly the sum of the shares), and its dampers' peaks;
- ``dampers``: per damper the largest force, stroke and velocity over every record with its
  case and seed, and per case the most probable maxima of its seeds' peaks (what a damper
  is specified by).

A record that did not finish makes the design incomplete: the records it would contribute
count as zero (the damage is a lower bound, the life an upper bound), the locations say
``"complete": false`` and ``warnings`` say why. docs/design.md defines every field.
Pure Python and NumPy (no dolfinx, no MPI).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["CaseRecord", "assemble_design", "write_design_figures", "case_record",
           "gumbel_moments", "window_maxima", "FINISHED", "EULER_GAMMA"]

#: the statuses of a record whose numbers are whole (``cablefem run`` writes "completed")
FINISHED = ("finished", "completed")
#: the Euler-Mascheroni constant: the mean of a standard Gumbel variable
EULER_GAMMA = 0.5772156649015329

DEFINITIONS = {
    "fatigue.damage": "Miner's sum over the design life: sum over the cases c and their "
    "seeds s of D_cs / T_cs * H_c * 3600 * L / n_c, with D_cs the seed's damage in its "
    "fatigue window of duration T_cs (s), H_c the case's hours per year, L the design life "
    "(years) and n_c the case's number of seeds (records); a seed that did not finish "
    "counts as zero (the damage is then a lower bound, 'complete': false)",
    "fatigue.life_years": "design_life_years / damage (absent when the damage is 0)",
    "fatigue.governing_case": "the case with the largest share of the damage",
    "cases.damage": "the record's share of the design damage at each location: its case's "
    "seed-averaged share divided among the case's seeds; the design damage is their sum",
    "extremes.max_moment": "the largest anchor or kink moment (magnitude) of every finished "
    "record in its statistics window, with its case and seed; max_tension likewise",
    "dampers.max_force": "the largest damper force peak (N, the run's force_peak: over its "
    "statistics window, summary.json dampers.<name>) of every finished record, with its case "
    "and seed; max_stroke (m) and max_velocity (m/s) likewise; 'cases': per case the MPM "
    "of its seeds' peaks as for extremes.cases.mpm",
    "extremes.cases.mpm": "most probable maximum over 'duration' (s): a Gumbel distribution "
    "fitted to the seeds' window maxima by the method of moments (beta = sqrt(6) s / pi, "
    "mu = mean - 0.5772 beta, s the sample standard deviation), MPM = mu + beta ln(duration "
    "/ window duration). It assumes the window maxima independent and identically "
    "Gumbel-distributed (a stationary response, windows long against its correlation time) "
    "and the maxima of consecutive windows independent; with 2 or 3 seeds the fit is rough "
    "(the standard error of beta is about beta * sqrt(1.1 / n)). With one seed: the seed's "
    "window maximum itself, over the window duration ('estimator': 'single seed')",
}


@dataclass
class CaseRecord:
    """One run (a load case and a seed) of a load-case set; see docs/design.md."""

    name: str
    seed: int
    hours_per_year: float
    status: str
    wall_time: float
    window: tuple[float, float] | None
    fatigue: dict[str, dict] = field(default_factory=dict)
    maxima: dict[str, dict] = field(default_factory=dict)
    folder: str = ""
    #: damper name -> its peaks and RMS over the statistics window (summary.json ``dampers``:
    #: ``force_peak``, ``stroke_peak``, ``velocity_peak``, ``*_rms``, ``window``)
    dampers: dict[str, dict] = field(default_factory=dict)
    #: the run's own warnings (summary.json ``warnings``: ``{"key", "message"}``), which
    #: the design repeats: a design is only as good as its runs
    warnings: list[dict] = field(default_factory=list)


# ---------------------------------------------------------------------------- the design
def assemble_design(records: list[CaseRecord], design_life_years: float, *,
                    extreme_duration: float | None = None,
                    year_seconds: float = 365.25 * 86400) -> dict:
    """The content of ``design.json`` from the records of a load-case set (every case and
    seed, finished or not): keys ``cases``, ``fatigue``, ``extremes``, ``design_life_years``,
    ``complete``, ``definitions``, ``warnings`` (docs/design.md). ``extreme_duration`` (s):
    the duration of the most probable maxima (default: each case's window duration).
    ``year_seconds``: the length of a year, to check that the hours per year fit in one.
    Raises ValueError for no records, a design life or an ``extreme_duration`` that is not
    positive and finite, a seed twice in a case, or records of one case with different or
    negative hours per year."""
    if not (isinstance(design_life_years, (int, float)) and math.isfinite(design_life_years)
            and design_life_years > 0):
        raise ValueError(f"design_life_years must be positive and finite, got "
                         f"{design_life_years!r}")
    if extreme_duration is not None and not (math.isfinite(extreme_duration)
                                             and extreme_duration > 0):
        raise ValueError(f"extreme_duration must be positive and finite, got "
                         f"{extreme_duration!r}")
    groups = _group(records)
    warnings: list[str] = []
    for name, recs in groups.items():
        bad = [r.seed for r in recs if r.status not in FINISHED]
        if bad:
            warnings.append(f"case {name!r}: seed(s) {bad} did not finish "
                            f"({', '.join(sorted({r.status for r in recs if r.seed in bad}))})"
                            ": the design is incomplete (its damage a lower bound)")
    hours = sum(recs[0].hours_per_year for recs in groups.values())
    if hours > year_seconds / 3600 * (1 + 1e-12):  # round-off of the weights' sum
        warnings.append(f"the cases' hours per year add up to {hours:.6g}, more than the "
                        f"{year_seconds / 3600:.6g} h of a year")
    for r in records:
        warnings += [f"case {r.name!r} seed {r.seed}: {w.get('key')}: {w.get('message')}"
                     for w in r.warnings]
    shares, fatigue = _fatigue(groups, design_life_years, warnings)
    cases = []
    for r in records:
        cases.append({"name": r.name, "seed": r.seed, "status": r.status,
                      "hours_per_year": r.hours_per_year,
                      "wall_time": _finite(r.wall_time),
                      "window": None if r.window is None else [float(t) for t in r.window],
                      "folder": r.folder, "damage": shares.get(id(r), {}),
                      "dampers": r.dampers, "warnings": len(r.warnings),
                      "fatigue_windows": {loc: rep["window"] for loc, rep in r.fatigue.items()
                                          if rep.get("window") is not None}})
    whole = sorted({f"{r.name}/{r.seed}" for r in records for rep in r.fatigue.values()
                    if (rep.get("window_rule") or {}).get("rule") == "all"})
    if whole:
        warnings.append(f"the fatigue window of {', '.join(whole)} is the whole run "
                        "(fatigue.window = 'all'): its start-up counts as if it recurred "
                        "over the design life")
    extremes = _extremes(groups, extreme_duration, warnings)
    dampers = _dampers(groups, extreme_duration)
    complete = (all(r.status in FINISHED for r in records)
                and all(f["complete"] for f in fatigue.values())
                and all(e["complete"] for e in extremes.values()))
    return {"design_life_years": float(design_life_years), "complete": complete,
            "hours_per_year_total": hours, "cases": cases, "fatigue": fatigue,
            "extremes": extremes, "dampers": dampers, "definitions": dict(DEFINITIONS),
            "warnings": warnings}


def _finite(x) -> float | None:
    """``x`` as a float, or None (JSON null) when it is not a finite number."""
    return float(x) if isinstance(x, (int, float)) and math.isfinite(x) else None


def _group(records: list[CaseRecord]) -> dict[str, list[CaseRecord]]:
    if not records:
        raise ValueError("a design needs at least one record")
    groups: dict[str, list[CaseRecord]] = {}
    for r in records:
        groups.setdefault(r.name, []).append(r)
    for name, recs in groups.items():
        seeds = [r.seed for r in recs]
        if len(set(seeds)) < len(seeds):
            raise ValueError(f"case {name!r}: a seed appears more than once in {seeds}")
        h = {float(r.hours_per_year) for r in recs}
        if len(h) > 1:
            raise ValueError(f"case {name!r}: its records have different hours per year "
                             f"{sorted(h)}")
        if not (math.isfinite(recs[0].hours_per_year) and recs[0].hours_per_year >= 0):
            raise ValueError(f"case {name!r}: hours_per_year must be finite and >= 0, got "
                             f"{recs[0].hours_per_year!r}")
    return groups


def _rate(rep: dict) -> float | None:
    """A report's damage per second of its window, or None when it cannot be computed
    (no damage, no positive duration, a duration not in seconds)."""
    d, t = rep.get("damage"), rep.get("duration")
    if "year" in rep and rep["year"] is None:  # a dimensionless run: its time is not in s
        return None
    if d is None or t is None or not (math.isfinite(d) and math.isfinite(t) and t > 0):
        return None
    return float(d) / float(t)


def _fatigue(groups: dict[str, list[CaseRecord]], life: float, warnings: list[str]):
    """Per record (by id) its share per location, and the ``fatigue`` entries."""
    locations = list(dict.fromkeys(loc for recs in groups.values() for r in recs
                                   if r.status in FINISHED for loc in r.fatigue))
    shares: dict[int, dict[str, float]] = {id(r): {} for recs in groups.values()
                                           for r in recs}
    fatigue = {}
    for loc in locations:
        per_case: dict[str, float] = {}
        missing = []
        parts = []
        for name, recs in groups.items():
            scale = recs[0].hours_per_year * 3600.0 * life / len(recs)
            case_parts = []
            for r in recs:
                rate = _rate(r.fatigue.get(loc, {})) if r.status in FINISHED else None
                if rate is None:
                    missing.append(f"{name}/{r.seed}")
                    continue
                shares[id(r)][loc] = rate * scale
                case_parts.append(rate * scale)
            per_case[name] = math.fsum(case_parts)
            parts += case_parts
        damage = math.fsum(parts)
        entry: dict = {"damage": damage, "complete": not missing,
                       "cases": per_case, "damage_per_year": damage / life}
        if damage > 0:
            entry["life_years"] = life / damage
            entry["governing_case"] = max(per_case, key=per_case.get)
            entry["governing_share"] = per_case[entry["governing_case"]] / damage
        else:
            entry["note"] = ("no damage in any case: the life is not limited by these "
                             "cases (life_years and governing_case absent)")
        if missing:
            entry["missing"] = missing
            warnings.append(f"fatigue at {loc}: no damage from {', '.join(missing)} (not "
                            "finished, or no damage and duration in seconds): the damage "
                            f"{damage:.4g} is a lower bound, the life an upper bound")
        fatigue[loc] = entry
    return shares, fatigue


def gumbel_moments(maxima) -> tuple[float, float]:
    """The Gumbel location μ and scale β fitted to ``maxima`` (at least 2) by the method of
    moments: β = √6 s / π (s the sample standard deviation, ddof 1), μ = mean − γ β."""
    x = np.asarray(maxima, float)
    if x.size < 2 or not np.all(np.isfinite(x)):
        raise ValueError(f"a Gumbel fit needs at least 2 finite maxima, got {x.tolist()}")
    beta = math.sqrt(6.0) * float(np.std(x, ddof=1)) / math.pi
    return float(np.mean(x)) - EULER_GAMMA * beta, beta


def _mpm(values: list[float], seeds: list[int], window: float | None,
         duration: float | None) -> dict:
    """The most probable maximum of one case and quantity from its seeds' window maxima."""
    out: dict = {"seeds": seeds, "seed_maxima": values, "window_duration": window}
    if len(values) == 1:
        out.update(mpm=values[0], duration=window, estimator="single seed",
                   note="one seed: its window maximum, no fit (no extrapolation in time)")
        return out
    mu, beta = gumbel_moments(values)
    n = 1.0 if duration is None or window is None else duration / window
    out.update(mu=mu, beta=beta, n_windows=n, mpm=mu + beta * math.log(n),
               duration=window if duration is None or window is None else duration,
               estimator="gumbel-moments")
    if duration is not None and window is None:
        out["note"] = "no window duration: the MPM is over one window"
    return out


def _extremes(groups: dict[str, list[CaseRecord]], duration: float | None,
              warnings: list[str]) -> dict:
    """Per location the largest moment and tension over the finished records, and per case
    the most probable maxima of its seeds' window maxima."""
    done = {n: [r for r in recs if r.status in FINISHED] for n, recs in groups.items()}
    locations = list(dict.fromkeys(loc for recs in done.values() for r in recs
                                   for loc in r.maxima))
    out = {}
    for loc in locations:
        entry: dict = {"complete": all(len(d) == len(groups[n]) for n, d in done.items())}
        per_case = {}
        for quantity, key, ckey, skey in (("moment", "max_moment", "case", "seed"),
                                          ("tension", "max_tension", "tension_case",
                                           "tension_seed")):
            best = None
            for name, recs in done.items():
                if any(loc not in r.maxima for r in recs):  # not reported by a record
                    entry["complete"] = False
                vals = [(float(r.maxima[loc][key]), r.seed, r.window) for r in recs
                        if loc in r.maxima and r.maxima[loc].get(key) is not None
                        and math.isfinite(r.maxima[loc][key])]
                if not vals:
                    continue
                if len(vals) < len(recs):  # a seed without the value (e.g. invalid moment)
                    entry["complete"] = False
                top = max(vals)
                if best is None or top[0] > best[0]:
                    best = (top[0], name, top[1])
                wins = [w[1] - w[0] for _, _, w in vals if w is not None]
                win = float(np.mean(wins)) if wins else None
                if wins and max(wins) - min(wins) > 1e-9 * max(wins):  # round-off of t1 - t0
                    warnings.append(f"extremes at {loc}, case {name!r}: the seeds' windows "
                                    f"differ ({min(wins):.6g} to {max(wins):.6g} s): the "
                                    "MPM uses their mean")
                if len(vals) == 1 and duration is not None and win is not None \
                        and abs(duration - win) > 1e-9 * win:  # round-off of t1 - t0
                    warnings.append(f"extremes at {loc}, case {name!r}: one seed: its "
                                    f"{quantity} maximum is over its window ({win:.6g} s), "
                                    f"not over extreme_duration ({duration:.6g} s)")
                per_case.setdefault(name, {})[quantity] = _mpm(
                    [v for v, _, _ in vals], [s for _, s, _ in vals], win, duration)
            if best is not None:
                entry[key], entry[ckey], entry[skey] = best
        entry["cases"] = per_case
        if not entry["complete"]:
            warnings.append(f"extremes at {loc}: not every seed of every case finished or "
                            "reported it: the maxima are over the records that did")
        out[loc] = entry
    return out


def _dampers(groups: dict[str, list[CaseRecord]], duration: float | None) -> dict:
    """Per damper the largest force, stroke and velocity peak over the finished records
    (with case and seed) and per case the MPM of its seeds' peaks (:func:`_mpm`)."""
    done = {n: [r for r in recs if r.status in FINISHED] for n, recs in groups.items()}
    names = list(dict.fromkeys(d for recs in done.values() for r in recs for d in r.dampers))
    out = {}
    for name in names:
        entry: dict = {"complete": all(len(d) == len(groups[n]) for n, d in done.items())}
        per_case: dict = {}
        for q in ("force", "stroke", "velocity"):
            best = None
            for case, recs in done.items():
                vals = [(float(r.dampers[name][f"{q}_peak"]), r.seed,
                         r.dampers[name].get("window")) for r in recs
                        if r.dampers.get(name, {}).get(f"{q}_peak") is not None]
                if len(vals) < len(recs):
                    entry["complete"] = False
                if not vals:
                    continue
                top = max(vals, key=lambda v: v[0])
                if best is None or top[0] > best[0]:
                    best = (top[0], case, top[1])
                wins = [w[1] - w[0] for _, _, w in vals if w is not None]
                per_case.setdefault(case, {})[q] = _mpm(
                    [v for v, _, _ in vals], [s for _, s, _ in vals],
                    float(np.mean(wins)) if wins else None, duration)
            if best is not None:
                entry[f"max_{q}"], entry[f"{q}_case"], entry[f"{q}_seed"] = best
        entry["cases"] = per_case
        out[name] = entry
    return out


# ---------------------------------------------------------------------------- figures
def write_design_figures(design: dict, outdir, *, comm=None) -> list[str]:
    """Draw the design's figures into ``outdir`` (docs/design.md): the damage per location
    stacked by case, the extremes per case. Without ``comm`` the caller calls it on rank 0
    only; with ``comm`` (an MPI communicator) every rank calls it, rank 0 draws and every
    rank gets the PNG paths."""
    paths: list[str] = []
    if comm is None or comm.rank == 0:
        from cablefem.app.designplots import design_figures

        paths = design_figures(design, Path(outdir))
    return paths if comm is None else comm.bcast(paths, root=0)


# ---------------------------------------------------------------------------- a case folder
def case_record(folder, name: str, seed: int, hours_per_year: float, *,
                relative_to=None) -> CaseRecord:
    """The record of one run from its output folder: status and wall time from
    ``summary.json`` (status "missing" without it), the fatigue reports of ``fatigue.json``
    (``anchors``: location -> report with ``damage`` and ``duration``; else
    summary.json's ``fatigue`` section), the statistics window (summary.json: the
    ``steady_state_moment`` window of the anchors and kinks) and the maxima of every anchor
    (``anchors.csv``) and kink (``kinks.csv``, as ``kink:<name>``) over that window.
    ``folder`` in the record: relative to ``relative_to`` when given."""
    folder = Path(folder)
    rel = str(folder if relative_to is None else os.path.relpath(folder, relative_to))
    try:
        summary = json.loads((folder / "summary.json").read_text())
    except (OSError, ValueError):
        return CaseRecord(name, seed, hours_per_year, "missing", math.nan, None, {}, {}, rel)
    status = str(summary.get("status", "missing"))
    wall = (summary.get("wall_time") or {}).get("total", math.nan)
    window = _summary_window(summary)
    if window is None and status in FINISHED:  # no moment statistics: pinned anchors only
        window = _csv_window(folder / "anchors.csv", summary.get("statistics_start"))
    fatigue = {}
    if status in FINISHED:
        try:
            fatigue = json.loads((folder / "fatigue.json").read_text())["anchors"]
        except (OSError, ValueError, KeyError):
            fatigue = summary.get("fatigue") or {}
    maxima = window_maxima(folder, window) if window is not None else {}
    dampers = dict(summary.get("dampers") or {}) if status in FINISHED else {}
    return CaseRecord(name, seed, hours_per_year, status, float(wall),
                      window, fatigue, maxima, rel, dampers,
                      list(summary.get("warnings") or []))


def _summary_window(summary: dict) -> tuple[float, float] | None:
    for group in ("anchors", "kinks"):
        for entry in (summary.get(group) or {}).values():
            w = (entry.get("steady_state_moment") or {}).get("window")
            if w:
                return float(w[0]), float(w[1])
    return None


def _csv_window(path: Path, start: float | None) -> tuple[float, float] | None:
    """The statistics window of a run's ``anchors.csv`` by the run's rule
    (:func:`cablefem.app.statistics.window_start`: from ``start``, else the last third)."""
    from cablefem.app.statistics import window_start
    from cablefem.io.anchorcsv import read

    if not path.is_file():
        return None
    data = read(path, ["tension"], empty_ok=True)
    times = next(iter(data.values()))["time"] if data else np.zeros(0)
    if times.size < 2:
        return None
    return window_start(times, start), float(times[-1])


def _window_max(t: np.ndarray, v: np.ndarray, ok: np.ndarray, window) -> float | None:
    sel = (t >= window[0]) & (t <= window[1]) & ok & np.isfinite(v)
    return float(np.max(np.abs(v[sel]))) if sel.any() else None


def window_maxima(folder, window: tuple[float, float]) -> dict[str, dict]:
    """Per anchor (``anchors.csv``) and kink (``kinks.csv``, as ``kink:<name>``) the largest
    moment magnitude over the valid samples and the largest tension in ``window``
    (absent, None, when there is none: a pinned anchor has no moment)."""
    from cablefem.app.fatigue import read_kinks
    from cablefem.io.anchorcsv import read

    folder = Path(folder)
    out = {}
    if (folder / "anchors.csv").is_file():
        data = read(folder / "anchors.csv", ["tension"], optional=["moment", "valid"],
                    empty_ok=True)
        for loc, d in data.items():
            m = d.get("moment", np.full(d["time"].size, np.nan))
            ok = (np.nan_to_num(d["valid"]) > 0) if "valid" in d else np.isfinite(m)
            out[loc] = {"max_moment": _window_max(d["time"], m, ok, window),
                        "max_tension": _window_max(d["time"], d["tension"],
                                                   np.ones(m.size, bool), window)}
    for loc, d in read_kinks(folder / "kinks.csv").items():
        out[f"kink:{loc}"] = {
            "max_moment": _window_max(d["time"], d["moment"], d["valid"] > 0, window),
            "max_tension": _window_max(d["time"], d["tension"], np.ones(d["time"].size, bool),
                                       window)}
    return out
