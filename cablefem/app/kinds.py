"""What a run does differently for each kind of model: a small registry keyed by the
model's kind (``"string"``: one cable, ``"network"``, ``"beam"``: the reference rod), so
that the stages ask the registry instead of branching on the model's flags."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ModelKind", "KINDS", "model_kind", "kind_of"]


@dataclass(frozen=True)
class ModelKind:
    """The run's behaviour for one kind of model."""

    name: str
    #: the model resolves the boundary layers itself (the rod): its moments are its own, no
    #: asymptotic error estimate, no outer correction, no span-bending report
    resolves_layers: bool
    #: the seabed's static report per cable group (cablefem.seabed.network_contact), not
    #: the single line's touchdown (cablefem.seabed.touchdown)
    seabed_per_group: bool
    #: where a damper acts when the model does not apply the rod node's offset
    damper_note: str | None
    #: where the moments of the figures come from
    moment_source: str


KINDS = {
    "string": ModelKind("string", False, False, None, "inner solution + string curvature"),
    "network": ModelKind("network", False, True,
                         "the network's dampers act at the string's node",
                         "inner solution + string curvature"),
    "beam": ModelKind("beam", True, False, None, "the rod's own moment (beam model)"),
}


def model_kind(model) -> str:
    """The kind of ``model``: ``"beam"``, ``"network"`` or ``"string"``."""
    if model.is_beam:
        return "beam"
    return "network" if model.is_network else "string"


def kind_of(model) -> ModelKind:
    """The registry's entry for ``model`` (:data:`KINDS`)."""
    return KINDS[model_kind(model)]
