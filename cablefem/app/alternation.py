"""Step-to-step alternation of the anchor forces: the signature of a time integration that
is not resolving what it computes (``summary.json`` ``dynamics.alternation``, a warning).

Generalised-α damps a mode far above the time step's resolution (``ω dt ≫ 1``) by only
``ρ∞`` per step, and on a cable's axially stiff, geometrically nonlinear modes it can lock
into a lasting oscillation from one step to the next: a small mooring line at ``dt = 0.02 s``
(its axial modes at ``ω dt`` of 5-17), kicked once, had its fairlead force alternating by
±3.5 kN on 30 kN for the rest of the run, where the run at ``dt/4`` stays smooth. The
smooth part of a force sampled every step changes little from step to step: its second
difference is ``(ω dt)²`` times its amplitude at a frequency ``ω``; an alternation ``z``
(+z, −z, ...) or a lone spike ``s`` gives a second difference of ``4 z`` or ``2 s``. So
the largest ``|F(n+1) − 2 F(n) + F(n−1)|/4`` over the run, against the anchor's static
tension, measures it; above :data:`ALTERNATION_WARN` the run warns (a smaller time step,
a smaller ``dynamics.rho_inf``). It sees only what the output rows show: with
``dynamics.output_every`` even, an alternation from step to step is sampled in phase and
invisible.
"""

from __future__ import annotations

import numpy as np

__all__ = ["ALTERNATION_WARN", "alternation"]

#: the largest second difference / 4 of an anchor force's magnitude, relative to its static
#: tension, above which the run warns
ALTERNATION_WARN = 0.01


def alternation(times: np.ndarray, force: np.ndarray) -> tuple[float, float] | None:
    """The largest ``|F(n+1) − 2 F(n) + F(n−1)|/4`` of the magnitudes of ``force``
    ((n_t, 3) or (n_t,)) at equally spaced ``times``, in the force's unit, and the time of
    its middle row; None with fewer than three rows or unequal spacing (a run whose last
    step is shorter: its rows up to that step are used)."""
    f = np.asarray(force, float)
    f = np.linalg.norm(f, axis=1) if f.ndim == 2 else f
    t = np.asarray(times, float)
    if t.size >= 3:
        step = np.diff(t)
        same = np.abs(step - step[0]) <= 1e-6 * step[0]
        n = t.size if same.all() else int(np.argmin(same)) + 1  # rows up to a change
        t, f = t[:n], f[:n]
    if t.size < 3:
        return None
    d2 = np.abs(f[2:] - 2.0 * f[1:-1] + f[:-2]) / 4.0
    d2 = np.where(np.isfinite(d2), d2, 0.0)
    k = int(np.argmax(d2))
    return float(d2[k]), float(t[k + 1])


def check_alternation(summary: dict, times: np.ndarray, forces: dict[str, np.ndarray],
                      dyn) -> None:
    """Record each anchor's alternation, relative to its static tension, as
    ``summary["anchors"][name]["alternation"]`` (``{"value", "time"}``) and warn, naming
    the worst anchor, where it exceeds :data:`ALTERNATION_WARN`; ``dyn``: the case's
    dynamics table (its ``dt``, ``rho_inf`` and ``output_every`` go into the advice)."""
    from cablefem.app.report import warn

    worst = None
    for name, entry in summary.get("anchors", {}).items():
        got = alternation(times, forces.get(name, np.zeros((0, 3))))
        T0 = entry.get("static_tension", 0.0)
        if got is None or not T0 > 0:
            continue
        rel = got[0] / T0
        entry["alternation"] = {"value": rel, "time": got[1]}
        if rel > ALTERNATION_WARN and (worst is None or rel > worst[0]):
            worst = (rel, name, got[1], got[0])
    if worst is None:
        return
    rel, name, t, size = worst
    every = f" every {dyn.output_every} steps" if dyn.output_every > 1 else ""
    warn(summary, "dynamics.dt", f"the force at anchor {name} alternates from output row to "
         f"row{every} by up to {100 * rel:.3g} % of its static tension ({size:.4g} near "
         f"t = {t:.6g}; a smooth history changes by (omega dt)^2 of its amplitude): the time "
         f"step dt = {dyn.dt:g} does not resolve the cable's stiff modes, which "
         "generalised-alpha then leaves ringing or locks into an oscillation from step to "
         "step; check with a smaller dynamics.dt (or dynamics.rho_inf = 0.5); a cable that "
         "goes slack and snaps taut also shows it")
