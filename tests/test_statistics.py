"""The steady-state statistics' window (``dynamics.statistics_start``), its drift test (a
response still building up or decaying in the window warns) and the whole run's peak
beside the window's (cablefem.app.statistics, docs/outputs.md)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import level_case
from mpi4py import MPI

from cablefem.app.run import run_case
from cablefem.app.statistics import DRIFT_LIMIT, drift, steady_state_stats
from cablefem.case import CaseError, parse_case

comm = MPI.COMM_WORLD
W1 = 15.71  # rad/s: the level test cable's first (out-of-plane) mode on 20 elements


def test_drift_of_a_steady_and_a_building_up_sinusoid():
    """A steady sinusoid with three periods in each half of the window: the halves' RMS
    differ by at most 2/(4 pi 3) = 5.3 % (the part period left over); the window's peak,
    RMS and the whole run's peak are the sinusoid's (sampling: 1e-3). A sinusoid building
    up as 1 - exp(-t/tau) over a run of length tau: the last third's halves have the RMS of
    the envelope at their midpoints, 0.75 tau and 0.917 tau, to O((W/tau)^2) = 1 %:
    drift 1 - 0.5276/0.6002 = 0.121, above the limit."""
    t = np.linspace(0.0, 9.0, 9001)  # the window [6, 9]: 3 periods per half of length 1.5
    v = 2.0 + np.sin(2 * np.pi * t / 0.5 + 0.3)
    st = steady_state_stats(t, v)
    assert st["window"] == pytest.approx([6.0, 9.0])
    assert abs(st["drift"]) < 2 / (4 * np.pi * 3) < DRIFT_LIMIT
    assert st["peak"] == pytest.approx(3.0, rel=1e-3)
    assert st["rms"] == pytest.approx(np.sqrt(4.5), rel=1e-3)
    assert st["run_peak"] == pytest.approx(3.0, rel=1e-3)
    tau = 30.0
    t = np.linspace(0.0, tau, 30001)
    v = (1 - np.exp(-t / tau)) * np.sin(20.0 * t)
    d, size = drift(t[t >= 2 * tau / 3], v[t >= 2 * tau / 3])
    want = 1 - (1 - np.exp(-0.75)) / (1 - np.exp(-11 / 12))
    assert d == pytest.approx(want, abs=0.01) and d > DRIFT_LIMIT
    assert size == pytest.approx(1.0, abs=1e-3)  # mean ~0 (part period): all fluctuation


def test_whole_run_peak_before_the_window():
    """A random-looking history whose largest value falls before the window: the window's
    peak is below it, and the whole run's peak and its time are reported beside it."""
    t = np.linspace(0.0, 60.0, 6001)
    v = 30.0 + 0.5 * np.sin(3.1 * t) * np.sin(0.37 * t) + 2.0 * np.exp(-((t - 37) / 0.3) ** 2)
    st = steady_state_stats(t, v)
    assert st["run_peak_time"] == pytest.approx(37.0, abs=0.02)
    assert st["run_peak"] > st["peak"] + 1.0


def _driven(tmp, ratio: float, t_end: float, **dynamics) -> dict:
    """The level test cable driven out of plane at its first mode, Rayleigh ratio
    ``ratio``, from rest without a ramp: the response builds up with the time constant
    1/(ratio W1)."""
    d = level_case(elements=20, motion={"type": "harmonic", "amplitude": [0, 1e-3, 0],
                                        "omega": W1, "ramp": 0},
                   damping={"ratio": ratio, "frequencies": [10.0, 30.0]},
                   dynamics={"t_end": t_end, "dt": 0.005, "fields_every": 1000,
                             **dynamics}, modal={"modes": 2})
    res = run_case(parse_case(d), tmp, comm, figures=False, progress=False)
    return res.summary


def _drift_warnings(summary) -> list[str]:
    return [w["key"] for w in summary["warnings"] if "in the statistics window" in
            w["message"]]


def test_a_run_too_short_for_its_damping_warns(mpi_tmp_path):
    """Damping ratio 0.5 %: time constant 1/(0.005 x 15.7) = 13 s, the run 1 s long: the
    response grows almost linearly through the window [0.67, 1]; both anchors warn, the
    message naming the remedy. Ratio 30 %: time constant 0.2 s, the window at 3.3 to 5
    time constants: steady (the transient is down to exp(-3.3) = 4 %), no warning."""
    short = _driven(mpi_tmp_path / "short", 0.005, 1.0)
    st = short["anchors"]["p"]["steady_state_moment"]
    assert st["drift"] > DRIFT_LIMIT
    assert sorted(_drift_warnings(short)) == ["anchors.p", "anchors.q"]
    msg = next(w["message"] for w in short["warnings"] if "statistics window" in
               w["message"])
    assert "building up" in msg and "dynamics.t_end" in msg and \
        "dynamics.statistics_start" in msg
    steady = _driven(mpi_tmp_path / "steady", 0.3, 1.0)
    assert abs(steady["anchors"]["p"]["steady_state_moment"]["drift"]) < DRIFT_LIMIT
    assert _drift_warnings(steady) == []


def test_statistics_start_sets_the_window(mpi_tmp_path):
    """dynamics.statistics_start = 0.2 s: the statistics and the validity summary run from
    0.2 s, not from the last third (0.33 s)."""
    s = _driven(mpi_tmp_path / "start", 0.3, 0.5, statistics_start=0.2)
    a = s["anchors"]["p"]
    assert a["steady_state_moment"]["window"] == pytest.approx([0.2, 0.5])
    assert a["validity"]["window"][0] == pytest.approx(0.2)
    assert s["statistics_start"] == 0.2


@pytest.mark.parametrize("start, fragment", [(1.0, "must be < t_end"), (-1.0, ">= 0"),
                                             ("late", "number")])
def test_bad_statistics_start_is_refused(start, fragment):
    d = level_case(dynamics={"t_end": 1.0, "dt": 0.01, "statistics_start": start})
    with pytest.raises(CaseError) as info:
        parse_case(d)
    assert any(k == "dynamics.statistics_start" and fragment in m
               for k, m in info.value.problems), info.value.problems
