"""Benchmark: the direct and domain-decomposition solvers of a network's dynamic step on
several ranks, on one Jacobian of the cable-net roof (bench_scaling.py's roofs). Prints a
JSON line per solver: setup (factorisation) and solve times (wall, the fastest of
``--repeat``, ranks synchronised), Krylov iterations and the solution's difference from
the first solver's.

    mpirun -n 2 python benchmarks/bench_dd.py 40       # the 94 000-dof roof

Solvers: ``redundant`` (an LU of the whole system on every rank), ``gathered`` (one LU on
rank 0, cablefem.gathered_lu), ``bddc`` (GMRES and PCBDDC on an unassembled MATIS matrix,
every interface node a primal vertex, so that the method is an exact substructuring:
one iteration), ``telescope`` (PETSc's gathering onto a sub-communicator, LU there).

The MATIS comes from dolfinx 0.5.2 without changes there: a matrix of type ``is`` whose
local-to-global map has -1 at the dofs no cell of this rank touches (the ghosts of the
ghost cells), so that dolfinx's assembly with ``MatSetValuesLocal`` fills each rank's
local (Neumann) matrix with its own cells' sum and nothing else.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
LU_AMD = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_ordering_type": "amd"}


def roof_model(n: int):
    """The roof of ``n`` cables per family (bench_scaling.py's), its network model."""
    from mpi4py import MPI

    sys.path.insert(0, str(ROOT / "meshes"))
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import meshio
    from bench_scaling import case_text, plan
    from make_roof import roof

    from cablefem.case import load_case
    from cablefem.network import NetworkModel

    comm = MPI.COMM_WORLD
    tmp = Path(comm.bcast(tempfile.mkdtemp() if comm.rank == 0 else None, root=0))
    if comm.rank == 0:
        meshio.write(tmp / "roof.msh", roof(n, 10, *plan(n)), file_format="gmsh22",
                     binary=False)
        (tmp / "case.toml").write_text(case_text(str(tmp / "roof.msh"), 5, 0.005))
    comm.Barrier()
    return NetworkModel(comm, load_case(tmp / "case.toml"))


def matis(model, form):
    """``form``'s matrix as a MATIS (see the module's text), and the global indices of
    the interface dofs (touched by cells of more than one rank) seen from this rank."""
    import dolfinx.la
    from petsc4py import PETSc

    V = form.function_spaces[0]
    imap, bs = V.dofmap.index_map, V.dofmap.index_map_bs
    n_local = imap.size_local + imap.num_ghosts
    cells = V.mesh.topology.index_map(V.mesh.topology.dim).size_local
    touched = np.zeros(n_local, bool)
    touched[V.dofmap.list().array.reshape(-1, V.dofmap.dof_layout.num_dofs)[:cells]] = True
    for t in model.node_terms:
        touched[np.asarray(t.blocks).ravel()] = True
    g = imap.local_to_global(np.arange(n_local, dtype=np.int32)).astype(PETSc.IntType)
    g[~touched] = -1
    l2g = PETSc.LGMap().create(g, bsize=bs, comm=model.comm)
    A = PETSc.Mat().createIS([(bs * imap.size_local, bs * imap.size_global)] * 2,
                             lgmapr=l2g, lgmapc=l2g, comm=model.comm)
    local = A.getISLocalMat()
    local.setPreallocationNNZ(8 * bs)  # a roof node: 4 neighbours, kinks reach 2 further
    local.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
    A.restoreISLocalMat(local)
    count = dolfinx.la.vector(imap, 1)
    count.array[:] = touched
    count.scatter_reverse(dolfinx.la.ScatterMode.add)
    count.scatter_forward()
    shared = np.flatnonzero(touched & (count.array > 1.5))
    iface = (bs * g[shared][:, None] + np.arange(bs)).ravel().astype(PETSc.IntType)
    return A, PETSc.IS().createGeneral(iface, comm=model.comm)


def timed(A, b, options, repeat, vertices=None) -> tuple[dict, object]:
    """Setup and solve times of the KSP with ``options`` on ``A``, the fastest of
    ``repeat`` (each a fresh numeric setup), and the solution."""
    from petsc4py import PETSc

    comm = A.getComm().tompi4py()
    opts = PETSc.Options()
    ksp = PETSc.KSP().create(A.getComm())
    ksp.setOptionsPrefix("dd_")
    for k, v in options.items():
        opts.setValue("dd_" + k, v)
    ksp.setOperators(A)
    ksp.setFromOptions()
    for k in options:
        opts.delValue("dd_" + k)
    if vertices is not None:
        ksp.getPC().setBDDCPrimalVerticesIS(vertices)
    x = b.duplicate()
    setup, solve = [], []
    for _ in range(repeat):
        A.assemble()  # a new state: the next setUp factors again
        ksp.setOperators(A)
        comm.Barrier()
        t0 = time.perf_counter()
        ksp.setUp()
        comm.Barrier()
        setup.append(time.perf_counter() - t0)
        for _ in range(3):
            t0 = time.perf_counter()
            ksp.solve(b, x)
            comm.Barrier()
            solve.append(time.perf_counter() - t0)
    out = {"setup_s": min(setup), "solve_s": min(solve), "its": ksp.getIterationNumber()}
    ksp.destroy()
    return out, x


def main() -> None:
    from dolfinx.fem import petsc as fpetsc
    from mpi4py import MPI

    from cablefem import junctions
    from cablefem.gathered_lu import PYTHON_TYPE
    from cablefem.petsc_utils import RowsAssembler

    n = int(sys.argv[1]) if len(sys.argv) > 1 else 40
    repeat = 3
    model = roof_model(n)
    comm = model.comm
    model.shift_v.value, model.shift_a.value = 400.0, 1.6e5  # dt = 5 ms, generalised-α
    rows = np.concatenate([a.flat_dofs for a in model.anchors]).astype(np.int32)
    rows = rows[rows < model.bs * model.V.dofmap.index_map.size_local]
    extra = (lambda arr: junctions.add_residual(model, arr),
             lambda A: junctions.add_jacobian(model, A))
    asm = RowsAssembler(model.f_dynamic, model.j_dynamic, model.bcs, rows, 1e9, comm, extra)
    b = fpetsc.create_vector(model.f_dynamic)
    asm.residual(b, model.u.vector)
    B = junctions.create_matrix(model, model.j_dynamic, "baij")
    asm.jacobian(B)
    A, iface = matis(model, model.j_dynamic)
    asm.jacobian(A)
    cases = [
        ("redundant", B, {"ksp_type": "preonly", "pc_type": "redundant",
                          **{"redundant_" + k: v for k, v in LU_AMD.items() if k != "ksp_type"}},
         None),
        ("gathered", B, {"ksp_type": "preonly", "pc_type": "python",
                         "pc_python_type": PYTHON_TYPE,
                         "gathered_pc_factor_mat_ordering_type": "amd"}, None),
        ("bddc", A, {"ksp_type": "gmres", "ksp_rtol": 1e-8, "pc_type": "bddc",
                     "pc_bddc_dirichlet_pc_factor_mat_ordering_type": "amd",
                     "pc_bddc_neumann_pc_factor_mat_ordering_type": "amd"}, iface),
        ("telescope", B, {"ksp_type": "preonly", "pc_type": "telescope",
                          "pc_telescope_reduction_factor": comm.size,
                          **{"telescope_" + k: v for k, v in LU_AMD.items()}}, None)]
    ref = None
    for name, M, options, vertices in cases:
        if name in ("bddc", "telescope") and comm.size == 1:
            continue
        out, x = timed(M, b, options, repeat, vertices)
        if ref is None:
            ref = x.copy()
        x.axpy(-1.0, ref)
        out.update(solver=name, ranks=comm.size, dofs=b.getSize(),
                   rel_diff=x.norm() / ref.norm(), interface_dofs=iface.getSize())
        if comm.rank == 0:
            print(json.dumps(out), flush=True)
    if comm.rank == 0:
        print(json.dumps({"load_after": round(__import__("os").getloadavg()[0], 2)}))
    MPI.COMM_WORLD.Barrier()


if __name__ == "__main__":
    main()
