"""A single cable without bending stiffness (section.EI = 0, cablefem.chain): the string
alone, its moments absent (serially and under mpirun -n 2)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import level_case
from mpi4py import MPI

from cablefem.app.run import run_case
from cablefem.case import CaseError, parse_case

comm = MPI.COMM_WORLD


def _chain(EI: float, **extra) -> dict:
    """The level test cable (clamped at both ends, 20 elements) with a sag, a point load
    (a kink) and a short dynamics."""
    d = level_case(EI=EI, elements=20, length=1.005, chord=1.0,
                   dynamics={"t_end": 0.05, "dt": 0.01},
                   motion={"type": "harmonic", "amplitude": [2e-4, 0, 0], "omega": 10.0},
                   point_loads=[{"s": 0.3, "value": [0, 0, -0.1]}], **extra)
    d["solver"]["outer_correction"] = "hinge"
    return d


def test_ei_0_is_the_string_alone_without_moments(mpi_tmp_path):
    """EI = 0 was refused ("must be > 0"). Now the run is the string alone: its static
    anchor forces are those of the same string with pinned anchors, no hinge and no span
    bending (the string's equations do not hold EI: equal to Newton's tolerance, 1e-9 of
    the tension allowed); no moment anywhere (no moment columns in anchors.csv, no kinks,
    no moment entries in summary.json: absent, not 0) and summary.json says why."""
    res = run_case(parse_case(_chain(0.0)), mpi_tmp_path / "chain", comm, figures=False,
                   progress=False, modes=2)
    s = res.summary
    assert s["status"] == "completed"
    assert s["bending"]["moments"] is False and "EI = 0" in s["bending"]["note"]
    assert s["outer_correction"] == "none" and s["span_bending"] is False
    assert s["dimensionless"]["gamma"] is None
    assert "kinks" not in s
    for entry in s["anchors"].values():
        assert entry["kind"] == "pinned"
        assert not [k for k in entry if "moment" in k], entry
    header = (mpi_tmp_path / "chain" / "anchors.csv").read_text().splitlines()[0]
    assert "moment" not in header
    assert not (mpi_tmp_path / "chain" / "kinks.csv").exists()
    ref = _chain(4e-4, solver={"outer_correction": "none", "span_bending": False})
    for a in ref["anchors"]:
        a["type"] = "pinned"
        a.pop("direction")
    ref["solver"]["outer_correction"] = "none"
    pinned = run_case(parse_case(ref), mpi_tmp_path / "pinned", comm, figures=False,
                      progress=False, modes=2)
    for name, F in s["static"]["anchor_forces"].items():
        G = pinned.summary["static"]["anchor_forces"][name]
        np.testing.assert_allclose(F, G, rtol=0, atol=1e-9 * np.linalg.norm(G))


def test_ei_0_refusals():
    """Negative EI is still refused; the rod (--model beam) needs EI > 0."""
    with pytest.raises(CaseError, match="section.EI"):
        parse_case(_chain(-1.0))
    from cablefem.rod import BeamModel

    with pytest.raises(CaseError, match="section.EI"):
        BeamModel(comm, parse_case(_chain(0.0)))


def test_post_refuses_ei_0(mpi_tmp_path):
    """'cablefem post' with an EI = 0 case has no moment to compute: refused (ValueError,
    exit 2 on the command line) rather than moments of 0."""
    from cablefem.app.post import run_post

    with pytest.raises(ValueError, match="section.EI = 0"):
        run_post(parse_case(_chain(0.0)), mpi_tmp_path / "none.csv", mpi_tmp_path / "o")
