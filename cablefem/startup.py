"""A lighter start: the FEniCSx Python packages of Debian's 0.5 stack (UFL 2022.2,
FFCx 0.5) read their own version with ``pkg_resources.get_distribution(...).version``
when they are imported, and importing ``pkg_resources`` scans every installed
distribution: about 0.1 s of CPU, a quarter of what importing dolfinx costs, in every
run, test and worker process.

:func:`install` puts a stand-in module under that name until both have read their
version: its ``get_distribution(name).version`` is ``importlib.metadata.version(name)``
(the same metadata), and anything else asked of it (another attribute of the module or of
a distribution, a distribution that metadata does not know) loads the real
``pkg_resources``, which then replaces the stand-in. Nothing is installed when
``pkg_resources``, UFL or FFCx is already imported.
"""

from __future__ import annotations

import importlib.metadata
import sys
import types

__all__ = ["install"]

#: the distributions whose version the stand-in serves before it leaves
_SERVES = frozenset({"fenics-ufl", "fenics-ffcx"})


def _real():
    """The real ``pkg_resources`` (imported now if the stand-in is in its place)."""
    if isinstance(sys.modules.get("pkg_resources"), _StandIn):
        del sys.modules["pkg_resources"]
    import pkg_resources
    return pkg_resources


class _Distribution:
    """A distribution's version from its metadata; anything else from the real one."""

    def __init__(self, name: str, version: str) -> None:
        self._name, self.version = name, version

    def __getattr__(self, attr):
        return getattr(_real().get_distribution(self._name), attr)


class _StandIn(types.ModuleType):
    def __init__(self) -> None:
        super().__init__("pkg_resources", "cablefem's stand-in until UFL and FFCx are in")
        self._served: set[str] = set()

    def get_distribution(self, name):
        try:
            version = importlib.metadata.version(name)
        except (importlib.metadata.PackageNotFoundError, TypeError):
            return _real().get_distribution(name)  # its own answer and its own error
        self._served.add(name)
        if self._served >= _SERVES and sys.modules.get("pkg_resources") is self:
            del sys.modules["pkg_resources"]  # both served: the next import is the real one
        return _Distribution(name, version)

    def __getattr__(self, attr):
        if attr.startswith("__") and attr.endswith("__"):
            raise AttributeError(attr)
        return getattr(_real(), attr)


def install() -> bool:
    """Put the stand-in in place; True when it is (see the module docs)."""
    if any(name in sys.modules for name in ("pkg_resources", "ufl", "ffcx")):
        return False
    sys.modules["pkg_resources"] = _StandIn()
    return True
