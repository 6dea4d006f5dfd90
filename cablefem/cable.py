"""A cable model: mesh, function spaces, unknowns, anchors and the string's forms.

:class:`CableModel` turns a :class:`cablefem.description.CableDescription` (built by
:func:`cablefem.create_cable`, or a :class:`cablefem.case.Case`) into dolfinx objects and
keeps them in the open: ``model.mesh``, ``model.V``, the unknowns ``model.u``, ``model.v``,
``model.a``, the boundary conditions ``model.bcs`` and the residual's terms ``model.forms``
(:class:`cablefem.forms.CableForms`), from which ``model.F_static``, ``model.F_dynamic``, their
Jacobians and the mass form are derived. A user adds a term with ``model.forms.add`` and
calls :meth:`CableModel.compile` again before solving (``docs/extending.md``).
"""

from __future__ import annotations

import logging
import time

import numpy as np
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI
from petsc4py import PETSc
from ufl.algorithms import expand_derivatives

from cablefem import catenary, forms
from cablefem.anchor import AnchorBC
from cablefem.chain import without_bending
from cablefem.dampers import damper_stations, damper_work, layer_length
from cablefem.description import CableDescription
from cablefem.errors import CaseError
from cablefem.fluid import add_fluid_terms, submerged_weight
from cablefem.geometry import create_line_mesh, graded_stations, polyline_cable, straight_cable
from cablefem.jit import quiet_compiler
from cablefem.seabed import GroundedCatenary, add_seabed_terms
from cablefem.span_bending import is_on
from cablefem.water import floating_problems, water_problems, wave_warnings

__all__ = ["CableModel", "AnchorBC", "comm_first"]  # AnchorBC: from cablefem.anchor

log = logging.getLogger(__name__)

#: largest plausible strain T/EA of the static catenary: steel wires and strands yield below
#: 1 %, fibre ropes break at 10-20 % and are far from linear beyond a few percent; a linear
#: law (T = EA strain) above this is outside what any cable material does
MAX_PLAUSIBLE_STRAIN = 0.05
#: plausible range of stress-free length / chord: a cable shorter than 0.9 chord must stretch
#: by more than 10 % to span it; one longer than 3 chords hangs deeper than the chord is long
PLAUSIBLE_LENGTH_RATIO = (0.9, 3.0)




def comm_first(comm, description) -> tuple[MPI.Comm, CableDescription]:
    """``(comm, description)`` from the arguments of a model's constructor, also in the
    order of version 0.2 (description, comm); anything else is a TypeError."""
    if isinstance(comm, CableDescription) and isinstance(description, MPI.Comm):
        comm, description = description, comm
    if not isinstance(comm, MPI.Comm) or not isinstance(description, CableDescription):
        raise TypeError(f"expected (comm, description), got ({type(comm).__name__}, "
                        f"{type(description).__name__})")
    return comm, description


def _chord_frame(p: np.ndarray, q: np.ndarray, gdir: np.ndarray) -> tuple[float, float]:
    """Horizontal span and rise of the chord p -> q in the vertical plane of gravity."""
    d = q - p
    up = -gdir
    rise = float(d @ up)
    span = float(np.linalg.norm(d - rise * up))
    return span, rise


def _plausibility(key: str, length: float, chord: float, max_tension: float,
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


class CableModel:
    """The extensible string of one cable, ready to be solved.

    Parameters
    ----------
    comm
        MPI communicator; the mesh is partitioned over it.
    description
        What to build (:func:`cablefem.description.describe_cable`, or a case from
        :func:`cablefem.case.load_case`: a case is a description). ``model.case`` is it.
    prefix
        PETSc options prefix of every solver of this model (``cable_`` by default, so that
        ``-cable_ts_type`` or ``-cable_static_snes_rtol`` reach them).

    :func:`cablefem.create_cable` checks its arguments and builds one. The order of
    version 0.2, ``CableModel(case, comm)``, is still accepted (:func:`comm_first`).
    """

    def __init__(self, comm: MPI.Comm, description: CableDescription, prefix: str = "cable_"):
        comm, case = comm_first(comm, description)
        #: section.EI = 0: the string alone (cablefem.chain): clamps pinned, no moments
        case, self.string_alone = without_bending(case)
        self.case = case  #: the description (named ``case`` as in version 0.2)
        self.comm = comm
        self.prefix = prefix
        #: (key, message) pairs for derived quantities that are physically implausible
        #: (run_case logs them and lists them in summary.json; --strict makes them fatal)
        self.warnings: list[tuple[str, str]] = []
        sec = case.section
        self.g_vec = np.asarray(case.gravity.direction, dtype=float) * case.gravity.g
        self.weight = sec.mass * case.gravity.g  # N/m
        self.tension_only = case.solver.tension_only

        self._t_build = time.perf_counter()
        self.warnings += wave_warnings(getattr(case, "fluid", None), case.gravity,
                                       getattr(case, "seabed", None))
        self.geometry, self.initial_shape = self._build_geometry()
        self.length = self.geometry.length
        self._phase(f"mesh of {len(self.geometry.stations) - 1} elements")
        self.mesh = create_line_mesh(comm, self.geometry.points, self.geometry.cells)
        self.mesh.topology.create_connectivity(0, 1)
        self._phase("function spaces")
        with quiet_compiler():  # the elements are JIT-compiled on first use
            self.V = self._space()
            self.W = fem.FunctionSpace(self.mesh, ("DG", 0))
        self.u = fem.Function(self.V, name="displacement")
        self.v = fem.Function(self.V, name="velocity")
        self.a = fem.Function(self.V, name="acceleration")
        self.u_static = fem.Function(self.V, name="static_displacement")
        self.u_bc = fem.Function(self.V, name="prescribed_displacement")
        self.du = ufl.TestFunction(self.V)
        self.dw = ufl.TrialFunction(self.V)
        self.t0 = forms.reference_tangent(self.mesh)

        m = self.mesh
        self._coefficients()
        self.law = None  # virtual hinges: the layer law's cell fields (_hinge_fields)
        if self.has_hinges():
            self._hinge_fields()
        self.gravity = fem.Constant(m, np.asarray(self.g_vec, dtype=PETSc.ScalarType))
        self.load_factor = fem.Constant(m, PETSc.ScalarType(1.0))
        self.shift_v = fem.Constant(m, PETSc.ScalarType(0.0))
        self.shift_a = fem.Constant(m, PETSc.ScalarType(0.0))
        self.loads = [(fem.Constant(m, np.asarray(ld.value, dtype=PETSc.ScalarType)), ld)
                      for ld in case.loads]
        self.point_loads = [(fem.Constant(m, np.asarray(pl.value, dtype=PETSc.ScalarType)), pl)
                            for pl in case.point_loads]

        self.anchors = self._build_anchors()
        self.hinges = None
        if self.has_hinges():
            from cablefem.hinge import HingeError, VirtualHinges

            try:
                self.hinges = VirtualHinges(self)
            except HingeError as err:
                raise CaseError([("solver.outer_correction", str(err))],
                                case.source) from None
        self.bcs = self._make_bcs()
        self._point_tags()
        self._phase("forms")
        self.build_forms()
        self.compile()
        self._phase("node map")
        self._nodal_map()
        self.set_time(0.0)
        self._phase("model ready")

    #: from this many nodes on, the build logs each of its phases (a build of 1e5 elements
    #: takes seconds, of 1e6 about a minute on one core)
    LOG_PHASES_FROM = 100_000

    def _phase(self, what: str) -> None:
        """Log a build phase of a large problem (rank 0), with the time so far."""
        if len(self.geometry.stations) >= self.LOG_PHASES_FROM:
            log.info("build: %s (%.1f s)", what, time.perf_counter() - self._t_build)

    bs = 3  #: components per node
    is_beam = False

    def has_hinges(self) -> bool:
        """True when the case asks for the first-order outer correction (virtual hinges at
        the clamped anchors, :mod:`cablefem.hinge`) and there is a clamped anchor."""
        return (self.case.solver.outer_correction == "hinge"
                and any(a.kind == "clamped" for a in self.case.anchors))

    def _space(self):
        return fem.VectorFunctionSpace(self.mesh, ("Lagrange", 1), dim=3)

    def _make_bcs(self):
        return [fem.dirichletbc(self.u_bc, a.dofs) for a in self.anchors]

    def initial_guess(self) -> np.ndarray:
        """Nodal start of statics (n, bs): the elastic catenary through the anchors."""
        return self.initial_shape - self.geometry.points

    # ------------------------------------------------------------------ geometry
    def _build_geometry(self):
        case = self.case
        sec = case.section
        a0, a1 = case.anchors
        names = (a0.name, a1.name)
        gdir = np.asarray(case.gravity.direction, dtype=float)
        extra = [pm.s for pm in case.point_masses] + [pl.s for pl in case.point_loads]
        geo = case.geometry
        if geo.kind == "polyline":
            poly = np.asarray(geo.polyline, dtype=float)
            p = np.asarray(a0.position if a0.position is not None else poly[0], dtype=float)
            q = np.asarray(a1.position if a1.position is not None else poly[-1], dtype=float)
            length = float(np.sum(np.linalg.norm(np.diff(poly, axis=0), axis=1)))
        else:
            p = np.asarray(a0.position, dtype=float)
            q = np.asarray(a1.position, dtype=float)
            span, rise = _chord_frame(p, q, gdir)
            try:
                if geo.kind == "length":
                    length = float(geo.value)
                elif geo.kind == "horizontal_tension":
                    length = catenary.length_for_horizontal_tension(
                        span, rise, float(geo.value), self.weight, sec.EA)
                else:
                    length = catenary.length_for_sag_ratio(
                        span, rise, float(geo.value), self.weight, sec.EA)
            except ValueError as err:
                raise CaseError([(f"geometry.{geo.kind}", str(err))], case.source) from None
        bad = [(f"point masses/loads s={s:g}", f"must satisfy 0 < s < l = {length:g} m")
               for s in extra if not 0.0 < s < length]
        try:
            self.damper_s = damper_stations(case, length)
        except ValueError as err:
            bad += err.args[0]
        if bad:
            raise CaseError(bad, case.source)
        extra += self.damper_s
        wet = water_problems(case.anchors, case.gravity, getattr(case, "fluid", None),
                             getattr(case, "seabed", None), positions=(p, q))
        if wet:  # a description built in Python (a case file's are refused when read)
            raise CaseError(wet, case.source)
        if geo.kind == "polyline":
            g = polyline_cable(poly, case.mesh.elements, case.mesh.grading, names, tuple(extra))
        else:
            stations = graded_stations(length, case.mesh.elements, case.mesh.grading,
                                       tuple(extra), self._damper_clearance(p, q, length, gdir))
            g = straight_cable(p, (q - p) / np.linalg.norm(q - p), stations, names)
        chord = float(np.linalg.norm(q - p))
        if len(g.stations) == 2 and length > chord * (1.0 + 1e-12):
            raise CaseError([("mesh.elements", f"one element between the anchors is straight "
                              f"along their chord ({chord:g} m), shorter than the stress-free "
                              f"length l = {length:g} m: a slack element that carries nothing "
                              "(the run would fail in the dynamics); give more elements")],
                            case.source)
        # initial shape: the elastic catenary through the anchors (exact for the bare cable;
        # with a seabed it crosses, the catenary with its grounded part)
        fl = getattr(case, "fluid", None)
        self.submerged_weight = (submerged_weight(fl, sec.mass, case.gravity.g)
                                 if fl is not None else self.weight)
        afloat = floating_problems(p, q, length, self.submerged_weight, sec.EA, gdir, fl)
        if afloat:
            raise CaseError(afloat, case.source)
        try:
            shape = catenary.catenary_between(p, q, length, self.weight, sec.EA, gdir)
            if getattr(case, "seabed", None) is not None:
                shape = self._grounded(shape, p, q, length, gdir)
            self.catenary_shape = shape
            r0 = shape.position(g.stations)
            max_tension = float(np.max(shape.tension(g.stations)))
            self.force_scale = float(max(self.weight * length, max_tension))
        except ValueError as err:
            raise CaseError([("geometry", f"no static equilibrium of the bare cable: {err}")],
                            case.source) from None
        self._anchor_positions = (p, q)
        self.warnings += _plausibility(f"geometry.{geo.kind}", length,
                                       float(np.linalg.norm(q - p)), max_tension, sec.EA)
        return g, r0

    def _grounded(self, shape, p, q, length, gdir):
        """The catenary with its grounded part when the free one dips below the seabed
        (:class:`cablefem.seabed.GroundedCatenary`), else ``shape``."""
        sb, up = self.case.seabed, -np.asarray(gdir, float) / np.linalg.norm(gdir)
        s = np.linspace(0.0, length, 201)
        if np.min(shape.position(s) @ up) >= sb.z:
            return shape
        anchor_first = float(p @ up) <= float(q @ up)
        a, f = (p, q) if anchor_first else (q, p)
        try:
            return GroundedCatenary(a, f, length, self.submerged_weight, up, anchor_first,
                                    self.case.section.EA)
        except ValueError as err:
            self.warnings.append(("seabed", f"statics starts from the free catenary ({err})"))
            return shape

    def anchor_span(self, name: str) -> float:
        """The length clamped anchor ``name``'s layer is measured against (its validity
        ``ell/l``, its error estimate): the cable's stress-free length, m (a network's:
        the anchor's chain of elements, :meth:`cablefem.network.NetworkModel.anchor_span`)."""
        return float(self.length)

    def _locate_node(self, k: int) -> np.ndarray:
        """Local vertex indices (0 or 1 of them) of reference node ``k``."""
        return np.nonzero(self._vertex_nodes() == k)[0].astype(np.int32)

    def _vertex_nodes(self) -> np.ndarray:
        """The reference node of every local vertex (owned, then ghosts), from the cells:
        each local cell's two vertices are matched to its reference cell's two nodes by
        position (distinct within a cell). Nodes at one point on different cells (a clamp
        split into its sides, :func:`cablefem.network.split_clamps`) stay apart."""
        if getattr(self, "_vertex_node", None) is None:
            imap = self.mesh.topology.index_map(0)
            n = imap.size_local + imap.num_ghosts
            verts = self.mesh.topology.connectivity(1, 0).array.reshape(-1, 2)
            # a vertex's "midpoint" is its position
            xyz = dmesh.compute_midpoints(self.mesh, 0, np.arange(n, dtype=np.int32))
            self._vertex_node = self._match_ends(xyz[verts], verts, n)
        return self._vertex_node

    def _dof_nodes(self, space) -> np.ndarray:
        """The reference node of every local dof block of the P1 ``space`` (owned, then
        ghosts), matched within each local cell like :meth:`_vertex_nodes`."""
        imap = space.dofmap.index_map
        n = imap.size_local + imap.num_ghosts
        dofs = np.asarray(space.dofmap.list.array, np.int64).reshape(-1, 2)
        return self._match_ends(space.tabulate_dof_coordinates()[dofs], dofs, n)

    def _match_ends(self, xyz: np.ndarray, items: np.ndarray, n: int) -> np.ndarray:
        """Reference nodes of ``n`` local items (vertices or dof blocks) given per local
        cell, ``items`` (cells, 2) at positions ``xyz`` (cells, 2, 3)."""
        out = np.full(n, -1, np.int64)
        ref = self._reference_cells()
        if ref.size:
            geo = self.geometry
            ends = np.asarray(geo.cells, np.int64)[ref]
            pts = np.asarray(geo.points, float)
            to = np.stack([np.linalg.norm(xyz - pts[ends[:, j]][:, None, :], axis=2)
                           for j in (0, 1)])  # (2, cells, 2): item's distance to each end
            first = to[0] <= to[1]
            scale = max(1.0, float(np.max(np.abs(pts))))
            if np.max(np.minimum(to[0], to[1])) > 1e-8 * scale:
                raise RuntimeError("could not map the mesh's nodes to the cable's nodes")
            out[items] = np.where(first, ends[:, [0]], ends[:, [1]])
        if np.any(out < 0):
            raise RuntimeError("a local node on no local cell")
        return out

    def _build_anchors(self) -> list[AnchorBC]:
        out = []
        imap = self.V.dofmap.index_map
        for spec, pos in zip(self.case.anchors, self._anchor_positions):
            k = self.geometry.anchor_nodes[spec.name]
            verts = self._locate_node(k)
            dofs = fem.locate_dofs_topological(self.V, 0, verts)
            owned = bool(np.any(dofs < imap.size_local))
            other = self._anchor_positions[1] if k == 0 else self._anchor_positions[0]
            direction = None
            if spec.kind == "clamped":
                direction = spec.direction
                if direction is None:
                    direction = (other - pos) / np.linalg.norm(other - pos)
                direction = np.asarray(direction, dtype=float)
                direction = direction / np.linalg.norm(direction)
            out.append(AnchorBC(spec.name, k, self.geometry.points[k].copy(), pos.copy(),
                                spec.kind, direction, spec.motion, dofs, owned,
                                self.case.section))
        nowners = [self.comm.allreduce(int(a.owned)) for a in out]
        if any(n != 1 for n in nowners):
            raise RuntimeError(f"anchor ownership is not unique across ranks: {nowners}")
        return out

    def _vertex_tags(self, node_tags: dict[int, int]):
        """Mesh tags of dimension 0: reference node -> tag (> 0; the node's local
        vertices)."""
        lookup = np.zeros(len(self.geometry.points), np.int32)
        for k, tag in node_tags.items():
            lookup[k] = tag
        vals = lookup[self._vertex_nodes()]
        ents = np.nonzero(vals)[0].astype(np.int32)
        return dmesh.meshtags(self.mesh, 0, ents, vals[ents])

    def _point_tags(self) -> None:
        """Vertex tags for point masses and point loads (one tag per loaded node).

        A node of two elements is reached by the interior facet measure :attr:`dS`; one of
        one element (a free end) or of three or more (a junction) is not, as no facet of
        two cells lies there: its point terms are integrated over one adjacent element
        against a nodal weight instead (:meth:`_nodal_weights`, :meth:`point_work`)."""
        self.damper_nodes = [self.geometry.node_at(s) for s in getattr(self, "damper_s", ())]
        nodes = sorted({k for item in list(self.case.point_masses) + list(self.case.point_loads)
                        for k in self._item_nodes(item)} | set(self.damper_nodes))
        self._node_tag = {k: i + 1 for i, k in enumerate(nodes)}
        # one measure for every interior-vertex term (a form takes one subdomain_data)
        tags = dict(self._node_tag)
        self._bend_tag = len(nodes) + 1  #: the tag of a network's bending vertices in dS
        tags.update({k: self._bend_tag for k in self._bending_nodes()})
        self.dS = ufl.Measure("dS", domain=self.mesh, subdomain_data=self._vertex_tags(tags))
        degree = np.bincount(np.asarray(self.geometry.cells).ravel(),
                             minlength=len(self.geometry.points))
        self._one_sided = [k for k in nodes if degree[k] != 2]
        if self._one_sided:
            self._nodal_weights()

    def bending_vertices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Where the span-bending term acts (docs/theory.md §6.1), whether it is on or not:
        the vertices (node before, node, node after), (n, 3), every interior node but the
        kinks' (:attr:`dS`'s tags); ``EI`` and the mean stress-free length of the two
        elements ``hbar`` at each (the outer string's: the mesh's)."""
        st = np.asarray(self.geometry.stations, float)
        k = np.array([i for i in range(1, len(st) - 1) if i not in self._node_tag], np.int64)
        v = np.column_stack([k - 1, k, k + 1]) if k.size else np.zeros((0, 3), np.int64)
        hbar = 0.5 * (st[k + 1] - st[k - 1]) if k.size else np.zeros(0)
        return v, np.full(k.size, float(self.case.section.EI)), hbar

    def _bending_nodes(self) -> list[int]:
        """The nodes a network's span bending acts at (:mod:`cablefem.network`); a single
        cable's span bending takes every interior facet of :attr:`dS` but the kinks."""
        return []

    def _nodal_weights(self) -> None:
        """For every loaded node of other than two elements (:attr:`_one_sided`): one of its
        elements, tagged with the node's tag in :attr:`dx_nodes`, and the weight
        :attr:`_delta` = (9 - 36 t + 30 t^2)/h on it, t the position along the element from
        the node (0) to its other end (1), h the element's length. Its integral against any
        polynomial of degree two in t is the polynomial's value at the node, so against the
        product of two linear fields (a load or an acceleration times a test function) it is
        the nodal value exactly: the weight is the node's Dirac delta for these products.

        The element is chosen on the global cell list (the same on every rank): free ends
        first, then junctions, each taking an element no other node has taken."""
        geo = self.geometry
        cells, pts = np.asarray(geo.cells), np.asarray(geo.points)
        degree = np.bincount(cells.ravel(), minlength=len(pts))
        taken: dict[int, int] = {}  # reference cell -> node
        for k in sorted(self._one_sided, key=lambda k: (degree[k], k)):
            free = [int(c) for c in np.nonzero(np.any(cells == k, axis=1))[0]
                    if int(c) not in taken]
            if not free:
                raise RuntimeError(f"node {k}: every element next to it carries another "
                                   "node's point terms")
            taken[free[0]] = k
        n_owned = self.mesh.topology.index_map(1).size_local  # owned: each counted once
        local = np.arange(n_owned, dtype=np.int32)
        idx = self._reference_cells()[:n_owned]
        with quiet_compiler():
            space = fem.VectorFunctionSpace(self.mesh, ("DG", 0), dim=3)
        X, D = fem.Function(space, name="node_position"), fem.Function(space, name="node_dir")
        inv_h = fem.Function(self.W, name="node_inv_h")
        ents, vals = [], []
        for i, c in zip(local, idx):
            k = taken.get(int(c))
            if k is None:
                continue
            a, b = cells[c]
            other = pts[b] if a == k else pts[a]
            d = other - pts[k]
            h = float(np.linalg.norm(d))
            X.x.array[3 * i:3 * i + 3] = pts[k]
            D.x.array[3 * i:3 * i + 3] = d / h ** 2
            inv_h.x.array[i] = 1.0 / h
            ents.append(i)
            vals.append(self._node_tag[k])
        order = np.argsort(ents)
        tags = dmesh.meshtags(self.mesh, 1, np.asarray(ents, np.int32)[order],
                              np.asarray(vals, np.int32)[order])
        self.dx_nodes = ufl.Measure("dx", domain=self.mesh, subdomain_data=tags)
        t = ufl.dot(ufl.SpatialCoordinate(self.mesh) - X, D)
        self._delta = (9.0 - 36.0 * t + 30.0 * t ** 2) * inv_h

    def _reference_cells(self) -> np.ndarray:
        """The reference cell (a row of ``geometry.cells``) of every local cell, owned then
        ghosts, matched by midpoints (the partitioner reorders the cells)."""
        if getattr(self, "_ref_cells", None) is not None:
            return self._ref_cells
        from scipy.spatial import cKDTree

        geo = self.geometry
        imap = self.mesh.topology.index_map(1)
        local = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
        pts, cells = np.asarray(geo.points), np.asarray(geo.cells)
        if not local.size:
            return np.zeros(0, np.int64)
        mid = dmesh.compute_midpoints(self.mesh, 1, local)
        dist, idx = cKDTree(0.5 * (pts[cells[:, 0]] + pts[cells[:, 1]])).query(mid)
        if dist.max() > 1e-8 * max(1.0, float(np.max(np.abs(pts)))):
            raise RuntimeError("could not map mesh cells to the reference cells")
        self._ref_cells = idx
        return idx

    def point_work(self, k: int, integrand):
        """The virtual work of a point term at reference node ``k`` (a loaded node):
        ``integrand(r)`` is the term's UFL scalar with ``r`` applied to every field in it
        (a restriction on the interior facet of a node of two elements, nothing on the
        element that carries the nodal weight of any other node)."""
        tag = self._node_tag[k]
        if k in self._one_sided:
            return integrand(lambda f: f) * self._delta * self.dx_nodes(tag)
        return integrand(lambda f: f("+")) * self.dS(tag)

    ramp_weight = False  #: statics ramps the weight with the extra loads (networks)

    def section_field(self, name: str, value):
        """UFL: ``value(section)`` of the cable's section, a Constant (a network's: a cell
        field, each cell its cable's section's, 0 on a damper's cells)."""
        return fem.Constant(self.mesh, PETSc.ScalarType(value(self.case.section)))

    def _coefficients(self) -> None:
        """Section coefficients of the forms: EA, m and c (stress-free length per mesh
        length, 1 for a single cable whose mesh is stress-free)."""
        sec = self.case.section
        self.m = fem.Constant(self.mesh, PETSc.ScalarType(sec.mass))
        if self.has_hinges():  # the hinges change the first elements: cell fields
            self.c = fem.Function(self.W, name="c")
            self.c.x.array[:] = 1.0
            self.EA = fem.Function(self.W, name="EA")
            self.EA.x.array[:] = sec.EA
        else:
            self.EA = fem.Constant(self.mesh, PETSc.ScalarType(sec.EA))
            self.c = fem.Constant(self.mesh, PETSc.ScalarType(1.0))

    def _hinge_fields(self) -> None:
        """The cell fields of the virtual hinges' layer law (:mod:`cablefem.hinge`,
        :func:`cablefem.forms.layer_law_tension`) in :attr:`law`, set to the elastic law
        of every cell; ``cos``: the cosine of the anchor angle in each cell of a hinge's
        region (``turn_dir``: the clamp direction, signed by the cell's orientation; zero
        elsewhere)."""
        from types import SimpleNamespace

        from cablefem.hinge import DCOS

        law = SimpleNamespace()
        for name in ("a", "b", "ka", "kb", "tf", "tc", "cos_ref", "tref", "qT", "qC"):
            setattr(law, name, fem.Function(self.W, name=f"law_{name}"))
            setattr(self, f"law_{name}" if name != "cos_ref" else "cos_ref",
                    getattr(law, name))
        law.a.x.array[:] = self.c.x.array
        law.ka.x.array[:] = self.c.x.array / self.EA.x.array
        law.kb.x.array[:] = law.ka.x.array
        law.dcos = DCOS
        with quiet_compiler():  # the element is JIT-compiled on first use
            space = fem.VectorFunctionSpace(self.mesh, ("DG", 0), dim=3)
        self.turn_dir = fem.Function(space, name="turn_dir")
        law.dir = self.turn_dir
        g = forms.stretch_vector(self.u, self.t0)
        law.cos = ufl.dot(self.turn_dir, g) / ufl.sqrt(ufl.dot(g, g))
        self.law = law

    def _damper_clearance(self, p, q, length, gdir) -> dict[float, float]:
        """The least length of the elements next to each damper's station (the rod node's
        offset is applied in full on elements at least :data:`cablefem.dampers.MESH_RATIO`
        layer lengths long): 1.1 times that, from the layer length at the elastic
        catenary's tension there (an estimate before statics); none at leading order, for
        the rod, or without a catenary."""
        case = self.case
        if not self.damper_s or not self.applies_damper_offsets():
            return {}
        from cablefem.dampers import MESH_RATIO

        sec = case.section
        try:
            shape = catenary.catenary_between(p, q, length, self.weight, sec.EA, gdir)
            T = np.asarray(shape.tension(np.asarray(self.damper_s, float)), float)
        except ValueError:
            return {}
        ok = T > 0
        ell = np.where(ok, np.sqrt(sec.EI / np.where(ok, T * (1 + T / sec.EA), 1.0)), 0.0)
        return {s: 1.1 * MESH_RATIO * float(e) for s, e in zip(self.damper_s, ell) if e > 0}

    def _item_nodes(self, item) -> list[int]:
        """Nodes of a point mass or point load (a single cable: the node at ``item.s``)."""
        return [self.geometry.node_at(item.s)]

    # ------------------------------------------------------------------ forms
    def build_forms(self) -> None:
        """Build the model's terms of the residual in :attr:`forms` (a
        :class:`cablefem.forms.CableForms`; users add theirs with ``model.forms.add``)."""
        u, v, a, du, t0, cc = self.u, self.v, self.a, self.du, self.t0, self.c
        T = T2 = g = None
        if self.law is not None:  # virtual hinges: their regions' law and offset
            T = forms.layer_law_tension(u, t0, self.law, self.tension_only)
            T2 = forms.layer_law_tension(u, t0, self.law, False)
            g = forms.layer_stretch_vector(u, t0, self.law, T2)  # the force's direction
        self._set_forms(
            F_int=forms.internal_work(u, du, t0, self.EA, self.tension_only, c=cc, T=T,
                                      g=g),
            F_weight=forms.load_work(self.m * self.gravity, du, c=cc),
            F_inertia=forms.inertia_work(self.m, a, du, c=cc),
            du_t=du, a_t=a, dx=ufl.dx,
            # the same with compression allowed: statics uses it to get off a guess on
            # which every element is slack (zero tangent stiffness under tension only)
            bilateral=forms.internal_work(u, du, t0, self.EA, False, c=cc, T=T2, g=g))
        self.forms.outputs = {
            "tension": T if T is not None else forms.tension(u, t0, self.EA,
                                                              self.tension_only, cc),
            "strain": forms.axial_strain(u, t0, cc)}
        if getattr(self.case, "fluid", None) is not None:  # water or wind (Morison)
            add_fluid_terms(self)
        if getattr(self.case, "seabed", None) is not None:
            add_seabed_terms(self, self.submerged_weight)
        strain = forms.strain_energy_density(u, t0, self.EA, self.tension_only, cc) * ufl.dx
        if is_on(self.case.solver.span_bending):
            strain = strain + self._add_span_bending()
        self.forms.energies = (
            0.5 * ufl.inner(v, v) * cc * self.m * ufl.dx, strain,
            -ufl.inner(cc * self.m * self.gravity, u) * ufl.dx)

    def _add_span_bending(self):
        """``solver.span_bending``: the span's own EI (``docs/theory.md`` §6.1) as the terms
        ``span_bending`` (a bending energy on the turning angle at every interior vertex)
        and ``end_moments`` (at each clamped anchor the moment ``EI κ_s`` of the outer
        curvature, handed over by the layer; the clamp's rotation stays with the layer).
        Returns the bending energy (a form)."""
        self.EI = fem.Constant(self.mesh, PETSc.ScalarType(self.case.section.EI))
        # the curvature per stress-free length of the *outer* string: the mesh's (a single
        # cable's mesh is stress-free), not the hinge region's c < 1, which holds the
        # layer's removed length (theory.md §6.1; with c the region was 1/(1 - sigma_h/K)
        # too stiff in bending). Not at a kink (a point load, point mass or damper: the
        # nodes tagged in dS): its turn belongs to the kink's own layer (cablefem.kinks),
        # as a clamp's to the clamp's; the span's moment is handed over on both sides.
        kinks = sorted(set(self._node_tag.values()))
        self.forms.add("span_bending", forms.span_bending_work(
            self.u, self.du, self.t0, self.EI, self.mesh, self.dS, c=1.0, skip=kinks),
            kind="static")
        T = self.forms.outputs["tension"]
        q = -(self.m * self.gravity + sum((f for f, _ in self.loads), 0.0 * self.gravity))
        clamped = [(i + 1, anc) for i, anc in enumerate(self.anchors) if anc.kind == "clamped"]
        work = []
        if clamped:
            ds = ufl.Measure("ds", domain=self.mesh, subdomain_data=self._vertex_tags(
                {anc.node: tag for tag, anc in clamped}))
            work += [forms.end_moment_work(
                self.u, self.du, self.t0, self.EI, T, q,
                fem.Constant(self.mesh, np.asarray(anc.direction, dtype=PETSc.ScalarType)),
                ds(tag)) for tag, anc in clamped]
        if kinks:
            density = forms.end_moment_density(self.u, self.du, self.t0, self.EI, T, q,
                                               self._away_from_kinks())
            work += [density(side) * self.dS(tag) for tag in kinks for side in ("+", "-")]
        if work:
            self.forms.add("end_moments", sum(work[1:], work[0]), kind="static")
        return forms.span_bending_form(self.u, self.t0, self.EI, self.mesh, self.dS, c=1.0,
                                       skip=kinks)

    def _away_from_kinks(self):
        """A cell field (DG0, 3): on each element next to a kink node (a node tagged in
        :attr:`dS`), the unit direction from that node into the element (the side's
        'clamp direction' of the span's moment handed over there); zero elsewhere. An
        element between two kink nodes takes the second's (such kinks' layers overlap:
        their rows are invalid, cablefem.kinks)."""
        geo = self.geometry
        pts, cells = np.asarray(geo.points), np.asarray(geo.cells)
        with quiet_compiler():
            space = fem.VectorFunctionSpace(self.mesh, ("DG", 0), dim=3)
        away = fem.Function(space, name="away_from_kink")
        for i, c in enumerate(self._reference_cells()):  # owned and ghost cells alike
            a, b = cells[c]
            for k, other in ((a, b), (b, a)):
                if int(k) in self._node_tag:
                    d = pts[other] - pts[k]
                    away.x.array[3 * i:3 * i + 3] = d / np.linalg.norm(d)
        return away

    def _axial_damping_work(self):
        """The "axial" damping model's virtual work (strain-rate damping along the axis)."""
        return forms.axial_damping_work(self.u, self.v, self.du, self.t0, self.EA,
                                         self.beta, c=self.c)

    def _set_forms(self, F_int, F_weight, F_inertia, du_t, a_t, dx, bilateral=None,
                   u_t=None, v_t=None, us_t=None) -> None:
        """What the string and the rod share: the extra loads (ramped by statics through
        ``load_factor``), point masses and damping; creates :attr:`forms` with the model's
        terms.

        ``F_int``, ``F_weight``, ``F_inertia``: the model's internal work, own weight and
        distributed inertia; ``du_t``, ``a_t``: the translational parts of the test function
        and the acceleration; ``dx``: the cell measure of distributed loads; ``bilateral``:
        the internal work with compression allowed (default ``F_int``); ``u_t``, ``v_t``,
        ``us_t``: the translational parts of displacement, velocity and static displacement
        (default: the fields themselves, a string's)."""
        u, v, a, dw = self.u, self.v, self.a, self.dw
        case, cc = self.case, self.c
        extra = [forms.load_work(q, du_t, dx=dx, c=cc) for q, _ in self.loads]
        extra += [self.point_work(k, lambda r, pm=pm: pm.mass * ufl.inner(self.gravity,
                                                                          r(du_t)))
                  for pm in case.point_masses for k in sorted(set(self._item_nodes(pm)))]
        extra += [self.point_work(k, lambda r, q=q: ufl.inner(q, r(du_t)))
                  for q, pl in self.point_loads for k in sorted(set(self._item_nodes(pl)))]
        F_ext = F_weight
        if self.ramp_weight:  # networks: statics ramps the weight too (from the pretension)
            F_ext = self.load_factor * sum(extra, F_weight)
        elif extra:
            F_ext = F_weight + self.load_factor * sum(extra[1:], extra[0])

        for pm in case.point_masses:
            for k in sorted(set(self._item_nodes(pm))):
                F_inertia = F_inertia + self.point_work(
                    k, lambda r, pm=pm: pm.mass * ufl.inner(r(a_t), r(du_t)))

        damp = case.damping
        # Constants, not floats: one compiled form serves every value (FFCx caches by code)
        self.alpha = fem.Constant(self.mesh, PETSc.ScalarType(damp.alpha))
        self.beta = fem.Constant(self.mesh, PETSc.ScalarType(damp.beta))
        F_damp = None
        if damp.model in ("rayleigh", "rayleigh_k0") and (damp.alpha > 0 or damp.beta > 0):
            F_damp = self.alpha * ufl.replace(F_inertia, {a: v})
            if damp.beta > 0 and damp.model == "rayleigh":
                # beta K_t(u) v = beta d/dt f_int(u): the current tangent, which turns with
                # the cable (its Jacobian in u, a second derivative of F_int, is derived)
                # (derivatives applied now: v must appear explicitly, or the Jacobian's
                # derivative in v does not see through the nested Gateaux derivative)
                F_damp = F_damp + self.beta * expand_derivatives(ufl.derivative(F_int, u, v))
            elif damp.beta > 0:  # rayleigh_k0: the tangent at the static state
                K0 = ufl.derivative(ufl.replace(F_int, {u: self.u_static}), self.u_static, dw)
                F_damp = F_damp + self.beta * ufl.action(K0, v)
        elif damp.model == "axial" and damp.beta > 0:
            F_damp = self._axial_damping_work()

        self.forms = forms.CableForms(u, v, a, self.du, dw, self.shift_v, self.shift_a,
                                      self.W.element.interpolation_points())
        self.forms.set_model_terms(F_int, F_ext, F_inertia, F_damp, bilateral)
        if case.dampers:  # dynamic terms on the motion from the static state
            parts = (u, v, self.u_static) if u_t is None else (u_t, v_t, us_t)
            self.forms.add("dampers", self._damper_work(*parts, du_t), kind="dynamic")

    def _damper_work(self, u_t, v_t, us_t, du_t):
        """The dampers' virtual work (:func:`cablefem.dampers.damper_work`: each at its
        node, from the ground)."""
        return damper_work(self.mesh, self.case.dampers,
                           [self._node_tag[k] for k in self.damper_nodes],
                           u_t, v_t, us_t, du_t, self.t0, self.dS, ell=self._kink_layer(us_t))

    #: the string's dampers act at the rod's node, inside the string's corner (the kinks'
    #: first-order correction, with the hinges' ``solver.outer_correction = "hinge"``);
    #: the rod resolves its layers
    kink_offsets = True

    def applies_damper_offsets(self) -> bool:
        """Whether the dampers act at the rod's node (:attr:`kink_offsets` and the
        first-order route; a network's dampers do not, cablefem.network)."""
        return self.kink_offsets and self.case.solver.outer_correction == "hinge"

    def _kink_layer(self, us_t):
        """The kink layer's length at a damper's node from the static state (UFL on
        :attr:`dS`, :func:`cablefem.dampers.layer_length`), or None at leading order
        (``solver.outer_correction = "none"``) and for a model that resolves its layers
        (:attr:`kink_offsets` false: the rod)."""
        if not self.applies_damper_offsets():
            return None
        T = forms.tension(us_t, self.t0, self.EA, c=self.c)

        def mean(f):
            return 0.5 * (f("+") + f("-"))
        EA = mean(self.EA) if isinstance(self.EA, fem.Function) else self.EA
        EI = fem.Constant(self.mesh, PETSc.ScalarType(self.case.section.EI))
        h = ufl.CellVolume(self.mesh)  # the elements' stress-free lengths (the mesh's)
        return layer_length(mean(T), EA, EI, ufl.min_value(h("+"), h("-")))

    def compile(self) -> None:
        """Derive every residual, Jacobian and mass form from the terms of :attr:`forms`
        and JIT-compile them (FFCx caches them: later runs take milliseconds).

        The C compiler's messages (setuptools logs them through the root logger) are kept
        off the console meanwhile (:func:`cablefem.jit.quiet_compiler`)."""
        self.forms.compile()
        with quiet_compiler():
            self._compile()

    def _compile(self) -> None:
        """What a model compiles beyond :attr:`forms` (nothing for the string)."""


    # ------------------------------------------------------------------ time
    def set_time(self, t: float) -> None:
        """Set prescribed anchor displacements, time-dependent loads and every term's time
        law (:meth:`cablefem.forms.CableForms.set_time`) to time ``t``."""
        if t == getattr(self, "_time", None):
            return
        self._time = t
        arr = self.u_bc.x.array
        fixed_done = getattr(self, "_fixed_written", False)
        for anc in self.anchors:
            # an anchor without motion is written once (again after invalidate_time)
            if anc.dofs.size and not (fixed_done and anc.motion is None):
                arr[anc.flat_dofs] = anc.prescribed("displacement", t)
        self._fixed_written = True
        for c, ld in self.loads:
            c.value[:] = np.asarray(ld.value) * ld.time.value(t)
        for c, pl in self.point_loads:
            c.value[:] = np.asarray(pl.value) * pl.time.value(t)
        self.forms.set_time(t)  # every term's time law (the fluid's: waves, gusts)

    def invalidate_time(self) -> None:
        """Make the next :meth:`set_time` write everything again (the hinges changed)."""
        self._time = None
        self._fixed_written = False

    # ------------------------------------------------------------------ fields
    def output_fields(self) -> list[fem.Function]:
        """The fields of ``string.xdmf`` at the current state (the same Function objects at
        every call): displacement, velocity, tension, strain."""
        if not hasattr(self, "_out"):
            self._out = [self.u, self.v, fem.Function(self.W, name="tension"),
                         fem.Function(self.W, name="strain")]
        self._out[2].interpolate(self.tension_expr)
        self._out[3].interpolate(self.strain_expr)
        return self._out

    def displacement_part(self, f: fem.Function, name: str) -> fem.Function:
        """The displacement components of a function of the model's space (a string's
        functions are nothing else)."""
        g = fem.Function(self.V, name=name)
        g.x.array[:] = f.x.array
        return g

    def tension_field(self, name: str = "tension") -> fem.Function:
        f = fem.Function(self.W, name=name)
        f.interpolate(self.tension_expr)
        return f

    def strain_field(self, name: str = "strain") -> fem.Function:
        f = fem.Function(self.W, name=name)
        f.interpolate(self.strain_expr)
        return f

    def slack_elements(self) -> int:
        """Number of elements that carry no tension (strain <= 0), over all ranks."""
        e = self.strain_field()
        n_owned = self.mesh.topology.index_map(1).size_local
        slack = (e.x.array[:n_owned] <= 0.0) & self.cable_cells()
        return self.comm.allreduce(int(np.count_nonzero(slack)))

    def residual_floor(self, displaced: bool = False) -> float:
        """The round-off floor of the residual's norm (N): the tension ``EA (λ/c − 1)`` is
        computed from a stretch known to the machine precision ε, so each nodal force
        carries a round-off of about ε EA, and the norm over the N unknowns ε EA_max
        sqrt(N). Newton cannot go below it: its absolute tolerances stay 10 times above (a
        stiff cable, EA/T = 1e4, moving by millimetres stalled at it, and its time steps
        were cut over and over).

        ``displaced`` (statics): the stretch's gradient is assembled as ``Σ u_i ∇φ_i``,
        each product rounded on its own, so its round-off grows to ε |u|/h with the
        displacement ``|u|`` from the reference (a sagging cable's sag from the straight
        stress-free line: 100 m over 5 m elements, 20 times ε) where the guess is far from
        it: the floor times max(1, |u|/h_min), ``|u|`` the larger of the current
        displacement and the statics' guess (a mooring line's statics on 2 ranks failed
        at its catenary guess 3 times above 10 ε EA sqrt(N)). Dynamics keeps the plain
        floor: its Newton, started from converged states, gets below it, and the looser
        tolerance let an irregular sea's mooring line drift into a failed step."""
        EA = self.EA.x.array if isinstance(self.EA, fem.Function) else \
            np.atleast_1d(self.EA.value)
        EA_max = self.comm.allreduce(float(np.max(np.abs(EA), initial=0.0)), op=MPI.MAX)
        n = self.bs * self.V.dofmap.index_map.size_global
        floor = float(np.finfo(float).eps * EA_max * np.sqrt(n))
        if not displaced:
            return floor
        u = self.u.x.array.reshape(-1, self.bs)[:, :3]
        size = float(np.max(np.linalg.norm(u, axis=1), initial=0.0))
        size = self.comm.allreduce(size, op=MPI.MAX)
        size = max(size, float(np.max(np.linalg.norm(self.initial_guess()[:, :3], axis=1),
                                      initial=0.0)))
        return floor * max(1.0, size / self.min_element_length())

    def min_element_length(self) -> float:
        """The shortest element's mesh length (m)."""
        pts, cells = self.geometry.points, np.asarray(self.geometry.cells)
        return float(np.min(np.linalg.norm(pts[cells[:, 1]] - pts[cells[:, 0]], axis=1)))

    def cable_cells(self) -> np.ndarray:
        """Which owned cells are a cable's (all of them; a network's dampers' are not)."""
        return np.ones(self.mesh.topology.index_map(1).size_local, dtype=bool)

    def energies(self) -> dict[str, float]:
        """Kinetic, strain and gravity potential energy (J), summed over ranks."""
        vals = [self.comm.allreduce(fem.assemble_scalar(f), op=MPI.SUM)
                for f in self.energy_forms]
        return {"kinetic": vals[0], "strain": vals[1], "gravity": vals[2]}

    # ------------------------------------------------------------------ nodal gather
    def _nodal_map(self) -> None:
        """Owned dof block -> node index in station order (for gathering to rank 0)."""
        self._owned_nodes = self._dof_nodes(self.V)[:self.V.dofmap.index_map.size_local]

    def gather_nodal(self, f: fem.Function, root: int = 0) -> np.ndarray | None:
        """Values of a P1 vector function of the model's space at the nodes in station
        order, (n, 3) (the displacement part for a beam), on ``root`` only
        (:meth:`gather_all` gives every component)."""
        full = self.gather_all(f, root)
        return None if full is None else full[:, :3]

    def gather_all(self, f: fem.Function, root: int = 0) -> np.ndarray | None:
        """Every component of ``f`` at the nodes in station order, (n, bs), on ``root``."""
        bs = self.bs
        n_owned = self.V.dofmap.index_map.size_local
        local = f.x.array[: bs * n_owned].reshape(-1, bs)
        parts = self.comm.gather((self._owned_nodes, local.copy()), root=root)
        if self.comm.rank != root:
            return None
        out = np.full((len(self.geometry.stations), bs), np.nan)
        for idx, vals in parts:
            out[idx] = vals
        return out

    def scatter_nodal(self, values: np.ndarray, f: fem.Function) -> None:
        """Set a P1 vector function from nodal values (n, bs) in station order (given on
        all ranks)."""
        n_owned = self.V.dofmap.index_map.size_local
        values = np.asarray(values)
        if values.shape[1] != self.bs:
            raise ValueError(f"nodal values have {values.shape[1]} components, the model "
                             f"{self.bs}")
        f.x.array[: self.bs * n_owned] = values[self._owned_nodes].reshape(-1)
        f.x.scatter_forward()

    def dimensionless_groups(self) -> dict:
        from cablefem.properties import dimensionless_groups

        return dimensionless_groups(self.case.section, self.length, self.case.gravity.g)


def _forwarded(name: str) -> property:
    """``model.<name>``: the form of ``model.forms`` (derived from its terms, read-only)."""

    def get(self):
        return getattr(self.forms, name)

    def refuse(self, value):
        raise AttributeError(f"model.{name} is derived from the terms of model.forms: add a "
                             "term with model.forms.add(name, form, kind) (docs/extending.md)")

    return property(get, refuse, doc=f"``{name}`` of :attr:`CableModel.forms` (read-only).")


for _name in forms.COMPILED + ("F_static", "J_static", "F_static_bilateral",
                               "J_static_bilateral", "F_dynamic", "J_dynamic", "M_form"):
    setattr(CableModel, _name, _forwarded(_name))
for _name, _term in (("F_internal", "internal"), ("F_external", "external"),
                     ("F_inertia", "inertia"), ("F_damping", "damping")):
    setattr(CableModel, _name, _forwarded(_term))
