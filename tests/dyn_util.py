"""Helpers for the dynamics tests: a taut string set into free vibration in its first
discrete mode, and the value of a nodal dof gathered over ranks."""

from __future__ import annotations

import numpy as np
from conftest import level_case
from mpi4py import MPI

from cablefem.cable import CableModel
from cablefem.case import parse_case
from cablefem.dynamics import DynamicsStats, integrate
from cablefem.statics import solve_static

EA, L0, L, M = 100.0, 1.0, 1.01, 1.0  # T = EA (L/l - 1) = 1, stretch 1.01
T = EA * (L / L0 - 1)


def omega_discrete(n: int, k: int = 1) -> float:
    """Exact transverse frequency of the P1/consistent-mass taut string (test_modal)."""
    h = L0 / n
    th = k * np.pi * h / L0
    return float(np.sqrt(6 * T / (L / L0) / (M * h * h) * (1 - np.cos(th)) / (2 + np.cos(th))))


def node_value(model, f, k: int, comp: int) -> float:
    """Component ``comp`` of P1 function ``f`` at node ``k`` (station order), all ranks."""
    idx = np.nonzero(model.line.owned_nodes == k)[0]
    val = f.x.array[3 * idx[0] + comp] if idx.size else 0.0
    return model.comm.allreduce(float(val), op=MPI.SUM)


def free_vibration(n=20, amplitude=1e-3, t_end=3.0, dt=0.01, rho_inf=1.0, damping=None,
                   record=None):
    """Taut weightless string released from A sin(pi s/l) e_y; yields (t, model, forces)."""
    d = level_case(EA=EA, EI=1e-6, mass=M, g=0.0, length=L0, chord=L, elements=n,
                   damping=damping,
                   dynamics={"t_end": t_end, "dt": dt, "rho_inf": rho_inf})
    model = CableModel(MPI.COMM_WORLD, parse_case(d))
    solve_static(model)
    s = model.geometry.stations
    shape = np.zeros((s.size, 3))
    shape[:, 1] = amplitude * np.sin(np.pi * s / L0)
    u0 = model.gather_nodal(model.u)
    u0 = model.comm.bcast(u0, root=0)
    model.scatter_nodal(u0 + shape, model.u)
    stats = DynamicsStats()
    for t, forces in integrate(model, t_end, dt, rho_inf, 1, stats):
        yield t, model, forces


def resume_round_trip(make_model, folder, t_end: float, dt: float, steps: int):
    """The anchor forces at ``t_end`` of a run from statics that writes a checkpoint at
    step ``steps // 2``, and of a run resumed from that ``checkpoint.npz`` in ``folder``:
    ``(uninterrupted, resumed, checkpoint)`` (``make_model()`` builds a fresh model)."""
    from cablefem.io.checkpoint import read_checkpoint, write_checkpoint

    def run(start=None):
        m = make_model()
        solve_static(m)
        m.u.x.array[:] = m.u_static.x.array
        if start is not None:
            m.scatter_nodal(start["u"], m.u)
            m.scatter_nodal(start["v"], m.v)
        out = [f.copy() for _, f in integrate(
            m, t_end, dt, 0.9, steps, start=None if start is None else start["checkpoint"],
            checkpoint_every=steps // 2 if start is None else 0,
            on_checkpoint=lambda ck: write_checkpoint(m, folder, ck, "-", {}))]
        return out[-1]

    full = run()
    ck = read_checkpoint(folder)
    return full, run(ck), ck
