"""The reference model: a geometrically exact rod (3D, large rotations) on the same meshes.

This is what the string + asymptotics route is checked against (issue 4): a cable with its
bending stiffness everywhere, solved by finite elements without any asymptotic assumption.
It is far more expensive (a mesh graded to resolve the layer length ``ℓ`` at every clamp,
six unknowns per node) and it is the model the paper's method avoids.

Formulation (Simo-Reissner rod, written in UFL)
-----------------------------------------------
Unknowns at every node: the displacement ``u`` of the centre line (``r = X + u``) and a
rotation of the cross-section, parametrised by its Cayley (Rodrigues, Gibbs) vector
``q = 2 tan(φ/2) n`` relative to the stress-free straight reference frame
``(E1, E2, E3 = t0)``::

    Λ(q) = I + 4/(4 + q·q) (Q + Q²/2),  Q = skew(q),   d_i = Λ E_i.

The parametrisation is rational (no trigonometry, no singularity at ``q = 0``) and covers
every rotation below 180° from the reference, which a cable never approaches. Strains
against the stress-free length ``s``, in the section's frame (material components)::

    Γ_i = d_i · ∂s r − δ_i3          (shear Γ1, Γ2; axial strain Γ3)
    K_i = ω · d_i,  ω = 4/(4 + q·q) (∂s q + q × ∂s q / 2)   (Λ' Λᵀ = skew(ω))

Energy per stress-free length ``Ψ = ½ (EA Γ3² + GA (Γ1² + Γ2²) + EI (K1² + K2²) + GJ K3²)``;
the internal virtual work is UFL's derivative of ``∫ Ψ ds``. The rod is shearable with a
shear stiffness ``GA`` high enough to be unshearable in effect (default ``1e5 T``, ``T`` the
catenary's largest tension, or ``EI/l²`` if larger: shear changes the anchor moment by
``O(T/GA)`` = 1e-5 and a cantilever's deflection by ``3 EI/(GA l²)``; a far
stiffer one slows Newton down as a stiff penalty does); linear elements
(P1 for ``u`` and ``q``) with one-point (reduced) integration of the energy, the classic
locking-free choice. The objectivity defect of interpolating a rotation parameter vanishes
with the mesh size (Crisfield and Jelenić, 1999); the convergence tests show it.

Inertia: the centre line's ``m ü`` (consistent mass) and the rotary inertia of a solid
section, ``ρI = m EI/EA`` per length (``2 ρI`` about the axis), in its small-rotation form
``ρI q̈``; its effect on the paper's cases is far below 1e-6 (``ρI ω²/T``), so the
simplification does not show, but a rod spinning through large angles would need the full
form. Damping: the string's (Rayleigh ``α M + β K0`` with this model's ``M`` and ``K0``).

Anchors: every anchor prescribes ``u`` (and its motion). A clamped anchor also holds the
rotation: the rod's tangent is the clamp direction (``d3 = c`` at ``s = 0``, ``d3 = −c`` at
``s = l``, since ``d3`` runs along ``s``) and the section does not twist. A pinned anchor
leaves the rotations free; it holds only the twist, through a torsional spring as stiff as
its end element (``GJ/h``), which removes the rigid twist of a rod with no clamp and does
nothing else (no torque acts on it). The anchor's force is the consistent reaction of the
position rows, as for the string, and its moment the consistent reaction of the rotation
rows (``M = −H⁻ᵀ R_q``, ``δθ = H δq``): the rod's internal moment at the anchor, which equals
``EI κ(0)`` of the discrete equilibrium and converges at the rate of the solution, unlike the
curvature of the first element (a mid-element value).

The beam takes single straight cables (geometry by length, tension or sag; not a polyline or
a network): its stress-free reference is straight and stress-free.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from cablefem.cable import CableModel, string_anchors
from cablefem.cable_geometry import cable_geometry
from cablefem.contract import Builders
from cablefem.description import CableDescription
from cablefem.errors import CaseError
from cablefem.geometry import straight_cable
from cablefem.jit import quiet_compiler
from cablefem.rod_kinematics import (
    cayley_from_rotation,
    cayley_rotation,
    energy_density,
    p1_product,
    rod_strains,
    rotation_matrix,
    split,
    virtual_rotation_map,
)
from cablefem.string_terms import add_model_terms, string_coefficients

__all__ = ["BeamModel", "ROD", "beam_stations", "cayley_from_rotation", "cayley_rotation",
           "p1_product", "rotation_matrix", "virtual_rotation_map", "rod_strains", "split",
           "rod_problems", "rod_geometry", "rod_coefficients", "rod_anchors", "rod_bcs"]

log = logging.getLogger(__name__)

#: default shear stiffness GA / T (T the catenary's largest tension): unshearable in effect,
#: shear changes the anchor moment by O(T/GA) = 1e-5; far stiffer makes Newton stagnate
#: (1e7 in case B: GA/EA = 1000) as a stiff penalty does
SHEAR_FACTOR = 1.0e5
#: default torsional stiffness when the case gives none: a solid circle, GJ = EI/(1 + nu)
POISSON = 0.3


def beam_stations(length: float, ends: dict[int, float], per_layer: float, growth: float,
                  h_max: float, extra: tuple[float, ...] = (),
                  kinks: dict[float, float] | None = None) -> np.ndarray:
    """Stress-free stations graded towards clamped ends and interior kinks.

    ``ends`` maps an end (0: ``s = 0``, 1: ``s = l``) to its layer length ``ℓ``. The element
    size is ``h(s) = min(h_max, min_a [ℓ_a/per_layer + (growth − 1) σ_a(s)])``, ``σ_a`` the
    distance from end ``a``: a geometric progression of ratio ``growth`` away from each clamp
    up to ``h_max``; ``kinks`` maps interior stations (where a point force kinks the cable)
    to their layer lengths, graded alike on both sides. Nodes follow ``∫ ds/h`` in equal
    steps; ``extra`` stations (point masses, loads, dampers) are inserted as nodes.
    """
    h_max = min(h_max, length)
    kinks = {float(k): float(v) for k, v in (kinks or {}).items() if 0.0 < k < length}
    # fine sampling, geometric near the ends and kinks, to integrate 1/h accurately
    h0 = min([ell / per_layer for ell in list(ends.values()) + list(kinks.values())]
             + [h_max])
    n_geo = 400
    g = np.geomspace(1e-3 * h0, length, n_geo)
    s = np.unique(np.concatenate([[0.0], g, length - g, np.linspace(0, length, 2001)]
                                 + [np.concatenate([k - g, k + g]) for k in kinks]))
    s = s[(s >= 0) & (s <= length)]

    def h(x):
        out = np.full_like(x, h_max)
        for end, ell in ends.items():
            sig = x if end == 0 else length - x
            out = np.minimum(out, ell / per_layer + (growth - 1.0) * sig)
        for k, ell in kinks.items():
            out = np.minimum(out, ell / per_layer + (growth - 1.0) * np.abs(x - k))
        return out

    inv = 1.0 / h(s)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (inv[1:] + inv[:-1]) * np.diff(s))])
    n = max(2, int(math.ceil(cum[-1])))
    st = np.interp(np.linspace(0.0, cum[-1], n + 1), cum, s)
    st[0], st[-1] = 0.0, length
    extra_arr = np.array(sorted(float(e) for e in extra if 0.0 < e < length))
    if extra_arr.size:
        hs = h(extra_arr)
        keep = np.ones(st.size, bool)
        for e, he in zip(extra_arr, hs):
            near = np.abs(st - e) < 0.25 * he
            near[[0, -1]] = False
            keep &= ~near
        st = np.unique(np.concatenate([st[keep], extra_arr]))
    return st


def rod_axial_damping(model):
    """The rod's axial strain-rate damping: ``β EA (dΓ3/dt) δΓ3`` (the axial strain
    ``Γ3`` and the one-point measure as :meth:`BeamModel.build_forms` made them)."""
    G3, u = model.axial_strain, model.u
    return (model.beta * model.EA * ufl.derivative(G3, u, model.v)
            * ufl.derivative(G3, u, model.du) * model.c * model.dx_rod)


# ----------------------------------------------------------------------------- the model
def rod_problems(case) -> list[tuple[str, str]]:
    """Why the rod cannot run ``case`` (``[(key, reason)]``; empty when it can): it takes a
    single cable with a straight stress-free reference, without seabed or fluid (a network:
    :func:`cablefem.rod_network.network_rod_problems`)."""
    if case.network is not None:  # the network rod (cablefem.rod_network)
        from cablefem.rod_network import network_rod_problems

        return network_rod_problems(case)
    if getattr(case, "seabed", None) is not None:
        return [("seabed", "the beam model has no seabed contact")]
    if getattr(case, "fluid", None) is not None:
        return [("fluid", "the beam model has no fluid forces: compare the string with the "
                 "rod in air without [fluid]")]
    if case.geometry.kind == "polyline":
        return [("geometry.polyline", "the beam model needs a straight stress-free "
                 "reference: give length, horizontal_tension or sag_ratio")]
    if case.section is not None and not case.section.EI > 0:
        return [("section.EI", "the beam model (a rod) needs EI > 0; a cable without bending "
                 "stiffness is the string alone")]
    return []


def rod_geometry(model):
    """The rod's stations, graded towards its clamps' and kinks' layers (:func:`beam_stations`),
    on the string's chord and catenary (:func:`cablefem.cable_geometry.cable_geometry`)."""
    g, r0 = cable_geometry(model)  # the string's: length, catenary, anchor nodes
    case, sec, spec = model.case, model.case.section, model.spec
    # a rod's force scale (Newton's tolerances, GA) is at least EI/l^2: a weightless
    # unstressed rod under an end load has no tension to scale with
    model.force_scale = max(model.force_scale, sec.EI / g.length**2)
    p, q = model.anchor_positions
    length = g.length
    shape = model.catenary_shape  # the string's, through the same anchors
    ends = {}
    for end, a in enumerate(case.anchors):
        if a.kind == "clamped":
            T = float(shape.tension(np.array([0.0 if end == 0 else length]))[0])
            # no tension (a weightless cable at its stress-free length): no layer
            ends[end] = math.sqrt(sec.EI / (T * (1.0 + T / sec.EA))) if T > 0 else length
            ends[end] = min(ends[end], length)
    model.layer_lengths = ends
    extra = ([pm.s for pm in case.point_masses] + [pl.s for pl in case.point_loads]
             + list(model.damper_s))
    # the kinks' layers (a point force turns the cable there), at the catenary's tension
    kinks = {}
    for s in extra:
        T = float(shape.tension(np.array([s]))[0])
        if T > 0:
            kinks[s] = math.sqrt(sec.EI / (T * (1.0 + T / sec.EA)))
    # refine scales the whole size function h(s) by 1/refine (a uniform refinement)
    stations = beam_stations(length, ends, spec.layer_elements * model.refine,
                             1.0 + (spec.growth - 1.0) / model.refine,
                             length / (spec.span_elements * model.refine), tuple(extra),
                             kinks)
    names = (case.anchors[0].name, case.anchors[1].name)
    geo = straight_cable(p, (q - p) / np.linalg.norm(q - p), stations, names)
    return geo, shape.position(geo.stations)


def rod_coefficients(model) -> None:
    """The string's coefficients, the rod's stiffnesses (EI, GJ, GA, rhoI) and its
    reference frame (E1 in the plane of chord and gravity, E3 along the chord)."""
    string_coefficients(model)
    sec, spec = model.case.section, model.case.beam
    GJ = sec.GJ
    if GJ <= 0.0:
        GJ = sec.EI / (1.0 + POISSON)
        if model.comm.rank == 0:
            log.info("beam: section.GJ not given; GJ = EI/(1 + %.1f) = %.6g N m^2 (solid "
                     "circle)", POISSON, GJ)
    GA = spec.shear_stiffness if spec.shear_stiffness is not None else \
        SHEAR_FACTOR * model.force_scale
    model.section_values = {"EA": sec.EA, "EI": sec.EI, "GJ": GJ, "GA": GA,
                           "rhoI": sec.mass * sec.EI / sec.EA}
    m = model.mesh
    model.EI = fem.Constant(m, PETSc.ScalarType(sec.EI))
    model.GJ = fem.Constant(m, PETSc.ScalarType(GJ))
    model.GA = fem.Constant(m, PETSc.ScalarType(GA))
    model.rhoI = fem.Constant(m, PETSc.ScalarType(model.section_values["rhoI"]))
    # the reference frame: E3 along the chord, E1 in the plane of chord and gravity
    p, q = model.anchor_positions
    E3 = (q - p) / np.linalg.norm(q - p)
    gdir = np.asarray(model.case.gravity.direction, float)
    trial = gdir - (gdir @ E3) * E3
    if np.linalg.norm(trial) < 1e-6:  # a vertical chord
        trial = np.eye(3)[int(np.argmin(np.abs(E3)))]
        trial = trial - (trial @ E3) * E3
    E1 = trial / np.linalg.norm(trial)
    E2 = np.cross(E3, E1)
    model._frame_np = (E1, E2, E3)
    model.frame = [fem.Constant(m, np.asarray(E, dtype=PETSc.ScalarType))
                  for E in model._frame_np]


def rod_anchors(model):
    """The string's anchors with six components per node: a clamp also holds the
    rotation (its Cayley vector), a pinned anchor the position only."""
    anchors = string_anchors(model)
    E3 = model._frame_np[2]
    for anc in anchors:
        anc.bs = 6
        if anc.kind == "clamped":
            d3 = anc.direction if anc.node == 0 else -anc.direction
            try:
                anc.rotation = cayley_from_rotation(E3, d3)
            except ValueError:
                raise CaseError([(f"anchors.{anc.name}.direction",
                                  "the clamp turns the rod by 180 degrees from its "
                                  "chord: point it into the cable")],
                                model.case.source) from None
            anc.comps = (0, 1, 2, 3, 4, 5)
            anc.moment_map = np.linalg.inv(virtual_rotation_map(anc.rotation)).T
        else:
            anc.comps = (0, 1, 2)
            anc.moment_map = np.eye(3)
    return anchors


def rod_bcs(model):
    """A clamp's condition on all six components; a pinned anchor's on the three
    positions (each a Constant set by ``set_time``, ``model._pin_values``)."""
    bcs, model._pin_values = [], []
    for anc in model.anchors:
        if anc.kind == "clamped":
            bcs.append(fem.dirichletbc(model.u_bc, anc.dofs))
            continue
        verts = model.line.locate_node(anc.node)
        for k in range(3):
            dofs = fem.locate_dofs_topological(model.V.sub(k), 0, verts)
            val = fem.Constant(model.mesh, PETSc.ScalarType(0.0))
            model._pin_values.append((anc, k, val))
            bcs.append(fem.dirichletbc(val, dofs, model.V.sub(k)))
    return bcs


#: what the rod is built from (:class:`cablefem.contract.Builders`)
ROD = Builders(geometry=rod_geometry, coefficients=rod_coefficients, anchors=rod_anchors,
               bcs=rod_bcs)


class BeamModel(CableModel):
    """The rod counterpart of :class:`~cablefem.cable.CableModel` (same attributes, with six
    components per node: ``u`` holds displacement and Cayley vector).

    ``refine`` scales the mesh density (elements per layer and per span) for convergence
    studies.
    """

    bs = 6
    is_beam = True
    builders = ROD
    kink_offsets = False  # the rod resolves its kinks' layers

    def has_hinges(self) -> bool:
        """The rod resolves its layers: no virtual hinge (``outer_correction`` is ignored)."""
        return False
    #: statics: a rod's Newton step that turns sections shortens the axis at second order,
    #: which the axial stiffness turns into a large residual (1e5 times the initial one
    #: for a cantilever under an end moment): a line search on the residual norm ("bt")
    #: then takes tiny steps and stagnates ("cp" too); full Newton steps converge
    static_options = {"snes_linesearch_type": "basic", "snes_divergence_tolerance": -1}

    def __init__(self, comm: MPI.Comm, description: CableDescription, prefix: str = "cable_",
                 refine: float = 1.0):
        if not isinstance(comm, MPI.Comm) or not isinstance(description, CableDescription):
            raise TypeError(f"expected (comm, description), got ({type(comm).__name__}, "
                            f"{type(description).__name__})")
        case = description
        problems = rod_problems(case)
        if not refine > 0:
            problems.append(("refine", f"must be > 0, got {refine}"))
        if problems:
            raise CaseError(problems, case.source)
        self.refine = float(refine)
        self.spec = case.beam
        super().__init__(comm, case, prefix)
        self.tension_only = False  # a rod carries compression (bending stiffness)

    def mesh_record(self) -> dict:
        """The rod's mesh for ``summary.json`` (``beam``): its shortest and longest
        elements and the layer lengths it was graded to, by anchor."""
        st = self.geometry.stations
        return {"min_element": float(np.min(np.diff(st))),
                "max_element": float(np.max(np.diff(st))),
                "layer_lengths_catenary": {self.case.anchors[e].name: ell
                                           for e, ell in self.layer_lengths.items()}}

    def set_time(self, t: float) -> None:
        changed = t != getattr(self, "_time", None)
        super().set_time(t)
        if changed:
            for anc, k, val in self._pin_values:
                val.value = anc.displacement(t)[k]

    # ------------------------------------------------------------------ forms
    def build_forms(self) -> None:
        u, a, du, t0, cc = self.u, self.a, self.du, self.t0, self.c
        dxr = ufl.dx(metadata={"quadrature_degree": 0})  # one point: locking-free
        G, K, d = rod_strains(u, t0, self.frame, cc)
        psi = energy_density(G, K, self.EA, self.GA, self.EI, self.GJ)
        self.Pi = psi * cc * dxr
        F_int = ufl.derivative(self.Pi, u, du)
        # pinned anchors hold the twist (a spring as stiff as the end element, GJ/h)
        pinned = [anc for anc in self.anchors if anc.kind == "pinned"]
        if pinned:
            F_int = F_int + self._twist_springs(pinned)
        duu, dqq = split(du)
        au, aq = split(a)
        E3 = self.frame[2]
        F_inertia = cc * (self.m * p1_product(au, duu, t0, self.mesh)
                          + self.rhoI * (p1_product(aq, dqq, t0, self.mesh)
                                         + p1_product(ufl.dot(aq, E3), ufl.dot(dqq, E3),
                                                       t0, self.mesh))) * dxr
        #: Γ3 and the one-point cell measure (rod_axial_damping, translational_inner)
        self.axial_strain, self.dx_rod = G[2], dxr
        # constant loads on P1 fields: one point integrates them exactly
        add_model_terms(self, F_int=F_int,
                        F_weight=cc * self.m * ufl.inner(self.gravity, duu) * dxr,
                        F_inertia=F_inertia, du_t=duu, a_t=au, dx=dxr, u_t=split(u)[0],
                        v_t=split(self.v)[0], us_t=split(self.u_static)[0],
                        axial_damping=rod_axial_damping)
        # output fields (DG0 at the element midpoint, where the strains are sampled)
        self.forms.dx = dxr  # user terms too: FFCx 0.5 cannot mix cell rules (forms.add)
        self.forms.outputs = {"tension": self.EA * G[2], "strain": G[2]}
        self._moment = self.EI * (K[0] * d[0] + K[1] * d[1]) + self.GJ * K[2] * d[2]
        vu, vq = split(self.v)
        kin = 0.5 * cc * (self.m * ufl.inner(vu, vu) + self.rhoI * (
            ufl.inner(vq, vq) + ufl.dot(vq, E3) ** 2))
        self.forms.energies = (kin * ufl.dx, self.Pi,
                               -ufl.inner(cc * self.m * self.gravity, split(u)[0]) * ufl.dx)

    def _twist_springs(self, pinned):
        _, qq = split(self.u)
        _, dqq = split(self.du)
        E3 = self.frame[2]
        tags = self.line.vertex_tags({anc.node: i + 1 for i, anc in enumerate(pinned)})
        ds = ufl.Measure("ds", domain=self.mesh, subdomain_data=tags)
        st = self.geometry.stations
        form = None
        for i, anc in enumerate(pinned):
            h = st[1] - st[0] if anc.node == 0 else st[-1] - st[-2]
            k_t = fem.Constant(self.mesh, PETSc.ScalarType(self.section_values["GJ"] / h))
            term = k_t * ufl.dot(qq, E3) * ufl.dot(dqq, E3) * ds(i + 1)
            form = term if form is None else form + term
        return form

    def compile(self) -> None:
        """The string's (:meth:`CableModel.compile`), then the output spaces of three
        components and the moment expression."""
        super().compile()
        with quiet_compiler():
            self._compile_outputs()

    def _compile_outputs(self) -> None:
        self.W3 = fem.VectorFunctionSpace(self.mesh, ("DG", 0), dim=3)
        self.V3 = fem.VectorFunctionSpace(self.mesh, ("Lagrange", 1), dim=3)
        # the output copies components node by node: both spaces must number nodes alike
        n3 = self.V3.dofmap.index_map.size_local + self.V3.dofmap.index_map.num_ghosts
        n6 = self.V.dofmap.index_map.size_local + self.V.dofmap.index_map.num_ghosts
        if n3 != n6 or not np.allclose(self.V3.tabulate_dof_coordinates(),
                                       self.V.tabulate_dof_coordinates()):
            raise RuntimeError("beam: P1 spaces of 3 and 6 components number nodes apart")
        self.moment_expr = fem.Expression(self._moment, self.W3.element.interpolation_points())

    def _part(self, f: fem.Function, comps: slice, out: fem.Function) -> fem.Function:
        out.x.array[:] = f.x.array.reshape(-1, self.bs)[:, comps].reshape(-1)
        return out

    def displacement_part(self, f: fem.Function, name: str) -> fem.Function:
        return self._part(f, slice(0, 3), fem.Function(self.V3, name=name))

    def output_fields(self) -> list[fem.Function]:
        """Displacement, velocity, rotation (Cayley vector), tension (axial force),
        axial strain and the internal moment vector per element."""
        if not hasattr(self, "_out"):
            self._out = [fem.Function(self.V3, name="displacement"),
                         fem.Function(self.V3, name="velocity"),
                         fem.Function(self.V3, name="rotation"),
                         fem.Function(self.W, name="tension"),
                         fem.Function(self.W, name="strain"),
                         fem.Function(self.W3, name="moment")]
        d, v, rot, T, e, mom = self._out
        self._part(self.u, slice(0, 3), d)
        self._part(self.v, slice(0, 3), v)
        self._part(self.u, slice(3, 6), rot)
        T.interpolate(self.tension_expr)
        e.interpolate(self.strain_expr)
        mom.interpolate(self.moment_expr)
        return self._out

    def moment_field(self, name: str = "moment") -> fem.Function:
        """The rod's internal moment vector per element (N m, DG0, spatial components)."""
        f = fem.Function(self.W3, name=name)
        f.interpolate(self.moment_expr)
        return f

    def translational(self, f):
        """The displacement part (the first three components) of ``f``."""
        return ufl.as_vector([f[i] for i in range(3)])

    def translational_inner(self, a, b):
        """``(integrand, measure)`` of the L2 product of two translational fields as the
        rod integrates its mass: the one-point rule's exact P1 product (:func:`p1_product`)
        on :attr:`forms`'s one-point measure."""
        return p1_product(a, b, self.t0, self.mesh), self.forms.dx

    # ------------------------------------------------------------------ statics start
    def static_stages(self):
        """Pre-solves of statics with a softer shear stiffness (``GA`` 1000, 100 and 10
        times smaller, while above the force scale): the initial guess turns the sections
        in the layers but leaves the centre line on the catenary, a shear strain of up to
        ``Δ`` that the full ``GA`` turns into a residual Newton cannot cross (case B at
        twice the default mesh). Yields a label per stage; restores ``GA``."""
        target = self.section_values["GA"]
        try:
            for f in (1e-3, 1e-2, 1e-1):
                if target * f > 10.0 * self.force_scale:
                    self.GA.value = target * f
                    yield f"GA = {target * f:.3g} N"
        finally:
            self.GA.value = target

    def initial_guess(self) -> np.ndarray:
        """Nodal (n, 6): the elastic catenary's positions, and rotations that turn the rod
        from the string's tangent towards each clamp over the layer, by the inner
        solution's angle ``φ(σ) = 4 atan(tan(Δ/4) exp(−σ/ℓ))`` (docs/theory.md §3, step 6)."""
        st = self.geometry.stations
        r = self.initial_shape
        tang = np.gradient(r, st, axis=0)
        tang = tang / np.linalg.norm(tang, axis=1)[:, None]
        E3 = self._frame_np[2]
        d3 = tang.copy()
        for anc in self.anchors:
            if anc.kind != "clamped":
                continue
            ell = self.layer_lengths[0 if anc.node == 0 else 1]
            c3 = anc.direction if anc.node == 0 else -anc.direction  # d3 wanted at the clamp
            t_a = tang[anc.node]
            delta = math.atan2(np.linalg.norm(np.cross(c3, t_a)), float(c3 @ t_a))
            sigma = st if anc.node == 0 else st[-1] - st
            phi = 4.0 * np.arctan(math.tan(delta / 4.0) * np.exp(-sigma / ell))
            for k in np.nonzero(phi > 1e-12 * max(delta, 1e-300))[0]:
                axis = np.cross(tang[k], c3)
                na = np.linalg.norm(axis)
                if na < 1e-14:
                    continue
                R = rotation_matrix(2.0 * math.tan(phi[k] / 2.0) * axis / na)
                d3[k] = R @ tang[k]
            d3[anc.node] = c3
        out = np.zeros((st.size, 6))
        out[:, :3] = r - self.geometry.points
        out[:, 3:] = np.array([cayley_from_rotation(E3, d) for d in d3])
        for anc in self.anchors:
            if anc.kind == "clamped":
                out[anc.node, 3:] = anc.rotation
        return out
