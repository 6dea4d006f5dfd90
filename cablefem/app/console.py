"""The static state on the console: each anchor's tension and, at a clamped anchor, its
moment (the tool's main result), each kink's moment, and the sag, logged once the statics
have converged and before the dynamics start (rank 0 only, through the log)."""

from __future__ import annotations

import logging

import numpy as np

from cablefem.composite import section_load
from cablefem.moments import anchor_moments
from cablefem.rodcolumns import rod_moment_columns
from cablefem.units import unit

__all__ = ["static_anchor_entries", "log_static_state", "log_touchdown"]

log = logging.getLogger(__name__)

#: at most this many anchors (and kinks) on the console, the most loaded; all are in
#: summary.json
MAX_LINES = 12


def static_anchor_entries(model, static, columns, form: str, kind: str) -> dict[str, dict]:
    """Per anchor: its static tension and, at a clamped anchor, the static moment and its
    layer (the entries of ``summary.json``'s ``anchors.<name>``): the composite moment of
    the static anchor force or, for the rod (``kind == "beam"``), the rod's own moment with
    the composite beside it. ``columns`` (:class:`~cablefem.moments.AnchorMoments`) gives
    the loads at t = 0."""
    out = {}
    for i, a in enumerate(model.anchors):
        F = np.asarray(static.anchor_forces[i], float)
        entry = {"static_tension": float(np.linalg.norm(F[:3]))}
        if a.kind == "clamped":
            st = anchor_moments(F[None, :3], a.direction, a.section.EI, a.section.EA,
                                a.section.mass, np.zeros((1, 3)),
                                section_load(columns, model.case, 0.0, a.section),
                                model.anchor_span(a.name),
                                None, form, 1 if model.hinges else 0,
                                junction=model.anchor_junction_offset(a.name))
            if kind == "beam":  # the rod's own; the composite with the beam's force beside
                entry["static_moment_composite"] = float(st["moment"][0])
                st = rod_moment_columns(st, F[None, 3:6], a.direction)
                entry["static_moment_vector"] = F[3:6]
            entry["static_moment"] = float(st["moment"][0])
            entry["static_moment_layer"] = float(st["moment_layer"][0])
            entry["static_delta"] = float(st["delta"][0])
            entry["layer_length"] = float(st["layer_length"][0])
            entry["static_error_estimate"] = float(st["error_estimate"][0])
        out[a.name] = entry
    return out


def static_state_lines(entries: dict[str, dict], kinks: dict[str, float], sag: float | None,
                       units: str | None, kind: str) -> list[str]:
    """The lines :func:`log_static_state` prints: one per anchor (tension; moment and
    estimated error at a clamped one), one per kink (moment), and the sag ratio; of more
    than :data:`MAX_LINES` anchors or kinks, the most loaded and their number."""
    force, moment = unit(units, "force"), unit(units, "moment")
    source = "the rod's own" if kind == "beam" else "inner solution"
    lines = []
    shown = entries
    if len(entries) > MAX_LINES:  # a large network: the most loaded anchors
        def load(name):
            e = entries[name]
            return (e.get("static_moment", -1.0), e["static_tension"])

        shown = {n: entries[n] for n in sorted(entries, key=load, reverse=True)[:MAX_LINES]}
    for name, e in shown.items():
        text = f"static: anchor {name}: tension {e['static_tension']:.6g} {force}"
        if "static_moment" in e:
            text += f", moment {e['static_moment']:.6g} {moment} ({source}"
            err = e.get("static_error_estimate")
            if kind != "beam" and err is not None and np.isfinite(err):
                text += f", estimated error {100 * err:.2g} %"
            text += ")"
        lines.append(text)
    if len(shown) < len(entries):
        lines.append(f"static: {len(entries) - len(shown)} more anchors (those with smaller "
                     "moments or tensions) in summary.json")
    finite = {n: m for n, m in kinks.items() if np.isfinite(m)}
    for name in sorted(finite, key=finite.get, reverse=True)[:MAX_LINES]:
        lines.append(f"static: kink {name}: moment {finite[name]:.6g} {moment}")
    if len(finite) > MAX_LINES:
        lines.append(f"static: {len(finite) - MAX_LINES} more kinks in summary.json")
    if sag is not None and np.isfinite(sag):
        lines.append(f"static: sag {sag:.6g} of the chord (mid-span, along gravity)")
    return lines


def log_static_state(entries: dict[str, dict], kinkout, sag: float | None,
                     units: str | None, kind: str) -> None:
    """Log the static state (:func:`static_state_lines`); ``kinkout`` the run's kinks
    (:class:`~cablefem.app.kinkout.KinkHistory`: their static columns)."""
    kinks = {}
    if kinkout is not None and kinkout.kinks:
        kinks = {k.name: float(kinkout.static["moment"][i])
                 for i, k in enumerate(kinkout.kinks)}
    for line in static_state_lines(entries, kinks, sag, units, kind):
        log.info("%s", line)


def log_touchdown(td: dict) -> None:
    """The static touchdown on the console: the contact's end, the rigid seabed's
    equivalent and the anchors on the seabed (cablefem.seabed.rigid_touchdown)."""
    from cablefem.seabed import penalty_offset_factor

    c = penalty_offset_factor()
    log.info("touchdown (the penalty contact's end) at s = %.6g (%s), grounded length %.6g",
             td["s"], ", ".join(f"{x:.6g}" for x in td["position"]), td["grounded_length"])
    if "rigid" in td:
        log.info("touchdown of the equivalent rigid seabed (suspended length V/w) at s = "
                 "%.6g, grounded length %.6g; the contact ends %.3g beyond it (penalty "
                 "offset %.4g sqrt(H/k) = %.3g)", td["rigid"]["s"],
                 td["rigid"]["grounded_length"], abs(td["s"] - td["rigid"]["s"]), c,
                 td["penalty_offset"])
    elif "rigid_missing" in td:
        log.info("touchdown of the equivalent rigid seabed: not computed (%s)",
                 td["rigid_missing"])
    for name, a in td.get("anchors_on_seabed", {}).items():
        log.info("anchor %s on the seabed: vertical force %.4g; the penalty contact alone "
                 "gives %.4g (the weight of %.4g sqrt(H/k) of line that the anchor holds "
                 "up, none on a rigid seabed; docs/seabed.md)%s", name, a["vertical_force"],
                 a["penalty_force"], c, "" if a["layer_elements"] >= 2 else
                 f"; sqrt(H/k) spans {a['layer_elements']:.2g} of the anchor's element: "
                 "unresolved, the anchor carries up to half that element's weight instead")
