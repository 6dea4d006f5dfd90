"""Case files: a TOML description of one cable, validated into dataclasses.

Pure Python/NumPy: no dolfinx import, nothing expensive (only the CSV tables are read; the
catenary for ``horizontal_tension``/``sag_ratio`` geometry is solved elsewhere).
:func:`load_case` reads a TOML file, :func:`parse_case` a dict of the same shape (for cases
built in Python). Validation collects every problem before raising one :class:`CaseError`.
Every key, its type, default, unit and meaning is documented in :data:`CASE_KEYS`, which
:func:`format_case_reference` renders for the command line and the README. Key paths index
arrays of tables from 0: ``anchors[1].motion.omega`` is the second anchor's.
"""

from cablefem.case.checks import check_table_ends, startup_time
from cablefem.case.keys import (
                                  CASE_KEYS,
                                  NETWORK_KEYS,
                                  REQUIRED,
                                  KeyDoc,
                                  TableDoc,
                                  format_case_reference,
)
from cablefem.case.parse import load_case, parse_case
from cablefem.case.schema import (
                                  Anchor,
                                  BeamSpec,
                                  CableSpec,
                                  Case,
                                  Damping,
                                  DistributedLoad,
                                  DynamicsSpec,
                                  FatigueSpec,
                                  Geometry,
                                  Gravity,
                                  MeshSpec,
                                  ModalSpec,
                                  NetworkSpec,
                                  PointLoad,
                                  PointMass,
                                  SolverSpec,
                                  rayleigh_coefficients,
)
from cablefem.errors import CaseError

__all__ = [
    "CaseError", "CASE_KEYS", "KeyDoc", "TableDoc", "REQUIRED", "format_case_reference",
    "load_case", "parse_case", "rayleigh_coefficients", "Gravity", "Geometry", "MeshSpec",
    "Anchor", "DistributedLoad", "PointMass", "PointLoad", "Damping", "DynamicsSpec",
    "ModalSpec", "SolverSpec", "BeamSpec", "Case", "check_table_ends", "startup_time",
    "NETWORK_KEYS", "CableSpec", "FatigueSpec", "NetworkSpec",
]
