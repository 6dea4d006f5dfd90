"""The validated case: :class:`Case`, a :class:`cablefem.description.CableDescription` (the
model's parts, defined in the core: :mod:`cablefem.description`, :mod:`cablefem.anchor`,
:mod:`cablefem.properties`) plus the run settings defined here (dynamics, modal, fatigue)."""

from __future__ import annotations

from dataclasses import dataclass, field, fields, is_dataclass
from typing import Any

import numpy as np

from cablefem.anchor import Anchor
from cablefem.description import (
    BeamSpec,
    CableDescription,
    CableSpec,
    Damping,
    DistributedLoad,
    Geometry,
    Gravity,
    MeshSpec,
    NetworkSpec,
    PointLoad,
    PointMass,
    SolverSpec,
    rayleigh_coefficients,
)


@dataclass
class DynamicsSpec:
    """Time integration: end time and step (s), spectral radius, output stride.

    Attributes:
        t_end: End time (s).
        dt: Time step (s).
        rho_inf: Spectral radius at infinite frequency of the integrator, in [0, 1].
        output_every: Steps between rows of the time series.
        fields_every: Steps between frames of the fields.
        checkpoint_every: Steps between checkpoints (0: none).
        initial: The velocity at t = 0: "quasi-static" or "rest".
        statistics_start: Start of the statistics window (s), or None.
    """

    t_end: float
    dt: float
    rho_inf: float
    output_every: int
    fields_every: int = 20
    checkpoint_every: int = 500
    #: the velocity at t = 0: "quasi-static" or "rest" (cablefem.initial.initial_velocity)
    initial: str = "quasi-static"
    #: start of the statistics window, s (None: the last third of the run)
    statistics_start: float | None = None


@dataclass
class FatigueSpec:
    """S-N curve, section for stresses and window of the fatigue assessment.

    Attributes:
        detail_category, m1, m2, knee, N_C, N_knee, N_cutoff: The S-N curve
            (:class:`cablefem.fatigue.SNCurve`).
        area, modulus: Effective section [m^2, m^3], or None (the section's solid circle).
        window: "after_startup", "all" or "steady".
        fibres: Number of scanned directions.
        units: Name of the stress unit.
    """

    detail_category: float
    m1: float
    m2: float
    knee: bool
    N_C: float
    N_knee: float
    N_cutoff: float
    area: float | None
    modulus: float | None
    window: str
    fibres: int
    units: str


@dataclass
class ModalSpec:
    """Number of modes of the modal analysis.

    Attributes:
        modes: Number of modes, >= 0.
    """

    modes: int


@dataclass(kw_only=True)
class Case(CableDescription):
    """A validated case (see :data:`CASE_KEYS` for every field's meaning): the description
    of the cable or network (:class:`cablefem.description.CableDescription`, what a model is
    built from) plus the run settings.

    Attributes:
        title: Free text echoed in the outputs.
        dynamics: The time integration, or None (statics and modes only).
        modal: The modal analysis.
        fatigue: The fatigue assessment, or None.
        warnings: ``(key, message)`` pairs for input that is valid but suspicious.
    """

    title: str = ""
    dynamics: DynamicsSpec | None = None
    modal: ModalSpec = field(default_factory=lambda: ModalSpec(4))
    fatigue: FatigueSpec | None = None
    #: (key, message) pairs for input that is valid but suspicious; a run logs them and
    #: lists them under ``warnings`` in summary.json (``--strict`` makes them fatal)
    warnings: list = field(default_factory=list, compare=False)

    def to_dict(self) -> dict:
        """JSON-serialisable echo of the inputs (motions and time functions via describe())."""
        out = _jsonable(self)
        out.pop("warnings", None)  # reported under summary.json's own "warnings"
        return out


def _jsonable(obj: Any) -> Any:
    if hasattr(obj, "describe"):
        return obj.describe()
    if is_dataclass(obj):
        return {f.name: _jsonable(getattr(obj, f.name)) for f in fields(obj)}
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, (np.ndarray, np.generic)):
        return obj.tolist()
    return obj


__all__ = ["Case", "DynamicsSpec", "ModalSpec", "FatigueSpec", "Anchor", "BeamSpec",
           "CableDescription", "CableSpec", "Damping", "DistributedLoad", "Geometry", "Gravity",
           "MeshSpec", "NetworkSpec", "PointLoad", "PointMass", "SolverSpec",
           "rayleigh_coefficients"]
