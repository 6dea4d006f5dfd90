"""Benchmark: the CPU cost of one dynamic step of a case, against the bare cost of the
compiled kernels and the factorisation it calls. Prints JSON.

In process, one rank: the case's model is built and its statics solved; then, for each of
``--repeat`` fresh :class:`cablefem.dynamics.DynamicProblem` objects, ``--steps`` steps
with the anchor forces at every step (what ``cablefem run`` does for ``anchors.csv``) and
``--steps`` steps without them, after 20 warm-up steps; the CPU time per step
(``time.process_time``), the best of the repeats; each repeat on both assembly routes in
turn, the C one (:mod:`cablefem.native_rows`) and the Python one, and their ratio. The
bare costs, best of 5 loops of ``--calls`` calls: the residual kernel on packed data
(``dolfinx.cpp.fem.assemble_vector``), the coefficients' packing, the Jacobian kernel with
PETSc's matrix assembly, and the Jacobian with an LU factorisation and solve. Newton
iterations, residuals and Jacobian assemblies per step come from the integrator's
counters (over the whole run: warm-up and both loops). ``--option KEY=VALUE`` passes an
option of the time integrator (without its ``cable_`` prefix), e.g. ``--option
newton_jacobian_reuse=0``.

    python benchmarks/bench_step.py                           # case B
    python benchmarks/bench_step.py demos/paper_inplane.toml --steps 3000
"""

from __future__ import annotations

import argparse
import json
import time


def per_step(model, dt: float, steps: int, repeat: int, options: dict | None = None) -> dict:
    """Both assembly routes (:mod:`cablefem.native_rows` in C, and the Python one), their
    repeats alternated: ``{"c": ..., "python": ..., "ratio_c_to_python": ...}``."""
    from cablefem.dynamics import DynamicProblem
    from cablefem.statics import solve_static

    solve_static(model)
    runs = {"c": ([], [], []), "python": ([], [], [])}
    counts = {}
    for _ in range(repeat):
        for route, native in (("c", True), ("python", False)):
            with_forces, bare, newton = runs[route]
            model.u.x.array[:] = model.u_static.x.array  # each run from the static state
            model.v.x.array[:] = 0.0
            opts = {**(options or {}), "native_assembly": native}
            with DynamicProblem(model, dt, petsc_options=opts) as problem:
                if route == "c" and problem._rows.native is None:
                    raise SystemExit("the C route is not available for this case here")
                problem.anchor_forces()
                for _ in range(20):
                    problem.step()
                    problem.anchor_forces()
                t0 = time.process_time()
                for _ in range(steps):
                    problem.step()
                    problem.anchor_forces()
                t1 = time.process_time()
                for _ in range(steps):
                    problem.step()
                t2 = time.process_time()
                with_forces.append((t1 - t0) / steps)
                bare.append((t2 - t1) / steps)
                n = problem.step_number
                newton.append(problem.stats.newton_iterations / n)
                counts = {"residuals_per_step": problem.newton.residuals / n,
                          "jacobians_per_step": problem.newton.assemblies / n}
    out = {route: {"step_and_anchor_forces_us": 1e6 * min(w), "step_us": 1e6 * min(b),
                   "newton_iterations_per_step": nw[-1], **counts}
           for route, (w, b, nw) in runs.items()}
    out["ratio_c_to_python"] = {k: out["c"][k] / out["python"][k]
                                for k in ("step_and_anchor_forces_us", "step_us")}
    return out


def kernels(model, calls: int) -> dict:
    import dolfinx.cpp as dcpp
    from dolfinx.fem import petsc as fpetsc
    from petsc4py import PETSc

    F, J = model.f_dynamic, model.j_dynamic
    b = fpetsc.create_vector(F)
    A = fpetsc.create_matrix(J, "baij")
    A.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
    cF, kF = dcpp.fem.pack_constants(F), dcpp.fem.pack_coefficients(F)
    cJ, kJ = dcpp.fem.pack_constants(J), dcpp.fem.pack_coefficients(J)
    arr = b.array_w
    ksp = PETSc.KSP().create(model.comm)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.setOperators(A)
    x = b.duplicate()

    def jacobian():
        A.zeroEntries()
        dcpp.fem.petsc.assemble_matrix(A, J, cJ, kJ, [])
        A.assemble()

    def jacobian_lu_solve():
        jacobian()
        ksp.solve(b, x)

    def best(f):
        out = []
        for _ in range(5):
            t = time.process_time()
            for _ in range(calls):
                f()
            out.append((time.process_time() - t) / calls)
        return 1e6 * min(out)

    res = {"residual_kernel_us": best(lambda: dcpp.fem.assemble_vector(arr, F, cF, kF)),
           "pack_coefficients_residual_us": best(lambda: dcpp.fem.pack_coefficients(F)),
           "jacobian_kernel_and_assembly_us": best(jacobian)}
    b.set(1.0)
    res["jacobian_lu_factor_and_solve_us"] = best(jacobian_lu_solve)
    for obj in (ksp, A, b, x):
        obj.destroy()
    return res


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("case", nargs="?", default="demos/paper_spatial.toml")
    p.add_argument("--steps", type=int, default=1500)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--calls", type=int, default=2000)
    p.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                   help="an option of the time integrator without its prefix, e.g. "
                        "newton_jacobian_reuse=0 (repeatable)")
    args = p.parse_args()
    options = dict(o.split("=", 1) for o in args.option)
    from mpi4py import MPI

    from cablefem.case import load_case
    from cablefem.create import model_from_case

    case = load_case(args.case)
    model = model_from_case(MPI.COMM_WORLD, case)
    out = {"case": args.case,
           "dofs": model.bs * model.V.dofmap.index_map.size_global,
           "options": options,
           "per_step": per_step(model, case.dynamics.dt, args.steps, args.repeat, options),
           "kernels": kernels(model, args.calls)}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
