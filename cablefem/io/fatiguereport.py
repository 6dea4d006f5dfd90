"""The fatigue assessment's files: ``fatigue.json``, ``fatigue.md`` and
``fatigue_histogram.png`` from the reports of :func:`cablefem.fatigue.fatigue_report`, each
written atomically (a temporary file, then a rename)."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import BinaryIO, Callable

import numpy as np

from cablefem.fatigue import YEAR_SECONDS, SNCurve, StressSection

__all__ = ["write_report"]


def _atomic(path: Path, write: Callable[[BinaryIO], object]) -> None:
    """Write through ``write(binary file)`` to a temporary name beside ``path``, then rename."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as fh:
            write(fh)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def _g(*xs: float | None) -> str:
    return " / ".join("-" if x is None else f"{x:.4g}" for x in xs)  # None: not defined


def _sn_text(curve: SNCurve, u: str) -> str:
    knee = (f"knee ds_D = {curve.delta_sigma_D:.4g} {u} at {curve.N_knee:.3g}, m2 = "
            f"{curve.m2:g}, cut-off ds_L = {curve.delta_sigma_L:.4g} {u} at "
            f"{curve.N_cutoff:.3g}" if curve.knee else "single slope, no cut-off")
    return (f"S-N curve: ds_C = {curve.detail_category:.4g} {u} at N_C = {curve.N_C:.3g}, "
            f"m1 = {curve.m1:g}, {knee}.")


def _years(x: float | None) -> str:
    return "" if x is None else f" ({x / YEAR_SECONDS:.3g} years of 365.25 d)"


def write_report(outdir: str | Path, reports: dict[str, dict], curve: SNCurve,
                 section: StressSection | None = None, units: str = "Pa",
                 time_unit: str = "s") -> list[str]:
    """Write ``fatigue.json``, ``fatigue.md`` and ``fatigue_histogram.png`` into ``outdir``
    (atomically). The top-level ``section`` is the reports' common one, None where they
    differ (``section``: for reports without one). Returns the file names.

    Args:
        outdir: Output folder (created if needed).
        reports: Anchor name -> :func:`cablefem.fatigue.fatigue_report` (each with its own
            ``section``).
        curve: The S-N curve.
        section: The reports' section, for reports without one.
        units: Name of the stress unit.
        time_unit: Name of the time unit.
    """
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    given = None if section is None else {"area": section.area, "modulus": section.modulus}
    secs = [r.get("section", given) for r in reports.values()]
    common = secs[0] if secs and all(x == secs[0] for x in secs) else None
    data = {"units": {"stress": units, "time": time_unit}, "section": common,
            "sn_curve": curve.as_dict(), "anchors": reports}
    text = json.dumps(data, indent=2, allow_nan=False) + "\n"
    _atomic(out / "fatigue.json", lambda fh: fh.write(text.encode()))
    lines = ["# Fatigue at the clamped anchors", "", _sn_text(curve, units),
             f"Stresses in {units}, times in {time_unit}; rainflow + Miner over the window "
             "(fields: docs/fatigue.md).", ""]
    for name, r in reports.items():
        f = r.get("fibre")
        fib = (f" (worst direction {f['angle_deg']:.6g} deg from e1; best of the "
               f"{f['scanned']} scanned: {f['damage_scan']:.4g})") if f else ""
        sec = r.get("section", given) or {"area": None, "modulus": None}
        s_yr = "" if time_unit != "s" else _years(r["time_to_failure"])
        rows = [("window t0 / t1", _g(*r["window"])), ("damage D", _g(r["damage"]) + fib),
                ("damage per year", _g(r.get("damage_per_year"))),
                ("time to failure", "inf (no damaging cycle)" if r["time_to_failure_infinite"]
                 else _g(r["time_to_failure"]) + s_yr),
                ("cycles (all / damaging)", _g(r["cycles"], r.get("damaging_cycles"))),
                ("max range / equivalent range / at N_C",
                 _g(r["max_range"], r["equivalent_range"], r["equivalent_range_N_C"])),
                ("stress min / max", _g(r["stress"]["min"], r["stress"]["max"])),
                ("range axial / bending",
                 _g(r["axial_stress"]["range"], r["bending_stress"]["range"])),
                ("D axial only / bending only",
                 _g(r["damage_axial_only"], r["damage_bending_only"])),
                ("section A / W", _g(sec["area"], sec["modulus"])),
                ("dropped invalid samples", _g(r["dropped_invalid_samples"]))]
        lines += [f"## Anchor {name}", "", "| quantity | value |", "|---|---|"]
        lines += [f"| {k} | {x} |" for k, x in rows] + [""]
    _atomic(out / "fatigue.md", lambda fh: fh.write("\n".join(lines).encode()))
    _histogram_png(out / "fatigue_histogram.png", reports, curve, units)
    return ["fatigue.json", "fatigue.md", "fatigue_histogram.png"]


def _histogram_png(path: Path, reports: dict[str, dict], curve: SNCurve, units: str) -> None:
    from matplotlib.figure import Figure  # no pyplot: savefig(format="png") uses Agg

    fig = Figure(figsize=(8, 2.8 * max(len(reports), 1)))
    axes = fig.subplots(max(len(reports), 1), 1, squeeze=False)[:, 0]
    marks = [("ds_C", curve.detail_category, "k")] + ([
        ("knee ds_D", curve.delta_sigma_D, "tab:orange"),
        ("cut-off ds_L", curve.delta_sigma_L, "tab:red")] if curve.knee else [])
    for ax, (name, rep) in zip(axes, reports.items()):
        e, h = np.array(rep["histogram"]["edges"]), np.array(rep["histogram"]["counts"])
        ax.bar(e[:-1], h, width=np.diff(e), align="edge", color="tab:blue", label="cycles")
        ax.set_yscale("log" if np.any(h > 0) else "linear")
        for label, x, col in marks:
            on = bool(x <= 1.5 * e[-1])  # marks far beyond the ranges: in the legend only
            ax.plot([x, x] * on, [0, 1] * on, ls="--", color=col,
                    transform=ax.get_xaxis_transform(),
                    label=f"{label} = {x:.3g}" + ("" if on else " (off axis)"))
        ax.set(ylabel="cycles", title=f"anchor {name}: D = {rep['damage']:.3g}")
        ax.grid(True, lw=0.3)
        ax.legend(fontsize=7)
    axes[-1].set_xlabel(f"stress range [{units}]")
    fig.tight_layout()
    _atomic(path, lambda fh: fig.savefig(fh, format="png", dpi=110))
