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
  (:meth:`cablefem.reactions.AnchorForces.compute`); the boundary layer (the anchor moment)
  and the hinge itself are computed from it;
* statics iterates hinge -> equilibrium -> anchor force -> hinge to a fixed point (the
  relative change falls by 1e-2 to 1e-3 per iteration on the paper's cases).

In dynamics the node stays where statics put it (it moves with the anchor): H moves only at
second order in a change of Delta, and a prescribed node that jumps with the tension feeds
velocity jumps into generalised-alpha (tried: the run blew up). The layer itself follows the
tension T and angle Delta of the first element (:meth:`VirtualHinges.follow`, after every
step): sigma is set so that the string from the fixed node lies, along the string, on the
rod's far-field line at the current T and Delta, ``h cos(Delta) - lambda_inf sigma = D_t(T,
Delta)`` (plus the static state's small mismatch between element tension and anchor force,
kept constant). The Delta part is first order in the motion: as the span swings, the layer
gives length, ``d sigma ~ -ell Delta dDelta / 2``, which softens the geometric stiffening of
a vibrating cable (case A: the steady-state RMS moment moves by 0.8 % towards the rod's).
The T part, ``sigma_T = d sigma/dT`` (the layer's axial compliance, from D_t ~ T^-1/2), is
tiny but cannot be lagged: the first element is stiff (EA/L), and EA/L times that compliance
is ~2.4 in case B, so a sigma updated from the last step's tension blew up within 15 steps.
It goes into the first element's law instead, linearised about the current tension, as a
compliance in series (EA' and a stress-free length R, exact at that tension, the layer's mass
``s1 - R``), so that each step solves the layer's response to its own tension implicitly.

Only the string model has hinges (``solver.outer_correction = "hinge"``); the rod resolves
its layers itself. A first element shorter than ``sigma_h / MAX_FRACTION`` is refused.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from cablefem.asymptotics import far_field_offsets, layer, virtual_hinge
from cablefem.errors import HingeError

__all__ = ["VirtualHinges", "HingeError", "MAX_FRACTION"]

#: Largest fraction of the first element's stress-free length that the hinge may remove.
MAX_FRACTION = 0.5


class _Hinge:
    """One clamped anchor's hinge: its cells, their base coefficient, h and sigma_h."""

    def __init__(self, index, anc, cells, lengths, c0, first, nodes):
        self.index = index  # position in model.anchors
        self.anchor = anc
        self.cells = cells  # local cell indices next to the anchor node (owned and ghost)
        self.lengths = lengths  # their mesh lengths, m
        self.c0 = c0  # their base stress-free length per mesh length
        self.first = first  # the first element's stress-free length (all ranks), m
        self.nodes = nodes  # first element: (anchor node, other node, X_other - X_anchor)
        self.h = 0.0  # the node is at A + h c
        self.sigma = 0.0  # the layer's stress-free length (the first element's, removed)
        self.shift = 0.0  # dynamics: sigma - sigma_far at the static state, m
        self.removed = 0.0  # stress-free length taken from the first element, m
        self.EA0 = None  # the first element's own EA (set by VirtualHinges)
        self.last = (np.nan, np.nan)  # dynamics: (T, Delta) the law was last set from


class VirtualHinges:
    """Virtual hinges at every clamped anchor of a string model (see the module docs)."""

    def __init__(self, model) -> None:
        self.model = model
        mesh = model.mesh
        mesh.topology.create_connectivity(0, 1)
        v2c = mesh.topology.connectivity(0, 1)
        x = mesh.geometry.x
        gdofs = mesh.geometry.dofmap
        X = model.V.tabulate_dof_coordinates()
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
            nodes = None
            if cells.size:  # the first element's two nodes, the anchor's first
                dofs = model.V.dofmap.cell_dofs(cells[0])
                at_anchor = np.linalg.norm(X[dofs] - anc.reference, axis=1)
                a, b = dofs[np.argmin(at_anchor)], dofs[np.argmax(at_anchor)]
                nodes = (a, b, X[b] - X[a])  # and the element in the reference geometry
            hg = _Hinge(i, anc, cells.astype(np.int32), lengths, c0, first, nodes)
            hg.EA0 = model.EA.x.array[cells].copy()
            self.items.append(hg)
        self.g_vec = np.asarray(model.g_vec, float)

    def __bool__(self) -> bool:
        return bool(self.items)

    def layer_force(self, i: int, acceleration: np.ndarray) -> np.ndarray:
        """Weight and inertia of anchor ``i``'s layer, ``m sigma_h (g - a)``, N (zero for
        an anchor without hinge)."""
        for hg in self.items:
            if hg.index == i:
                mass = hg.anchor.section.mass * hg.removed
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
            hg.h, hg.sigma, hg.removed = h, sig, sig
            hg.anchor.offset = h * hg.anchor.direction
            if hg.cells.size:
                self.model.c.x.array[hg.cells] = hg.c0 - sig / hg.lengths
                self.model.EA.x.array[hg.cells] = hg.EA0
        self.model.invalidate_time()
        return change

    def _measure(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tension and anchor angle Delta (between the clamp direction and the first
        element) of every hinge's first element in the displacement ``u`` (a Function's
        array, ghosts up to date); from the ranks that have the element, to all ranks."""
        x = u.reshape(-1, 3)
        local = np.zeros((len(self.items), 3))
        for k, hg in enumerate(self.items):
            if hg.nodes is None:
                continue
            a, b, E = hg.nodes
            e = E + x[b] - x[a]
            le = float(np.linalg.norm(e))
            stretch = le / (self.model.c.x.array[hg.cells[0]] * hg.lengths[0])
            cosd = float(np.dot(hg.anchor.direction, e)) / le
            local[k] = (self.model.EA.x.array[hg.cells[0]] * (stretch - 1.0),
                        np.arccos(np.clip(cosd, -1.0, 1.0)), 1.0)
        tot = self.model.comm.allreduce(local, op=MPI.SUM)  # every holder has the same values
        return tot[:, 0] / tot[:, 2], tot[:, 1] / tot[:, 2]

    def _sigma_far(self, hg: _Hinge, T: float, delta: float) -> float:
        """The stress-free length to remove from the first element for the string from the
        (fixed) node at A + h c to lie on the rod's far-field line at tension T and angle
        Delta: along the string, ``h cos(Delta) - lambda_inf sigma = D_t(T, Delta)``."""
        sec = hg.anchor.section
        D_t, _ = far_field_offsets(delta, T, sec.EI, sec.EA)
        return float((hg.h * np.cos(delta) - D_t) / (1.0 + T / sec.EA))

    def start_dynamics(self, u_static: np.ndarray) -> None:
        """Reference of :meth:`follow`: the first elements' tension and angle in the static
        state ``u_static``, where sigma is the static sigma_h."""
        T, delta = self._measure(u_static)
        for hg, t_k, d_k in zip(self.items, T, delta):
            hg.shift = hg.sigma - self._sigma_far(hg, t_k, d_k)

    def follow(self, u: np.ndarray, t: float) -> None:
        """Dynamics, after a step: let each layer follow the tension T and angle Delta of
        its first element in ``u`` (module docs); the node stays at A + h c.

        sigma(T, Delta) = sigma_far(T, Delta) + shift is linearised in T about the current
        T and put into the first element's law as a compliance in series, so that the
        next step solves the layer's response to its own tension implicitly: the element
        of full stress-free length s1 has length (s1 - sigma(T)) (1 + T/EA) = R (1 + T/EA')
        to first order, with R = s1 - sigma + sigma_T T and EA' = R / ((s1 - sigma)/EA -
        sigma_T); the layer's mass is s1 - R. Raises :class:`HingeError` when sigma leaves
        (0, MAX_FRACTION x first element] or the element is slack."""
        self.set_state(np.column_stack(self._measure(u)), t)

    def state(self) -> np.ndarray:
        """(n_hinges, 2): the tension and angle each layer's law was last set from (what a
        checkpoint must keep: the state alone does not give them back, the tension measured
        in it depends on the law it was solved with)."""
        return np.array([hg.last for hg in self.items], float).reshape(-1, 2)

    def set_state(self, state: np.ndarray, t: float) -> None:
        """Set each layer's sigma and its first element's law from a tension and angle
        (n_hinges, 2); see :meth:`follow`."""
        for hg, (t_k, d_k) in zip(self.items, np.asarray(state, float).reshape(-1, 2)):
            sig = self._sigma_far(hg, t_k, d_k) + hg.shift
            dT = 1e-4 * t_k
            sig_T = (self._sigma_far(hg, t_k + dT, d_k)
                     - self._sigma_far(hg, t_k - dT, d_k)) / (2 * dT)
            if not (t_k > 0.0 and np.isfinite(sig + sig_T)
                    and 0.0 < sig <= MAX_FRACTION * hg.first):
                raise HingeError(f"anchor {hg.anchor.name}: at t = {t:.6g} s the virtual "
                                 f"hinge's layer length sigma = {sig:.3g} m left (0, "
                                 f"{MAX_FRACTION * hg.first:.3g}] m (tension {t_k:.3g} N, "
                                 f"angle {np.degrees(d_k):.3g} deg)")
            s1 = hg.first  # the full stress-free length of the first element
            R = s1 - sig + sig_T * t_k
            hg.sigma, hg.removed, hg.last = sig, s1 - R, (t_k, d_k)
            if hg.cells.size:
                self.model.c.x.array[hg.cells] = R / hg.lengths
                self.model.EA.x.array[hg.cells] = R / ((s1 - sig) / hg.EA0 - sig_T)

    def report(self) -> dict[str, dict]:
        """Per anchor: the hinge distance h along the clamp direction and the stress-free
        length sigma_h removed (m)."""
        return {hg.anchor.name: {"h": hg.h, "sigma_h": hg.sigma} for hg in self.items}
