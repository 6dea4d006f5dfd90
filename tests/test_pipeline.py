"""A run as a pipeline of stages (cablefem.app.stages, integration, reports), each a
function returning a dataclass, and summary.json assembled from them
(cablefem.app.summary): the stages called one by one are the run."""

from __future__ import annotations

import numpy as np
from conftest import level_case
from mpi4py import MPI

from cablefem.app import stages
from cablefem.app.kinds import model_kind
from cablefem.app.run import run_case
from cablefem.app.summary import StageResults, assemble
from cablefem.case import parse_case
from cablefem.io.summary import jsonable


def taut(**extra) -> dict:
    """A weightless level cable of stress-free length 1 between anchors 1.001 apart
    (strain 1e-3), clamped, without the span's bending: its transverse modes are the taut
    string's."""
    d = level_case(g=0.0, chord=1.001, elements=30, **extra)
    d["solver"]["span_bending"] = False
    d["modal"] = {"modes": 2}
    return d


def test_stages_give_the_taut_string(mpi_tmp_path):
    """build -> statics -> modes as functions: the static tension and the first transverse
    frequency of the taut string, omega_1 = (pi / L) sqrt(T / mu) with mu = m l0 / L the
    mass per stretched length (rtol 2e-3: the P1 mesh's frequency error (pi h / L)^2 / 12
    = 9e-4 for 30 elements, and the consistent mass's the same order)."""
    case = parse_case(taut())
    b = stages.build(MPI.COMM_WORLD, case, "string", 1.0, 2, 0.0)
    assert model_kind(b.model) == "string" and b.kind.name == "string"
    st = stages.statics(b)
    EA, L, l0 = case.section.EA, 1.001, 1.0
    T = EA * (L / l0 - 1)  # the axial force at the strain L / l0 - 1
    # the string's tension is EA times the strain (linear law): exact to the solver's
    # tolerance (1e-9 relative leaves room for it)
    np.testing.assert_allclose(st.entries["max_tension"], T, rtol=1e-9)
    md = stages.modes(b, st, mpi_tmp_path)
    mu = case.section.mass * l0 / L
    w1 = np.pi / L * np.sqrt(T / mu)
    np.testing.assert_allclose(md.result.omegas[0], w1, rtol=2e-3)
    assert md.entries[0]["omega"] == md.result.omegas[0]


def test_summary_is_assembled_from_the_stages(mpi_tmp_path):
    """The stages' results assembled (status "running": the reports not reached) hold the
    same static state, modes and warnings, in the same order, as run_case's summary.json,
    to the last digit (the same operations); and the run's warnings are the stages'."""
    d = taut()
    # more modes than free degrees of freedom (87) and modes outside the method: warnings
    d["modal"] = {"modes": 100}
    case = parse_case(d)
    b = stages.build(MPI.COMM_WORLD, case, "string", 1.0, 100, 0.0)
    r = StageResults(b)
    r.statics = stages.statics(b)
    r.modes = stages.modes(b, r.statics, mpi_tmp_path / "stages")
    part = assemble(r)
    assert part["status"] == "running" and "anchors" not in part
    run = run_case(case, mpi_tmp_path / "run", MPI.COMM_WORLD, dynamics=False,
                   figures=False, progress=False).summary
    assert run["status"] == "completed"
    part, run = jsonable(part), jsonable(run)  # as summary.json holds them
    for key in ("static", "modes", "outer_correction", "span_bending", "dimensionless"):
        assert part[key] == run[key], key
    keys = [k for k in run if k in part]
    assert keys == list(part)  # the run adds its keys after the stages' ones
    assert part["warnings"] == run["warnings"][:len(part["warnings"])]
    got = [w for s in (b, r.statics, r.modes) for w in s.warnings]
    assert got == part["warnings"] and [w["key"] for w in got] == ["modal.modes", "modal"]
