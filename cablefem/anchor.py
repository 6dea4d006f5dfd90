"""The anchor of a cable: where it is, how it holds the cable and how it moves.

:class:`Anchor` is the one user-facing description of an anchor, shared by the Python API
(:func:`cablefem.create_cable`) and the case files (:mod:`cablefem.case`). Pure Python/NumPy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cablefem.motion import Motion

__all__ = ["Anchor", "ANCHOR_KINDS"]

#: how an anchor holds the cable: "clamped" (position and tangent) or "pinned" (position)
ANCHOR_KINDS = ("clamped", "pinned")


@dataclass
class Anchor:
    """An anchor of a cable (or an anchor group of a network's mesh).

    Parameters
    ----------
    name : str
        Its name in the outputs (A-Z a-z 0-9 _ -); for a network, the 0D group of the mesh.
    position : (3,) array or None
        Static position (m). ``None``: a network's (the mesh's nodes), or the polyline's end.
    kind : str
        ``"clamped"`` (holds the tangent: the anchor moment is computed) or ``"pinned"``.
    direction : (3,) array or None
        Unit clamp direction pointing into the cable (clamped only); ``None``: along the
        chord (single cable) or along the one cell at the anchor (network).
    motion : Motion or None
        Prescribed displacement from the static position (:mod:`cablefem.motion`), or None.
    """

    name: str
    position: np.ndarray | None = None
    kind: str = "clamped"
    direction: np.ndarray | None = None
    motion: Motion | None = None

    def __post_init__(self) -> None:
        # lists of numbers become arrays; anything else is left for the checks to report
        for attr in ("position", "direction"):
            value = getattr(self, attr)
            if isinstance(value, (list, tuple)):
                try:
                    setattr(self, attr, np.asarray(value, dtype=float))
                except (TypeError, ValueError):
                    pass
