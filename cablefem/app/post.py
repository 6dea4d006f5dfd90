"""``cablefem post``: anchor moments from anchor-force histories of any string solver.

No dolfinx: the case file gives the section, the clamp directions, gravity and the loads;
the CSV gives the forces. Writes ``anchors.csv`` (with the moment columns),
``summary.json`` and the figures. The composite field along the cable needs the string's
positions and is therefore only written by ``cablefem run``.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from cablefem import __version__
from cablefem.app.plots import anchor_figures
from cablefem.app.report import anchor_validity, max_excitation, steady_state_stats, warn
from cablefem.app.statistics import warn_drifts
from cablefem.asymptotics import wrap_azimuth
from cablefem.case import Case
from cablefem.description import stress_free_length
from cablefem.io.anchorcsv import ANCHOR_COLUMNS, MOMENT_COLUMNS, AnchorCSV, read_forces
from cablefem.io.series import write_json
from cablefem.moments import ERROR_THRESHOLD, MAX_ANCHOR_ANGLE, anchor_moments

__all__ = ["run_post", "case_length"]

log = logging.getLogger(__name__)


#: the stress-free length of a case's cable (the catenary's for tension/sag geometry)
case_length = stress_free_length


#: an anchor is refused when more than this share of its (non-slack) rows has the force
#: more than 90 degrees from the clamp direction: then the file's sign convention is wrong,
#: not a few samples (``docs/post.md``)
MAX_BACKWARDS_SHARE = 0.5


def run_post(case: Case, forces_csv: Path, outdir: Path, form: str = "exact",
             comm: MPI.Comm = MPI.COMM_WORLD, sign: str = "span") -> dict:
    """Post-process ``forces_csv`` with ``case``; raises ValueError on bad input.

    ``sign``: "span" when the CSV holds the force of the span on the anchor (pointing into
    the span, what ``cablefem run`` writes), "anchor" when it holds the force of the anchor
    on the cable (flipped here). An anchor most of whose rows have the force more than 90
    degrees from its clamp direction is refused (ValueError naming the convention and
    ``--sign``); single such rows are kept with ``valid = 0``."""
    t0 = time.perf_counter()
    if sign not in ("span", "anchor"):
        raise ValueError(f"sign must be 'span' or 'anchor', got {sign!r}")
    if case.network is not None:
        raise ValueError(f"{case.source}: 'cablefem post' takes single-cable cases; for a "
                         "network, its anchor forces come from 'cablefem run'")
    if case.section is not None and not case.section.EI > 0:
        raise ValueError(f"{case.source}: section.EI = 0: a cable without bending stiffness "
                         "has no anchor moment to compute (cablefem.chain)")
    hist = read_forces(forces_csv)
    if sign == "anchor":
        hist.forces = {k: -v for k, v in hist.forces.items()}
    names = [a.name for a in case.anchors]
    unknown = sorted(set(hist.forces) - set(names))
    if unknown:
        raise ValueError(f"{forces_csv}: anchors {unknown} are not in the case "
                         f"(case anchors: {names})")
    length = case_length(case)
    outdir = Path(outdir)
    if comm.rank == 0:
        outdir.mkdir(parents=True, exist_ok=True)
    comm.Barrier()
    sec = case.section
    g_vec = np.asarray(case.gravity.direction, float) * case.gravity.g
    times = hist.times
    omega = max_excitation(case)
    moments, summary_anchors, warnings = {}, {}, {}
    order = 1 if getattr(case.solver, "outer_correction", "none") == "hinge" else 0
    for a in case.anchors:
        if a.name not in hist.forces or a.kind != "clamped":
            continue
        acc = np.array([a.motion.acceleration(t) if a.motion else np.zeros(3) for t in times])
        fluid = getattr(case, "fluid", None)
        buoy = (-fluid.density * g_vec * np.pi * fluid.diameter_on(sec)**2 / 4
                if fluid is not None and fluid.buoyancy else np.zeros(3))
        load = np.array([sec.mass * g_vec + buoy + sum((np.asarray(ld.value) * ld.time.value(t)
                                                        for ld in case.loads), np.zeros(3))
                         for t in times])
        res = anchor_moments(hist.forces[a.name], a.direction, sec.EI, sec.EA, sec.mass, acc,
                             load, length, omega, form, order)
        if times.size:  # psi0 on the branch of the first row's, as a run writes it
            res["psi0"] = wrap_azimuth(res["psi0"], res["psi0"][0])
        backwards = res["delta"] > MAX_ANCHOR_ANGLE
        taut = ~res["slack"]
        if np.count_nonzero(backwards) > MAX_BACKWARDS_SHARE * max(np.count_nonzero(taut), 1):
            other = "anchor" if sign == "span" else "span"
            raise ValueError(
                f"{forces_csv}: anchor '{a.name}': {np.count_nonzero(backwards)} of "
                f"{np.count_nonzero(taut)} rows have the force more than 90 degrees from the "
                f"clamp direction (median angle "
                f"{np.degrees(np.median(res['delta'][taut])):.1f} deg): the CSV must hold the "
                "force of the span on the anchor (tension times the tangent into the span)"
                + (f"; if it holds the anchor's reaction, run again with --sign {other}"
                   if sign == "span" else f"; --sign anchor flipped it: try --sign {other}"))
        moments[a.name] = {k: res[k] for k in MOMENT_COLUMNS}
        reasons, counts = np.unique(res["invalid_reason"][res["invalid_reason"] != ""],
                                    return_counts=True)
        summary_anchors[a.name] = {
            # the first row is the static state when the history starts at rest, as a run's
            # anchors.csv does: the name 'cablefem run' gives it
            "static_moment": float(res["moment"][0]),
            "valid_fraction": float(np.mean(res["valid"])),
            "invalid_rows": {str(r): int(c) for r, c in zip(reasons, counts)},
            "steady_state_moment": steady_state_stats(times, res["moment"]),
            "validity": anchor_validity(warnings, a.name, times, res, ERROR_THRESHOLD)}
        for r, c in zip(reasons, counts):
            log.warning("anchor %s: %d of %d rows invalid: %s", a.name, c, times.size, r)
    drifts = {"anchors": summary_anchors}  # a response not steady in the window warns
    warn_drifts(drifts, warn)
    if drifts.get("warnings"):
        warnings.setdefault("warnings", []).extend(drifts["warnings"])
    cols = ANCHOR_COLUMNS + MOMENT_COLUMNS
    names = list(hist.forces)
    N = np.stack([hist.forces[n] for n in names], axis=1)  # (time, anchor, 3): row order
    table = {"time": np.repeat(times, len(names)), "anchor": names * times.size,
             "Nx": N[..., 0].ravel(), "Ny": N[..., 1].ravel(), "Nz": N[..., 2].ravel(),
             "tension": np.linalg.norm(N, axis=2).ravel()}
    for k in MOMENT_COLUMNS:  # empty at anchors without moments
        table[k] = np.column_stack([moments[n][k] if n in moments else
                                    np.full(times.size, np.nan) for n in names]).ravel()
    with AnchorCSV(outdir / "anchors.csv", cols, comm) as out:
        out.write(table)
    figs = (anchor_figures(outdir, times, moments, comm, units=case.units)
            if moments and times.size > 1 else [])
    summary = {"cablefem": __version__, "status": "completed", "command": "post",
               "forces": str(forces_csv), "sign": sign, "case": case.to_dict(), "length": length,
               "anchors": summary_anchors, "figures": figs, **warnings,
               "wall_time": {"total": time.perf_counter() - t0}}
    write_json(outdir / "summary.json", summary, comm)
    log.info("post-processed %d times x %d anchors into %s", times.size, len(hist.forces),
             outdir)
    return summary
