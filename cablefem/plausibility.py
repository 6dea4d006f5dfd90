"""Warnings for a static cable that no real cable is: a strain no material stays linear to,
a stress-free length far from the chord (:func:`catenary_warnings`), a network's
pretension beyond that strain (:func:`pretension_warnings`). ``run_case`` logs them and
lists them in ``summary.json``; ``--strict`` makes them fatal."""

from __future__ import annotations

import numpy as np

__all__ = ["MAX_PLAUSIBLE_STRAIN", "PLAUSIBLE_LENGTH_RATIO", "chord_frame",
           "catenary_warnings", "pretension_warnings"]

#: largest plausible strain T/EA of the static catenary: steel wires and strands yield below
#: 1 %, fibre ropes break at 10-20 % and are far from linear beyond a few percent; a linear
#: law (T = EA strain) above this is outside what any cable material does
MAX_PLAUSIBLE_STRAIN = 0.05
#: plausible range of stress-free length / chord: a cable shorter than 0.9 chord must stretch
#: by more than 10 % to span it; one longer than 3 chords hangs deeper than the chord is long
PLAUSIBLE_LENGTH_RATIO = (0.9, 3.0)


def chord_frame(p: np.ndarray, q: np.ndarray, gdir: np.ndarray) -> tuple[float, float]:
    """Horizontal span and rise of the chord p -> q in the vertical plane of gravity."""
    d = q - p
    up = -gdir
    rise = float(d @ up)
    span = float(np.linalg.norm(d - rise * up))
    return span, rise


def catenary_warnings(key: str, length: float, chord: float, max_tension: float,
                      EA: float) -> list[tuple[str, str]]:
    """Warnings for a static catenary that no real cable has: a strain above
    :data:`MAX_PLAUSIBLE_STRAIN`, a stress-free length outside
    :data:`PLAUSIBLE_LENGTH_RATIO` of the chord."""
    out = []
    strain = max_tension / EA
    if strain > MAX_PLAUSIBLE_STRAIN:
        out.append((key, f"the static cable's largest strain T/EA is {100 * strain:.3g} % "
                         f"(tension {max_tension:.4g} N, EA {EA:.4g} N), above the "
                         f"{100 * MAX_PLAUSIBLE_STRAIN:g} % that any cable material stays "
                         "linear to: check the value and the section"))
    lo, hi = PLAUSIBLE_LENGTH_RATIO
    ratio = length / chord
    if not lo <= ratio <= hi:
        out.append((key, f"the stress-free length {length:.4g} m is {ratio:.3g} times the "
                         f"chord {chord:.4g} m (plausible: {lo:g} to {hi:g})"))
    return out


def pretension_warnings(cables, sections) -> list[tuple[str, str]]:
    """A network's cables whose pretension / EA is a strain above
    :data:`MAX_PLAUSIBLE_STRAIN` (``cables``: the case's ``[[cables]]``)."""
    out = []
    for i, c in enumerate(cables):
        strain = c.pretension / sections[c.section].EA
        if strain > MAX_PLAUSIBLE_STRAIN:
            out.append((f"cables[{i}].pretension", (
                f"pretension / EA is a strain of {100 * strain:.3g} %, above the "
                f"{100 * MAX_PLAUSIBLE_STRAIN:g} % that any cable material stays linear "
                "to: check the value and the section")))
    return out
