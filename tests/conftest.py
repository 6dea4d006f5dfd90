"""Shared fixtures: collective teardown, an MPI-safe temporary folder, case factories.

Tests that run under ``mpirun -n 2`` must not create different objects on different ranks;
everything here is collective or rank-independent.
"""

from __future__ import annotations

import gc
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from cablefem.case import parse_case


@pytest.fixture(scope="module", autouse=True)
def _collective_module_teardown():
    """After a module's tests and fixtures: everything the tests left alive is looked at
    again (:func:`_collective_teardown` froze it) and collected on every rank."""
    yield
    gc.unfreeze()
    gc.collect()
    MPI.COMM_WORLD.Barrier()


@pytest.fixture(autouse=True)
def _collective_teardown():
    """Destructors of PETSc objects can be collective: collect, then wait for all ranks.
    What is left alive is frozen (``gc.freeze``): the next test's collection looks only
    at what that test made. A full collection looked at everything every test had left
    (the imports, a module's fixtures, the form caches) again: 84 ms a test, 80 s of the
    serial suite's 11 minutes and more on 2 ranks. The module's teardown collects the
    frozen ones too."""
    yield
    gc.collect()
    gc.freeze()
    MPI.COMM_WORLD.Barrier()


@pytest.fixture
def mpi_tmp_path(tmp_path) -> Path:
    """One temporary folder shared by all ranks (rank 0's, broadcast)."""
    return Path(MPI.COMM_WORLD.bcast(str(tmp_path), root=0))


def level_case(EA=17857.14, EI=4e-4, mass=1.0, g=1.0, length=1.0, chord=1.0013333,
               elements=30, motion=None, damping=None, dynamics=None, **extra):
    """A level cable between p = (0,0,0) and q = (chord,0,0), clamped along the chord
    (docs/theory.md §9 coordinates); keyword overrides for every table (``solver``: merged).
    The string is the paper's leading order (``outer_correction = "none"``), whose closed
    forms the tests that use this check."""
    d = {"title": "test", "section": {"EA": EA, "EI": EI, "mass": mass},
         "gravity": {"g": g}, "geometry": {"length": length},
         "mesh": {"elements": elements}, "solver": {"outer_correction": "none"},
         "anchors": [{"name": "p", "position": [0.0, 0.0, 0.0], "direction": [1.0, 0, 0]},
                     {"name": "q", "position": [chord, 0.0, 0.0], "direction": [-1.0, 0, 0]}]}
    if motion is not None:
        d["anchors"][1]["motion"] = motion
    if damping is not None:
        d["damping"] = damping
    if dynamics is not None:
        d["dynamics"] = dynamics
    for key, val in extra.items():
        d[key] = {**d["solver"], **val} if key == "solver" else val
    return d


def toml_text(d: dict) -> str:
    """A case dict (:func:`level_case`'s) as the TOML text of a case file: scalars and
    lists of numbers or strings, tables and arrays of tables (one level of nesting in
    each, as case files have)."""

    def value(v) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return '"' + v + '"'
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)

    def body(table: dict, name: str) -> list[str]:
        lines = [f"{k} = {value(v)}" for k, v in table.items() if not isinstance(v, dict)]
        for k, v in table.items():
            if isinstance(v, dict):
                lines += [f"[{name}.{k}]", *body(v, f"{name}.{k}")]
        return lines

    out = [f"{k} = {value(v)}" for k, v in d.items()
           if not isinstance(v, (dict, list)) or (isinstance(v, list) and v
                                                   and not isinstance(v[0], dict))]
    for k, v in d.items():
        if isinstance(v, dict):
            out += [f"[{k}]", *body(v, k)]
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            for item in v:
                out += [f"[[{k}]]", *body(item, k)]
    return "\n".join(out) + "\n"


@pytest.fixture
def make_case():
    """Factory: ``make_case(**overrides)`` -> a validated Case of a level clamped cable."""

    def factory(**kw):
        return parse_case(level_case(**kw))

    return factory


def observed_order(h: np.ndarray, err: np.ndarray) -> float:
    """Least-squares slope of log(err) against log(h)."""
    return float(np.polyfit(np.log(h), np.log(err), 1)[0])


def read_series(path) -> list[tuple[float, dict]]:
    """Every frame (time, {field: values}) of an XDMF time series, read with meshio as users
    do; cell fields are flattened to their single block."""
    import meshio

    frames = []
    with meshio.xdmf.TimeSeriesReader(path) as reader:
        reader.read_points_cells()
        for k in range(reader.num_steps):
            t, pd, cd = reader.read_data(k)
            frames.append((t, {**pd, **{key: v[0] for key, v in cd.items()}}))
    return frames


def sagging_paper_case(eps: float) -> dict:
    """The validation matrix's sagging cables as a case dict: case A's section with
    ``EI = eps^2`` and chord 0.974 (10 % sag, horizontal clamps, anchor angles 0.44 rad), q
    moving 0.01 out of plane at 2.5 rad/s (below the first frequency, 3.5), 1 % Rayleigh
    damping at 3.5 and 7 rad/s."""
    import tomllib

    root = Path(__file__).resolve().parents[1]
    data = tomllib.loads((root / "demos" / "paper_inplane.toml").read_text())
    data["section"]["EI"] = eps**2
    data["anchors"][1]["position"] = [0.974, 0.0, 0.0]
    data["anchors"][1]["motion"] = {"type": "harmonic", "amplitude": [0.0, 0.01, 0.0],
                                    "omega": 2.5}
    data["damping"] = {"model": "rayleigh", "ratio": 0.01, "frequencies": [3.5, 7.0]}
    return data
