"""``anchors.csv`` (cablefem.io.anchorcsv): what is written is read back to the last bit,
truncation for a restart keeps exactly the complete rows up to the checkpoint's time, and
every malformed input is reported as ``file:line: column``."""

from __future__ import annotations

import re

import numpy as np
import pytest
from mpi4py import MPI

from cablefem.app.run import run_case
from cablefem.io import anchorcsv
from cablefem.io.anchorcsv import MOMENT_COLUMNS, AnchorCSV, columns, read, truncate

comm = MPI.COMM_WORLD
COLS = columns(True)
FLOATS = [c for c in COLS if c not in ("anchor", "valid")]


def _bits(a: np.ndarray) -> np.ndarray:
    """The IEEE-754 bit patterns (an equality of these is an equality to the last bit,
    -0.0 != 0.0 included)."""
    return np.ascontiguousarray(a, np.float64).view(np.int64)


def _random_table(rng, n_times: int, names: list[str]) -> dict:
    """Rows of ``len(names)`` anchors at ``n_times`` increasing times: floats of every
    magnitude (subnormal to 1e308, random mantissas), negative zeros, NaN (empty cells)."""
    A = len(names)
    n = n_times * A
    times = np.cumsum(rng.uniform(1e-3, 1.0, n_times)) * 10.0 ** rng.integers(-5, 5)
    table = {"time": np.repeat(times, A), "anchor": names * n_times}
    for c in FLOATS[1:]:
        x = rng.standard_normal(n) * 10.0 ** rng.integers(-320, 308, n).astype(float)
        x[rng.random(n) < 0.1] = -0.0
        x[rng.random(n) < 0.1] = np.nan
        x[rng.random(n) < 0.02] = 5e-324  # the smallest subnormal
        x[rng.random(n) < 0.02] = -1.7976931348623157e308
        table[c] = x
    table["valid"] = rng.integers(0, 2, n)
    return table


def test_round_trip_to_the_last_bit(tmp_path):
    """Written in several blocks (as a run does), read back: every float bit for bit
    (repr round-trips: Python's float repr is the shortest string that parses back to the
    same double), NaN as an empty cell and back, anchors with a comma or a quote in
    their name too."""
    rng = np.random.default_rng(14)
    names = ["p", "q:1", 'odd, "name"']
    table = _random_table(rng, 200, names)
    path = tmp_path / "anchors.csv"
    with AnchorCSV(path, COLS, MPI.COMM_SELF) as out:
        n = len(table["time"])
        for lo, hi in ((0, 3), (3, 300), (300, n)):  # block sizes 1, 99, 101 rows
            out.write({k: v[lo:hi] for k, v in table.items()})
    text = path.read_text()
    assert text.count("\n") == 1 + 200 * 3 and text.endswith("\n")
    data = read(path, COLS[2:])
    assert list(data) == names  # in the order of their first row
    for j, name in enumerate(names):
        rows = slice(j, None, 3)
        for c in FLOATS:
            want, got = table[c][rows], data[name][c]
            assert np.array_equal(np.isnan(got), np.isnan(want)), (name, c)
            ok = ~np.isnan(want)
            assert np.array_equal(_bits(got[ok]), _bits(want[ok])), (name, c)
        assert np.array_equal(data[name]["valid"], table["valid"][rows])
        assert np.array_equal(data[name]["line"], 2 + j + 3 * np.arange(200))


def test_run_history_is_the_file(mpi_tmp_path, make_case):
    """A run's histories (RunResult, every rank) are what its anchors.csv holds, to the
    last bit: the blocks are written in the order they were computed, none lost or
    doubled, whatever the flushes (rows every step, fields every 4th, checkpoints)."""
    case = make_case(elements=8, motion={"type": "harmonic", "amplitude": [2e-4, 0, 0],
                                         "omega": 32.814},
                     dynamics={"t_end": 0.1, "dt": 0.005, "fields_every": 4,
                               "checkpoint_every": 7})
    res = run_case(case, mpi_tmp_path / "run", comm, figures=False, progress=False, modes=0)
    data = read(mpi_tmp_path / "run" / "anchors.csv", COLS[2:])
    assert list(data) == list(res.forces)
    for name, d in data.items():
        assert np.array_equal(_bits(d["time"]), _bits(res.times))
        F = np.column_stack([d["Nx"], d["Ny"], d["Nz"]])
        assert np.array_equal(_bits(F), _bits(res.forces[name]))
        for k in MOMENT_COLUMNS:
            a, b = d[k], res.moments[name][k].astype(float)
            assert np.array_equal(np.isnan(a), np.isnan(b))
            assert np.array_equal(_bits(a[~np.isnan(a)]), _bits(b[~np.isnan(b)])), k


def _write(path, times, names=("p", "q")) -> list[str]:
    """A small file; returns its lines (with their newlines)."""
    A = len(names)
    table = {"time": np.repeat(times, A), "anchor": list(names) * len(times),
             "Nx": np.arange(len(times) * A) + 0.5}
    with AnchorCSV(path, COLS, MPI.COMM_SELF) as out:
        out.write(table)
    return path.read_text().splitlines(keepends=True)


@pytest.mark.parametrize("partial", [
    "",  # the file as written
    "0.30000000000000004,p,7",  # a kill in the middle of a row (cut in a number)
    # a kill in the last cell: the row has all its fields and reads as a row
    "0.1,p,4.5,,,,,,,,,,,,1",
])
def test_truncate_keeps_the_complete_rows_up_to_t(tmp_path, partial):
    """Rows at t = 0, 0.1, 0.2, 0.2 + 1e-16 (4 ulps after 0.2), 0.1 + 0.2 and 1:
    truncating to 0.2 keeps exactly the header and the rows with time <= 0.2 (not the one
    a few ulps after it: times round-trip exactly, no tolerance is needed), and never a
    partial last line (no newline: a kill in the middle of a write)."""
    times = np.array([0.0, 0.1, 0.2, 0.2 + 1e-16, 0.1 + 0.2, 1.0])
    lines = _write(tmp_path / "a.csv", times)
    path = tmp_path / "a.csv"
    path.write_text("".join(lines) + partial)
    truncate(MPI.COMM_SELF, path, 0.2)
    assert path.read_text() == "".join(lines[:1 + 2 * 3])  # header, 3 times x 2 anchors
    assert not (tmp_path / "a.csv.tmp").exists()
    truncate(MPI.COMM_SELF, path, 5.0)  # nothing after: unchanged
    assert path.read_text() == "".join(lines[:1 + 2 * 3])
    path.write_text("".join(lines) + partial)
    truncate(MPI.COMM_SELF, path, 1.0)  # every complete row, the partial line dropped
    assert path.read_text() == "".join(lines)


# the header of a file written before the optional columns (error_estimate) existed: the
# rows below are such files, which every reader keeps accepting
HEADER = ",".join(c for c in COLS if c not in anchorcsv.OPTIONAL_MOMENT_COLUMNS)


def _at(path, rest: str) -> str:
    """A pattern for a message that starts with ``path`` and goes on with ``rest``."""
    return "^" + re.escape(str(path)) + rest
GOOD = "0.0,p,1,0,0,25,0.02,0.002,0,0.002,0,3.14,0.004,0.002,1"


@pytest.mark.parametrize("row, line, column", [
    ("0.5,p,1,0,0,abc,0.02,0.003,0,0.003,0,3.14,0.004,0.003,1", 3, "tension"),
    ("0.5,p,1,0,0,25,0.02,0.003,0,1e,0,3.14,0.004,0.003,1", 3, "My"),
    (",p,1,0,0,25,0.02,0.003,0,0.003,0,3.14,0.004,0.003,1", 3, "time"),
    ("inf,p,1,0,0,25,0.02,0.003,0,0.003,0,3.14,0.004,0.003,1", 3, "time"),
    ("0.5,p,1,0,0,25,0.02,0.003,0,0.003,0,3.14,0.004,0.003,2", 3, "valid"),
    ("0.5,p,1,0,0,25,0.02,0.003,0,0.003,0,3.14,0.004,0.003,0.5", 3, "valid"),
    ("0.5, ,1,0,0,25,0.02,0.003,0,0.003,0,3.14,0.004,0.003,1", 3, "anchor"),
    ("0.0,p,1,0,0,25,0.02,0.003,0,0.003,0,3.14,0.004,0.003,1", 3, "time"),  # not increasing
    ("\n0.5,q,1,0,0,25,0.02,0.003,0,0.003,0,3.14,0.004,0.003,1\n"  # blank line skipped
     "0.4,q,1,0,0,25,0.02,0.003,0,0.003,0,3.14,0.004,0.003,1", 5, "time"),
])
def test_reader_errors_name_file_line_column(tmp_path, row, line, column):
    p = tmp_path / "anchors.csv"
    p.write_text(HEADER + "\n" + GOOD + "\n" + row + "\n")
    for reader in (lambda: read(p, COLS[2:]), lambda: anchorcsv.read_moments(p)):
        with pytest.raises(ValueError, match=_at(p, f":{line}: column '{column}'")):
            reader()


def test_reader_errors_of_the_file(tmp_path):
    p = tmp_path / "anchors.csv"
    p.write_text(HEADER + "\n" + GOOD + "\n0.5,p,1,0,0,25\n")
    with pytest.raises(ValueError, match=_at(p, ":3: 6 fields, the header has 15$")):
        read(p, COLS[2:])
    p.write_text("time,anchor,Nx\n0,p,1\n")
    with pytest.raises(ValueError, match=_at(p, r":1: header lacks column\(s\) Ny, Nz")):
        anchorcsv.read_forces(p)
    p.write_text(HEADER + "\n")
    with pytest.raises(ValueError, match=_at(p, ": no data rows$")):
        read(p, COLS[2:])
    assert read(p, COLS[2:], empty_ok=True) == {}
    p.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe")
    with pytest.raises(ValueError, match=_at(p, ": not a text file")):
        read(p, COLS[2:])
    with pytest.raises(ValueError, match=_at(tmp_path / "none.csv", ": no such file")):
        read(tmp_path / "none.csv", COLS[2:])


def test_read_forces_errors(tmp_path):
    """``cablefem post``'s input (also from other tools): every force finite, every anchor
    at the first anchor's times."""
    p = tmp_path / "forces.csv"
    p.write_text("time,anchor,Nx,Ny,Nz\n0,p,1,0,0\n0,q,-1,0,0\n0.1,p,1,,0\n")
    with pytest.raises(ValueError, match=_at(p, ":4: column 'Ny': empty or not finite")):
        anchorcsv.read_forces(p)
    p.write_text("time,anchor,Nx,Ny,Nz\n0,p,1,0,0\n0,q,-1,0,0\n0.1,p,1,0,0\n0.2,q,1,0,0\n")
    with pytest.raises(ValueError, match=_at(p, ":5: anchor 'q' has other times than the "
                                                "first anchor 'p'")):
        anchorcsv.read_forces(p)
    p.write_text("time, anchor ,Nx,Ny,Nz,extra\n0,p,1,0,0,x\n0.5,p,2,0,-0.0,y\n")
    h = anchorcsv.read_forces(p)  # other columns ignored, header names stripped
    assert h.times.tolist() == [0.0, 0.5]
    assert _bits(h.forces["p"]).tolist() == _bits(np.array([[1.0, 0, 0], [2, 0, -0.0]])).tolist()


def test_read_moments_valid_and_vector(tmp_path):
    """An empty ``valid`` is 0, a missing one is 1 where the moment is finite; the moment
    vector when Mx, My, Mz are there."""
    p = tmp_path / "anchors.csv"
    p.write_text(HEADER + "\n" + GOOD + "\n0.0,q,1,0,0,25,,,,,,,,,\n")
    d = anchorcsv.read_moments(p)
    assert d["p"]["valid"].tolist() == [1.0] and d["q"]["valid"].tolist() == [0.0]
    assert d["p"]["moment_vector"].tolist() == [[0.0, 0.002, 0.0]]
    p.write_text("time,anchor,tension,moment\n0,p,25,0.002\n0,q,26,\n")
    d = anchorcsv.read_moments(p)
    assert d["p"]["valid"].tolist() == [1.0] and d["q"]["valid"].tolist() == [0.0]
    assert "moment_vector" not in d["p"]


def test_blocks_of_unequal_columns_refused(tmp_path):
    with AnchorCSV(tmp_path / "a.csv", COLS, MPI.COMM_SELF) as out:
        with pytest.raises(ValueError, match="different lengths"):
            out.write({"time": [0.0, 1.0], "anchor": ["p"]})
