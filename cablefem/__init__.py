"""cablefem: bending moments at the anchors of vibrating cables.

The extensible string (outer solution) is solved with FEniCSx; the closed-form inner
solution of a matched asymptotic expansion gives the bending moment in the boundary layer at
every clamped anchor (``docs/theory.md``).

The public API is importable from here; the names load their modules on first use, so that
``import cablefem`` stays cheap (no dolfinx until a model is built).
"""

from __future__ import annotations

import importlib

__version__ = "0.2.0.dev0"

#: public name -> module that defines it (loaded on first access, PEP 562)
_API = {
    "CableFemError": "cablefem.errors", "InputError": "cablefem.errors",
    "CaseError": "cablefem.errors", "SolveError": "cablefem.errors",
    "load_case": "cablefem.case", "parse_case": "cablefem.case",
    "CableModel": "cablefem.cable", "NetworkModel": "cablefem.network",
    "BeamModel": "cablefem.rod", "run_case": "cablefem.app.run",
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
