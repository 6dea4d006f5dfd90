"""``solver.model = "auto"`` (``--model auto``): the string, and the rod where the string's
own error estimate says it is outside its range.

The string + asymptotics runs first. Where the estimated moment error
(:func:`cablefem.moments.error_estimate`) of any clamped anchor exceeds
:data:`cablefem.moments.ERROR_THRESHOLD` over the anchor's output window (``validity.max``
in ``summary.json``), the same case runs again as the reference rod (:mod:`cablefem.rod`),
whose files replace the string's: the moments reported are the rod's. ``model_auto`` in
``summary.json`` says what was decided and why, the string's estimates and static moments,
and the cost (both wall times). A case the rod cannot take (a seabed, a fluid, a
polyline geometry: :func:`cablefem.rod.rod_problems`) keeps the
string's numbers and warns (``solver.model``) when the estimate is exceeded. A string
run that fails is not retried.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

from cablefem.io.series import write_json
from cablefem.moments import ERROR_THRESHOLD

__all__ = ["run_auto", "string_estimates"]

log = logging.getLogger(__name__)


def string_estimates(summary: dict) -> dict[str, float]:
    """Per clamped anchor of a string run's summary: the largest estimated moment error over
    its output window (``validity.max``; the static estimate when the run has no window).
    Anchors without an estimate are left out."""
    out = {}
    for name, entry in (summary.get("anchors") or {}).items():
        if entry.get("kind") != "clamped":
            continue
        est = (entry.get("validity") or {}).get("max")
        if est is None:
            est = entry.get("static_error_estimate")
        if est is not None and math.isfinite(est):
            out[name] = float(est)
    return out


def run_auto(run, case, outdir, comm, **kwargs):
    """Run ``case`` as ``solver.model = "auto"``: ``run(case, outdir, comm, model=...,
    **kwargs)`` is :func:`cablefem.app.run._run_case`. Returns the run's result: the rod's
    where the string's estimate exceeds the threshold and the rod can take the case, the
    string's otherwise; its summary has ``model_auto``."""
    from cablefem.rod import rod_problems

    refine = kwargs.pop("refine", 1.0)
    kwargs.pop("model", None)
    string = run(case, outdir, comm, model="string", **kwargs)
    est = string_estimates(string.summary)
    over = {n: e for n, e in est.items() if e > ERROR_THRESHOLD}
    record = {"asked": "auto", "threshold": ERROR_THRESHOLD, "string_error_estimate": est,
              # rank 0's clock, as summary.json has it: every rank returns the same record
              "string_wall_time": comm.bcast(string.summary["wall_time"]["total"], root=0)}
    if not over:
        record.update(decision="string", reason=(
            "the string's estimated moment error is at most the threshold at every clamped "
            "anchor" if est else "no clamped anchor with an error estimate"))
        log.info("model auto: the string (%s)", record["reason"])
        return _record(string, record, outdir, comm)
    worst = max(over, key=over.get)
    why = (f"the string's estimated moment error at anchor {worst} is "
           f"{100 * over[worst]:.3g} % (> {100 * ERROR_THRESHOLD:g} %)")
    problems = rod_problems(case)
    if problems:
        key, reason = problems[0]
        record.update(decision="string", reason=f"{why}, but the rod cannot run this case "
                      f"({key}: {reason})")
        from cablefem.app.report import warn

        warn(string.summary, "solver.model", f"'auto' cannot fall back to the rod: {why}, "
             f"and the rod cannot run this case ({key}: {reason}); the string's numbers "
             "are reported, outside their range")
        return _record(string, record, outdir, comm)
    log.info("model auto: %s: running the rod on the same case (its results replace the "
             "string's; the string took %.3g s)", why, record["string_wall_time"])
    static = {n: string.summary["anchors"][n].get("static_moment") for n in est}
    warnings = string.summary.get("warnings", [])
    rod = run(case, outdir, comm, model="beam", refine=refine, **kwargs)
    t_rod = comm.bcast(rod.summary["wall_time"]["total"], root=0)
    record.update(decision="beam", reason=why, string_static_moment=static,
                  string_warnings=warnings, rod_wall_time=t_rod,
                  cost_ratio=t_rod / max(record["string_wall_time"], 1e-300))
    log.info("model auto: the rod's moments are reported (the rod took %.3g s, %.3g times "
             "the string's %.3g s)", t_rod, record["cost_ratio"], record["string_wall_time"])
    return _record(rod, record, outdir, comm)


def _record(result, record: dict, outdir, comm):
    """Put ``record`` under ``model_auto`` in the result's summary and write it again."""
    result.summary["model_auto"] = record
    write_json(Path(outdir) / "summary.json", result.summary, comm)
    return result
