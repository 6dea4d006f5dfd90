"""The reference rod on a network mesh (``cablefem run NET.toml --model beam``).

Every cable of the network is the geometrically exact rod of :mod:`cablefem.rod` (the same
Simo-Reissner strains, Cayley rotations, one-point integration, consistent mass and rotary
inertia), straight when stress-free: each cable (a connected set of cells of one 1D group)
has one stress-free frame ``(E1, E2, E3)``, ``E3`` along it, and its stress-free length is
the mesh length over ``1 + T0/EA`` as the string network's. The mesh is the network's,
graded in memory towards every clamp and every junction or loaded node
(:func:`cablefem.rod_network_mesh.graded_network`, ``[beam]`` as for a single rod).

Junctions: the cables share the node's displacement and keep their own rotation (a pinned
tie). Without multi-point constraints, the cables are coloured so that cables meeting at a
node differ (:func:`cablefem.rod_network_mesh.cable_colours`) and the node carries its
displacement and one Cayley vector per colour: ``bs = 3 + 3 n_colours`` (one colour: the
single rod's six). A cell's strains use its colour's vector (a DG0 indicator per colour).
A colour's vector at a node no cell of that colour reaches is held at zero by a stiffness
of its own (a nodal spring, ``park``: it touches no other unknown, so it changes nothing
else); its rows stay out of the anchors'. A cable through a junction is one rod (its
two elements at the node share its rotation): its kink is the rod's own bending.

Anchors: a clamp holds the displacement and its cable's rotation (``d3`` along the clamp
direction, no twist); a pinned anchor the displacement, with the single rod's twist spring.
The anchor moment is the reaction of the clamp's cable's rotation rows, as for one rod; a
kink's moment (``kinks.csv``) the cable's internal moment at the node: the reaction of the
node's rotation rows to the kink's first element (:func:`network_rod_kink_moments`). A
network's dampers act between their nodes as in the string (their cells carry no rod).
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from cablefem.cable import CableModel
from cablefem.contract import Builders
from cablefem.errors import CaseError
from cablefem.jit import quiet_compiler
from cablefem.network import NetworkModel, network_anchors, network_coefficients, network_geometry
from cablefem.rod import POISSON, SHEAR_FACTOR, BeamModel, rod_bcs
from cablefem.rod_kinematics import (
    cayley_from_rotation,
    energy_density,
    p1_product,
    rod_strains,
    virtual_rotation_map,
)
from cablefem.rod_network_mesh import cable_colours, cable_frames, graded_network
from cablefem.string_terms import add_model_terms

__all__ = ["NetworkRodModel", "NETWORK_ROD", "network_rod_problems",
           "network_rod_kink_moments", "rod_network_warnings"]


def network_rod_problems(case) -> list[tuple[str, str]]:
    """Why the network rod cannot run ``case`` (``[(key, reason)]``)."""
    out = []
    if getattr(case, "seabed", None) is not None:
        out.append(("seabed", "the beam model has no seabed contact"))
    if getattr(case, "fluid", None) is not None:
        out.append(("fluid", "the beam model has no fluid forces"))
    return out


def rod_network_geometry(model):
    """The network's geometry (:func:`cablefem.network.network_geometry`), graded towards its
    clamps and kinks; its cables' colours, frames and ``model.bs``."""
    geo, _ = network_geometry(model)
    spec, r = model.spec, model.refine
    geo, model.layer_lengths = graded_network(
        model, geo, spec.layer_elements * r, 1.0 + (spec.growth - 1.0) / r,
        spec.span_elements * r)
    model.cable, model.colour, model.n_colours = cable_colours(geo)
    model.warnings += rod_network_warnings(model, geo)
    model.bs = 3 + 3 * model.n_colours
    model.frames = cable_frames(geo, model.cable, model.case.gravity.direction)
    secs = model.case.network.sections
    EI = max(sec.EI for sec in secs.values())
    model.force_scale = max(model.force_scale, EI / geo.length ** 2)
    return geo, geo.points.copy()


def rod_network_warnings(model, geo) -> list[tuple[str, str]]:
    """What the network rod models otherwise than a user may expect: a cable with three
    or more of its own elements at a node (one rod with a rigid joint there), and cables
    without pretension (their clamps and junctions not graded: no layer length at the
    pretension)."""
    out = []
    cells = np.asarray(geo.cells, np.int64)
    mine = model.cable >= 0
    pairs = np.concatenate([np.column_stack([cells[mine, j], model.cable[mine]])
                            for j in (0, 1)])
    _, counts = np.unique(pairs, axis=0, return_counts=True)
    if np.any(counts > 2):
        out.append(("cables", f"{int(np.sum(counts > 2))} node(s) where a cable group meets "
                              "itself with three or more elements: the rod joins them "
                              "rigidly there (one rod with a rigid joint)"))
    slack = sorted(c.group for c in model.case.network.cables if not c.pretension > 0)
    if slack:
        out.append(("cables", f"groups {slack} have no pretension: the rod's mesh is not "
                              "graded towards their clamps and junctions (no layer length "
                              "at the pretension); check its convergence with --refine"))
    return out


def rod_network_coefficients(model) -> None:
    """The network's cell fields (EA, m, c), the rod's (EI, GJ, GA, rhoI), each cell's
    frame and colour indicator, and each colour's parked nodes (a P1 indicator)."""
    network_coefficients(model)
    GA_value = model.case.beam.shear_stiffness
    if GA_value is None:
        GA_value = SHEAR_FACTOR * model.force_scale
    model.EI = model.section_field("EI", lambda s: s.EI)
    model.GJ = model.section_field("GJ", lambda s: s.GJ if s.GJ > 0 else
                                   s.EI / (1.0 + POISSON))
    model.rhoI = model.section_field("rhoI", lambda s: s.mass * s.EI / s.EA)
    model.GA = fem.Constant(model.mesh, PETSc.ScalarType(GA_value))
    model.section_values = {"GA": GA_value}
    idx = model.cell_index
    with quiet_compiler():
        space = fem.VectorFunctionSpace(model.mesh, ("DG", 0), dim=3)
        P1 = fem.FunctionSpace(model.mesh, ("Lagrange", 1))
    model.frame = []
    for i in range(3):
        f = fem.Function(space, name=f"E{i + 1}")
        f.x.array[:] = model.frames[idx, i, :].reshape(-1)
        model.frame.append(f)
    model.chi = []
    for c in range(model.n_colours):
        f = fem.Function(model.W, name=f"colour{c}")
        f.x.array[:] = (model.colour[idx] == c).astype(float)
        model.chi.append(f)
    # each colour's nodes: those of its cells; the others are parked (held at q = 0)
    cells = np.asarray(model.geometry.cells, np.int64)
    nodes = model.line.dof_nodes(P1)
    model.parked = []
    for c in range(model.n_colours):
        used = np.zeros(len(model.geometry.points), bool)
        used[cells[model.colour == c].ravel()] = True
        z = fem.Function(P1, name=f"parked{c}")
        z.x.array[:] = (~used[nodes]).astype(float)
        model.parked.append(z if np.any(~used) else None)


def rod_network_anchors(model):
    """The network's anchors (:func:`cablefem.network.network_anchors`) with the rod's
    components: a clamp holds every component (its cable's rotation at the clamp's, the
    other colours' at zero), a pinned anchor the displacement."""
    anchors = network_anchors(model)
    cells = np.asarray(model.geometry.cells, np.int64)
    for anc in anchors:
        anc.bs = model.bs
        es = np.nonzero(np.any(cells == anc.node, axis=1) & model.geometry.is_cable)[0]
        c = int(model.colour[es[0]]) if es.size else 0
        anc.rot_offset = 3 + 3 * c
        anc.colour = c
        E3 = model.frames[es[0], 2] if es.size else np.array([0.0, 0.0, 1.0])
        if anc.kind == "clamped":
            d3 = anc.direction if anc.direction @ E3 >= 0 else -anc.direction
            try:
                anc.rotation = cayley_from_rotation(E3, d3)
            except ValueError:
                raise CaseError([(f"anchors[{anc.name}].direction", "the clamp turns the "
                                  "rod by 180 degrees from its cable: point it into the "
                                  "cable")], model.case.source) from None
            anc.comps = tuple(range(model.bs))
            anc.moment_map = np.linalg.inv(virtual_rotation_map(anc.rotation)).T
        else:
            anc.comps = (0, 1, 2)
            anc.moment_map = np.eye(3)
    return anchors


#: what the network rod is built from (:class:`cablefem.contract.Builders`)
NETWORK_ROD = Builders(geometry=rod_network_geometry, coefficients=rod_network_coefficients,
                       anchors=rod_network_anchors, bcs=rod_bcs)


def _colour_part(w, c):
    """The displacement and colour ``c``'s Cayley vector of ``w``, as a six-vector."""
    return ufl.as_vector([w[0], w[1], w[2], w[3 + 3 * c], w[4 + 3 * c], w[5 + 3 * c]])


def _q(w, c):
    return ufl.as_vector([w[3 + 3 * c], w[4 + 3 * c], w[5 + 3 * c]])


class NetworkRodModel(BeamModel, NetworkModel):
    """The reference rod of a network (module docstring): a
    :class:`~cablefem.network.NetworkModel`'s mesh, anchors and kinks with the rod's
    physics (:class:`~cablefem.rod.BeamModel`: its soft-shear statics stages, outputs,
    ``string.xdmf`` fields with the first colour's ``rotation``)."""

    builders = NETWORK_ROD
    is_network = True
    ramp_weight = True

    def __init__(self, comm, description, prefix: str = "cable_", refine: float = 1.0):
        problems = network_rod_problems(description)
        if not refine > 0:
            problems.append(("refine", f"must be > 0, got {refine}"))
        if problems:
            raise CaseError(problems, description.source)
        self.refine = float(refine)
        self.spec = description.beam
        CableModel.__init__(self, comm, description, prefix)
        self.tension_only = False

    def build_forms(self) -> None:
        u, a, du, cc = self.u, self.a, self.du, self.c
        dxr = ufl.dx(metadata={"quadrature_degree": 0})
        E1, E2, E3 = self.frame
        # each cell's tangent along its cable's E3 (the mesh's may point either way)
        t0 = ufl.sign(ufl.dot(self.t0, E3)) * self.t0
        psi, G3, moment = 0, 0, 0
        rot_inertia, rot_kin = 0, 0
        vq_all = self.v
        for c, chi in enumerate(self.chi):
            G, K, d = rod_strains(_colour_part(u, c), t0, self.frame, cc)
            psi = psi + chi * energy_density(G, K, self.EA, self.GA, self.EI, self.GJ)
            G3 = G3 + chi * G[2]
            moment = moment + chi * (self.EI * (K[0] * d[0] + K[1] * d[1])
                                     + self.GJ * K[2] * d[2])
            aq, dq, vq = _q(a, c), _q(du, c), _q(vq_all, c)
            rot_inertia = rot_inertia + chi * (
                p1_product(aq, dq, t0, self.mesh)
                + p1_product(ufl.dot(aq, E3), ufl.dot(dq, E3), t0, self.mesh))
            rot_kin = rot_kin + chi * (ufl.inner(vq, vq) + ufl.dot(vq, E3) ** 2)
        self.Pi = psi * cc * dxr
        self._psi = psi
        F_int = ufl.derivative(self.Pi, u, du)
        # parked rotations: a stiffness (GA) and a mass (the largest rhoI), so that
        # their own frequencies, sqrt(GA/rhoI), lie with the rod's shear modes
        GA, rhoI_max = float(self.GA.value), float(np.max(self.rhoI.x.array, initial=0.0))
        rhoI_max = self.comm.allreduce(rhoI_max, op=MPI.MAX)
        park = self._parking(self.u, GA, dxr)
        if park is not None:
            F_int = F_int + park
        pinned = [anc for anc in self.anchors if anc.kind == "pinned"]
        if pinned:
            F_int = F_int + self._twist_springs(pinned)
        duu = self.translational(du)
        au = self.translational(a)
        F_inertia = cc * (self.m * p1_product(au, duu, t0, self.mesh)
                          + self.rhoI * rot_inertia) * dxr
        if park is not None:
            F_inertia = F_inertia + self._parking(a, rhoI_max, dxr)
        self.axial_strain, self.dx_rod = G3, dxr
        add_model_terms(self, F_int=F_int,
                        F_weight=cc * self.m * ufl.inner(self.gravity, duu) * dxr,
                        F_inertia=F_inertia, du_t=duu, a_t=au, dx=dxr,
                        u_t=self.translational(u), v_t=self.translational(self.v),
                        us_t=self.translational(self.u_static),
                        axial_damping=_axial_damping)
        self.forms.dx = dxr
        self.forms.outputs = {"tension": self.EA * G3, "strain": G3}
        self._moment = moment
        vu = self.translational(self.v)
        kin = 0.5 * cc * (self.m * ufl.inner(vu, vu) + self.rhoI * rot_kin)
        self.forms.energies = (kin * ufl.dx, self.Pi,
                               -ufl.inner(cc * self.m * self.gravity, self.translational(u))
                               * ufl.dx)

    def _parking(self, w, value, dxr):
        """A nodal term ``k q_c·δq_c`` (``q_c`` colour c's vector of ``w``, ``k`` =
        ``value``) on every colour's parked nodes (``z_c = 1``),
        integrated exactly as the trapezoidal rule does from the element's midpoint
        values: ``h [z q·δq + (h²/4)(z ∂q·∂δq + ∂z (q·∂δq + ∂q·δq))]`` is
        ``(h/2) Σ_ends z q·δq`` for P1 fields (``∂`` along the element)."""
        k = fem.Constant(self.mesh, PETSc.ScalarType(value))
        h = ufl.CellVolume(self.mesh)
        out = None
        for c, z in enumerate(self.parked):
            if z is None:
                continue
            q, dq = _q(w, c), _q(self.du, c)
            dz = ufl.dot(ufl.grad(z), self.t0)
            gq, gdq = ufl.grad(q) * self.t0, ufl.grad(dq) * self.t0
            term = k * (z * ufl.dot(q, dq) + h * h / 4.0 * (
                z * ufl.dot(gq, gdq) + dz * (ufl.dot(q, gdq) + ufl.dot(gq, dq)))) * dxr
            out = term if out is None else out + term
        return out

    def _twist_springs(self, pinned):
        """The single rod's twist spring ``GJ/h`` at every pinned anchor, on its cable's
        rotation (an end of one element: ``ds``; a node of two: ``dS``)."""
        cells = np.asarray(self.geometry.cells, np.int64)
        lengths = self.geometry.cell_lengths
        tags = self.line.vertex_tags({anc.node: i + 1 for i, anc in enumerate(pinned)})
        ds = ufl.Measure("ds", domain=self.mesh, subdomain_data=tags)
        dS = ufl.Measure("dS", domain=self.mesh, subdomain_data=tags)
        E3 = self.frame[2]
        form = None
        for i, anc in enumerate(pinned):
            es = np.nonzero(np.any(cells == anc.node, axis=1) & self.geometry.is_cable)[0]
            if not es.size:
                continue
            GJ = self.case.network.sections[self.geometry.cell_section[es[0]]]
            GJ = GJ.GJ if GJ.GJ > 0 else GJ.EI / (1.0 + POISSON)
            k_t = fem.Constant(self.mesh, PETSc.ScalarType(GJ / float(np.min(lengths[es]))))
            q, dq = _q(self.u, anc.colour), _q(self.du, anc.colour)
            if es.size == 1:
                term = k_t * ufl.dot(q, E3) * ufl.dot(dq, E3) * ds(i + 1)
            else:
                term = k_t * ufl.dot(q("+"), E3("+")) * ufl.dot(dq("+"), E3("+")) * dS(i + 1)
            form = term if form is None else form + term
        return form

    def mesh_record(self) -> dict:
        """The graded mesh for ``summary.json`` (``beam``): the shortest and longest
        elements (stress-free), the number of colours and the layer lengths at the
        pretension it was graded to, by node (``node<k>``, the mesh file's numbers)."""
        h = self.geometry.cell_lengths[self.geometry.is_cable]
        return {"min_element": float(np.min(h)), "max_element": float(np.max(h)),
                "elements": int(h.size), "colours": int(self.n_colours),
                "layer_lengths_pretension": {f"node{k}": ell
                                             for k, ell in self.layer_lengths.items()}}

    def initial_guess(self) -> np.ndarray:
        """Nodal (n, bs): the mesh's positions; each cable's rotation at a node turns its
        ``E3`` onto the mean of its elements' directions there (a clamp's: the clamp's)."""
        geo = self.geometry
        cells = np.asarray(geo.cells, np.int64)
        pts = np.asarray(geo.points, float)
        out = np.zeros((len(pts), self.bs))
        out[:, :3] = self.initial_shape - pts
        tang = np.zeros((len(pts), self.n_colours, 3))
        d = pts[cells[:, 1]] - pts[cells[:, 0]]
        d = d / np.linalg.norm(d, axis=1)[:, None]
        for e in np.nonzero(geo.is_cable)[0]:
            de = d[e] if d[e] @ self.frames[e, 2] >= 0 else -d[e]
            for k in cells[e]:
                tang[k, self.colour[e]] += de
        for e in np.nonzero(geo.is_cable)[0]:
            c = self.colour[e]
            for k in cells[e]:
                t = tang[k, c]
                out[k, 3 + 3 * c: 6 + 3 * c] = cayley_from_rotation(self.frames[e, 2], t)
        for anc in self.anchors:
            if anc.kind == "clamped":
                out[anc.node, anc.rot_offset: anc.rot_offset + 3] = anc.rotation
        return out


def _axial_damping(model):
    """The axial strain-rate damping ``β EA (dΓ3/dt) δΓ3`` (:func:`cablefem.rod.
    rod_axial_damping` with the network rod's strain)."""
    G3, u = model.axial_strain, model.u
    return (model.beta * model.EA * ufl.derivative(G3, u, model.v)
            * ufl.derivative(G3, u, model.du) * model.c * model.dx_rod)


class KinkReactions:
    """The rod's internal moment at each kink's node, as a clamp's is computed: the
    reaction of the node's rotation rows (its cable's colour) to the elastic forces of the
    kink's first element alone, mapped to a moment (``M = −H⁻ᵀ R_q``). The cable's moment
    at the node, which converges at the rate of the solution (the element moments are
    mid-element values). Needs each kink's first element to touch no other kink's node."""

    def __init__(self, model, kinks):
        self.model, self.kinks = model, kinks
        first = np.array([k.cells[0] for k in kinks], np.int64)
        cells = np.asarray(model.geometry.cells, np.int64)
        nodes = {int(k.node) for k in kinks}
        self.ok = not any(sum(int(n) in nodes for n in cells[e]) > 1 for e in first)
        if not self.ok:
            return
        side = fem.Function(model.W, name="kink_side")
        side.x.array[:] = np.isin(model.cell_index, first).astype(float)
        with quiet_compiler():
            self.form = fem.form(ufl.derivative(side * model._psi * model.c * model.forms.dx,
                                                model.u, model.du))
        where = np.full(len(model.geometry.points), -1, np.int64)
        where[model.line.owned_nodes] = np.arange(model.line.owned_nodes.size)
        self.dof = where[[int(k.node) for k in kinks]]
        self.off = np.array([3 + 3 * int(model.colour[k.cells[0]]) for k in kinks])

    def moments(self) -> np.ndarray:
        """(n_kinks, 3) the moment vectors, the same on every rank (collective)."""
        from dolfinx.fem import petsc as fpetsc

        m, bs = self.model, self.model.bs
        vec = fpetsc.assemble_vector(self.form)
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        arr, u = vec.array_r, m.u.x.array
        out = np.zeros((len(self.kinks), 3))
        for i in np.nonzero(self.dof >= 0)[0]:
            rows = bs * int(self.dof[i]) + self.off[i] + np.arange(3)
            H = virtual_rotation_map(u[rows])
            out[i] = -np.linalg.solve(H.T, arr[rows])
        vec.destroy()
        return m.comm.allreduce(out)


def network_rod_kink_moments(model, kinks) -> np.ndarray:
    """The network rod's moment magnitude at each kink's node (collective): the reaction
    of the node's rotation rows (:class:`KinkReactions`); where two kinks share an element,
    along the kink's cable on each side its three nearest elements' moments extrapolated
    quadratically to the node (stress-free distances of their midpoints), the two sides
    averaged."""
    if not kinks:
        return np.zeros(0)
    cached = getattr(model, "_kink_reactions", None)
    if cached is None or cached.kinks is not kinks:
        cached = model._kink_reactions = KinkReactions(model, kinks)
    if cached.ok:
        return np.linalg.norm(cached.moments(), axis=1)
    f = model.moment_field()
    n_owned = model.mesh.topology.index_map(1).size_local
    idx = model.line.reference_cells()[:n_owned]
    vals = f.x.array[: 3 * n_owned].reshape(-1, 3)
    parts = model.comm.allgather((idx, np.linalg.norm(vals, axis=1)))
    geo = model.geometry
    M = np.full(len(geo.cells), np.nan)
    for i, v in parts:
        M[i] = v
    cells = np.asarray(geo.cells, np.int64)
    length = geo.cell_lengths
    at = model.cable_cells_at()
    out = []
    for kink in kinks:
        sides = []
        for e in kink.cells:
            node, es, s_mid, s = kink.node, [], [], 0.0
            group = geo.net.cell_group[e]
            while len(es) < 3:
                es.append(e)
                s_mid.append(s + 0.5 * length[e])
                s += length[e]
                node = int(cells[e][cells[e] != node][0])
                nxt = [c for c in at[node] if c != e and geo.net.cell_group[c] == group]
                if len(nxt) != 1:
                    break
                e = nxt[0]
            if len(es) < 3:
                sides.append(M[es[0]])
                continue
            coef = np.polyfit(np.asarray(s_mid), M[es], 2)
            sides.append(np.polyval(coef, 0.0))
        out.append(0.5 * (sides[0] + sides[1]))
    return np.array(out)

