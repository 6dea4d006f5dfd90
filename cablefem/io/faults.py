"""A test hook: ``CABLEFEM_KILL_AT=<point>:<n>`` makes the process SIGKILL itself the
``n``-th time it reaches ``<point>`` (default ``n = 1``), to test that a run killed at any
instant can be resumed. Points: ``step`` (after a time step's outputs), ``checkpoint``
(``checkpoint.npz`` written to its temporary file, not yet renamed), ``xml`` (a series'
XDMF file written whole to its temporary file, not yet renamed, or, at a checkpoint, its
new frames appended and its closing lines not yet), ``frame-string`` and
``frame-moments`` (in the middle of a frame of that series: one array written, the others
not). Unset (the normal case), it does nothing. The variable is read once, when this
module is imported (a run's process sets it before it starts): a call costs nothing then.
"""

from __future__ import annotations

import os
import signal

__all__ = ["kill_point"]

_counts: dict[str, int] = {}
_SPEC = os.environ.get("CABLEFEM_KILL_AT", "")


def kill_point(name: str) -> None:
    """SIGKILL this process if ``CABLEFEM_KILL_AT`` names this point and its count.

    Args:
        name: The point reached (one of the module docstring's).
    """
    if not _SPEC:
        return
    where, _, n = _SPEC.partition(":")
    if where != name:
        return
    _counts[name] = _counts.get(name, 0) + 1
    if _counts[name] == int(n or 1):
        os.kill(os.getpid(), signal.SIGKILL)
