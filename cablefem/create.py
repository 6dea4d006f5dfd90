"""Building models from Python objects: :func:`create_cable`, :func:`create_rod`,
:func:`create_network`, :func:`create_network_rod` (plain functions, ``comm`` first,
options keyword-only, as dolfinx's ``create_*``). Each checks its arguments into a
:class:`cablefem.description.CableDescription` (every problem in one
:class:`cablefem.errors.CaseError`, under the argument's name) and builds the model on it.
``docs/python-api.md`` shows them at work.
"""

from __future__ import annotations

import os
from typing import Any

from mpi4py import MPI

from cablefem.anchor import Anchor
from cablefem.arguments import describe_cable, describe_network
from cablefem.description import (
    BEAM_BOUNDS,
    BeamSpec,
    CableSpec,
    Damping,
    Gravity,
)
from cablefem.errors import CaseError
from cablefem.properties import Section
from cablefem.validation import number_problem

__all__ = ["create_cable", "create_rod", "create_network", "create_network_rod",
           "model_from_case"]


def create_cable(comm: MPI.Comm, anchors: list[Anchor], section: Section, *,
                 length: float | None = None, horizontal_tension: float | None = None,
                 sag_ratio: float | None = None, polyline: Any = None, elements: int = 30,
                 grading: float = 1.0, gravity: Gravity | None = None, loads=(),
                 point_masses=(), point_loads=(), damping: Damping | None = None,
                 tension_only: bool = True, outer_correction: str = "hinge",
                 span_bending: bool | str = False, petsc_options: dict | None = None,
                 petsc_options_prefix: str = "cable_", units: str = "SI",
                 name: str = "<python>", dampers=(), fluid=None):
    """The extensible string of one cable between two anchors
    (:class:`cablefem.cable.CableModel`), ready for :func:`cablefem.statics.solve_static`.

    Args:
        comm: MPI communicator; the mesh is partitioned over it (collective).
        anchors: The two :class:`cablefem.anchor.Anchor` (first at ``s = 0``).
        section: The cross-section (:class:`cablefem.properties.Section`).
        length, horizontal_tension, sag_ratio, polyline: Exactly one: the stress-free length l (m);
            the horizontal tension H (N) or the sag ratio (sag / span, -) of the elastic catenary
            through the anchors (needs gravity); or the stress-free points (n, 3) (m), whose ends
            are the anchors' default positions.
        elements, grading: Number of elements, and the mid-span / end element length ratio (>= 1).
        gravity: :class:`cablefem.description.Gravity`; default 9.81 m/s^2 along -z.
        loads, point_masses, point_loads: :class:`~cablefem.description.DistributedLoad` (N/m),
            :class:`~cablefem.description.PointMass` (kg at s m),
            :class:`~cablefem.description.PointLoad` (N at s m).
        damping: :class:`cablefem.description.Damping` (default none).
        dampers: :class:`cablefem.description.Damper` (external dashpots with springs, from the
            ground to the cable; they act on the motion from the static state, ``docs/dampers.md``).
        fluid: :class:`cablefem.description.Fluid`: water or air around the cable (Morison drag,
            added mass, buoyancy; ``docs/fluid.md``).
        tension_only: No compression (``T = EA max(strain, 0)``).
        outer_correction: 'hinge' (default: the first-order outer correction, :mod:`cablefem.hinge`)
            or 'none' (the paper's leading order, for comparison).
        span_bending: The span's own bending stiffness EI in the string (``docs/theory.md`` §6.1;
            the clamps' rotation stays with the boundary layer). ``"auto"`` is resolved by
            :func:`cablefem.run_case` (on where it would move a computed frequency by more than 0.5
            %, :mod:`cablefem.span_bending`); a model built here takes it as off.
        petsc_options, petsc_options_prefix: Options of the model's solvers (without the prefix) and
            the prefix.
        units: 'SI' or 'dimensionless': labels of the outputs only.
        name: Name of the cable in error messages.

    Raises:
        CaseError: Every problem of the arguments, each under the argument's name, e.g.
            ``("sag_ratio", "must be > 0 and <= 10, got -0.1")``; a static catenary that does not
            exist (``("horizontal_tension", ...)``).
    """
    from cablefem.cable import CableModel

    description = describe_cable(
        anchors, section, length=length, horizontal_tension=horizontal_tension,
        sag_ratio=sag_ratio, polyline=polyline, elements=elements, grading=grading,
        gravity=gravity, loads=loads, point_masses=point_masses, point_loads=point_loads,
        damping=damping, tension_only=tension_only, outer_correction=outer_correction,
        span_bending=span_bending, petsc_options=petsc_options, units=units, source=name,
        dampers=dampers, fluid=fluid)
    return _named(CableModel, comm, description, petsc_options_prefix)


def create_rod(comm: MPI.Comm, anchors: list[Anchor], section: Section, *,
               layer_elements: float = 8.0, growth: float = 1.1, span_elements: int = 100,
               shear_stiffness: float | None = None, refine: float = 1.0, **options):
    """The reference rod (:class:`cablefem.rod.BeamModel`, geometrically exact, bending
    stiffness everywhere) of the same cable as :func:`create_cable`.

    Args:
        comm: MPI communicator (collective).
        anchors: The two :class:`cablefem.anchor.Anchor` (first at ``s = 0``).
        section: The cross-section (:class:`cablefem.properties.Section`).
        layer_elements: Elements per layer length at a clamp.
        growth: Ratio of the lengths of neighbouring elements.
        span_elements: Elements are at most l / ``span_elements`` long.
        shear_stiffness: GA (N); default 1e5 times the largest tension.
        refine: Scales the mesh density (> 0).
        **options: The keyword arguments of :func:`create_cable`, but not ``polyline``;
            ``elements``, ``grading``, ``tension_only``, ``outer_correction`` and
            ``span_bending`` do not apply.

    Raises:
        CaseError: Every problem of the arguments, each under the argument's name.
    """
    from cablefem.rod import BeamModel

    prefix = options.pop("petsc_options_prefix", "cable_")
    source = options.pop("name", "<python>")
    beam = _beam_spec(layer_elements, growth, span_elements, shear_stiffness, refine, source)
    description = describe_cable(anchors, section, beam=beam, source=source, **options)
    return BeamModel(comm, description, prefix, refine=refine)


def _beam_spec(layer_elements, growth, span_elements, shear_stiffness, refine, source):
    """The rod's :class:`BeamSpec`, its values and ``refine`` checked (CaseError)."""
    beam = BeamSpec(layer_elements, growth, span_elements, shear_stiffness)
    problems = []
    for key, value in (("layer_elements", layer_elements), ("growth", growth),
                       ("span_elements", span_elements), ("shear_stiffness", shear_stiffness)):
        bounds, unit = BEAM_BOUNDS[key]
        if key == "span_elements" and not (isinstance(value, int) and value >= 1):
            problems.append((key, f"expected an integer >= 1, got {value!r}"))
        elif value is not None and number_problem(value, unit, **bounds):
            problems.append((key, number_problem(value, unit, **bounds)))
    if number_problem(refine, "", gt=0):
        problems.append(("refine", number_problem(refine, "", gt=0)))
    if problems:
        raise CaseError(problems, source)
    return beam


def create_network(comm: MPI.Comm, mesh_file: str | os.PathLike, sections: dict[str, Section],
                   anchors: list[Anchor], *, cables: list[CableSpec],
                   gravity: Gravity | None = None, loads=(), point_masses=(),
                   point_loads=(), damping: Damping | None = None, tension_only: bool = True,
                   outer_correction: str = "hinge", span_bending: bool | str = False,
                   petsc_options: dict | None = None, petsc_options_prefix: str = "cable_",
                   units: str = "SI", name: str = "<python>"):
    """A cable network from a tagged gmsh file (:class:`cablefem.network.NetworkModel`; tag
    convention in ``meshes/README.md``).

    Args:
        comm: MPI communicator (collective).
        mesh_file: The gmsh ``.msh`` file: the *pretensioned* geometry (m).
        sections: Section name -> :class:`cablefem.properties.Section`.
        anchors: :class:`cablefem.anchor.Anchor` whose names are 0D groups of the mesh (no position:
            every node of the group is anchored there).
        cables: :class:`cablefem.description.CableSpec` (1D group of the mesh, section name,
            pretension N) for every cable group of the mesh.
        gravity, loads, point_masses, point_loads, damping: As for :func:`create_cable`;
            point masses and point loads name 0D groups in ``s``.
        tension_only, petsc_options, petsc_options_prefix, units, name: As for
            :func:`create_cable`.
        outer_correction: ``"hinge"`` (default): a virtual hinge at every clamped anchor (a
            clamp a cable runs through: one per side, :func:`cablefem.network.split_clamps`);
            ``"none"``: the paper's leading order.
        span_bending: The bending energy at every node of two cable elements that holds no
            anchor or point term, the span's moment handed over at the others
            (:meth:`cablefem.network.NetworkModel.add_span_bending`).

    Returns:
        The :class:`cablefem.network.NetworkModel`, its mesh read from ``mesh_file``.

    Raises:
        CaseError: Every problem of the arguments, each under the argument's name.
    """
    from cablefem.network import NetworkModel

    description = describe_network(
        mesh_file, sections, anchors, cables=cables, gravity=gravity, loads=loads,
        point_masses=point_masses, point_loads=point_loads, damping=damping,
        tension_only=tension_only, outer_correction=outer_correction,
        span_bending=span_bending, petsc_options=petsc_options, units=units, source=name)
    return _named(NetworkModel, comm, description, petsc_options_prefix)


def create_network_rod(comm: MPI.Comm, mesh_file: str | os.PathLike,
                       sections: dict[str, Section], anchors: list[Anchor], *,
                       cables: list[CableSpec], layer_elements: float = 8.0,
                       growth: float = 1.1, span_elements: int = 100,
                       shear_stiffness: float | None = None, refine: float = 1.0, **options):
    """The reference rod of a network (:class:`cablefem.rod_network.NetworkRodModel`: each
    cable a geometrically exact rod, junctions pinned ties, the mesh graded towards clamps
    and junctions; ``docs/rod.md``).

    Args:
        comm, mesh_file, sections, anchors, cables: As for :func:`create_network`.
        layer_elements, growth, span_elements, shear_stiffness, refine: As for
            :func:`create_rod` (the grading also towards junctions and loaded nodes).
        **options: The keyword arguments of :func:`create_network` (``tension_only``,
            ``outer_correction`` and ``span_bending`` do not apply).

    Raises:
        CaseError: Every problem of the arguments, each under the argument's name.
    """
    from cablefem.rod_network import NetworkRodModel

    prefix = options.pop("petsc_options_prefix", "cable_")
    source = options.pop("name", "<python>")
    beam = _beam_spec(layer_elements, growth, span_elements, shear_stiffness, refine, source)
    description = describe_network(mesh_file, sections, anchors, cables=cables, beam=beam,
                                   source=source, **options)
    return NetworkRodModel(comm, description, prefix, refine=refine)


def _named(cls, comm, description, prefix):
    if not isinstance(prefix, str):
        raise CaseError([("petsc_options_prefix", f"expected a string, got {prefix!r}")],
                        description.source)
    return cls(comm, description, prefix)



def model_from_case(comm: MPI.Comm, case, *, model: str = "string", refine: float = 1.0):
    """The model of a case (a :class:`cablefem.case.Case`, itself a description) built as
    the string (:class:`cablefem.cable.CableModel`, a :class:`cablefem.network.NetworkModel`
    for a network) or, with ``model="beam"``, the reference rod
    (:class:`cablefem.rod.BeamModel`; a network's: :class:`cablefem.rod_network.
    NetworkRodModel`; mesh density scaled by ``refine``). Collective on
    ``comm``."""
    if model not in ("string", "beam"):
        raise ValueError(f"model must be 'string' or 'beam', got {model!r}")
    if model == "beam" and case.network is not None:
        from cablefem.rod_network import NetworkRodModel

        return NetworkRodModel(comm, case, refine=refine)
    if model == "beam":
        from cablefem.rod import BeamModel

        return BeamModel(comm, case, refine=refine)
    if case.network is not None:
        from cablefem.network import NetworkModel

        return NetworkModel(comm, case)
    from cablefem.cable import CableModel

    return CableModel(comm, case)
