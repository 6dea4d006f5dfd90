"""The figures of a load-case set's design (:mod:`cablefem.design`): the damage over the
design life per location stacked by case (``design_damage.png``) and the extremes per case
(``design_extremes.png``: each seed's window maximum and the most probable maximum). The
caller draws on one rank (:func:`cablefem.design.write_design_figures`); matplotlib's Agg
backend through ``Figure`` (no pyplot), PNG files."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["design_figures", "MAX_PANELS"]

#: at most this many locations in the extremes figure: those with the largest moment
MAX_PANELS = 8


def design_figures(design: dict, outdir: Path) -> list[str]:
    """Draw the figures the design has data for into ``outdir``; their paths."""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    paths = []
    if design.get("fatigue"):
        paths.append(str(damage_figure(design, outdir / "design_damage.png")))
    if design.get("extremes"):
        paths.append(str(extremes_figure(design, outdir / "design_extremes.png")))
    return paths


def damage_figure(design: dict, path: Path) -> Path:
    """One bar per location, its damage over the design life stacked by case; a location
    whose damage is a lower bound (an unfinished record) is hatched and says so."""
    from matplotlib.figure import Figure

    fatigue = design["fatigue"]
    locs = list(fatigue)
    cases = list(dict.fromkeys(c for e in fatigue.values() for c in e.get("cases", {})))
    fig = Figure(figsize=(max(6.0, 1.2 * len(locs) + 3), 4.5))
    ax = fig.subplots()
    x = np.arange(len(locs))
    bottom = np.zeros(len(locs))
    colours = _colours(len(cases))
    for c, colour in zip(cases, colours):
        h = np.array([fatigue[loc].get("cases", {}).get(c, 0.0) for loc in locs])
        ax.bar(x, h, 0.6, bottom=bottom, label=c, color=colour, edgecolor="k", lw=0.3)
        bottom += h
    for i, loc in enumerate(locs):
        e = fatigue[loc]
        life = e.get("life_years")
        complete = e.get("complete", True)
        text = ("no damage" if life is None else
                f"life {'' if complete else '<= '}{life:.3g} y")
        if not complete:
            ax.bar(x[i], bottom[i], 0.6, fill=False, hatch="//", edgecolor="r", lw=0.5)
            text += "\n(incomplete: damage\na lower bound)"
        ax.annotate(text, (x[i], bottom[i]), ha="center", va="bottom", fontsize=7,
                    xytext=(0, 2), textcoords="offset points")
    # the axis scales to the largest damage (a damage far below 1, the usual design, would
    # be an invisible sliver under the failure line); the line is drawn when it is in view
    top = 1.2 * float(bottom.max(initial=0.0))
    top = 1.05 if top <= 0.0 or 0.5 <= top < 1.05 else top
    if top >= 1.0:
        ax.axhline(1.0, color="r", lw=0.6, ls="--", label="damage 1 (failure)")
    ax.set_xticks(x)
    ax.set_xticklabels(locs, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel(f"damage over {design['design_life_years']:g} years"
                  + ("" if top >= 1.0 else "\n(failure, 1, off the scale)"))
    ax.set_ylim(0, top)
    ax.grid(True, axis="y", lw=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), title="case",
              title_fontsize=7)
    ax.set_title("Fatigue damage over the design life per location, stacked by load case"
                 + ("" if design.get("complete", True) else " (incomplete set)"), fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    return path


def extremes_figure(design: dict, path: Path) -> Path:
    """Per location (rows: the :data:`MAX_PANELS` with the largest moment) and quantity
    (columns: moment, tension) each case's seed maxima (dots) and its most probable maximum
    (a bar) over its stated duration."""
    from matplotlib.figure import Figure

    ext = design["extremes"]
    locs = sorted(ext, key=lambda n: -(ext[n].get("max_moment") or 0.0))[:MAX_PANELS]
    fig = Figure(figsize=(11, 2.8 * len(locs) + 0.6))
    axes = fig.subplots(len(locs), 2, squeeze=False)
    for row, loc in zip(axes, locs):
        cases = list(ext[loc].get("cases", {}))
        x = np.arange(len(cases))
        for ax, quantity in zip(row, ("moment", "tension")):
            for i, c in enumerate(cases):
                q = ext[loc]["cases"][c].get(quantity)
                if q is None:
                    continue
                ax.plot(np.full(len(q["seed_maxima"]), x[i]), q["seed_maxima"], "o", ms=4,
                        color="C0", mfc="none", label="seeds' window maxima" if i == 0
                        else None)
                single = q.get("estimator") == "single seed"
                ax.plot(x[i], q["mpm"], "_", ms=18, mew=2, color="C3" if not single
                        else "0.5", label="MPM (Gumbel, moments)" if i == 0 and not single
                        else "one seed: its maximum" if single and i == 0 else None)
            ax.set_xticks(x)
            ax.set_xticklabels(cases, rotation=20, ha="right", fontsize=7)
            ax.set_ylabel(f"max {quantity}\nat {loc}", fontsize=8)
            ax.grid(True, lw=0.3)
            if any(ext[loc]["cases"][c].get(quantity) for c in cases):
                ax.legend(fontsize=6, loc="upper left")
            else:  # a pinned anchor's moment: say so rather than leave an empty frame
                ax.set_yticks([])
                ax.text(0.5, 0.5, f"no {quantity} at {loc} in any case\n(e.g. a pinned "
                        "anchor has no moment)", transform=ax.transAxes, ha="center",
                        va="center", fontsize=8)
    durations = {q.get("duration") for e in ext.values() for c in e.get("cases", {}).values()
                 for q in c.values()}
    dur = ", ".join(f"{d:.4g} s" for d in sorted(d for d in durations if d is not None))
    fig.suptitle(f"Extremes per load case: seeds' window maxima and the most probable "
                 f"maximum over {dur or 'one window'} (moment and tension in the cases' "
                 "units)", fontsize=9)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.35 / fig.get_figheight()))
    fig.savefig(path, dpi=130)
    return path


def _colours(n: int) -> list:
    from matplotlib import colormaps

    cmap = colormaps["tab10" if n <= 10 else "tab20"]
    return [cmap(i % cmap.N) for i in range(n)]
