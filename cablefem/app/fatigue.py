"""``cablefem fatigue DIR --case CASE.toml``: fatigue at the clamped anchors of a run.

Reads ``DIR/anchors.csv`` (written by ``cablefem run`` or ``cablefem post``), takes the S-N
curve and the section from the case's ``[fatigue]`` table (and ``section.diameter``), and
writes ``fatigue.json``, ``fatigue.md`` and ``fatigue_histogram.png``; the interior kinks
of ``DIR/kinks.csv`` are reported as ``kink:<name>``. Stresses use the moment *vector*
(``Mx, My, Mz``) at the worst direction round the section (``docs/fatigue.md``: the steps
and every field): the magnitude alone would fold a moment that changes sign or turns, and
underestimate the damage. No dolfinx.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
from mpi4py import MPI

from cablefem.case import Case, CaseError, startup_time
from cablefem.fatigue import YEAR_SECONDS, SNCurve, StressSection, fatigue_report
from cablefem.io.anchorcsv import read_moments
from cablefem.io.fatiguereport import write_report
from cablefem.units import unit

__all__ = ["run_fatigue"]

log = logging.getLogger(__name__)


def read_kinks(path: Path) -> dict[str, dict[str, np.ndarray]]:
    """``kinks.csv`` (:mod:`cablefem.app.kinkout`) as kink -> ``time, tension, moment,
    valid, moment_vector`` arrays (empty cells: NaN); nothing when there is no file."""
    import csv

    if not path.is_file():
        return {}
    rows: dict[str, list] = {}
    with open(path, newline="") as fh:
        for i, row in enumerate(csv.DictReader(fh), start=2):
            try:
                vals = [float(row[c]) if row[c] else np.nan for c in
                        ("time", "tension", "moment", "Mx", "My", "Mz", "valid")]
            except (KeyError, ValueError, TypeError) as err:
                raise ValueError(f"{path}:{i}: not a kinks.csv row ({err})") from None
            rows.setdefault(row["kink"], []).append(vals)
    out = {}
    for name, v in rows.items():
        a = np.array(v)
        out[name] = {"time": a[:, 0], "tension": a[:, 1], "moment": a[:, 2],
                     "moment_vector": a[:, 3:6], "valid": np.nan_to_num(a[:, 6])}
    return out


def _stress_section(spec, section) -> StressSection:
    if spec.area is not None:
        return StressSection.effective(spec.area, spec.modulus)
    if section.diameter is None:
        raise ValueError("stresses need section.diameter (or fatigue.area and "
                         "fatigue.modulus)")
    return StressSection.solid_circle(section.diameter)


def _network_sections(rundir: Path, given: dict | None) -> dict:
    """A network's anchor -> section name: ``given`` (a run that is still writing its
    summary passes them), or from the run's summary.json, of the anchors whose kind is
    "clamped" there (a clamp the cable runs through has its moments in kinks.csv)."""
    if given is not None:
        return given
    import json

    path = rundir / "summary.json"
    try:
        return {n: e.get("section") for n, e in
                json.loads(path.read_text()).get("anchors", {}).items()
                if e.get("kind", "clamped") == "clamped"}
    except (OSError, ValueError) as err:
        raise ValueError(f"{path}: cannot read the anchors' sections of the network "
                         f"run ({err})") from None


def _anchor_sections(case: Case, rundir: Path, names: list[str],
                     given: dict[str, str] | None = None) -> dict:
    """The Section of every anchor: the case's for a single cable; for a network the one
    named for the anchor by ``given`` (anchor -> section name; a run that is still writing
    its summary passes them) or else by the run's summary.json."""
    if case.network is None:
        return {n: case.section for n in names}
    given = _network_sections(rundir, given)
    out = {}
    for n in names:
        sec = given.get(n)
        if sec not in case.network.sections:
            raise ValueError(f"{rundir}/summary.json names no known section for anchor {n}")
        out[n] = case.network.sections[sec]
    return out


def fatigue_window(case: Case, rule: str) -> tuple[str | tuple[float, float] | None, dict]:
    """The window argument of :func:`cablefem.fatigue.fatigue_report` for a window rule
    ('after_startup', 'all', 'steady': from ``dynamics.statistics_start`` when the case
    sets it, else the last third of the run), and its description for fatigue.json."""
    if rule == "all":
        return None, {"rule": "all", "reason": "the whole run"}
    if rule == "steady":
        start = getattr(case.dynamics, "statistics_start", None)
        if start is not None:  # the run's own statistics window
            return (float(start), math.inf), {"rule": "steady", "start": float(start),
                                              "reason": "dynamics.statistics_start"}
        return "steady", {"rule": "steady", "reason": "the last third of the run"}
    if rule != "after_startup":
        raise ValueError(f"window must be 'after_startup', 'all' or 'steady', got {rule!r}")
    t0, why = startup_time(case)
    return ((t0, math.inf) if t0 > 0 else None), {"rule": "after_startup", "start": t0,
                                                  "reason": why}


def _kink_section(case: Case, name: str):
    """The Section of a kink: the case's for a single cable; in a network that of the cable
    group the kink's name ends with (``<where>/<group>``)."""
    if case.network is None:
        return case.section
    group = name.rsplit("/", 1)[-1]
    for c in case.network.cables:
        if c.group == group:
            return case.network.sections[c.section]
    raise ValueError(f"kinks.csv: kink {name!r} names no cable group of the network")


def run_fatigue(case: Case, rundir: Path, outdir: Path | None = None, *,
                window: str | None = None, invalid: str = "raise",
                comm: MPI.Comm = MPI.COMM_WORLD, sections: dict[str, str] | None = None
                ) -> dict:
    """Fatigue reports of every clamped anchor in ``rundir/anchors.csv`` and of every
    interior kink in ``rundir/kinks.csv`` (``kink:<name>``, with its cable's section);
    rank 0 computes and writes, the reports are returned on every rank. Raises CaseError without a
    ``[fatigue]`` table and ValueError on bad data (invalid samples with
    ``invalid="raise"``: the message names the anchor and the first bad time).

    ``window`` (default ``fatigue.window``): 'after_startup' from the end of the anchor
    motions' start-up (:func:`cablefem.case.startup_time`), 'all' or 'steady'; every
    report says which under ``window_rule``.
    ``sections``: a network's anchor -> section name (default: from rundir/summary.json)."""
    spec = case.fatigue
    if spec is None:
        raise CaseError([("fatigue", "the case has no [fatigue] table (detail_category, ...): "
                                     "see 'cablefem keys'")], case.source)
    outdir = Path(outdir or rundir)
    reports, error = None, None
    if comm.rank == 0:
        try:
            curve = SNCurve(spec.detail_category, spec.m1, spec.m2, spec.knee, spec.N_C,
                            spec.N_knee, spec.N_cutoff)
            groups = {a.name for a in case.anchors if a.kind == "clamped"}
            # no clamped anchor: no moment columns in anchors.csv (the kinks may have some)
            data = read_moments(Path(rundir) / "anchors.csv") if groups else {}
            if case.network is None:
                clamped = sorted(groups)
                missing = [n for n in clamped if n not in data]
                if missing:
                    raise ValueError(f"{rundir}/anchors.csv has no rows for the clamped "
                                     f"anchors {missing}")
            else:  # network anchors are "group:k"; not those a cable runs through
                sections = _network_sections(Path(rundir), sections) if data else {}
                clamped = [n for n in data if n.split(":")[0] in groups and n in sections]
            sections = _anchor_sections(case, Path(rundir), clamped, sections)
            win, rule = fatigue_window(case, window or spec.window)
            t_last = max((float(data[n]["time"][-1]) for n in clamped), default=0.0)
            if isinstance(win, tuple) and win[0] >= t_last:
                raise ValueError(f"the run ends at t = {t_last:g}, before the end of the "
                                 f"start-up at t = {win[0]:g} ({rule['reason']}) that the "
                                 "fatigue window 'after_startup' leaves out: run longer, or "
                                 "set fatigue.window = 'all'")
            tu = unit(case.units, "time")
            year = YEAR_SECONDS if tu == "s" else None  # sqrt(l/g): no fixed length
            reports = {}
            for name in clamped:
                d = data[name]
                M = d.get("moment_vector", d["moment"])
                reports[name] = fatigue_report(
                    d["time"], d["tension"], M, d["valid"], _stress_section(spec,
                                                                            sections[name]),
                    curve, invalid=invalid, window=win, fibres=spec.fibres, anchor=name,
                    year=year)
                reports[name]["window_rule"] = rule
            kink_sections = {}
            for name, d in read_kinks(Path(rundir) / "kinks.csv").items():
                # the interior kinks (kinks.csv), as "kink:<name>"
                vec = d["moment_vector"]  # a rod's file has the magnitude only
                M = vec if np.any(np.isfinite(vec)) else d["moment"]
                kink_sections[name] = _kink_section(case, name)
                reports[f"kink:{name}"] = fatigue_report(
                    d["time"], d["tension"], M, d["valid"],
                    _stress_section(spec, kink_sections[name]), curve, invalid=invalid,
                    window=win, fibres=spec.fibres, anchor=f"kink:{name}", year=year)
                reports[f"kink:{name}"]["window_rule"] = rule
            if not reports:
                raise ValueError(f"{rundir}: no clamped anchor and no interior kink: no "
                                 "bending moment to assess")
            outdir.mkdir(parents=True, exist_ok=True)
            write_report(outdir, reports, curve, units=spec.units, time_unit=tu)
            for name, rep in reports.items():
                ttf = rep.get("time_to_failure")
                per_year = rep.get("damage_per_year")
                log.info("fatigue at %s: damage %.3g over %.4g %s%s, time to failure %s", name,
                         rep.get("damage", np.nan), rep.get("duration", np.nan), tu,
                         "" if per_year is None else f" ({per_year:.3g} per year)",
                         "infinite (no damaging cycle)" if ttf is None
                         else f"{ttf:.3g} {tu}" + (f" ({ttf / YEAR_SECONDS:.3g} years of "
                                                    "365.25 d)" if tu == "s" else ""))
        except (ValueError, OSError) as err:
            error = str(err)
    error = comm.bcast(error, root=0)
    if error is not None:
        raise ValueError(error)
    return comm.bcast(reports, root=0)
