"""Output: XDMF for ParaView, CSV histories and the JSON summary, MPI-correct.

* ``string.xdmf`` (+ ``.h5``): displacement, velocity (P1, point data), tension and strain
  (DG0, cell data) over time, written collectively by dolfinx (each function a grid of its
  own, which ParaView shows as separate blocks), and the same fields as one dataset per
  time in ``string.pvd`` (+ ``.vtu``/``.pvtu``), the file to open in ParaView. The mesh is
  the reference; apply *Warp By Vector* with ``displacement`` to see the cable move.
* ``moments.xdmf`` (+ ``.h5``): the composite curvature and bending moment on a line mesh of
  its own, graded towards the clamped anchors, written by rank 0 with meshio from gathered
  data. Points are the static deformed positions; ``displacement`` moves them to the
  current ones (*Warp By Vector* again).
* ``anchors.csv``: one row per output time and anchor, written by rank 0 and flushed at
  every row, so that an interrupted run keeps what it computed.
* ``summary.json``: written atomically (temporary file, then rename) by rank 0.
"""

from __future__ import annotations

import json
import math
import os
import re
from pathlib import Path

import numpy as np
from dolfinx import fem
from dolfinx.io import VTKFile, XDMFFile
from mpi4py import MPI

__all__ = ["StringWriter", "AnchorCSV", "MomentsWriter", "write_json", "write_modes",
           "jsonable"]


def jsonable(obj):
    """Convert numpy scalars/arrays and non-finite floats to plain JSON values."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        x = float(obj)
        return x if math.isfinite(x) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if isinstance(obj, Path):
        return str(obj)
    return obj


def write_json(path: Path, data: dict, comm: MPI.Comm = MPI.COMM_WORLD) -> None:
    """Write ``data`` as JSON from rank 0, atomically; collective (all ranks call it)."""
    if comm.rank == 0:
        path = Path(path)
        tmp = path.with_suffix(path.suffix + ".tmp")
        tmp.write_text(json.dumps(jsonable(data), indent=2) + "\n")
        os.replace(tmp, path)
    comm.Barrier()


class StringWriter:
    """``string.xdmf``: the string's fields over time (collective)."""

    def __init__(self, model, path: Path, append_after: float | None = None) -> None:
        """``append_after``: resume an existing file, skipping times up to that one (they
        are in the file already)."""
        self.model = model
        self.skip_until = append_after
        if append_after is not None and Path(path).is_file():
            self.file = XDMFFile(model.comm, str(path), "a")
        else:
            self.file = XDMFFile(model.comm, str(path), "w")
            self.file.write_mesh(model.mesh)
        # the same fields as one dataset per time (ParaView shows the XDMF's functions as
        # separate blocks): string.pvd, or string_restart.pvd when a run is resumed
        pvd = Path(path).with_suffix(".pvd")
        if append_after is not None:
            pvd = pvd.with_name(pvd.stem + "_restart.pvd")
        self.vtk = VTKFile(model.comm, str(pvd), "w")
        self._pvd = pvd
        self._vtk_count = 0

    def write(self, t: float) -> None:
        m = self.model
        if self.skip_until is not None and t <= self.skip_until * (1 + 1e-12) + 1e-300:
            return
        fields = m.output_fields()
        for f in fields:
            if not np.all(np.isfinite(f.x.array)):
                raise FloatingPointError(f"non-finite {f.name} at t = {t:g}: not written")
        for f in fields:
            self.file.write_function(f, t)
        self.vtk.write_function(fields, t)
        # dolfinx 0.5.2 lists each rank's .vtu once per function in the .pvtu: ParaView
        # would load as many overlapping copies; keep one entry per piece
        m.comm.Barrier()
        if m.comm.rank == 0:
            _dedupe_pieces(self._pvd.with_name(f"{self._pvd.stem}{self._vtk_count:06d}.pvtu"))
        self._vtk_count += 1

    def close(self) -> None:
        self.file.close()
        self.vtk.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class AnchorCSV:
    """``anchors.csv``, one row per output time and anchor (rank 0 writes; others no-op)."""

    def __init__(self, path: Path, columns: list[str], comm: MPI.Comm = MPI.COMM_WORLD,
                 append: bool = False):
        self.columns = columns
        self.fh = None
        if comm.rank == 0:
            resume = append and Path(path).is_file()
            self.fh = open(path, "a" if resume else "w", newline="")
            if not resume:
                self.fh.write(",".join(columns) + "\n")
            self.fh.flush()

    def write(self, rows: list[dict]) -> None:
        if self.fh is None:
            return
        cols = self.columns
        self.fh.write("".join(",".join(_cell(row.get(c, "")) for c in cols) + "\n"
                              for row in rows))
        self.fh.flush()

    def close(self) -> None:
        if self.fh is not None:
            self.fh.close()
            self.fh = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _cell(v) -> str:
    if isinstance(v, str):
        return v if not any(ch in v for ch in ',"\n') else '"' + v.replace('"', '""') + '"'
    if isinstance(v, (bool, np.bool_)):
        return str(int(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    x = float(v)
    return "" if not math.isfinite(x) else repr(x)


class MomentsWriter:
    """``moments.xdmf``: composite curvature and moment on a line mesh of its own (rank 0)."""

    def __init__(self, path: Path, points: np.ndarray, comm: MPI.Comm = MPI.COMM_WORLD,
                 keep_until: float | None = None, cells: np.ndarray | None = None):
        """``keep_until``: resume, keeping the frames of an existing file up to that time."""
        self.points0 = np.asarray(points, float)
        self.writer = None
        old = _read_frames(path, keep_until) if comm.rank == 0 and keep_until is not None \
            else []
        if comm.rank == 0:
            import meshio

            path = Path(path).resolve()
            self.writer = meshio.xdmf.TimeSeriesWriter(path)
            cwd = os.getcwd()
            os.chdir(path.parent)  # meshio opens "<stem>.h5" in the current folder
            try:
                self.writer.__enter__()
            finally:
                os.chdir(cwd)
            n = len(points)
            if cells is None:  # one polyline through all points
                cells = np.column_stack([np.arange(n - 1), np.arange(1, n)])
            self.writer.write_points_cells(self.points0, [("line", np.asarray(cells))])
            for t, data in old:
                self.writer.write_data(t, point_data=data)

    def write(self, t: float, positions: np.ndarray, curvature: np.ndarray,
              moment: np.ndarray, stations: np.ndarray) -> None:
        if self.writer is None:
            return
        data = {"displacement": positions - self.points0, "curvature": curvature,
                "moment": moment, "moment_magnitude": np.linalg.norm(moment, axis=1),
                "s": stations}
        for k, v in data.items():
            if not np.all(np.isfinite(v)):
                raise FloatingPointError(f"non-finite composite {k} at t = {t:g}")
        self.writer.write_data(t, point_data=data)

    def dump(self) -> None:
        """Make the file readable as it is now (XML written, HDF5 flushed): checkpoints."""
        if self.writer is not None:
            import meshio

            self.writer.h5_file.flush()
            meshio.xdmf.time_series.write_xml(self.writer.filename, self.writer.xdmf_file)
            _patch_polyline(self.writer.filename)

    def close(self) -> None:
        if self.writer is not None:
            self.writer.__exit__(None, None, None)
            _patch_polyline(self.writer.filename)
            self.writer = None


def _dedupe_pieces(path: Path) -> None:
    """Remove repeated ``<Piece Source=...>`` lines of a .pvtu file (atomically)."""
    if not path.is_file():
        return
    seen, out = set(), []
    for line in path.read_text().splitlines(keepends=True):
        if "<Piece " in line:
            if line.strip() in seen:
                continue
            seen.add(line.strip())
        out.append(line)
    tmp = path.with_suffix(".pvtu.tmp")
    tmp.write_text("".join(out))
    os.replace(tmp, path)


def _patch_polyline(path: Path) -> None:
    """meshio writes line cells as a ``Polyline`` topology without ``NodesPerElement``;
    ParaView's XDMF3 reader aborts on that: add ``NodesPerElement="2"``."""
    path = Path(path)
    text = path.read_text()
    fixed = re.sub(r'TopologyType="Polyline"(?![^>]*NodesPerElement)',
                   'TopologyType="Polyline" NodesPerElement="2"', text)
    if fixed != text:
        tmp = path.with_suffix(path.suffix + ".tmp")
        tmp.write_text(fixed)
        os.replace(tmp, path)


def _read_frames(path: Path, t_max: float) -> list[tuple[float, dict]]:
    """The frames of a meshio XDMF time series up to ``t_max`` (unreadable file: none)."""
    import meshio

    frames = []
    if not Path(path).is_file():
        return frames
    cwd = os.getcwd()
    try:
        os.chdir(Path(path).resolve().parent)
        with meshio.xdmf.TimeSeriesReader(Path(path).name) as reader:
            reader.read_points_cells()
            for k in range(reader.num_steps):
                t, data, _ = reader.read_data(k)
                if t <= t_max * (1 + 1e-12) + 1e-300:
                    frames.append((t, {key: np.array(v) for key, v in data.items()}))
    except Exception:  # noqa: BLE001 - a file cut off by a kill: start it again
        frames = []
    finally:
        os.chdir(cwd)
    return frames


def write_modes(model, modal, path: Path) -> None:
    """Mode shapes to XDMF; mode ``i`` is stored at "time" ``i`` (ParaView's time slider)."""
    with XDMFFile(model.comm, str(path), "w") as f:
        f.write_mesh(model.mesh)
        for i, mode in enumerate(modal.shapes):
            shape = model.displacement_part(mode, "mode_shape")
            f.write_function(shape, float(i + 1))
