"""cablefem's lighter start (cablefem.startup): UFL and FFCx read their versions without
importing pkg_resources, and pkg_resources is the real one for everybody else. Checked in
fresh interpreters (this process has imported everything already)."""

import subprocess
import sys

import pytest

pytestmark = pytest.mark.serial  # subprocesses of one interpreter each, not an MPI job


def _run(code: str) -> str:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    return out.stdout.strip()


def test_fenics_versions_without_pkg_resources():
    out = _run(
        "import sys, importlib.metadata as md\n"
        "import cablefem.cable, ufl, ffcx\n"
        "real = 'pkg_resources' in sys.modules\n"
        "print(real, ufl.__version__ == md.version('fenics-ufl'),"
        " ffcx.__version__ == md.version('fenics-ffcx'))")
    # the real module never imported; the versions are the distributions' own
    assert out == "False True True"


def test_anything_else_gets_the_real_pkg_resources():
    out = _run(
        "import cablefem, sys\n"
        "import pkg_resources\n"  # before UFL and FFCx: the stand-in
        "stand_in = type(pkg_resources).__name__ == '_StandIn'\n"
        "ws = pkg_resources.working_set\n"  # an attribute of the real module: loaded
        "dist = pkg_resources.get_distribution('numpy')\n"
        "loc = dist.location\n"  # a distribution's other attribute: the real one's
        "real = sys.modules['pkg_resources']\n"
        "print(stand_in, type(real).__name__, hasattr(real, 'WorkingSet'), bool(loc))")
    assert out == "True module True True"


def test_an_unknown_distribution_raises_pkg_resources_own_error():
    out = _run(
        "import cablefem, pkg_resources\n"
        "try:\n"
        "    pkg_resources.get_distribution('no-such-distribution-cablefem')\n"
        "except Exception as err:\n"
        "    print(type(err).__name__)")
    assert out == "DistributionNotFound"


def test_a_singleton_gets_open_mpis_own_transport():
    """A process started without mpirun gets OMPI_MCA_pml=ob1 when cablefem is imported
    (before MPI_Init: Open MPI's default UCX layer probes the network devices, 0.2 s of wall
    time a command), and MPI then works on its one rank."""
    import os

    env = {k: v for k, v in os.environ.items()
           if k != "OMPI_MCA_pml" and not k.startswith(("OMPI_COMM_WORLD", "PMIX_", "PMI_"))}
    out = subprocess.run(
        [sys.executable, "-c", "import os, cablefem\n"
         "pml = os.environ.get('OMPI_MCA_pml')\n"
         "from mpi4py import MPI\n"
         "print(pml, MPI.COMM_WORLD.size, MPI.COMM_WORLD.allreduce(2))"],
        capture_output=True, text=True, check=True, env=env).stdout.strip()
    assert out == "ob1 1 2"


@pytest.mark.parametrize("given", [{"OMPI_COMM_WORLD_SIZE": "2"}, {"PMIX_RANK": "0"},
                                   {"OMPI_MCA_pml": "ucx"}])
def test_a_launched_rank_or_a_given_transport_is_left_alone(given):
    """A rank of an mpirun job (its launcher's variables) keeps the job's transport (every
    rank must use the same); a transport the user gave stays."""
    from cablefem.startup import singleton_transport

    env = dict(given)
    assert not singleton_transport(env)
    assert env == given


def test_every_module_is_byte_compiled_and_current():
    """``.ci/setup`` byte-compiles cablefem, as a pip install (not an editable one) does:
    every module's ``.pyc`` exists and matches its source (the header's magic number,
    modification time and size, as the import system checks them), so a command loads
    them instead of compiling ~100 sources (0.25 s a command where PYTHONDONTWRITEBYTECODE
    is set, as on this project's machines). Fails after an edit until the setup runs
    again (``./dev.sh test`` runs it first)."""
    import importlib.util
    import pathlib
    import struct

    import cablefem

    root = pathlib.Path(cablefem.__file__).parent
    stale = []
    for src in sorted(root.rglob("*.py")):
        pyc = pathlib.Path(importlib.util.cache_from_source(str(src)))
        if not pyc.exists():
            stale.append(f"{src.relative_to(root)} (none)")
            continue
        head = pyc.read_bytes()[:16]
        flags, mtime, size = struct.unpack("<III", head[4:16])
        st = src.stat()
        if (head[:4] != importlib.util.MAGIC_NUMBER or flags != 0
                or mtime != int(st.st_mtime) & 0xFFFFFFFF or size != st.st_size & 0xFFFFFFFF):
            stale.append(f"{src.relative_to(root)} (stale)")
    assert len(list(root.rglob("*.py"))) > 50
    assert not stale, f"run .ci/setup, which byte-compiles cablefem: {stale[:5]}"


def test_a_cables_run_imports_no_scipy(tmp_path):
    """A single cable's whole run (statics, modes, dynamics, every output, both fields)
    maps the mesh's cells to the cable's elements through the mesh's own input index
    (``original_cell_index``): SciPy's k-d tree, and with it about 0.1 s of SciPy's
    modules at every start (``python -X importtime``: 104 ms of 670), is not needed. Nor
    are HTTP and e-mail parsing, which ``xml.sax.saxutils`` (the XDMF files' attribute
    quoting) imported through ``urllib.request``: 30 ms. Nor is cffi's C parser
    (``pycparser``, 50 ms), which ``cffi.FFI()`` imports: the time integrator's C route
    (``cablefem.native_rows``) takes its kernels' addresses through cffi's backend."""
    from conftest import level_case, toml_text

    case = level_case(elements=12, motion={"type": "harmonic", "amplitude": [0, 0, 1e-3],
                                           "omega": 20.0},
                      damping={"ratio": 0.01, "frequencies": [10.0, 20.0]},
                      dynamics={"t_end": 0.05, "dt": 0.01, "fields_every": 2})
    path = tmp_path / "cable.toml"
    path.write_text(toml_text(case))
    out = _run(
        "import sys\n"
        "from cablefem.app.cli import main\n"
        f"code = main(['run', {str(path)!r}, '--no-figures', '--quiet',"
        f" '--output', {str(tmp_path / 'out')!r}])\n"
        "print(code, sorted({m.split('.')[0] for m in sys.modules}"
        " & {'scipy', 'http', 'email', 'pycparser'}))")
    assert out.splitlines()[-1] == "0 []"
    assert (tmp_path / "out" / "string.xdmf").exists()


def test_versions_read_without_importlib_metadata():
    """UFL's and FFCx's versions come from their ``METADATA`` files' ``Version`` lines:
    importing ``importlib.metadata`` (its e-mail parser) cost every command about 35 ms,
    half of ``cablefem --help``'s imports. A distribution described otherwise (an egg's
    metadata, as Debian's NumPy) is left to ``importlib.metadata``, with its answer."""
    out = _run(
        "import sys\n"
        "import cablefem.app.cli, ufl, ffcx\n"
        "loaded = 'importlib.metadata' in sys.modules\n"
        "import importlib.metadata as md\n"
        "from cablefem.startup import _dist_info_version as v\n"
        "print(loaded, ufl.__version__ == md.version('fenics-ufl'),"
        " ffcx.__version__ == md.version('fenics-ffcx'),"
        " v('fenics-ufl') == md.version('fenics-ufl'), v('no-such-distribution'))")
    assert out == "False True True True None"
