"""The XDMF time series for ParaView (``string.xdmf``, ``moments.xdmf``, ``modes.xdmf``) and
the cleaning of an output folder, MPI-correct (rank 0 writes).

Every output survives a kill at any instant: what a killed run leaves is either complete or
discarded by ``cablefem run --restart`` (``docs/outputs.md``).

* ``string.xdmf``: the string's fields over time, one grid per time holding every field
  (ParaView shows one dataset per time): ``displacement`` (from the stress-free reference,
  which is the mesh), ``dynamic_displacement`` (from the static state), ``velocity`` (point
  data), ``tension``, ``strain`` (cell data), and a rod's extra fields. Gathered to rank 0
  and written there with h5py, see :class:`Series`.
* ``moments.xdmf``: the composite curvature and bending moment on a line mesh of its own,
  graded towards the clamped anchors (rank 0). Its points are the static deformed
  positions; ``dynamic_displacement`` moves them to the current ones.
* ``series/<name>/``: the heavy data of both: ``mesh.h5`` and one ``part-NNNN.h5`` per
  checkpoint interval.

``anchors.csv`` is :mod:`cablefem.io.anchorcsv`'s, ``summary.json`` :mod:`cablefem.io.summary`'s.
"""

from __future__ import annotations

import os
import re
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from dolfinx.io import XDMFFile
from mpi4py import MPI

from cablefem.errors import OutputError
from cablefem.io.faults import kill_point
from cablefem.io.summary import jsonable, write_json

__all__ = ["StringWriter", "MomentsWriter", "Series", "OutputError",
           "write_json", "write_modes", "jsonable", "clean_outputs", "remove_temporaries",
           "SERIES"]

SERIES = "series"  #: the folder of the series' HDF5 data, under the output folder
#: the XDMF file's closing lines, after its frames; a frame's grid ends with _FRAME_END
_TAIL = b"    </Grid>\n  </Domain>\n</Xdmf>\n"
_FRAME_END = b"\n      </Grid>\n"


class Series:
    """A time series of fields on a fixed line mesh: ``<name>.xdmf`` and its data under
    ``series/<name>/`` (``mesh.h5``, ``part-NNNN.h5``), written by rank 0 with h5py.

    Built to survive a kill at any instant: the frames go to a part file, which is closed
    and a new one started at every checkpoint (:meth:`checkpoint`), and the XDMF file (one
    grid per time with every field, XML of our own) lists them from then on. The XDMF file
    is written whole, atomically (a temporary file renamed), when the series starts or
    resumes; at a checkpoint and at :meth:`close` only the frames since the last one are
    written, over the file's closing lines, which follow them (:meth:`_write_xml`): the
    cost of a checkpoint does not grow with the frames before it (rewriting the whole
    file made a long run's checkpoints cost the square of its length: 8000 frames, 1.7 s
    against 0.05 s). A kill can only damage the part written after the last checkpoint,
    which the XDMF file does not list yet, and, when it falls inside such an append, the
    XDMF file's end (it then lacks its closing lines: resuming repairs it). Resuming
    (``resume_after``) keeps the XDMF file's frames up to that time (there must be
    ``expected_frames`` of them: a lost frame is an error, never silent), deletes every
    part they do not use, and continues in a new part. All methods are collective; only
    rank 0 holds data. A frame costs its arrays only: no barrier, no XML file written (each
    grid's XML is serialised once, with its frame).

    Args:
        outdir: The output folder.
        name: The series' name (``<name>.xdmf``).
        points: (n, 3) node positions (rank 0; None on the others).
        cells: (m, 2) line cells (rank 0; None on the others).
        comm: MPI communicator.
        resume_after: Resume after this time (s), or None for a new series.
        expected_frames: The frames the XDMF file must hold up to ``resume_after``.
    """

    def __init__(self, outdir: Path, name: str, points: np.ndarray | None,
                 cells: np.ndarray | None, comm: MPI.Comm = MPI.COMM_WORLD,
                 resume_after: float | None = None, expected_frames: int | None = None):
        self.comm = comm
        self.name = name
        self.xdmf = Path(outdir) / f"{name}.xdmf"
        self.rel = f"{SERIES}/{name}"
        self.dir = Path(outdir) / SERIES / name
        self._xml: list[bytes] = []  # each frame's grid, serialised once (see _write_xml)
        #: frames the XDMF file lists, and the offset of its closing lines (None: the file
        #: is to be written whole)
        self._listed, self._end = 0, None
        self.h5 = None
        self.part = 0
        error = None
        if comm.rank == 0:
            try:
                self._setup(np.asarray(points, float), np.asarray(cells, np.int64),
                            resume_after, expected_frames)
            except (OSError, ValueError, ET.ParseError) as err:
                error = f"{self.xdmf}: {err}"
        error = comm.bcast(error, root=0)
        if error is not None:
            raise OutputError(error)

    def _setup(self, points, cells, resume_after, expected_frames) -> None:
        import h5py

        self.dir.mkdir(parents=True, exist_ok=True)
        self.n_points, self.n_cells = len(points), len(cells)
        tmp = self.dir / "mesh.h5.tmp"
        tmp.unlink(missing_ok=True)  # a killed run's: never open an HDF5 file it had open
        with h5py.File(tmp, "w") as f:
            f["points"] = points
            f["cells"] = cells
        os.replace(tmp, self.dir / "mesh.h5")
        grids = []
        if resume_after is not None:
            grids = _frames_until(self.xdmf, resume_after)
            if expected_frames is not None and len(grids) != expected_frames:
                raise ValueError(f"{len(grids)} frames up to t = {resume_after:g} s, "
                                 f"the checkpoint says {expected_frames}: frames were lost")
            self._xml = [_serialise(g) for g in grids]
        used = {item.text.strip().split(":")[0].rsplit("/", 1)[-1]
                for grid in grids for item in grid.iter("DataItem")}
        for f in self.dir.iterdir():  # parts of a replaced or killed run
            if f.name.startswith("part-") and f.name not in used:
                f.unlink()
        nums = [int(n[5:9]) for n in used if n.startswith("part-")]
        self.part = max(nums) + 1 if nums else 0
        self._write_xml()

    @property
    def frames(self) -> int:
        """Frames written (rank 0; 0 elsewhere)."""
        return len(self._xml)

    def write(self, t: float, point_data: dict, cell_data: dict | None = None) -> None:
        """Append a frame (rank 0's arrays; the other ranks pass anything)."""
        if self.comm.rank != 0:
            return
        import h5py

        if self.h5 is None:
            self.h5 = h5py.File(self.dir / f"part-{self.part:04d}.h5", "w")
        k = len(self._xml)
        group = h5py.h5g.create(self.h5.id, f"f{k:06d}".encode())
        lines = [f'      <Grid Name={quoteattr(f"{self.name}-{k}")} GridType="Uniform">',
                 '        <Topology TopologyType="Polyline" NodesPerElement="2" '
                 f'NumberOfElements="{self.n_cells}">',
                 _item_xml(10, (self.n_cells, 2), "Int", f"{self.rel}/mesh.h5:/cells"),
                 "        </Topology>", '        <Geometry GeometryType="XYZ">',
                 _item_xml(10, (self.n_points, 3), "Float", f"{self.rel}/mesh.h5:/points"),
                 "        </Geometry>", f'        <Time Value="{float(t)!r}" />']
        first = True
        for center, data in (("Node", point_data), ("Cell", cell_data or {})):
            for key, arr in data.items():
                arr = np.ascontiguousarray(arr, dtype=np.float64)
                _dataset(h5py, group, key, arr)
                if first:
                    kill_point(f"frame-{self.name}")
                    first = False
                kind = "Scalar" if arr.ndim == 1 else ("Vector" if arr.shape[1] == 3
                                                       else "Matrix")
                lines += [f"        <Attribute Name={quoteattr(key)} AttributeType=\"{kind}\" "
                          f'Center="{center}">',
                          _item_xml(10, arr.shape, "Float",
                                    f"{self.rel}/part-{self.part:04d}.h5:/f{k:06d}/{key}"),
                          "        </Attribute>"]
        lines.append("      </Grid>\n")
        self._xml.append("\n".join(lines).encode())

    def checkpoint(self) -> None:
        """Close the current part (the next frame starts a new one) and rewrite the XDMF
        file: everything written so far is complete and listed."""
        if self.comm.rank == 0:
            if self.h5 is not None:
                self.h5.close()
                self.h5 = None
                self.part += 1
            self._write_xml()

    def close(self) -> None:
        self.checkpoint()

    def _write_xml(self) -> None:
        """List every frame in the XDMF file, from the grids' XML serialised when their
        frames were written (nothing is serialised twice). The first time (and whenever
        the file does not end as this writer left it) the whole file, to a temporary file,
        then renamed; afterwards the frames not yet listed, written where the closing
        lines begin, then the closing lines again."""
        if self._end is not None and self._appendable():
            new = b"".join(self._xml[self._listed:])
            with open(self.xdmf, "r+b") as fh:
                fh.seek(self._end)
                fh.write(new)
                fh.flush()
                kill_point("xml")  # the frames written, the closing lines not yet
                fh.write(_TAIL)
                fh.truncate()
            self._end += len(new)
        else:
            head = (f'<?xml version="1.0"?>\n<Xdmf Version="3.0">\n  <Domain>\n    <Grid '
                    f'Name={quoteattr(self.name)} GridType="Collection" '
                    'CollectionType="Temporal">\n').encode()
            body = b"".join([head, *self._xml])
            tmp = self.xdmf.with_name(self.xdmf.name + ".tmp")
            with open(tmp, "wb") as fh:
                fh.write(body + _TAIL)
            kill_point("xml")
            os.replace(tmp, self.xdmf)
            self._end = len(body)
        self._listed = len(self._xml)

    def _appendable(self) -> bool:
        """The XDMF file ends with its closing lines where this writer put them."""
        try:
            with open(self.xdmf, "rb") as fh:
                fh.seek(self._end)
                return fh.read(len(_TAIL) + 1) == _TAIL
        except OSError:
            return False


def _serialise(grid: ET.Element) -> bytes:
    """A frame's grid as its lines of the XDMF file (indented at its depth there)."""
    grid.tail = None
    ET.indent(grid, space="  ", level=3)
    return b"      " + ET.tostring(grid, encoding="utf-8", xml_declaration=False) + b"\n"


def escape(data: str) -> str:
    """``&``, ``<`` and ``>`` as XML entities, as ``xml.sax.saxutils.escape`` does: that
    module imports ``urllib.request`` and with it HTTP and e-mail parsing, 30 ms at every
    start of a run."""
    return data.replace("&", "&amp;").replace(">", "&gt;").replace("<", "&lt;")


def quoteattr(data: str) -> str:
    """``data`` as a quoted XML attribute value, as ``xml.sax.saxutils.quoteattr`` does:
    escaped, with line breaks and tabs as character references, in double quotes (single
    ones when it holds a double quote and no single one)."""
    data = escape(data).replace("\n", "&#10;").replace("\r", "&#13;").replace("\t", "&#9;")
    if '"' not in data:
        return f'"{data}"'
    if "'" not in data:
        return f"'{data}'"
    return '"' + data.replace('"', "&quot;") + '"'


def _item_xml(indent: int, shape, kind: str, ref: str) -> str:
    """A DataItem pointing into an HDF5 file, as :func:`_serialise` would write it."""
    return (f'{" " * indent}<DataItem Dimensions="{" ".join(map(str, shape))}" '
            f'NumberType="{kind}" Precision="8" Format="HDF">{escape(ref)}</DataItem>')


def _dataset(h5py, group, name: str, arr: np.ndarray) -> None:
    """``arr`` (float64, C order) as a contiguous dataset ``name`` of ``group`` (an h5py
    group id): h5py's low-level calls, a quarter of ``create_dataset``'s time."""
    space = h5py.h5s.create_simple(arr.shape)
    dset = h5py.h5d.create(group, name.encode(), h5py.h5t.IEEE_F64LE, space)
    dset.write(h5py.h5s.ALL, h5py.h5s.ALL, arr)


def _frames_until(path: Path, t_max: float) -> list[ET.Element]:
    """The grids of a :class:`Series`' XDMF file with ``time <= t_max``. A file a kill
    left without its closing lines (in the middle of an append) is read up to its last
    whole frame."""
    if not path.is_file():
        raise ValueError("no such file: the run to resume did not write it")
    data = path.read_bytes()
    try:
        root = ET.fromstring(data)
    except ET.ParseError:
        end = data.rfind(_FRAME_END)
        if end < 0:
            raise
        root = ET.fromstring(data[:end + len(_FRAME_END)] + _TAIL)
    coll = next((g for g in root.iter("Grid") if g.get("CollectionType") == "Temporal"),
                None)
    if coll is None:
        raise ValueError("not a time series written by cablefem")
    out = []
    for grid in coll.findall("Grid"):
        if float(grid.find("Time").get("Value")) <= t_max * (1 + 1e-12) + 1e-300:
            out.append(grid)
    return out


class _SeriesWriter:
    """What the two series writers share: their :class:`Series` (``self.series``), its frame
    count, checkpoint and close; a context manager."""

    series: Series

    @property
    def frames(self) -> int:
        return self.series.frames

    def checkpoint(self) -> None:
        self.series.checkpoint()

    def close(self) -> None:
        self.series.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class StringWriter(_SeriesWriter):
    """``string.xdmf``: the string's fields over time (collective; see :class:`Series`).

    The fields are gathered to rank 0 in the order of the reference geometry's nodes and
    cells (the mesh's input order), whatever the partition.

    Args:
        model: The cable model whose fields are written.
        outdir: The output folder.
        resume_after: Resume after this time (s), or None.
        expected_frames: The frames expected up to ``resume_after``.
    """

    def __init__(self, model, outdir: Path, resume_after: float | None = None,
                 expected_frames: int | None = None) -> None:
        self.model = model
        geo = model.geometry
        self._maps: dict = {}
        self.static = model.gather_nodal(model.u_static)
        self.series = Series(outdir, "string", geo.points, geo.cells, model.comm,
                             resume_after, expected_frames)

    def _gather(self, f) -> np.ndarray | None:
        """``f`` (P1 or DG0, any block size) at the reference nodes or cells, on rank 0."""
        m = self.model
        S = f.function_space
        key = id(S)
        if key not in self._maps:
            geo = m.geometry
            cellwise = S.ufl_element().degree() == 0
            n_owned = S.dofmap.index_map.size_local
            if cellwise:  # a cell's dof: its reference cell, checked by the midpoints
                targets = 0.5 * (geo.points[geo.cells[:, 0]] + geo.points[geo.cells[:, 1]])
                dofs = np.asarray(S.dofmap.list.array, np.int64)
                ref = m.line.reference_cells()
                idx = np.full(n_owned, -1, np.int64)
                if dofs.size == ref.size:  # one dof a cell; an owned cell's is owned
                    owned = dofs < n_owned
                    idx[dofs[owned]] = ref[owned]
                xyz = S.tabulate_dof_coordinates()[:n_owned]
                scale = max(1.0, float(np.max(np.abs(geo.points))))
                ok = not (idx.size and (idx.min() < 0 or np.max(np.abs(xyz - targets[idx]))
                                        > 1e-8 * scale))
            else:  # by the cells (a split clamp's nodes share a point)
                targets = geo.points
                try:
                    idx, ok = m.line.dof_nodes(S)[:n_owned], True
                except RuntimeError:
                    idx, ok = np.zeros(n_owned, np.int64), False
            allidx = m.comm.gather(idx, root=0)
            if m.comm.rank == 0:
                allidx = np.concatenate(allidx)
                ok = ok and allidx.size == len(targets) and \
                    np.unique(allidx).size == len(targets)
            if not m.comm.allreduce(ok, op=MPI.LAND):
                raise OutputError(f"could not map the dofs of {f.name} to the mesh's "
                                  f"{'cells' if cellwise else 'nodes'}")
            self._maps[key] = (idx, n_owned, S.dofmap.index_map_bs, len(targets))
        idx, n_owned, bs, n = self._maps[key]
        parts = m.comm.gather((idx, f.x.array[: bs * n_owned].reshape(-1, bs).copy()),
                              root=0)
        if m.comm.rank != 0:
            return None
        out = np.empty((n, bs))
        for i, vals in parts:
            out[i] = vals
        return out[:, 0] if bs == 1 else out

    def write(self, t: float) -> None:
        m = self.model
        fields = m.output_fields()
        values = {f.name: self._gather(f) for f in fields}
        bad = None
        if m.comm.rank == 0:
            bad = next((k for k, v in values.items() if not np.all(np.isfinite(v))), None)
        bad = m.comm.bcast(bad, root=0)
        if bad is not None:
            raise FloatingPointError(f"non-finite {bad} at t = {t:g}: not written")
        point, cell = {}, {}
        for f in fields:
            (cell if f.function_space.ufl_element().degree() == 0 else point)[f.name] = \
                values[f.name]
            if f.name == "displacement" and m.comm.rank == 0:
                point["dynamic_displacement"] = values[f.name] - self.static
        self.series.write(t, point, cell)


class MomentsWriter(_SeriesWriter):
    """``moments.xdmf``: composite curvature and moment on a line mesh of its own (data on
    rank 0; collective, see :class:`Series`). The mesh's points are the static deformed
    positions; ``dynamic_displacement`` moves them to the current ones.

    Args:
        outdir: The output folder.
        points: (n, 3) static deformed positions of the stations.
        comm: MPI communicator.
        resume_after: Resume after this time (s), or None.
        expected_frames: The frames expected up to ``resume_after``.
        cells: (m, 2) line cells; None: one polyline through all points.
    """

    def __init__(self, outdir: Path, points: np.ndarray, comm: MPI.Comm = MPI.COMM_WORLD,
                 resume_after: float | None = None, expected_frames: int | None = None,
                 cells: np.ndarray | None = None):
        self.comm = comm
        self.points0 = np.asarray(points, float)
        n = len(self.points0)
        if cells is None:  # one polyline through all points
            cells = np.column_stack([np.arange(n - 1), np.arange(1, n)])
        self.series = Series(outdir, "moments", self.points0, cells, comm, resume_after,
                             expected_frames)

    def write(self, t: float, positions: np.ndarray, curvature: np.ndarray,
              moment: np.ndarray, stations: np.ndarray) -> None:
        bad = None
        if self.comm.rank == 0:
            data = {"dynamic_displacement": positions - self.points0, "curvature": curvature,
                    "moment": moment, "moment_magnitude": np.linalg.norm(moment, axis=1),
                    "s": stations}
            bad = next((k for k, v in data.items() if not np.all(np.isfinite(v))), None)
        bad = self.comm.bcast(bad, root=0)
        if bad is not None:
            raise FloatingPointError(f"non-finite composite {bad} at t = {t:g}")
        if self.comm.rank == 0:
            self.series.write(t, data)


#: what a run writes into its folder, removed before a new (not resumed) run: the current
#: layout and the one before it (string.pvd, one .pvtu/.vtu per frame, string.h5, ...)
_RUN_OUTPUTS = ("summary.json", "anchors.csv", "kinks.csv", "touchdown.csv", "dampers.csv",
                "string.xdmf",
                "string.h5", "moments.xdmf", "moments.h5", "modes.xdmf", "modes.h5",
                "checkpoint.npz",
                "string.pvd", "string_restart.pvd", "anchor_moments.png", "anchor_polar.png",
                "fatigue.json", "fatigue.md", "fatigue_histogram.png",
                "anchor_tensions.png", "touchdown.png", "kink_moments.png", "dampers.png")
_RUN_PATTERNS = (re.compile(r"string(_restart)?\d{6}\.pvtu"),
                 re.compile(r"string(_restart)?_p\d+_\d{6}\.vtu"))


#: the temporary files of the atomic writes (temporary file, then rename) of a run
_TEMPORARIES = ("summary.json.tmp", "anchors.csv.tmp", "kinks.csv.tmp", "touchdown.csv.tmp",
                "dampers.csv.tmp",
                "checkpoint.npz.tmp.npz", "string.xdmf.tmp", "moments.xdmf.tmp")


def remove_temporaries(outdir: Path, comm: MPI.Comm = MPI.COMM_WORLD) -> None:
    """Remove the temporary files a killed run left (rank 0; collective).

    Args:
        outdir: The output folder.
        comm: MPI communicator.
    """
    if comm.rank == 0:
        for name in _TEMPORARIES:
            (Path(outdir) / name).unlink(missing_ok=True)
    comm.Barrier()


def clean_outputs(outdir: Path, comm: MPI.Comm = MPI.COMM_WORLD) -> None:
    """Remove the outputs of an earlier run from ``outdir`` (rank 0; collective), so that
    a new run leaves no stale frame, checkpoint or figure. Other files are left alone.

    Args:
        outdir: The output folder.
        comm: MPI communicator.
    """
    if comm.rank == 0 and Path(outdir).is_dir():
        outdir = Path(outdir)
        shutil.rmtree(outdir / SERIES, ignore_errors=True)
        for f in outdir.iterdir():
            if f.is_file() and (f.name in _RUN_OUTPUTS or
                                any(p.fullmatch(f.name) for p in _RUN_PATTERNS)):
                f.unlink()
    remove_temporaries(outdir, comm)


def write_modes(model, modal, path: Path) -> None:
    """Mode shapes to XDMF; mode ``i`` is stored at "time" ``i`` (ParaView's time slider).

    Args:
        model: The cable model.
        modal: The modal result (its ``shapes``).
        path: The XDMF file.
    """
    with XDMFFile(model.comm, str(path), "w") as f:
        f.write_mesh(model.mesh)
        for i, mode in enumerate(modal.shapes):
            shape = model.displacement_part(mode, "mode_shape")
            f.write_function(shape, float(i + 1))
