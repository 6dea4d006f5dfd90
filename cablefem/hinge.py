"""The first-order outer correction: the string pinned at a virtual hinge near each clamp.

At leading order the string is pinned at the clamped anchor A itself. The rod's far field
is a string too, but one that starts at the virtual hinge ``H = A + h c`` on the clamp line,
with ``sigma_h`` of stress-free length less (:func:`cablefem.asymptotics.virtual_hinge`:
the exact far field of the layer's elastica, at finite anchor angle and with the layer's
stretch kept). Leaving the hinge out makes the outer solution wrong at O(ell/l): the anchor
tension of a sagging cable (the far field is offset by O(ell Delta^2) along the string) and
the frequencies (the span turns about H, not about A).

:class:`VirtualHinges` puts that into the finite-element string:

* the anchor node is prescribed at H (the anchor's ``offset`` h c, added to its
  prescribed displacement, so an anchor motion moves the hinge with it);
* the stress-free length of the element next to the anchor is shortened by ``sigma_h``
  (its coefficient ``c``, stress-free length per mesh length): the layer's
  material is not in the string;
* the layer's own weight and inertia, ``m sigma_h (g - a_A)``, are added to the hinge
  force, so that the anchor force is the force at the real anchor
  (:meth:`cablefem.anchors.AnchorForces.compute`); the boundary layer (the anchor moment)
  and the hinge itself are computed from it;
* statics iterates hinge -> equilibrium -> anchor force -> hinge to a fixed point (the
  relative change falls by 1e-2 to 1e-3 per iteration on the paper's cases).

In dynamics the hinge stays where statics put it (it moves with the anchor). That keeps the
first-order effect on the dynamics, the span turning about H: H moves only at second order
in a change of Delta. What it leaves out is the layer's response to the changing tension and
angle: h and sigma_h follow T (ell ~ T^-1/2) and Delta, but along the string the far field
moves only by the change of D_t = O(ell Delta^2) (:func:`cablefem.asymptotics.
far_field_offsets`), an axial compliance |D_t|/(2T) per anchor far below the cable's own
(case A: 8e-9 against l/EA = 4e-5 m/N; case B: 1.2e-5 against the sag compliance 5e-3
m/N). Updating the hinge from the anchor force after every step (a lagged, explicit
coupling) was tried and is unstable: the shortened element is axially stiff, EA/L, so a
change of sigma_h moves the anchor force by far more than the force change that caused it
(a loop gain of about 2.5 in case B), and the run blows up within a few steps. Following
the layer in time needs the coupling inside Newton (not done).

Only the string model has hinges (``solver.outer_correction = "hinge"``); the rod resolves
its layers itself. A first element shorter than ``sigma_h / MAX_FRACTION`` is refused.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from .asymptotics import layer, virtual_hinge

__all__ = ["VirtualHinges", "HingeError", "MAX_FRACTION"]

#: Largest fraction of the first element's stress-free length that the hinge may remove.
MAX_FRACTION = 0.5


class HingeError(RuntimeError):
    """The virtual hinge cannot be placed (what and where are in the message)."""


class _Hinge:
    """One clamped anchor's hinge: its cells, their base coefficient, h and sigma_h."""

    def __init__(self, index, anc, cells, lengths, c0, first):
        self.index = index  # position in model.anchors
        self.anchor = anc
        self.cells = cells  # local cell indices next to the anchor node (owned and ghost)
        self.lengths = lengths  # their mesh lengths, m
        self.c0 = c0  # their base stress-free length per mesh length
        self.first = first  # the first element's stress-free length (all ranks), m
        self.h = 0.0  # the node is at A + h c
        self.sigma = 0.0  # stress-free length removed from the first element


class VirtualHinges:
    """Virtual hinges at every clamped anchor of a string model (see the module docs)."""

    def __init__(self, model) -> None:
        self.model = model
        mesh = model.mesh
        mesh.topology.create_connectivity(0, 1)
        v2c = mesh.topology.connectivity(0, 1)
        x = mesh.geometry.x
        gdofs = mesh.geometry.dofmap
        self.items: list[_Hinge] = []
        for i, anc in enumerate(model.anchors):
            if anc.kind != "clamped":
                continue
            verts = model._locate_node(anc.node)
            cells = np.unique(np.concatenate([v2c.links(v) for v in verts])) if verts.size \
                else np.zeros(0, np.int32)
            ncell = model.comm.allreduce(int(cells.size), op=MPI.MAX)
            if ncell > 1:
                raise HingeError(f"anchor {anc.name}: the virtual hinge needs the anchor at "
                                 f"the end of one cable (it is on {ncell} elements)")
            lengths = np.array([np.linalg.norm(x[gdofs.links(c)[1]] - x[gdofs.links(c)[0]])
                                for c in cells])
            c0 = model.c.x.array[cells].copy()
            first = model.comm.allreduce(float(np.min(c0 * lengths, initial=np.inf)),
                                         op=MPI.MIN)
            self.items.append(_Hinge(i, anc, cells.astype(np.int32), lengths, c0, first))
        self.g_vec = np.asarray(model.g_vec, float)

    def __bool__(self) -> bool:
        return bool(self.items)

    def layer_force(self, i: int, acceleration: np.ndarray) -> np.ndarray:
        """Weight and inertia of anchor ``i``'s layer, ``m sigma_h (g - a)``, N (zero for
        an anchor without hinge)."""
        for hg in self.items:
            if hg.index == i:
                mass = hg.anchor.section.mass * hg.sigma
                return mass * (self.g_vec - np.asarray(acceleration, float))
        return np.zeros(3)

    def _place(self, hg: _Hinge, forces: np.ndarray) -> tuple[float, float]:
        sec = hg.anchor.section
        lay = layer(np.asarray(forces[hg.index][:3], float), hg.anchor.direction, sec.EI,
                    sec.EA)
        h, sig = (float(v) for v in virtual_hinge(lay.delta, lay.tension, sec.EI, sec.EA))
        why = None
        if not (np.isfinite(h) and np.isfinite(sig)):
            why = "no layer (slack anchor or anchor angle near 180 deg)"
        elif sig <= 0.0:
            why = f"sigma_h = {sig:.3g} m <= 0 (anchor angle above ~120 deg)"
        elif sig > MAX_FRACTION * hg.first:
            why = (f"sigma_h = {sig:.3g} m is more than {MAX_FRACTION:g} of the first "
                   f"element's stress-free length {hg.first:.3g} m")
        if why is not None:
            raise HingeError(f"anchor {hg.anchor.name}: cannot place the virtual hinge: "
                             f"{why}. Use solver.outer_correction = \"none\" (or "
                             "--outer-correction none), or a coarser mesh near the anchor.")
        return h, sig

    def update(self, forces: np.ndarray) -> float:
        """Place every hinge from the anchor forces (n_anchors, >= 3) at the real anchors
        (statics); returns the largest change of h or sigma_h relative to sigma_h (inf the
        first time). Raises :class:`HingeError` where a hinge cannot be placed."""
        change = 0.0
        for hg in self.items:
            h, sig = self._place(hg, forces)
            change = max(change, np.inf if hg.sigma == 0.0 else
                         max(abs(h - hg.h), abs(sig - hg.sigma)) / sig)
            hg.h, hg.sigma = h, sig
            hg.anchor.offset = h * hg.anchor.direction
            if hg.cells.size:
                self.model.c.x.array[hg.cells] = hg.c0 - sig / hg.lengths
        self.model.invalidate_time()
        return change

    def report(self) -> dict[str, dict]:
        """Per anchor: the hinge distance h along the clamp direction and the stress-free
        length sigma_h removed (m)."""
        return {hg.anchor.name: {"h": hg.h, "sigma_h": hg.sigma} for hg in self.items}
