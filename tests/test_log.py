"""The console under MPI: a warning reaches the console once over all ranks, not once per
rank (issue 31), and it is still listed in the summary of every rank."""

from __future__ import annotations

import logging

from mpi4py import MPI

from cablefem.app.log import setup_logging
from cablefem.app.report import warn


def test_a_warning_is_printed_once_over_the_ranks(capfd):
    """Every rank records the warning (the summary is the same on all); the lines printed
    on stderr, summed over the ranks, are exactly one (before rank-0 logging: one per
    rank)."""
    comm = MPI.COMM_WORLD
    setup_logging(logging.INFO, comm)
    capfd.readouterr()
    summary: dict = {}
    warn(summary, "dynamics.dt", "a test warning seen by every rank")
    logging.getLogger("cablefem.test").info("an info line seen by every rank")
    err = capfd.readouterr().err
    mine = sum("a test warning seen by every rank" in line for line in err.splitlines())
    info = sum("an info line seen by every rank" in line for line in err.splitlines())
    assert comm.allreduce(mine, op=MPI.SUM) == 1
    assert comm.allreduce(info, op=MPI.SUM) == 1
    assert summary["warnings"] == [{"key": "dynamics.dt",
                                    "message": "a test warning seen by every rank"}]
