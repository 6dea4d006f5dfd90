"""A cable model: a line discretisation, the string's terms and its anchors.

:class:`CableModel` turns a :class:`cablefem.description.CableDescription` (built by
:func:`cablefem.create_cable`, or a :class:`cablefem.case.Case`) into dolfinx objects and
keeps them in the open: ``model.mesh``, ``model.V``, the unknowns ``model.u``, ``model.v``,
``model.a``, the boundary conditions ``model.bcs`` and the residual's terms ``model.forms``
(:class:`cablefem.forms.CableForms`), from which ``model.F_static``, ``model.F_dynamic``, their
Jacobians and the mass form are derived. A user adds a term with ``model.forms.add`` and
calls :meth:`CableModel.compile` again before solving (``docs/extending.md``).

The model *uses* a :class:`cablefem.line.LineDiscretisation` (``model.line``: mesh, spaces,
node maps, gather and scatter, point-term measures); its geometry comes from
:mod:`cablefem.cable_geometry`, its terms from :mod:`cablefem.string_terms`, its
plausibility warnings from :mod:`cablefem.plausibility`. What the solvers read of it is
declared in :class:`cablefem.contract.LineModel`.
"""

from __future__ import annotations

import logging
import time

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from cablefem import forms, string_terms
from cablefem.anchor import AnchorBC
from cablefem.cable_geometry import cable_geometry
from cablefem.chain import without_bending
from cablefem.contract import Builders
from cablefem.description import CableDescription
from cablefem.errors import CaseError
from cablefem.line import LineDiscretisation, anchor_bcs, cable_anchors
from cablefem.plausibility import MAX_PLAUSIBLE_STRAIN, PLAUSIBLE_LENGTH_RATIO
from cablefem.water import wave_warnings

__all__ = ["CableModel", "AnchorBC", "MAX_PLAUSIBLE_STRAIN", "PLAUSIBLE_LENGTH_RATIO", "STRING",
           "string_anchors", "string_bcs"]

log = logging.getLogger(__name__)


def _phase(model, what: str) -> None:
    """Log a build phase of a large problem (rank 0), with the time so far."""
    if len(model.geometry.stations) >= model.LOG_PHASES_FROM:
        log.info("build: %s (%.1f s)", what, time.perf_counter() - model._t_build)


def string_anchors(model) -> list[AnchorBC]:
    """A single cable's two anchors (:func:`cablefem.line.cable_anchors`)."""
    return cable_anchors(model.line, model.case, model.anchor_positions)


def string_bcs(model) -> list:
    """Every anchor's Dirichlet condition on all its components (the string's)."""
    return anchor_bcs(model.u_bc, model.anchors)


#: what a single cable's string is built from (:class:`cablefem.contract.Builders`)
STRING = Builders(geometry=cable_geometry, coefficients=string_terms.string_coefficients,
                  anchors=string_anchors, bcs=string_bcs)


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

    :func:`cablefem.create_cable` checks its arguments and builds one. The class
    attributes below are the declared defaults of :class:`cablefem.contract.LineModel`
    (what the solvers read); a network or a rod sets its own.
    """

    #: from this many nodes on, the build logs each of its phases (a build of 1e5 elements
    #: takes seconds, of 1e6 about a minute on one core)
    LOG_PHASES_FROM = 100_000
    bs = 3  #: components per node
    is_beam = False
    is_network = False  #: a network of cables (cablefem.network)
    string_alone = False  #: section.EI = 0 (cablefem.chain): no layers, no moments
    hinges = None  #: the virtual hinges (cablefem.hinge), or None at leading order
    law = None  #: virtual hinges: the layer law's cell fields (string_terms.hinge_law_fields)
    #: statics' pre-solves (a callable yielding a label per stage: the rod's soft shear),
    #: or None; a model with stages is also checked for a buckled equilibrium
    static_stages = None
    static_options: dict = {}  #: PETSc options of statics over the defaults (the rod's)
    damper_s: tuple = ()  #: the stations of a single cable's dampers, m
    damper_nodes: tuple = ()  #: their nodes
    kink_gaps: tuple = ()  #: a network's kinks left without a moment (cablefem.kinks)
    ramp_weight = False  #: statics ramps the weight with the extra loads (networks)
    #: the string's dampers act at the rod's node, inside the string's corner (the kinks'
    #: first-order correction, with the hinges' ``solver.outer_correction = "hinge"``);
    #: the rod resolves its layers
    kink_offsets = True
    #: terms assembled outside UFL onto a few nodes' rows (a network's kink corners,
    #: cablefem.junctions): the solvers add their residual and Jacobian
    node_terms: tuple = ()
    #: the names of a network's kinks the corner term corrects, and (name, why) of those
    #: it leaves out (cablefem.junctions)
    corner_kinks: frozenset = frozenset()
    junction_gaps: tuple = ()
    #: a network's kinks' offsets at the static state (cablefem.junctions.junction_state)
    junction_offsets: dict = {}
    builders = STRING  #: what the model is built from (cablefem.contract.Builders)

    def __init__(self, comm: MPI.Comm, description: CableDescription, prefix: str = "cable_"):
        if not isinstance(comm, MPI.Comm) or not isinstance(description, CableDescription):
            raise TypeError(f"expected (comm, description), got ({type(comm).__name__}, "
                            f"{type(description).__name__})")
        #: section.EI = 0: the string alone (cablefem.chain): clamps pinned, no moments
        case, self.string_alone = without_bending(description)
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
        self.geometry, self.initial_shape = self.builders.geometry(self)
        self.length = self.geometry.length
        line = self.line = LineDiscretisation(comm, self.geometry, self.bs,
                                              lambda what: _phase(self, what))
        self.mesh, self.V, self.W = line.mesh, line.V, line.W
        # the line's gather, scatter and sizes, as the model's own
        self.gather_nodal, self.gather_all = line.gather_nodal, line.gather_all
        self.scatter_nodal, self.min_element_length = line.scatter_nodal, line.min_element_length
        self.u = fem.Function(self.V, name="displacement")
        self.v = fem.Function(self.V, name="velocity")
        self.a = fem.Function(self.V, name="acceleration")
        self.u_static = fem.Function(self.V, name="static_displacement")
        self.u_bc = fem.Function(self.V, name="prescribed_displacement")
        self.du = ufl.TestFunction(self.V)
        self.dw = ufl.TrialFunction(self.V)
        self.t0 = forms.reference_tangent(self.mesh)

        m = self.mesh
        self.builders.coefficients(self)
        self.law = None  # virtual hinges: the layer law's cell fields
        if self.has_hinges():
            string_terms.hinge_law_fields(self)
        self.gravity = fem.Constant(m, np.asarray(self.g_vec, dtype=PETSc.ScalarType))
        self.load_factor = fem.Constant(m, PETSc.ScalarType(1.0))
        self.shift_v = fem.Constant(m, PETSc.ScalarType(0.0))
        self.shift_a = fem.Constant(m, PETSc.ScalarType(0.0))
        self.loads = [(fem.Constant(m, np.asarray(ld.value, dtype=PETSc.ScalarType)), ld)
                      for ld in case.loads]
        self.point_loads = [(fem.Constant(m, np.asarray(pl.value, dtype=PETSc.ScalarType)), pl)
                            for pl in case.point_loads]

        self.anchors = self.builders.anchors(self)
        self.hinges = None
        if self.has_hinges():
            from cablefem.hinge import HingeError, VirtualHinges

            try:
                self.hinges = VirtualHinges(self)
            except HingeError as err:
                raise CaseError([("solver.outer_correction", str(err))],
                                case.source) from None
        self.bcs = self.builders.bcs(self)
        # point terms' nodes (point masses, point loads, dampers) and their measures
        self.damper_nodes = [self.geometry.node_at(s) for s in self.damper_s]
        line.tag_points({k for item in list(case.point_masses) + list(case.point_loads)
                         for k in self.item_nodes(item)} | set(self.damper_nodes),
                        self.bending_nodes)
        self.dS = line.dS  #: the interior facet measure, its nodes tagged (line.node_tag)
        _phase(self, "forms")
        self.build_forms()
        self.compile()
        _phase(self, "node map")
        line.map_nodes()
        self.set_time(0.0)
        _phase(self, "model ready")

    def has_hinges(self) -> bool:
        """True when the case asks for the first-order outer correction (virtual hinges at
        the clamped anchors, :mod:`cablefem.hinge`) and there is a clamped anchor."""
        return (self.case.solver.outer_correction == "hinge"
                and any(a.kind == "clamped" for a in self.case.anchors))

    def initial_guess(self) -> np.ndarray:
        """Nodal start of statics (n, bs): the elastic catenary through the anchors."""
        return self.initial_shape - self.geometry.points

    def anchor_junction_offset(self, name: str) -> float:
        """The rod node offsets the string leaves at the far end of anchor ``name``'s span
        (a network's junctions, :meth:`cablefem.network.NetworkModel.
        anchor_junction_offset`): none on a single cable, m."""
        return 0.0

    def anchor_span(self, name: str) -> float:
        """The length clamped anchor ``name``'s layer is measured against (its validity
        ``ell/l``, its error estimate): the cable's stress-free length, m (a network's:
        the anchor's chain of elements, :meth:`cablefem.network.NetworkModel.anchor_span`)."""
        return float(self.length)

    def item_nodes(self, item) -> list[int]:
        """Nodes of a point mass or point load (a single cable: the node at ``item.s``)."""
        return [self.geometry.node_at(item.s)]

    def bending_vertices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Where the span-bending term acts (docs/theory.md §6.1), whether it is on or not:
        the vertices (node before, node, node after), (n, 3), every interior node but the
        kinks' (:attr:`dS`'s tags); ``EI`` and the mean stress-free length of the two
        elements ``hbar`` at each (the outer string's: the mesh's)."""
        st = np.asarray(self.geometry.stations, float)
        tagged = self.line.node_tag
        k = np.array([i for i in range(1, len(st) - 1) if i not in tagged], np.int64)
        v = np.column_stack([k - 1, k, k + 1]) if k.size else np.zeros((0, 3), np.int64)
        hbar = 0.5 * (st[k + 1] - st[k - 1]) if k.size else np.zeros(0)
        return v, np.full(k.size, float(self.case.section.EI)), hbar

    def bending_nodes(self) -> list[int]:
        """The nodes a network's span bending acts at (:mod:`cablefem.network`); a single
        cable's span bending takes every interior facet of :attr:`dS` but the kinks."""
        return []

    def section_field(self, name: str, value):
        """UFL: ``value(section)`` of the cable's section, a Constant (a network's: a cell
        field, each cell its cable's section's, 0 on a damper's cells)."""
        return fem.Constant(self.mesh, PETSc.ScalarType(value(self.case.section)))

    # ------------------------------------------------------------------ forms
    def build_forms(self) -> None:
        """Build the model's terms of the residual in :attr:`forms` (a
        :class:`cablefem.forms.CableForms`; users add theirs with ``model.forms.add``):
        :func:`cablefem.string_terms.build_string_forms`."""
        string_terms.build_string_forms(self)

    def add_span_bending(self):
        """``solver.span_bending``'s terms (:func:`cablefem.string_terms.add_span_bending`);
        returns the bending energy."""
        return string_terms.add_span_bending(self)

    def damper_work(self, u_t, v_t, us_t, du_t):
        """The dampers' virtual work (:func:`cablefem.string_terms.string_damper_work`)."""
        return string_terms.string_damper_work(self, u_t, v_t, us_t, du_t)

    def applies_damper_offsets(self) -> bool:
        """Whether the dampers act at the rod's node (:attr:`kink_offsets` and the
        first-order route; a network's dampers do not, cablefem.network)."""
        return self.kink_offsets and self.case.solver.outer_correction == "hinge"

    def compile(self) -> None:
        """Derive every residual, Jacobian and mass form from the terms of :attr:`forms`
        and JIT-compile them (FFCx caches them: later runs take milliseconds).

        The C compiler's messages (setuptools logs them through the root logger) are kept
        off the console meanwhile (:func:`cablefem.jit.quiet_compiler`)."""
        self.forms.compile()

    def translational(self, f):
        """The displacement part of ``f`` (a function or test function of :attr:`V`): for
        the string, ``f`` itself (a rod's: its first three components)."""
        return f

    def translational_inner(self, a, b):
        """``(integrand, measure)`` of the L2 product of two translational fields over the
        cells, as the model integrates its mass (the string: ``a·b dx``)."""
        return ufl.inner(a, b), ufl.dx

    # ------------------------------------------------------------------ time
    def set_time(self, t: float) -> None:
        """Set prescribed anchor displacements, time-dependent loads and every term's time
        law (:meth:`cablefem.forms.CableForms.set_time`) to time ``t``."""
        if t == getattr(self, "_time", None):
            return
        self._time = t
        arr = self.u_bc.x.array
        if getattr(self, "_fixed_written", False) and all(
                getattr(a, k) is v for a, held in self._held for k, v in zip(_HELD, held)):
            # the moving anchors' rows: (position - reference + motion) + offset, the
            # operations of AnchorBC.prescribed with its fixed part kept from the last
            # invalidate_time, or from the last time an anchor was given another motion,
            # offset, position or dofs (checked above: the same objects)
            for rows, values in self._moving:
                arr[rows] = values(t)
        else:  # every anchor once (again after invalidate_time or such a change)
            for anc in self.anchors:
                if anc.dofs.size:
                    arr[anc.flat_dofs] = anc.prescribed("displacement", t)
            self._moving = [(anc.flat_dofs, _displacement_rows(anc)) for anc in self.anchors
                            if anc.dofs.size and anc.motion is not None]
            self._held = [(a, [getattr(a, k) for k in _HELD]) for a in self.anchors]
        self._fixed_written = True
        for c, ld in self.loads:
            c.value[:] = np.asarray(ld.value) * ld.time.value(t)
        for c, pl in self.point_loads:
            c.value[:] = np.asarray(pl.value) * pl.time.value(t)
        self.forms.set_time(t)  # every term's time law (the fluid's: waves, gusts)

    def invalidate_time(self) -> None:
        """Make the next :meth:`set_time` write everything again. :meth:`set_time` keeps
        the fixed anchors' rows and the moving ones' fixed parts; it writes them again by
        itself when an anchor is given another ``motion``, ``offset``, ``position``,
        ``reference`` or ``dofs`` (other objects), so call this after changing one of
        those arrays in place."""
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

    def cable_cells(self) -> np.ndarray:
        """Which owned cells are a cable's (all of them; a network's dampers' are not)."""
        return np.ones(self.mesh.topology.index_map(1).size_local, dtype=bool)

    def energies(self) -> dict[str, float]:
        """Kinetic, strain and gravity potential energy (J), summed over ranks."""
        vals = [self.comm.allreduce(fem.assemble_scalar(f), op=MPI.SUM)
                for f in self.energy_forms]
        return {"kinetic": vals[0], "strain": vals[1], "gravity": vals[2]}

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


for _name in forms.COMPILED + forms.ON_DEMAND + ("F_static", "J_static", "F_static_bilateral",
                               "J_static_bilateral", "F_dynamic", "J_dynamic", "M_form"):
    setattr(CableModel, _name, _forwarded(_name))
for _name, _term in (("F_internal", "internal"), ("F_external", "external"),
                     ("F_inertia", "inertia"), ("F_damping", "damping")):
    setattr(CableModel, _name, _forwarded(_term))


#: what set_time keeps an anchor's rows from (the same objects: else written again)
_HELD = ("motion", "offset", "position", "reference", "dofs")


def _displacement_rows(anc):
    """``t -> anc.prescribed("displacement", t)``, the same operations, with the anchor's
    fixed part ``position - reference`` computed once (a string's anchor; a rod's: the
    method itself)."""
    if anc.bs != 3:
        return lambda t: anc.prescribed("displacement", t)
    fixed, motion, offset = anc.position - anc.reference, anc.motion.displacement, anc.offset
    comps = anc._layout()[1]
    if np.array_equal(comps, np.arange(3)):  # one node, all three components: as they are
        return lambda t: (fixed + motion(t)) + offset
    return lambda t: ((fixed + motion(t)) + offset)[comps]

