"""A lighter start: the FEniCSx Python packages of Debian's 0.5 stack (UFL 2022.2,
FFCx 0.5) read their own version with ``pkg_resources.get_distribution(...).version``
when they are imported, and importing ``pkg_resources`` scans every installed
distribution: about 0.1 s of CPU, a quarter of what importing dolfinx costs, in every
run, test and worker process.

:func:`install` puts a stand-in module under that name until both have read their
version: its ``get_distribution(name).version`` is the ``Version`` line of the
distribution's ``METADATA`` (what ``importlib.metadata.version(name)`` reads, without
importing it), and anything else asked of it (another attribute of the module or of
a distribution, a distribution that metadata does not know) loads the real
``pkg_resources``, which then replaces the stand-in. Nothing is installed when
``pkg_resources``, UFL or FFCx is already imported.

:func:`singleton_transport`: a process started without ``mpirun`` (one rank, an MPI
"singleton") talks to no other process, yet Open MPI's default point-to-point layer (UCX)
probes the machine's network devices in ``MPI_Init``: 0.2 s of wall time in every
``cablefem`` command on the machines measured (docs/benchmarks.md). Such a process gets
Open MPI's own layer (``OMPI_MCA_pml=ob1``) unless the variable is set already; a process
of an ``mpirun`` job (``OMPI_COMM_WORLD_SIZE`` or a PMI/PMIx rank in its environment) is
left as it is, and so is one whose MPI is already initialised.
"""

from __future__ import annotations

import os
import re
import sys
import types

__all__ = ["install", "singleton_transport"]

#: environment variables that say the process is a rank of a launched MPI job
_LAUNCHED = ("OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE")

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
        version = _dist_info_version(name) if isinstance(name, str) else None
        if version is None:
            import importlib.metadata
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


def _dist_info_version(name: str) -> str | None:
    """``name``'s version from the ``Version`` line of its ``*.dist-info/METADATA``, in
    the first ``sys.path`` entry that holds metadata of that name (as
    ``importlib.metadata`` looks); None when that is no ``.dist-info`` folder with such a
    line (the caller asks ``importlib.metadata``). Importing ``importlib.metadata`` costs
    every command about 35 ms (its e-mail parser): half of ``cablefem --help``'s imports."""
    prefix = re.sub(r"[-_.]+", "_", name).lower() + "-"
    for entry in sys.path:
        try:
            found = [d for d in os.listdir(entry or ".") if d.lower().startswith(prefix)
                     and d.lower().endswith((".dist-info", ".egg-info"))]
        except OSError:
            continue
        if len(found) != 1 or not found[0].lower().endswith(".dist-info"):
            if found:
                return None  # several, or an egg's: importlib.metadata decides
            continue
        try:
            with open(os.path.join(entry or ".", found[0], "METADATA"),
                      encoding="utf-8") as fh:
                for line in fh:
                    if line.startswith("Version:"):
                        return line[len("Version:"):].strip() or None
                    if not line.strip():
                        return None  # the headers end without one
        except OSError:
            return None
        return None
    return None


def install() -> bool:
    """Put the stand-in in place; True when it is (see the module docs)."""
    if any(name in sys.modules for name in ("pkg_resources", "ufl", "ffcx")):
        return False
    sys.modules["pkg_resources"] = _StandIn()
    return True


def singleton_transport(environ=None) -> bool:
    """Give a process started without ``mpirun`` Open MPI's ``ob1`` point-to-point layer
    (see the module docs); True when it set ``OMPI_MCA_pml``. ``environ``: the mapping to
    change (default ``os.environ``)."""
    env = os.environ if environ is None else environ
    if "OMPI_MCA_pml" in env or any(k in env for k in _LAUNCHED):
        return False
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None and mpi.Is_initialized():
        return False
    env["OMPI_MCA_pml"] = "ob1"
    return True
