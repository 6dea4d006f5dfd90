"""Unit labels for logs, figures and reports, from the case's ``units`` key.

A case is either in SI units (m, N, s, kg) or dimensionless in the paper's scaling: lengths
in units of the stress-free length ``l``, forces in ``w l`` (``w = m g``, the weight per
length), moments in ``w l^2`` and times in ``sqrt(l/g)``. The numbers are the same either
way; only what they are called changes.
"""

from __future__ import annotations

__all__ = ["SYSTEMS", "unit"]

#: quantity -> label, per unit system
SYSTEMS: dict[str, dict[str, str]] = {
    "SI": {"length": "m", "force": "N", "moment": "N m", "time": "s",
           "omega": "rad/s", "frequency": "Hz", "stress": "Pa"},
    "dimensionless": {"length": "l", "force": "w l", "moment": "w l^2",
                      "time": "sqrt(l/g)", "omega": "1/sqrt(l/g)",
                      "frequency": "1/sqrt(l/g)", "stress": "w/l"},
}


def unit(system: str | None, quantity: str) -> str:
    """The label of ``quantity`` ('length', 'force', 'moment', 'time', 'omega',
    'frequency', 'stress') in ``system`` ('SI' when None)."""
    return SYSTEMS[system or "SI"][quantity]
