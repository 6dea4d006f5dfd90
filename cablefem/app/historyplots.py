"""Figures of every kind of case, from the histories a run recorded (rank 0 draws;
matplotlib's Agg backend without pyplot, PNG files; docs/outputs.md lists which run writes
which):

* ``anchor_tensions.png``: every anchor's tension (a mooring line's fairlead included),
* ``touchdown.png``: with a seabed, where the line leaves it (the touchdown's station and
  the grounded length; a network's: each group's grounded length),
* ``kink_moments.png``: the moment at every kink (``kinks.csv``),
* ``dampers.png``: every damper's force and stroke (``dampers.csv``).

At most :data:`cablefem.app.plots.MAX_PANELS` curves or panel rows: the most loaded, and
the title says so."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from mpi4py import MPI

from cablefem.app.plots import MAX_PANELS, moment_axis_range
from cablefem.units import unit

__all__ = ["history_figures", "tension_figure", "touchdown_figure", "kink_figure",
           "damper_figure"]

DPI = 130


def _figure(rows: int, height: float = 2.6):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 1.0 + height * rows))
    return fig, fig.subplots(rows, 1, sharex=True, squeeze=False)[:, 0]


def _save(fig, outdir: Path, name: str, title: str, tu: str, axes) -> str:
    axes[-1].set_xlabel(f"time t [{tu}]")
    for ax in axes:
        ax.grid(True, lw=0.3)
    fig.suptitle(title)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.35 / fig.get_figheight()))
    fig.savefig(Path(outdir) / name, dpi=DPI)
    return name


def _most_loaded(values: dict[str, np.ndarray]) -> tuple[list[str], str]:
    """The names of the (at most :data:`MAX_PANELS`) largest histories and the phrase that
    says how many of how many they are."""
    peak = {n: float(np.nanmax(np.abs(v), initial=0.0)) for n, v in values.items()}
    keep = sorted(peak, key=peak.get, reverse=True)[:MAX_PANELS]
    keep = [n for n in values if n in keep]  # the file's order
    return keep, ("" if len(keep) == len(values)
                  else f" (the {len(keep)} most loaded of {len(values)})")


def tension_figure(outdir, times, forces: dict[str, np.ndarray], units: str) -> str:
    """Every anchor's tension ``|N|``, one panel each (the axis spans its own range: a
    mooring line's fairlead and anchor differ by the line's weight)."""
    fu, tu = unit(units, "force"), unit(units, "time")
    tension = {n: np.linalg.norm(F, axis=1) for n, F in forces.items()}
    keep, which = _most_loaded(tension)
    fig, axes = _figure(len(keep), 2.2)
    for ax, name in zip(axes, keep):
        ax.plot(times, tension[name], lw=0.8)
        lims = moment_axis_range(tension[name])
        if lims is not None:
            ax.set_ylim(*lims)
        ax.set_ylabel(f"T at {name} [{fu}]")
    return _save(fig, outdir, "anchor_tensions.png", f"Anchor tension{which}", tu, axes)


def touchdown_figure(outdir, rows, units: str) -> str | None:
    """The touchdown (the rows of ``touchdown.csv``, a :class:`cablefem.app.touchdownout.
    TouchdownRows`): a single cable's station ``s`` of the point where it leaves the seabed
    (and its grounded length where that differs: a line not grounded from its first
    anchor); a network's grounded length per cable group. None without rows."""
    if not len(rows):
        return None
    lu, tu = unit(units, "length"), unit(units, "time")
    fig, axes = _figure(1, 3.2)
    ax = axes[0]
    lines = list(dict.fromkeys(rows.lines))
    if lines == ["cable"]:
        t, s, g = (rows.values.array[:, k] for k in (0, 1, 5))
        ax.plot(t, s, lw=0.8, label="touchdown station s (stress-free arc length)")
        if np.isfinite(s).any():
            ax.set_title(f"excursion along the line {np.nanmax(s) - np.nanmin(s):.4g} {lu}",
                         fontsize=9)
        if np.nanmax(np.abs(g - s), initial=0.0) > 1e-6 * np.nanmax(np.abs(g), initial=1.0):
            ax.plot(t, g, lw=0.8, ls="--", label="grounded length")
        ax.set_ylabel(f"s, length [{lu}]")
    else:
        for line in lines[:MAX_PANELS]:
            g = dict(rows.of(line)[:, [0, 5]].tolist())  # a row per touchdown point
            ax.plot(list(g), list(g.values()), lw=0.8, label=line)
        ax.set_ylabel(f"grounded length [{lu}]")
    ax.legend(loc="upper left", fontsize=7)
    return _save(fig, outdir, "touchdown.png", "Touchdown on the seabed (touchdown.csv)",
                 tu, axes)


def kink_figure(outdir, history, units: str) -> str | None:
    """The moment at every kink (:class:`cablefem.app.kinkout.KinkHistory`), invalid rows
    marked at the foot of the axes. None without kinks or rows."""
    if not history.kinks or len(history.times) < 2:
        return None
    mu, tu = unit(units, "moment"), unit(units, "time")
    times = np.array(history.times)
    moment = {k.name: np.array(history.rows[k.name]["moment"], float) for k in history.kinks}
    keep, which = _most_loaded(moment)
    fig, axes = _figure(1, 3.2)
    ax = axes[0]
    for name in keep:
        ok = np.array(history.rows[name]["valid"], float) == 1
        ax.plot(times, np.where(ok, moment[name], np.nan), lw=0.8, label=name)
        if np.any(~ok):
            ax.plot(times[~ok], np.zeros(np.count_nonzero(~ok)), "x", ms=3,
                    transform=ax.get_xaxis_transform(), label=f"{name}: invalid rows")
    lims = moment_axis_range(np.concatenate([moment[n] for n in keep]))
    if lims is not None:
        ax.set_ylim(*lims)
    ax.set_ylabel(f"kink moment |M| [{mu}]")
    ax.legend(loc="upper left", fontsize=7)
    return _save(fig, outdir, "kink_moments.png", f"Bending moment at the kinks{which} "
                 "(kinks.csv)", tu, axes)


def damper_figure(outdir, history, units: str) -> str | None:
    """Every damper's force and stroke (:class:`cablefem.app.damperout.DamperHistory`):
    two panels, one curve per damper. None without dampers or rows."""
    if history is None or not history.names or history.times.size < 2:
        return None
    fu, lu, tu = unit(units, "force"), unit(units, "length"), unit(units, "time")
    keep, which = _most_loaded({n: history.rows[n]["force"] for n in history.names})
    fig, axes = _figure(2)
    for name in keep:
        for ax, q in zip(axes, ("force", "stroke")):
            ax.plot(history.times, history.rows[name][q], lw=0.8, label=name)
    axes[0].set_ylabel(f"damper force [{fu}]")
    axes[1].set_ylabel(f"stroke [{lu}]")
    axes[0].legend(loc="upper left", fontsize=7)
    note = ("signed along its direction, or the magnitude in the plane normal to the "
            "cable (dampers.csv)")
    axes[0].set_title(note, fontsize=8)
    return _save(fig, outdir, "dampers.png", f"Dampers{which}: force and stroke from the "
                 "static state", tu, axes)


def history_figures(outdir, h, units: str, comm: MPI.Comm = MPI.COMM_WORLD) -> list[str]:
    """The figures above that the run's histories ``h`` (:class:`cablefem.app.output.
    Histories`) have data for; their file names on every rank."""
    names: list[str] = []
    if comm.rank == 0 and len(h.times) > 1:
        drawn = [tension_figure(outdir, h.times, h.forces, units)]
        if h.touchdown_rows:
            drawn.append(touchdown_figure(outdir, h.touchdown_rows, units))
        drawn.append(kink_figure(outdir, h.kinks, units))
        drawn.append(damper_figure(outdir, h.dampers, units))
        names = [n for n in drawn if n is not None]
    return comm.bcast(names, root=0)
