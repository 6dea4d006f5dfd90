"""The XDMF time series (cablefem.io.series.Series): a checkpoint appends the frames since the
last one in place instead of rewriting the whole file (whose cost grew with the square of a
run's length), the file is the one a whole write gives, and a file a kill cut in the middle
of an append resumes with its whole frames.

Each rank writes a series of its own (``COMM_SELF``): the same under mpirun."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from conftest import read_series
from mpi4py import MPI

from cablefem.io.series import Series, escape, quoteattr

POINTS = np.column_stack([np.linspace(0.0, 1.0, 5), np.zeros(5), np.zeros(5)])
CELLS = np.array([[i, i + 1] for i in range(4)])


def frame(k: int) -> tuple[dict, dict]:
    """The fields of frame ``k``: values that tell the frames apart."""
    return ({"displacement": np.full((5, 3), 0.1 * k)},
            {"tension": np.arange(4.0) + k})


def write(series: Series, frames) -> None:
    for k in frames:
        point, cell = frame(k)
        series.write(0.5 * k, point, cell)


def open_series(folder, **kw) -> Series:
    return Series(folder, "string", POINTS, CELLS, MPI.COMM_SELF, **kw)


def test_checkpoints_append_in_place_and_give_the_whole_file(tmp_path):
    s = open_series(tmp_path / "a")
    xdmf = tmp_path / "a" / "string.xdmf"
    write(s, range(3))
    s.checkpoint()
    inode = xdmf.stat().st_ino
    first = xdmf.read_bytes()
    write(s, range(3, 5))
    s.checkpoint()
    write(s, range(5, 7))
    s.close()
    # appended where the closing lines were: the same file, its listed part unchanged
    # (a whole rewrite renames a temporary file over it: a new inode)
    assert xdmf.stat().st_ino == inode
    body = first[:-len(b"    </Grid>\n  </Domain>\n</Xdmf>\n")]
    assert xdmf.read_bytes().startswith(body)
    # the bytes a series written whole at its end has (the same frames, one part)
    w = open_series(tmp_path / "b")
    write(w, range(7))
    w.close()
    whole = (tmp_path / "b" / "string.xdmf").read_bytes()
    parts = [xdmf.read_bytes(), whole]
    # the part files differ by name only (three parts against one)
    for k in (1, 2):
        parts[0] = parts[0].replace(f"part-000{k}.h5".encode(), b"part-0000.h5")
    assert parts[0] == parts[1]
    frames = read_series(xdmf)
    assert [t for t, _ in frames] == [0.5 * k for k in range(7)]
    for k, (_, data) in enumerate(frames):
        np.testing.assert_array_equal(data["displacement"], frame(k)[0]["displacement"])
        np.testing.assert_array_equal(data["tension"], frame(k)[1]["tension"])


def test_a_file_not_ending_as_left_is_written_whole(tmp_path):
    s = open_series(tmp_path)
    xdmf = tmp_path / "string.xdmf"
    write(s, range(2))
    s.checkpoint()
    with open(xdmf, "ab") as fh:  # someone else's bytes after the closing lines
        fh.write(b"<!-- not ours -->\n")
    write(s, range(2, 4))
    s.close()
    ET.parse(xdmf)  # well-formed
    assert [t for t, _ in read_series(xdmf)] == [0.0, 0.5, 1.0, 1.5]


@pytest.mark.parametrize("cut", ["inside a frame", "before the closing lines"])
def test_a_file_cut_inside_an_append_resumes_with_its_whole_frames(tmp_path, cut):
    """A kill in the middle of a checkpoint's append leaves the file without its closing
    lines (and maybe half a frame): resuming from the checkpoint before reads its whole
    frames up to that time and writes the file whole again."""
    s = open_series(tmp_path)
    xdmf = tmp_path / "string.xdmf"
    write(s, range(3))
    s.checkpoint()  # frames at t = 0, 0.5, 1.0 listed: the checkpoint a restart uses
    write(s, range(3, 5))
    s.close()
    data = xdmf.read_bytes()
    tail = len(b"    </Grid>\n  </Domain>\n</Xdmf>\n")
    # the file as a kill leaves it: everything up to the new frames' end, or to the
    # middle of the last one
    data = data[:-tail] if cut == "before the closing lines" else data[:-tail - 200]
    xdmf.write_bytes(data)
    with pytest.raises(ET.ParseError):
        ET.fromstring(data)
    r = open_series(tmp_path, resume_after=1.0, expected_frames=3)
    ET.parse(xdmf)  # written whole again
    write(r, range(3, 6))
    r.close()
    frames = read_series(xdmf)
    assert [t for t, _ in frames] == [0.5 * k for k in range(6)]
    np.testing.assert_array_equal(frames[5][1]["tension"], frame(5)[1]["tension"])


@pytest.mark.parametrize("text", ["tension", "a&b<c>d", 'say "x"', "it's", """both ' and \"""",
                                  "line\nbreak\tand\rreturn", "", "displacement-12"])
def test_xml_quoting_is_the_standard_librarys(text):
    """The series quote names and escape file references as ``xml.sax.saxutils`` does (its
    import is left out of a run for the HTTP modules it brings): the same characters out."""
    from xml.sax.saxutils import escape as sax_escape
    from xml.sax.saxutils import quoteattr as sax_quoteattr

    assert quoteattr(text) == sax_quoteattr(text)
    assert escape(text) == sax_escape(text)
