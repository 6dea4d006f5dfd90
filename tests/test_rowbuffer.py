"""The row buffer of a run's histories (cablefem.app.rowbuffer): rows appended one at a
time and in blocks come back bit for bit, through its growth, and it holds 8 bytes a
number (16 just after it doubled)."""

from __future__ import annotations

import numpy as np

from cablefem.app.rowbuffer import RowBuffer


def test_rows_come_back_bit_for_bit_through_the_growth():
    rng = np.random.default_rng(1)
    rows = rng.standard_normal((1000, 3)) * 10.0 ** rng.integers(-300, 300, (1000, 3))
    rows[5] = [-0.0, np.inf, np.nan]
    buf = RowBuffer((3,), rows[:10])
    for r in rows[10:500]:
        buf.append(r)
    buf.extend(rows[500:999])
    buf.extend(rows[999:])
    assert len(buf) == 1000
    assert buf.array.tobytes() == rows.tobytes()  # every bit: -0.0, inf, nan included
    assert buf[-1].tobytes() == rows[-1].tobytes()
    assert buf[-20:].tobytes() == rows[-20:].tobytes()
    # 8 bytes a number, at most twice that after a doubling (the first 64 rows aside)
    assert buf._data.nbytes <= 2 * 8 * 3 * 1000


def test_single_numbers_and_an_empty_buffer():
    buf = RowBuffer()
    assert len(buf) == 0 and buf.array.shape == (0,)
    assert RowBuffer((3,)).array.shape == (0, 3)
    for k in range(200):
        buf.append(0.5 * k)
    np.testing.assert_array_equal(buf.array, 0.5 * np.arange(200))
    view = buf[-3:]  # a view stays what it was while rows are added (they go after it)
    buf.extend(np.ones(1000))
    np.testing.assert_array_equal(view, [98.5, 99.0, 99.5])
