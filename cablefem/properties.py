"""Cable cross-section properties and the paper's dimensionless groups.

Pure Python: no dolfinx import. The symbols follow ``docs/theory.md`` §1: ``EA``, ``EI``,
``GJ`` are the axial, bending and torsional stiffnesses, ``m`` the mass per unit stress-free
length and ``w = m g`` the weight per unit stress-free length.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Section", "dimensionless_groups"]


@dataclass(frozen=True)
class Section:
    """Stiffness and mass of a cable cross-section.

    Args:
        EA (float): Axial stiffness (N), > 0.
        EI (float): Bending stiffness (N m^2), >= 0; 0 (a chain): the string alone, no moments
            (single cables only, :mod:`cablefem.chain`).
        GJ (float): Torsional stiffness (N m^2), >= 0. It does not enter the string or the inner
            solution (torsion decouples from bending, paper section 2); it is reported as ``gamma``.
        mass (float): Mass per unit stress-free length (kg/m), > 0.
        diameter (float or None): Outer diameter (m), > 0 if given; used for stresses.

    Raises:
        ValueError: If a value is not finite or out of range.
    """

    EA: float
    EI: float
    GJ: float
    mass: float
    diameter: float | None = None

    def __post_init__(self) -> None:
        limits = [("EA", self.EA, True, "N"), ("EI", self.EI, False, "N m^2"),
                  ("GJ", self.GJ, False, "N m^2"), ("mass", self.mass, True, "kg/m")]
        if self.diameter is not None:
            limits.append(("diameter", self.diameter, True, "m"))
        bad = []
        for name, value, strict, unit in limits:
            ok = math.isfinite(value) and (value > 0 if strict else value >= 0)
            if not ok:
                bad.append(f"{name} must be {'>' if strict else '>='} 0 ({unit}), got {value!r}")
        if bad:
            raise ValueError("; ".join(bad))

    def weight(self, g: float) -> float:
        """Weight per unit stress-free length ``w = m g`` (N/m) for gravity ``g`` (m/s^2)."""
        return self.mass * g


def dimensionless_groups(section: Section, length: float, g: float) -> dict[str, float | None]:
    """The paper's dimensionless groups of one cable (``docs/theory.md`` §1).

    Args:
        section (Section): The cable's section.
        length (float): Stress-free length ``l`` (m), > 0.
        g (float): Gravitational acceleration (m/s^2), >= 0.

    Returns:
        dict: ``eps = sqrt(EI/(w l^3))`` (-), ``eps_b = w l/EA`` (-), ``gamma = GJ/EI`` (-),
            ``time_unit = sqrt(l/g)`` (s), ``force_unit = w l`` (N), ``moment_unit = w l^2`` (N m).
            With ``g == 0`` every group that needs the weight is ``None`` (only ``gamma`` remains).

    Raises:
        ValueError: If ``length <= 0`` or ``g < 0`` (or either is not finite).
    """
    if not (math.isfinite(length) and length > 0):
        raise ValueError(f"length must be > 0 (m), got {length!r}")
    if not (math.isfinite(g) and g >= 0):
        raise ValueError(f"g must be >= 0 (m/s^2), got {g!r}")
    # EI = 0 (a chain): no torsion-to-bending ratio and eps = 0 (no layer)
    groups: dict[str, float | None] = {
        "gamma": section.GJ / section.EI if section.EI > 0 else None}
    if g == 0:
        groups.update(eps=None, eps_b=None, time_unit=None, force_unit=None, moment_unit=None)
        return groups
    w = section.weight(g)
    groups.update(
        eps=math.sqrt(section.EI / (w * length**3)),
        eps_b=w * length / section.EA,
        time_unit=math.sqrt(length / g),
        force_unit=w * length,
        moment_unit=w * length**2,
    )
    return groups
