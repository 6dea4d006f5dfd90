"""The exceptions of cablefem: one hierarchy, so that a script can catch them all.

::

    CableFemError
    ├── InputError (also a ValueError): what the user gave cannot be used; ``.problems``
    │   ├── CaseError        a case file or a case built in Python
    │   └── MeshError        a network's mesh file
    ├── OutdirError (also a ValueError): the output folder cannot be used
    ├── SolveError (also a RuntimeError): a solve failed; the message says where and why
    │   ├── StaticError      no static equilibrium
    │   ├── DynamicsError    the time integration cannot go on (``.time``)
    │   └── HingeError       the first-order outer correction cannot be placed or followed
    ├── Interrupted: a run asked to stop (a signal) (``.time``, ``.signal``)
    ├── OutputError (also a RuntimeError): an output cannot be written or resumed
    └── RunError (also a RuntimeError): a run stopped before its end

The command line maps them to exit codes (``cablefem.app.cli``): input errors 2, the rest 1.
"""

from __future__ import annotations

__all__ = ["CableFemError", "InputError", "CaseError", "MeshError", "OutdirError",
           "SolveError", "StaticError", "DynamicsError", "HingeError", "Interrupted",
           "OutputError", "RunError", "RunInterrupted"]


class CableFemError(Exception):
    """Base class of every error cablefem raises on purpose."""


class InputError(CableFemError, ValueError):
    """One or more problems in what the user gave.

    ``str()`` gives one line per problem: ``"<source>: <key>: <message>"``.

    Args:
        problems: ``(key path, message)`` pairs, e.g. ``("anchors[1].motion.omega", "must be >
            0 (rad/s)")``; kept as the attribute ``problems``.
        source: The case file (or ``'<dict>'``, or the CSV or mesh file concerned); kept as the
            attribute ``source``.
    """

    def __init__(self, problems: list[tuple[str, str]], source: str = "<dict>") -> None:
        self.problems = list(problems)
        self.source = source
        super().__init__(str(self))

    def __str__(self) -> str:
        return "\n".join(f"{self.source}: {k}: {m}" if k else f"{self.source}: {m}"
                         for k, m in self.problems)


class CaseError(InputError):
    """Problems in a case (a TOML file, a dict of its shape, or objects built in Python)."""


class MeshError(InputError):
    """A network's mesh file that cannot be used."""


class OutdirError(CableFemError, ValueError):
    """The output folder cannot be used (not a directory, not writable, in use)."""


class SolveError(CableFemError, RuntimeError):
    """A solve failed; the message says where and why."""


class StaticError(SolveError):
    """Static equilibrium could not be found."""


class DynamicsError(SolveError):
    """The time integration cannot continue; ``.time`` is the last time reached."""

    def __init__(self, message: str, time: float) -> None:
        super().__init__(message)
        self.time = time


class HingeError(SolveError):
    """The virtual hinge cannot be placed or followed (what and where are in the message)."""


class Interrupted(CableFemError):
    """A run was asked to stop; ``.time`` is the last completed time (None if unknown),
    ``.signal`` the signal's number (None if not a signal)."""

    def __init__(self, message: str, time: float | None = None,
                 signum: int | None = None) -> None:
        super().__init__(message)
        self.time = time
        self.signal = signum


class OutputError(CableFemError, RuntimeError):
    """An output cannot be written or resumed (e.g. frames of a run to resume are lost)."""


class RunError(CableFemError, RuntimeError):
    """A run stopped before its end; the files written so far are valid."""


class RunInterrupted(Interrupted):
    """A whole run stopped on a signal; ``.signal`` is its number. Resume with
    ``cablefem run --restart``."""

    def __init__(self, message: str, signum: int | None) -> None:
        super().__init__(message, None, signum)
