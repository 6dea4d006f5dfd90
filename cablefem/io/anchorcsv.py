"""``anchors.csv``: the one owner of its schema, writing, reading and truncation.

The file is long-format CSV: a header, then one row per output time and anchor. Numbers are
written as Python's shortest round-trip representation (``repr(float)``), so reading a file
back gives every value to the last bit (``-0.0`` and ``1e+300`` included); an empty cell is
a number that does not exist (a slack anchor's moment: NaN when read, never zero). The
writer formats whole blocks of rows at once (one NumPy column at a time) and hands each
block to the operating system at once, so that a stopped or killed run keeps every row it
wrote; a kill in the middle of a block leaves at most one partial last line, which
:func:`truncate` drops when a run is resumed.

One reader (:func:`read`) serves every consumer, with one validation: the header must name
the columns asked for, every row must have the header's number of fields, a number that
cannot be parsed, a ``valid`` other than 0, 1 or empty, an empty ``anchor``, an empty or
non-finite ``time`` and decreasing times are errors (``ValueError`` naming
``file:line: column 'name'``). :func:`read_forces` (``cablefem post``: anchor forces, also
from other tools) and :func:`read_moments` (fatigue, compare) shape its result for their
callers.
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping, Sequence

import numpy as np

__all__ = ["ANCHOR_COLUMNS", "MOMENT_COLUMNS", "OPTIONAL_MOMENT_COLUMNS", "FORCE_COLUMNS",
           "INTEGER_COLUMNS", "columns", "AnchorCSV", "format_rows", "read", "read_forces",
           "read_moments", "AnchorHistory", "truncate", "stacked_rows"]

#: The anchor force (of the span on the anchor, into the span) and its magnitude.
ANCHOR_COLUMNS = ["time", "anchor", "Nx", "Ny", "Nz", "tension"]
#: The anchor moment and the boundary layer's quantities (clamped anchors; empty at others).
MOMENT_COLUMNS = ["delta", "moment", "Mx", "My", "Mz", "psi0", "layer_length",
                  "moment_layer", "valid", "error_estimate"]
#: Moment columns that files of older versions lack: readers accept them absent (NaN).
OPTIONAL_MOMENT_COLUMNS = ("error_estimate",)
FORCE_COLUMNS = ["Nx", "Ny", "Nz"]
#: Columns written as integers (all others but ``anchor`` are floats).
INTEGER_COLUMNS = ("valid",)
_TEXT = ("anchor", "kink", "line", "damper")  # text columns (anchors, kinks, touchdown, dampers)


def columns(clamped: bool) -> list[str]:
    """The columns of a run's ``anchors.csv``: the moment columns only with a clamped
    anchor.

    Args:
        clamped: Whether the model has a clamped anchor.
    """
    return ANCHOR_COLUMNS + (MOMENT_COLUMNS if clamped else [])


# ---------------------------------------------------------------------------- writing
class AnchorCSV:
    """``anchors.csv`` opened for writing by rank 0 (the other ranks' calls do nothing).

    ``append=True`` continues an existing file (a resumed run, after :func:`truncate`) in
    the columns of its header (a file of an older version without the optional columns
    stays without them); otherwise the file is replaced and starts with the header.

    Args:
        path: The file.
        columns: The schema's columns, in order.
        comm: MPI communicator (None: serial).
        append: Continue an existing file.
    """

    def __init__(self, path: Path, columns: Sequence[str], comm=None, append: bool = False):
        self.columns = list(columns)
        self.fh = None
        if _rank(comm) == 0:
            resume = append and Path(path).is_file()
            if resume:  # the file's own columns (an older version's file lacks optional ones)
                with open(path, newline="") as fh:
                    head = [h.strip() for h in next(csv.reader(fh), [])]
                if head and set(head) <= set(self.columns):
                    self.columns = head
            self.fh = open(path, "a" if resume else "w", newline="")
            if not resume:
                self.fh.write(",".join(self.columns) + "\n")
            self.fh.flush()

    def write(self, table: Mapping[str, Sequence]) -> None:
        """Append a block of rows given column by column (every column the same length;
        a column of the schema not in ``table`` is left empty) and hand it to the
        operating system."""
        if self.fh is None:
            return
        text = format_rows(self.columns, table)
        if text:
            self.fh.write(text)
            self.fh.flush()

    def close(self) -> None:
        if self.fh is not None:
            self.fh.close()
            self.fh = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def format_rows(cols: Sequence[str], table: Mapping[str, Sequence]) -> str:
    """The CSV lines (each ending in a newline) of the rows given column-wise in
    ``table``, in the order ``cols``: floats as ``repr`` (round trip to the last bit),
    integer columns as integers, non-finite numbers and absent columns as empty cells.

    Args:
        cols: The columns, in order.
        table: Column name -> values (every column the same length).

    Raises:
        ValueError: Columns of different lengths.
    """
    lengths = {len(v) for v in table.values()}
    if len(lengths) > 1:
        raise ValueError(f"columns of different lengths: {sorted(lengths)}")
    n = lengths.pop() if lengths else 0
    if n == 0:
        return ""
    cells = []
    for c in cols:
        v = table.get(c)
        if v is None:
            cells.append([""] * n)
        elif c in _TEXT:  # names repeat (every anchor, kink at every time): quoted once
            quoted = {s: _text(str(s)) for s in dict.fromkeys(v)}
            cells.append([quoted[s] for s in v])
        else:
            cells.append(_numbers(np.asarray(v, float).ravel(), c in INTEGER_COLUMNS))
    return "\n".join(map(",".join, zip(*cells))) + "\n"


def _numbers(a: np.ndarray, integer: bool) -> list[str]:
    bad = np.flatnonzero(~np.isfinite(a))
    if integer:
        out = list(map(str, np.where(np.isfinite(a), a, 0).astype(np.int64).tolist()))
    else:
        out = list(map(float.__repr__, a.tolist()))
    for i in bad.tolist():
        out[i] = ""
    return out


def _text(s: str) -> str:
    return s if not any(ch in s for ch in ',"\n\r') else '"' + s.replace('"', '""') + '"'


# ---------------------------------------------------------------------------- reading
def read(path: str | Path, cols: Sequence[str], optional: Sequence[str] = (),
         finite: Sequence[str] = (), empty_ok: bool = False
         ) -> dict[str, dict[str, np.ndarray]]:
    """Read the columns ``cols`` (required, but for :data:`OPTIONAL_MOMENT_COLUMNS`, NaN
    when a file of an older version lacks them) and those of ``optional`` the header has:
    anchor -> column -> float array over that anchor's rows, anchors in the order of
    their first row; empty cells are NaN (the ``finite`` columns refuse them); ``"line"``
    holds each row's line in the file.

    Raises ``ValueError`` naming the file, line and column of malformed input (see the
    module's docstring; a file without rows too, unless ``empty_ok``); blank lines are
    skipped.

    Args:
        path: The CSV file.
        cols: Required columns (beside ``time`` and ``anchor``).
        optional: Columns read when the header has them.
        finite: Columns whose cells must be finite numbers.
        empty_ok: Accept a file without data rows.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    late = [c for c in cols if c in OPTIONAL_MOMENT_COLUMNS]  # absent in older files
    cols = [c for c in cols if c not in late]
    try:
        with path.open(newline="") as fh:
            out = _read(path, fh, list(cols), list(optional) + late, set(finite))
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file") from None
    except csv.Error as err:
        raise ValueError(f"{path}: not a CSV file ({err})") from None
    if not out and not empty_ok:
        raise ValueError(f"{path}: no data rows")
    for d in out.values():
        for c in late:
            d.setdefault(c, np.full(d["time"].size, np.nan))
    return out


def _read(path: Path, fh, cols: list[str], optional: list[str], finite: set[str]):
    reader = csv.reader(fh)
    head = [h.strip() for h in next(reader, [])]
    missing = [c for c in ["time", "anchor"] + cols if c not in head]
    if missing:
        raise ValueError(f"{path}:1: header lacks column(s) {', '.join(dict.fromkeys(missing))}"
                         f" (it has: {', '.join(head) or 'nothing'})")
    want = [c for c in dict.fromkeys(["time"] + cols + optional) if c in head]
    idx = [head.index(c) for c in want]
    i_anchor = head.index("anchor")
    i_valid = want.index("valid") if "valid" in want else None
    check = [(k, c) for k, c in enumerate(want) if c in finite or c == "time"]
    rows: dict[str, list[list[float]]] = {}
    lines: dict[str, list[int]] = {}
    for row in reader:
        line = reader.line_num
        if not any(f.strip() for f in row):
            continue
        if len(row) != len(head):
            raise ValueError(f"{path}:{line}: {len(row)} fields, the header has {len(head)}")
        vals = []
        for c, i in zip(want, idx):
            s = row[i].strip()
            try:
                vals.append(float(s) if s else math.nan)
            except ValueError:
                raise ValueError(f"{path}:{line}: column '{c}': not a number: {s!r}") from None
        for k, c in check:
            if not math.isfinite(vals[k]):
                raise ValueError(f"{path}:{line}: column '{c}': empty or not finite")
        if i_valid is not None and not (math.isnan(vals[i_valid]) or
                                        vals[i_valid] in (0.0, 1.0)):
            raise ValueError(f"{path}:{line}: column 'valid': must be 0, 1 or empty")
        name = row[i_anchor].strip()
        if not name:
            raise ValueError(f"{path}:{line}: column 'anchor': empty")
        rows.setdefault(name, []).append(vals)
        lines.setdefault(name, []).append(line)
    out = {}
    for name, r in rows.items():
        a = np.array(r, float).reshape(-1, len(want))
        back = np.flatnonzero(np.diff(a[:, 0]) <= 0)
        if back.size:
            k = back[0] + 1
            raise ValueError(f"{path}:{lines[name][k]}: column 'time': times of anchor "
                             f"'{name}' are not strictly increasing ({a[k, 0]!r} after "
                             f"{a[k - 1, 0]!r})")
        out[name] = {c: a[:, k] for k, c in enumerate(want)}
        out[name]["line"] = np.asarray(lines[name])
    return out


@dataclass
class AnchorHistory:
    """Anchor-force histories read from a CSV: ``forces[name]`` is (n, 3), ``times`` (n,).

    Attributes:
        times: (n,) times.
        forces: Anchor name -> (n, 3) force [N].
    """

    times: np.ndarray
    forces: dict[str, np.ndarray]


def read_forces(path: str | Path) -> AnchorHistory:
    """Anchor forces from a long-format CSV with columns ``time, anchor, Nx, Ny, Nz``
    (others ignored), one row per time and anchor, as cablefem writes and as other tools
    can export: every force finite, every anchor at the same times. ValueError names the
    file, line and column of malformed input.

    Args:
        path: The CSV file.
    """
    data = read(path, FORCE_COLUMNS, finite=FORCE_COLUMNS)
    (first, d0), *others = data.items()
    times = d0["time"]
    for name, d in others:
        n = min(times.size, d["time"].size)
        bad = np.flatnonzero(d["time"][:n] != times[:n])
        if bad.size or d["time"].size != times.size:
            k = bad[0] if bad.size else n
            where = (f":{d['line'][k]}" if k < d["time"].size
                     else f":{d0['line'][k]}" if k < times.size else "")
            raise ValueError(f"{path}{where}: anchor '{name}' has other times than the "
                             f"first anchor '{first}' ({d['time'].size} rows, "
                             f"'{first}' has {times.size})")
    return AnchorHistory(times, {name: np.column_stack([d[c] for c in FORCE_COLUMNS])
                                 for name, d in data.items()})


def read_moments(path: str | Path) -> dict[str, dict[str, np.ndarray]]:
    """cablefem's ``anchors.csv`` for fatigue and comparisons: anchor -> ``time, tension,
    moment, valid, error_estimate`` arrays (empty fields -> NaN; an empty ``valid`` -> 0,
    a missing one -> 1 where the moment is finite; ``error_estimate`` NaN in files of
    older versions without it) and, when the columns exist, ``moment_vector``
    (n, 3) from ``Mx, My, Mz``. ValueError names the file, line and column of malformed
    input.

    Args:
        path: The run's ``anchors.csv``.
    """
    data = read(path, ["tension", "moment"],
                optional=["valid", "Mx", "My", "Mz", *OPTIONAL_MOMENT_COLUMNS])
    out = {}
    for name, d in data.items():
        e = {"time": d["time"], "tension": d["tension"], "moment": d["moment"]}
        e["valid"] = (np.nan_to_num(d["valid"]) if "valid" in d
                      else np.isfinite(d["moment"]).astype(float))
        for c in OPTIONAL_MOMENT_COLUMNS:
            e[c] = d[c] if c in d else np.full(d["time"].size, np.nan)
        if all(c in d for c in ("Mx", "My", "Mz")):
            e["moment_vector"] = np.column_stack([d["Mx"], d["My"], d["Mz"]])
        out[name] = e
    return out


# ---------------------------------------------------------------------------- truncation
def read_rows(comm, path: str | Path) -> list[dict]:
    """The rows of a CSV file as dicts of strings, on every rank (rank 0 reads; small
    files: a restart's ``kinks.csv``, ``touchdown.csv``); none without the file.

    Args:
        comm: MPI communicator (None: serial).
        path: The CSV file.
    """
    data = None
    if _rank(comm) == 0 and Path(path).is_file():
        with open(path, newline="") as fh:
            data = list(csv.DictReader(fh))
    return _comm(comm).bcast(data, root=0) or []


def open_series(comm, path: str | Path, columns: Sequence[str], resume_after: float | None,
                load: Callable[[Path], None] | None = None) -> AnchorCSV:
    """A time-series CSV for a run: a new file with ``columns``, or, resuming after the
    checkpoint time ``resume_after``, the existing one cut to its rows up to it
    (:func:`truncate`), read back by ``load(path)`` (the history the summary needs) and
    continued.

    Args:
        comm: MPI communicator (None: serial).
        path: The CSV file.
        columns: Its columns, for a new file.
        resume_after: The checkpoint's time, or None for a new run.
        load: Called with the cut file before it is continued, or None.
    """
    path = Path(path)
    if resume_after is not None:
        truncate(comm, path, resume_after)
        if load is not None:
            load(path)
    return AnchorCSV(path, columns, comm, append=resume_after is not None)


def truncate(comm, path: str | Path, t_max: float) -> None:
    """Keep the header and the complete rows with ``time <= t_max`` (collective; rank 0
    rewrites the file atomically: a temporary file, then a rename). A row is complete when
    its line ends in a newline: a partial last line (a kill in the middle of a write) is
    dropped. The times are compared exactly: the writer's numbers round-trip.

    Args:
        comm: MPI communicator (None: serial).
        path: The CSV file (nothing happens without it).
        t_max: The last time kept.
    """
    path = Path(path)
    if _rank(comm) == 0 and path.is_file():
        text = path.read_text()
        end = text.rfind("\n") + 1  # after the last complete line
        lines = text[:end].splitlines(keepends=True)
        keep = lines[:1]
        for line in lines[1:]:
            cell = line.split(",", 1)[0].strip()
            try:
                if float(cell) <= t_max:
                    keep.append(line)
            except ValueError:
                continue  # not a row of ours (cannot be resumed from)
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_text("".join(keep))
        os.replace(tmp, path)
    _comm(comm).Barrier()


def _comm(comm):
    """``comm``, or MPI's world communicator for None (mpi4py imported only then: the
    readers serve pure-NumPy post-processing too)."""
    if comm is None:
        from mpi4py import MPI

        comm = MPI.COMM_WORLD
    return comm


def _rank(comm) -> int:
    return _comm(comm).rank


def stacked_rows(pending: Sequence[tuple[float, Mapping[str, np.ndarray]]],
                 labels: Mapping[str, Sequence], columns: Sequence[str]) -> dict:
    """The rows of several items (kinks, dampers) per time as one table of columns.

    Args:
        pending: ``(t, cols)`` per time, ``cols`` a column -> (n,) array of the n items.
        labels: The columns that name the items (``"kink"``, ``"s"``, ...), n values each,
            the same at every time.
        columns: The numeric columns taken from ``cols``.

    Returns:
        Column -> values, ``time`` first, n rows per time in the items' order.
    """
    n = len(next(iter(labels.values())))
    table: dict = {"time": [t for t, _ in pending for _ in range(n)]}
    for key, values in labels.items():
        table[key] = list(values) * len(pending)
    for c in columns:
        table[c] = np.concatenate([cols[c] for _, cols in pending])
    return table
