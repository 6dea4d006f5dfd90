"""The command line's ranks (``cablefem.app.ranks``, also run by ``.ci/mpitest`` on 2
ranks): a case too small for two ranks runs on rank 0 alone, with the numbers of a serial
run, says so in ``summary.json``, and every rank returns its exit code; ``solver.ranks =
"all"`` keeps every rank."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from conftest import level_case, toml_text
from mpi4py import MPI

from cablefem.app.ranks import estimate_dofs, mesh_nodes, ranks_for
from cablefem.app.resources import MIN_DOFS_PER_RANK

comm = MPI.COMM_WORLD
ROOT = Path(__file__).resolve().parents[1]

#: a 12-element cable (39 unknowns), 10 steps, one mode
SMALL = level_case(elements=12, motion={"type": "harmonic", "amplitude": [2e-4, 0, 0],
                                        "omega": 32.814},
                   dynamics={"t_end": 0.05, "dt": 0.005, "fields_every": 5},
                   modal={"modes": 1})


def _write(folder: Path, ranks: str | None = None) -> Path:
    path = folder / f"case_{ranks}.toml"
    if comm.rank == 0:
        solver = {**SMALL["solver"], **({"ranks": ranks} if ranks else {})}
        path.write_text(toml_text({**SMALL, "solver": solver}))
    comm.Barrier()
    return path


def _rows(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(row for row in fh if not row.startswith("#")))


def test_the_mesh_files_node_count_without_reading_the_nodes(tmp_path):
    """Format 2 (the count after ``$Nodes``) as meshio reads it; format 4 (its second
    number); a file without the section, or missing: None (every rank then runs)."""
    import meshio

    small = ROOT / "meshes" / "roof_small.msh"
    assert mesh_nodes(small) == len(meshio.read(small).points) == 45
    four = tmp_path / "four.msh"
    four.write_text("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n3 17 1 17\n")
    assert mesh_nodes(four) == 17
    (tmp_path / "none.msh").write_text("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n")
    assert mesh_nodes(tmp_path / "none.msh") is None
    assert mesh_nodes(tmp_path / "missing.msh") is None


def test_the_estimate_is_the_built_models_size(make_case):
    """3 unknowns a node: a single cable's ``elements + 1`` nodes, a network's mesh
    nodes; the rod's size is not known before it is built (None)."""
    from cablefem.case import load_case
    from cablefem.create import model_from_case

    case = make_case(elements=12)
    model = model_from_case(MPI.COMM_SELF, case)
    assert estimate_dofs(case) == model.u.x.array.size == 39
    roof = load_case(ROOT / "demos" / "roof.toml")
    net = model_from_case(MPI.COMM_SELF, roof)
    assert estimate_dofs(roof, "auto") == net.u.x.array.size == 135
    assert estimate_dofs(case, "beam") is None


def test_ranks_for_sizes():
    """One rank below two ranks' worth of MIN_DOFS_PER_RANK, else all; all when unknown."""
    assert ranks_for(2 * MIN_DOFS_PER_RANK - 1, 2) == 1
    assert ranks_for(2 * MIN_DOFS_PER_RANK, 2) == 2
    assert ranks_for(2 * MIN_DOFS_PER_RANK, 8) == 8
    assert ranks_for(100, 1) == 1
    assert ranks_for(None, 4) == 4


def test_a_small_case_runs_on_one_rank_with_the_serial_numbers(mpi_tmp_path):
    """``cablefem run`` of 39 unknowns: on one rank whatever was launched (``mpi_ranks``
    1; ``mpi_ranks_launched`` and a note when more were), every rank returning 0, and
    ``anchors.csv`` the very text of a run on ``COMM_SELF`` (the same operations on one
    rank: bit for bit). Before, 2 ranks split the 13 nodes."""
    from cablefem.app.cli import main

    path = _write(mpi_tmp_path)
    code = main(["run", str(path), "-o", str(mpi_tmp_path / "auto"), "-q", "--no-figures"])
    assert comm.allgather(code) == [0] * comm.size
    s = json.loads((mpi_tmp_path / "auto" / "summary.json").read_text())
    assert s["status"] == "completed" and s["mpi_ranks"] == 1
    assert s.get("mpi_ranks_launched") == (comm.size if comm.size > 1 else None)
    assert any("run on 1 of the" in n for n in s.get("notes", [])) == (comm.size > 1)
    if comm.rank == 0:
        from cablefem.app.run import run_case
        from cablefem.case import load_case

        run_case(load_case(path), mpi_tmp_path / "self", MPI.COMM_SELF, figures=False,
                 progress=False)
        assert ((mpi_tmp_path / "auto" / "anchors.csv").read_text()
                == (mpi_tmp_path / "self" / "anchors.csv").read_text())
    comm.Barrier()


def test_all_keeps_every_rank_and_the_numbers(mpi_tmp_path):
    """``solver.ranks = "all"``: every launched rank runs (``mpi_ranks``), no note; the
    anchor forces equal the one-rank run's to the direct solvers' round-off (1e-9
    relative, as the other partitioned runs are compared)."""
    from cablefem.app.cli import main

    path = _write(mpi_tmp_path, "all")
    one = _write(mpi_tmp_path)
    assert main(["run", str(path), "-o", str(mpi_tmp_path / "all"), "-q",
                 "--no-figures"]) == 0
    assert main(["run", str(one), "-o", str(mpi_tmp_path / "one"), "-q",
                 "--no-figures"]) == 0
    s = json.loads((mpi_tmp_path / "all" / "summary.json").read_text())
    assert s["mpi_ranks"] == comm.size and "mpi_ranks_launched" not in s
    assert not any("run on 1 of the" in n for n in s.get("notes", []))
    a, b = _rows(mpi_tmp_path / "all" / "anchors.csv"), _rows(mpi_tmp_path / "one" /
                                                             "anchors.csv")
    assert len(a) == len(b) > 0
    for ra, rb in zip(a, b):
        for key in ("Nx", "Ny", "Nz", "moment"):
            assert float(ra[key]) == pytest.approx(float(rb[key]), rel=1e-9, abs=1e-12)


def test_every_rank_returns_rank_0s_failure(mpi_tmp_path):
    """A run refused inside the run (the output folder is a file: exit 2 from rank 0's
    check) ends with 2 on every rank, not with 0 on the ranks that waited."""
    from cablefem.app.cli import main

    path = _write(mpi_tmp_path)
    blocker = mpi_tmp_path / "a_file"
    if comm.rank == 0:
        blocker.write_text("not a folder\n")
    comm.Barrier()
    code = main(["run", str(path), "-o", str(blocker), "-q", "--no-figures"])
    assert comm.allgather(code) == [2] * comm.size
