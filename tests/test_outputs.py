"""The field series under MPI (also run by ``.ci/mpitest`` on 2 ranks): gathered to rank 0
in the mesh's order whatever the partition, and resumed from a checkpoint collectively,
ending with the files of the uninterrupted run."""

from __future__ import annotations

import json

import numpy as np
from conftest import read_series
from mpi4py import MPI

from cablefem.app.run import run_case

comm = MPI.COMM_WORLD


def test_series_resumed_and_partitioned(mpi_tmp_path, make_case):
    """A run to t = 0.15 s, then resumed (``restart=True``, the API) to 0.3 s from its
    last checkpoint (t = 0.1 s: what it wrote after it is discarded) equals the
    uninterrupted 0.3 s run on the same ranks (same operations: exactly, to round-off), and
    the partitioned fields equal a run on one rank (direct solvers: 1e-9, as in
    test_network)."""
    case = make_case(elements=8, damping={"ratio": 0.005, "frequencies": [16.407, 32.814]},
                     motion={"type": "harmonic", "amplitude": [2e-4, 0, 0],
                             "omega": 32.814},
                     dynamics={"t_end": 0.3, "dt": 0.005, "fields_every": 4,
                               "checkpoint_every": 10})
    kw = dict(figures=False, progress=False, modes=0)
    ref = run_case(case, mpi_tmp_path / "ref", comm, **kw)
    part = run_case(case, mpi_tmp_path / "resumed", comm, t_end=0.15, **kw)
    assert part.times[-1] == 0.15
    res = run_case(case, mpi_tmp_path / "resumed", comm, restart=True, t_end=0.3, **kw)
    assert res.summary["restarted_from"] == 0.1
    np.testing.assert_allclose(res.times, ref.times, rtol=0, atol=0)
    for name in ref.forces:  # repeated operations: round-off
        np.testing.assert_allclose(res.forces[name], ref.forces[name], rtol=1e-12)
    for key in ("steps", "newton_iterations", "rejected_steps", "outputs"):
        assert res.summary["dynamics"][key] == ref.summary["dynamics"][key]
    if comm.rank == 0:
        one = run_case(case, mpi_tmp_path / "one", MPI.COMM_SELF, **kw)
        assert one.summary["status"] == "completed"
        for name in ("string.xdmf", "moments.xdmf"):
            a = read_series(mpi_tmp_path / "resumed" / name)
            b = read_series(mpi_tmp_path / "ref" / name)
            c = read_series(mpi_tmp_path / "one" / name)
            assert [t for t, _ in a] == [t for t, _ in b] == [t for t, _ in c]
            assert len(a) == 1 + 60 // 4  # t = 0 and every 4th of 60 steps
            for (_, da), (_, db), (_, dc) in zip(a, b, c):
                for key in db:
                    np.testing.assert_allclose(da[key], db[key], rtol=1e-12, atol=1e-15)
                    scale = max(np.max(np.abs(dc[key])), 1e-300)
                    np.testing.assert_allclose(db[key], dc[key], rtol=1e-9,
                                               atol=1e-9 * scale)
        ls = lambda d: sorted(str(p.relative_to(d)) for p in d.rglob("*"))  # noqa: E731
        assert ls(mpi_tmp_path / "resumed") == ls(mpi_tmp_path / "ref")
        s = json.loads((mpi_tmp_path / "resumed" / "summary.json").read_text())
        assert s["status"] == "completed" and s["mpi_ranks"] == comm.size
    comm.Barrier()


def test_a_new_run_leaves_nothing_of_the_last_one(mpi_tmp_path):
    """A run into a folder that holds another case's outputs (a point load: kinks.csv, a
    damper, figures, modes) ends with exactly the files of the same run into an empty
    folder: nothing stale that ``cablefem fatigue`` or ParaView would read as this run's
    (kinks.csv was left behind, and fatigue reported the old run's kink)."""
    from cablefem.case import parse_case

    base = {"title": "t", "section": {"EA": 1e6, "EI": 1.0, "mass": 1.0},
            "gravity": {"g": 0.0}, "geometry": {"length": 9.9},
            "mesh": {"elements": 20},
            "anchors": [{"name": "p", "position": [0.0, 0, 0], "type": "clamped"},
                        {"name": "q", "position": [10.0, 0, 0], "type": "pinned"}],
            "dynamics": {"t_end": 0.01, "dt": 0.005}}
    rich = dict(base, point_loads=[{"s": 4.0, "value": [0.0, 0.0, -100.0]}],
                dampers=[{"anchor": "p", "distance": 0.5, "coefficient": 100.0,
                          "direction": [0.0, 0, 1]}])
    run_case(parse_case(rich), mpi_tmp_path / "reused", comm, progress=False, modes=2)
    kw = dict(figures=False, progress=False, modes=0)
    run_case(parse_case(base), mpi_tmp_path / "reused", comm, **kw)
    run_case(parse_case(base), mpi_tmp_path / "clean", comm, **kw)
    if comm.rank == 0:
        ls = lambda d: sorted(str(p.relative_to(d)) for p in d.rglob("*"))  # noqa: E731
        assert ls(mpi_tmp_path / "reused") == ls(mpi_tmp_path / "clean")
    comm.Barrier()


def test_a_field_waiting_for_its_rows_block_is_the_field_written_at_once(
        mpi_tmp_path, make_case, monkeypatch):
    """moments.xdmf's frames wait for their row's block of layers (the anchors.csv rows
    are computed in blocks); with no wait at all (every frame flushing its block at once,
    the route before) the composite fields, anchors.csv and every field time are the same
    to the last bit: the same layers of the same rows. Field times off the output rows
    (fields_every 3, output_every 2) and a checkpoint are in the run."""
    from cablefem.app.output import RunOutput

    case = make_case(elements=8, damping={"ratio": 0.005, "frequencies": [16.407, 32.814]},
                     motion={"type": "harmonic", "amplitude": [2e-4, 0, 0],
                             "omega": 32.814},
                     dynamics={"t_end": 0.2, "dt": 0.005, "fields_every": 3,
                               "output_every": 2, "checkpoint_every": 15})
    kw = dict(figures=False, progress=False, modes=0)
    waited = run_case(case, mpi_tmp_path / "waited", comm, **kw)
    monkeypatch.setattr(RunOutput, "WAITING_BYTES", -1)  # every frame written at once
    at_once = run_case(case, mpi_tmp_path / "at_once", comm, **kw)
    for name in waited.forces:
        assert np.array_equal(waited.forces[name], at_once.forces[name])
    if comm.rank == 0:
        a = read_series(mpi_tmp_path / "waited" / "moments.xdmf")
        b = read_series(mpi_tmp_path / "at_once" / "moments.xdmf")
        assert [t for t, _ in a] == [t for t, _ in b] and len(a) > 10
        for (_, fa), (_, fb) in zip(a, b):
            assert fa.keys() == fb.keys()
            for key in fa:
                assert np.array_equal(fa[key], fb[key]), key
        assert ((mpi_tmp_path / "waited" / "anchors.csv").read_text()
                == (mpi_tmp_path / "at_once" / "anchors.csv").read_text())


def test_a_runs_histories_hold_about_8_bytes_a_number(make_case, mpi_tmp_path, monkeypatch):
    """What the run keeps of its rows until the reports (times, anchor forces, moment
    columns) in row buffers: at most 24 bytes a number. A float64 is 8 bytes, 16 just
    after its buffer doubled; each row also holds one pointer per clamped anchor for its
    reason (why it is invalid) and, with a virtual hinge, one for its range flag (4 x 8
    bytes over 27 numbers). In lists (before) it was above 40: a Python float is 24 bytes
    and its list pointer 8, a force row a NumPy view of over 100."""
    import tracemalloc

    from cablefem.app import output

    case = make_case(elements=8, dynamics={"t_end": 5.0, "dt": 0.005, "fields_every": 10**6,
                                           "checkpoint_every": 0})
    held = {}
    close = output.RunOutput.close

    def measured_close(self):
        close(self)  # every row flushed
        snap = tracemalloc.take_snapshot().filter_traces(
            [tracemalloc.Filter(True, output.__file__, all_frames=True)])
        held["bytes"] = sum(s.size for s in snap.statistics("filename"))
        # a row: its time, 3 force components per anchor, 10 moment columns per clamp
        held["numbers"] = len(self.times) * (1 + 3 * len(self.forces)
                                             + 10 * len(self.columns))

    monkeypatch.setattr(output.RunOutput, "close", measured_close)
    tracemalloc.start(12)
    try:
        run_case(case, mpi_tmp_path / "run", comm, figures=False, progress=False, modes=0)
    finally:
        tracemalloc.stop()
    assert held["numbers"] == 1001 * 27
    assert held["bytes"] / held["numbers"] < 24
