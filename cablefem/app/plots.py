"""Figures: the anchor-moment history at every clamped anchor (the paper's Fig. 2 kind) and,
for spatial motion, the steady-state polar plot of the moment against the bending-plane
azimuth ψ0 (its Fig. 3). Rank 0 draws; matplotlib's Agg backend, PNG files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from mpi4py import MPI

from cablefem.units import unit

__all__ = ["anchor_figures", "is_spatial", "moment_axis_range"]

#: at most this many anchors in a figure: those with the largest moment
MAX_PANELS = 8


def is_spatial(psi0: np.ndarray, valid: np.ndarray) -> bool:
    """True when the bending plane turns: its azimuth ψ0, taken modulo π (a plane is a line:
    ψ0 jumps by π when an in-plane moment changes sign), spreads by more than 1°."""
    p = psi0[(valid > 0) & np.isfinite(psi0)]
    if p.size < 3:
        return False
    z = np.exp(2j * p)  # doubling the angle identifies psi0 and psi0 + pi
    m = np.mean(z)
    spread = np.angle(z / m) / 2 if abs(m) > 1e-12 else np.angle(z) / 2
    return float(np.ptp(spread)) > np.radians(1.0)


def moment_axis_range(values: np.ndarray, margin: float = 0.05) -> tuple[float, float] | None:
    """Limits of a moment axis: the finite data's range widened by ``margin`` of it on each
    side (zero is *not* forced in: a ±1 % variation about a large static moment must fill
    the axes, not a sliver at their top); None without finite data."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return None
    lo, hi = float(v.min()), float(v.max())
    pad = margin * (hi - lo) if hi > lo else max(abs(hi), 1e-300) * margin
    return lo - pad, hi + pad


def anchor_figures(outdir: Path, times: np.ndarray, moments: dict[str, dict[str, np.ndarray]],
                   comm: MPI.Comm = MPI.COMM_WORLD, fraction: float = 1 / 3,
                   source: str = "inner solution + string curvature",
                   units: str = "SI") -> list[str]:
    """Draw the figures (at most :data:`MAX_PANELS` anchors: the most loaded, and the title
    says so); returns their file names (on every rank). ``source`` says where the moments
    come from (title); ``units`` names the unit system of the axes (:mod:`cablefem.units`).
    The moment axis spans the data (zero included only when the moment changes sign), so a
    small variation about a large static moment is visible."""
    names: list[str] = []
    n_all = len(moments)
    mu, tu = unit(units, "moment"), unit(units, "time")
    if len(moments) > MAX_PANELS:  # a network: the most loaded anchors
        peak = {n: np.nanmax(np.where(mo["valid"] > 0, mo["moment"], np.nan), initial=0.0)
                for n, mo in moments.items()}
        keep = sorted(peak, key=peak.get, reverse=True)[:MAX_PANELS]
        moments = {n: moments[n] for n in keep}
    if comm.rank == 0:
        # no pyplot (a third of the import time): a Figure saves to PNG with Agg
        from matplotlib.figure import Figure

        outdir = Path(outdir)
        fig = Figure(figsize=(9, 2.8 * len(moments)))
        axes = fig.subplots(len(moments), 1, sharex=True, squeeze=False)
        for ax, (name, mo) in zip(axes[:, 0], moments.items()):
            ok = mo["valid"] > 0
            M = np.column_stack([mo["Mx"], mo["My"], mo["Mz"]])
            first = np.flatnonzero(ok & (mo["moment"] > 0))
            b0 = M[first[0]] / mo["moment"][first[0]] if first.size else np.zeros(3)
            signed = np.where(ok, M @ b0, np.nan)
            ax.plot(times, signed, lw=0.8, label="M . b0 (b0: initial bending-plane normal)")
            shown = [signed[ok]]
            if is_spatial(mo["psi0"], mo["valid"]):
                ax.plot(times, np.where(ok, mo["moment"], np.nan), lw=0.5, color="0.5",
                        label="|M| (the bending plane turns)")
                shown.append(mo["moment"][ok])
            if np.any(~ok):  # at the foot of the axes, whatever the moment's range
                ax.plot(times[~ok], np.zeros(np.count_nonzero(~ok)), "rx", ms=3,
                        transform=ax.get_xaxis_transform(),
                        label="invalid (slack / thick layer): no moment")
            lims = moment_axis_range(np.concatenate(shown))
            if lims is not None:
                ax.set_ylim(*lims)
                if lims[0] < 0 < lims[1]:
                    ax.axhline(0.0, color="k", lw=0.4)  # only where it is inside the data
            ax.set_ylabel(f"M at {name} [{mu}]")
            ax.grid(True, lw=0.3)
            ax.legend(loc="upper left", fontsize=7)
        axes[-1, 0].set_xlabel(f"time t [{tu}]")
        which = (f"the {len(moments)} most loaded of {n_all} clamped anchors"
                 if n_all > len(moments) else "the clamped anchors")
        fig.suptitle(f"Bending moment at {which}: {source}")
        fig.tight_layout(rect=(0, 0, 1, 1 - 0.35 / fig.get_figheight()))
        fig.savefig(outdir / "anchor_moments.png", dpi=130)
        names.append("anchor_moments.png")

        t0 = times[-1] - fraction * (times[-1] - times[0])
        sel = times >= t0
        spatial = {n: mo for n, mo in moments.items()
                   if is_spatial(mo["psi0"][sel], mo["valid"][sel])}
        if spatial:
            fig = Figure(figsize=(5 * len(spatial), 5))
            for i, (name, mo) in enumerate(spatial.items()):
                ax = fig.add_subplot(1, len(spatial), i + 1, projection="polar")
                ok = sel & (mo["valid"] > 0)
                ax.plot(mo["psi0"][ok], mo["moment"][ok], ".", ms=2)
                ax.set_title(f"anchor {name}: |M| [{mu}] vs psi0 (t >= {t0:.3g} {tu})",
                             fontsize=9)
            fig.tight_layout()
            fig.savefig(outdir / "anchor_polar.png", dpi=130)
            names.append("anchor_polar.png")
    return comm.bcast(names, root=0)
