"""The touchdown's recorded rows (cablefem.app.touchdownout.TouchdownRows): the rows of
touchdown.csv kept as each row's line and a row buffer of its numbers; a line's rows, the
figure of a single cable's and of a network's rows."""

from __future__ import annotations

import numpy as np

from cablefem.app.historyplots import touchdown_figure
from cablefem.app.touchdownout import TouchdownRows


def rows_of_a_network() -> list[tuple]:
    """Two cable groups; the first touches at two points at each time (two rows a time),
    the second at one."""
    out = []
    for k in range(300):
        t = 0.1 * k
        out += [(t, "g1", np.nan, 1.0, 0.0, -9.0, 5.0 + np.sin(t)),
                (t, "g1", np.nan, 3.0, 0.0, -9.0, 5.0 + np.sin(t)),
                (t, "g2", np.nan, 7.0, 1.0, -9.0, 2.0 + 0.5 * np.cos(t))]
    return out


def test_the_rows_come_back_and_a_lines_rows_are_its_own():
    rows = rows_of_a_network()
    rec = TouchdownRows()
    rec.extend(rows[:100])
    rec.extend(rows[100:])
    assert len(rec) == len(rows) and rec.lines == [r[1] for r in rows]
    expected = np.array([(r[0],) + r[2:] for r in rows])
    assert rec.values.array.tobytes() == expected.tobytes()  # every bit, NaN included
    g2 = rec.of("g2")
    assert g2.shape == (300, 6)
    np.testing.assert_array_equal(g2[:, 5], [r[6] for r in rows if r[1] == "g2"])


def test_the_touchdown_figure_of_a_network_and_of_a_cable(tmp_path):
    rec = TouchdownRows()
    rec.extend(rows_of_a_network())
    (tmp_path / "net").mkdir()
    (tmp_path / "one").mkdir()
    assert (tmp_path / "net" / touchdown_figure(tmp_path / "net", rec, "SI")).is_file()
    cable = TouchdownRows()
    cable.extend([(0.1 * k, "cable", 300.0 + np.sin(0.1 * k), 0.0, 0.0, -100.0,
                   300.0 + np.sin(0.1 * k)) for k in range(200)])
    assert (tmp_path / "one" / touchdown_figure(tmp_path / "one", cable, "SI")).is_file()
    assert touchdown_figure(tmp_path / "one", TouchdownRows(), "SI") is None
