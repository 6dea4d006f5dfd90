"""cablefem: bending moments at the anchors of vibrating cables.

The extensible string (outer solution) is solved with FEniCSx; the closed-form inner
solution of a matched asymptotic expansion gives the bending moment in the boundary layer at
every clamped anchor (``docs/theory.md``).

The public API is importable from here; the names load their modules on first use, so that
``import cablefem`` stays cheap (no dolfinx until a model is built).
"""

from __future__ import annotations

import importlib

from cablefem import startup

__version__ = "0.2.0.dev0"

startup.install()  # UFL's and FFCx's version lookups without pkg_resources' scan
startup.singleton_transport()  # one rank without mpirun: no network probing in MPI_Init

#: public name -> module that defines it (loaded on first access, PEP 562)
_API = {
    "CableFemError": "cablefem.errors", "InputError": "cablefem.errors",
    "CaseError": "cablefem.errors", "SolveError": "cablefem.errors",
    "load_case": "cablefem.case", "parse_case": "cablefem.case",
    "CableModel": "cablefem.cable", "NetworkModel": "cablefem.network",
    "BeamModel": "cablefem.rod", "NetworkRodModel": "cablefem.rod_network",
    "run_case": "cablefem.app.run",
    "model_from_case": "cablefem.create",
    # building models in Python (docs/python-api.md)
    "create_cable": "cablefem.create", "create_rod": "cablefem.create",
    "create_network": "cablefem.create", "create_network_rod": "cablefem.create",
    "Anchor": "cablefem.anchor",
    "Section": "cablefem.properties", "CableDescription": "cablefem.description",
    "describe_cable": "cablefem.arguments", "describe_network": "cablefem.arguments",
    "Gravity": "cablefem.description", "DistributedLoad": "cablefem.description",
    "PointMass": "cablefem.description", "PointLoad": "cablefem.description",
    "Damper": "cablefem.description", "DamperLink": "cablefem.description",
    "Fluid": "cablefem.description",
    "Seabed": "cablefem.description",
    "Profile": "cablefem.flow", "AiryWave": "cablefem.flow", "VelocitySeries": "cablefem.flow",
    "Damping": "cablefem.description", "CableSpec": "cablefem.description",
    "HarmonicMotion": "cablefem.motion", "EllipseMotion": "cablefem.motion",
    "TableMotion": "cablefem.motion", "TimeFunction": "cablefem.motion",
    "solve_static": "cablefem.statics",
    # a term of the residual through model.forms.add (docs/extending.md); what solvers read
    "Term": "cablefem.terms", "LineModel": "cablefem.contract",
    "LineDiscretisation": "cablefem.line",
    # the problems, each owning its PETSc objects under an options prefix
    "StaticProblem": "cablefem.statics", "ModalProblem": "cablefem.modal",
    "DynamicProblem": "cablefem.dynamics", "AnchorReactions": "cablefem.reactions",
}

__all__ = ["__version__", *_API]


def __getattr__(name: str):
    try:
        module = _API[name]
    except KeyError:
        raise AttributeError(f"module 'cablefem' has no attribute {name!r}") from None
    return getattr(importlib.import_module(module), name)


def __dir__():
    return sorted(__all__)
