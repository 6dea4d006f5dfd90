"""Parallel runs give the serial numbers: every rank also solves the same case alone on
COMM_SELF and compares. Under plain pytest both are serial (a check of determinism);
under mpirun -n 2 the COMM_WORLD model is partitioned."""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from cablefem.cable import CableModel
from cablefem.dynamics import integrate
from cablefem.modal import solve_modes
from cablefem.statics import solve_static


def _history(case, comm):
    model = CableModel(comm, case)
    st = solve_static(model)
    om = solve_modes(model, 4).omegas
    model.u.x.array[:] = model.u_static.x.array
    hist = [f.copy() for _, f in integrate(model, 0.3, 0.005, 0.9, 10)]
    return st.anchor_forces, om, np.array(hist)


def test_parallel_equals_serial(make_case):
    """Static anchor forces, frequencies and a 60-step anchor-force history of case A
    (anchor q moving) agree between the partitioned and the serial run to 1e-9 relative:
    both solve the same equations with direct solvers (PETSc LU on every rank vs PETSc LU)
    and Newton tolerances of 1e-9 to 1e-10, so they differ by round-off amplified by the solver
    tolerance, not by a discretisation error."""
    case = make_case(motion={"type": "harmonic", "amplitude": [2e-4, 0, 0], "omega": 32.814},
                     damping={"ratio": 0.005, "frequencies": [16.407, 32.814]})
    f_par, om_par, h_par = _history(case, MPI.COMM_WORLD)
    f_ser, om_ser, h_ser = _history(case, MPI.COMM_SELF)
    np.testing.assert_allclose(f_par, f_ser, rtol=0, atol=1e-9 * 25.0)
    np.testing.assert_allclose(om_par, om_ser, rtol=1e-9)
    np.testing.assert_allclose(h_par, h_ser, rtol=0, atol=1e-9 * 25.0)
