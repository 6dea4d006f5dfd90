"""A single cable without bending stiffness (``section.EI = 0``: a chain, a wire rope
treated as a string): the string alone (docs/theory.md's outer solution), with no boundary
layer, no moment and nothing that needs ``EI``.

:func:`without_bending` turns such a description into the one the model solves: every
clamped anchor a pinned one (a string holds no tangent: without ``EI`` the layer's length
``sqrt(EI/T)`` and its moment are 0, a number that means "no moment", not a measured
one), the first-order outer correction and the span's bending off (both scale with
``EI``). Its statics and dynamics are those of the string with the same anchors
(the correction's virtual hinge sits at the clamp when the layer has no length). The
run reports the moments absent (empty CSV cells, no moment entries in ``summary.json``)
and says so (``summary.json`` ``bending``, the log). Networks and the rod
(``--model beam``) need ``EI > 0``.
"""

from __future__ import annotations

from dataclasses import replace

__all__ = ["NOTE", "without_bending"]

#: what the run logs and records (summary.json "bending")
NOTE = ("section.EI = 0: no bending stiffness, the string alone: no anchor or kink "
        "moments (absent, not 0), clamped anchors act as pinned, no boundary layer, "
        "virtual hinge or span bending")


def without_bending(description):
    """``(description, True)`` with the changes above when a single cable has
    ``section.EI == 0``, else ``(description, False)`` unchanged."""
    sec = getattr(description, "section", None)
    if getattr(description, "network", None) is not None or sec is None or sec.EI > 0:
        return description, False
    anchors = [replace(a, kind="pinned", direction=None) if a.kind == "clamped" else a
               for a in description.anchors]
    solver = replace(description.solver, outer_correction="none", span_bending=False)
    return replace(description, anchors=anchors, solver=solver), True
