"""The anchor of a cable: where it is, how it holds the cable and how it moves.

:class:`Anchor` is the one user-facing description of an anchor, shared by the Python API
(:func:`cablefem.create_cable`) and the case files (:mod:`cablefem.case`). Pure Python/NumPy.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from cablefem.motion import Motion

__all__ = ["Anchor", "AnchorBC", "ANCHOR_KINDS"]

#: how an anchor holds the cable: "clamped" (position and tangent) or "pinned" (position)
ANCHOR_KINDS = ("clamped", "pinned")


@dataclass
class Anchor:
    """An anchor of a cable (or an anchor group of a network's mesh).

    Args:
        name (str): Its name in the outputs (A-Z a-z 0-9 _ -); for a network, the 0D group of the
            mesh.
        position ((3,) array or None): Static position (m). ``None``: a network's (the mesh's
            nodes), or the polyline's end.
        kind (str): ``"clamped"`` (holds the tangent: the anchor moment is computed) or
            ``"pinned"``.
        direction ((3,) array or None): Unit clamp direction pointing into the cable (clamped only);
            ``None``: along the chord (single cable) or along the one cell at the anchor (network).
        motion (Motion or None): Prescribed displacement from the static position
            (:mod:`cablefem.motion`), or None.
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


@dataclass
class AnchorBC:
    """One anchor of the cable: where it is, how it moves, which degrees of freedom it holds."""

    name: str
    node: int  #: node index in the cable's station order
    reference: np.ndarray  #: reference (stress-free) position X of the anchor node, m
    position: np.ndarray  #: static position of the anchor, m
    kind: str  #: "clamped" or "pinned"
    direction: np.ndarray | None  #: unit clamp direction into the cable (clamped only)
    motion: Motion | None
    dofs: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int32))
    owned: bool = False  #: True on the one rank that owns the anchor's dofs
    section: object = None  #: the Section of the cable at the anchor
    bs: int = 3  #: components per node of the model (3: string, 6: beam)
    comps: tuple = (0, 1, 2)  #: the components the anchor prescribes
    rotation: np.ndarray | None = None  #: beam: Cayley vector held by a clamp
    moment_map: np.ndarray | None = None  #: beam: reaction of the q rows -> moment
    #: beam: the first of the anchor's rotation components (a network rod's cable colour)
    rot_offset: int = 3
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))  #: string: where the
    #: node is prescribed relative to the anchor (a virtual hinge, cablefem.hinge), m
    #: a network's clamp a cable runs through, whose side this anchor is (cablefem.network)
    clamp: str | None = None

    def _layout(self) -> tuple[np.ndarray, np.ndarray]:
        """The unrolled rows and the component of each, computed once per layout (a rod
        changes ``bs`` and ``comps`` after construction: the cache is keyed on them)."""
        key = (self.bs, tuple(self.comps), id(self.dofs), self.dofs.size)
        if getattr(self, "_layout_key", None) != key:
            comps = np.asarray(self.comps, dtype=np.int64)
            rows = (self.bs * np.asarray(self.dofs, np.int64)[:, None]
                    + comps[None, :]).reshape(-1)
            self._layout_cache = (rows, np.tile(comps, self.dofs.size))
            self._layout_key = key
        return self._layout_cache

    @property
    def flat_dofs(self) -> np.ndarray:
        """Unrolled indices (in a local array) of the components the anchor prescribes
        (computed once; do not modify the array)."""
        return self._layout()[0]

    def prescribed(self, kind: str, t: float) -> np.ndarray:
        """Values of ``kind`` ("displacement", "velocity", "acceleration") at ``t`` for
        :attr:`flat_dofs`."""
        val = getattr(self, kind)(t)
        if kind == "displacement":
            val = val + self.offset
        if self.bs > 3:  # a rod: its rotation (a network rod's: its cable's colour)
            full = np.zeros(self.bs)
            full[:3] = val
            if kind == "displacement" and self.rotation is not None:
                full[self.rot_offset:self.rot_offset + 3] = self.rotation
            val = full
        return np.asarray(val)[self._layout()[1]]

    def prescribed_from(self, value: np.ndarray) -> np.ndarray:
        """:meth:`prescribed`'s values for a velocity or acceleration ``value`` (3,) the
        caller already has."""
        if self.bs > 3:
            full = np.zeros(self.bs)
            full[:3] = value
            value = full
        return np.asarray(value)[self._layout()[1]]

    def displacement(self, t: float) -> np.ndarray:
        """Prescribed displacement of the anchor node from its reference position, m."""
        d = self.position - self.reference
        if self.motion is not None:
            d = d + self.motion.displacement(t)
        return d

    def velocity(self, t: float) -> np.ndarray:
        return np.zeros(3) if self.motion is None else np.asarray(self.motion.velocity(t))

    def acceleration(self, t: float) -> np.ndarray:
        return np.zeros(3) if self.motion is None else np.asarray(self.motion.acceleration(t))
