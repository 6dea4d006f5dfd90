"""Tests of cablefem.fatigue against hand calculations and the ASTM E1049-85 example.

Every expected number is worked out by hand in the comments from the formulas of
docs/theory.md §7 / EN 1993-1-9: N = N_C (ds_C/ds)^m1 above the knee, N = N_D (ds_D/ds)^m2
between the knee and the cut-off, no damage below the cut-off; Miner D = sum n_i/N_i.
Histories are sampled 40 times per period, so that cos/sin peaks are samples and the ranges are
exact up to the rounding of cos/sin (relative 1e-15): tolerances of 1e-12 cover that rounding
times slopes <= 5. The S-N curve used mostly: ds_C = 100 (any unit), m1 = 3, m2 = 5, knee at
5e6 (ds_D = 100 (2/5)^(1/3) = 73.68), cut-off at 1e8 (ds_L = ds_D (1/20)^(1/5) = 40.47).
"""

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cablefem import fatigue as fat
from cablefem.io.anchorcsv import ANCHOR_COLUMNS, MOMENT_COLUMNS, read_moments
from cablefem.io.fatiguereport import write_report

DS_C = 100.0
DS_D = DS_C * 0.4 ** (1 / 3)  # (2e6/5e6)^(1/3) ds_C
DS_L = DS_D * 0.05 ** (1 / 5)  # (5e6/1e8)^(1/5) ds_D
DS_MID = DS_D * 2 ** (-1 / 5)  # between knee and cut-off: N = 5e6 * 2 = 1e7 exactly
UNIT = fat.StressSection.effective(1.0, 1.0)  # A = W = 1: sigma = T + M, numbers stay readable
RTOL = 1e-12  # rounding of sampled cos/sin (1e-15) times slopes <= 5, with margin


def cos_history(amplitude: float, periods: int, per: int = 40) -> np.ndarray:
    """amplitude cos(2 pi t) at t = j/per, j = 0..per*periods: starts and ends at a peak."""
    return amplitude * np.cos(2 * np.pi * np.arange(per * periods + 1) / per)


def summed(ranges, counts, value, rel=1e-9):
    """Total count of the cycles whose range is `value` (to `rel`: sampling rounding)."""
    return float(np.sum(counts[np.isclose(ranges, value, rtol=rel, atol=0)]))


# ------------------------------------------------------------------ S-N curve

def test_sn_default_ratios_and_values():
    c = fat.SNCurve(DS_C)
    # (2/5)^(1/3) = 0.73681 and (1/20)^(1/5) = 0.54928: EN 1993-1-9 Fig. 7.1; 1e-15: pow rounding
    assert c.delta_sigma_D / DS_C == pytest.approx((2 / 5) ** (1 / 3), rel=1e-15)
    assert c.delta_sigma_L / c.delta_sigma_D == pytest.approx((1 / 20) ** (1 / 5), rel=1e-15)
    assert c.delta_sigma_D / DS_C == pytest.approx(0.737, abs=5e-4)  # the rounded 0.737
    assert c.delta_sigma_L / c.delta_sigma_D == pytest.approx(0.549, abs=5e-4)
    # above the knee: ds = 200: N = 2e6 (100/200)^3 = 2.5e5; at ds_C: N = N_C = 2e6
    assert c.cycles_to_failure(200.0) == pytest.approx(2.5e5, rel=1e-15)
    assert c.cycles_to_failure(DS_C) == pytest.approx(2e6, rel=1e-15)
    # between: ds = ds_D 2^(-1/5): N = 5e6 (2^(1/5))^5 = 1e7 (rounding of the 1/5 powers)
    assert c.cycles_to_failure(DS_MID) == pytest.approx(1e7, rel=1e-14)
    # below the cut-off and zero range: no damage
    assert c.cycles_to_failure(30.0) == math.inf and c.cycles_to_failure(0.0) == math.inf
    N = c.cycles_to_failure(np.array([200.0, DS_MID, 30.0]))  # vectorised, same values
    np.testing.assert_allclose(N, [2.5e5, 1e7, np.inf], rtol=1e-14)


def test_sn_continuity_at_knee_and_cutoff():
    c = fat.SNCurve(DS_C)
    sd, sl = c.delta_sigma_D, c.delta_sigma_L
    above, below = c.cycles_to_failure(np.nextafter(sd, np.inf)), \
        c.cycles_to_failure(np.nextafter(sd, 0))
    # both branches give N_knee = 5e6 at ds_D: continuous to 1e-12 (rounding of the powers)
    assert above == pytest.approx(5e6, rel=1e-12) and below == pytest.approx(5e6, rel=1e-12)
    assert abs(above - below) / 5e6 < 1e-12
    # the m2 branch reaches N_cutoff = 1e8 at ds_L; just below, no damage
    assert c.cycles_to_failure(sl) == pytest.approx(1e8, rel=1e-12)
    assert c.cycles_to_failure(np.nextafter(sl, 0)) == math.inf


def test_sn_single_slope_and_custom_knee():
    c = fat.SNCurve(160.0, m1=4, knee=False)  # stay-cable wires example: 160 at 2e6, m = 4
    # ds = 16: N = 2e6 * 10^4 = 2e10, no cut-off
    assert c.cycles_to_failure(16.0) == pytest.approx(2e10, rel=1e-15)
    assert c.delta_sigma_D is None and c.delta_sigma_L is None
    c = fat.SNCurve(DS_C, N_knee=1e7, N_cutoff=2e8)
    # ds_D = 100 (2e6/1e7)^(1/3) = 100 * 0.2^(1/3)
    assert c.delta_sigma_D == pytest.approx(DS_C * 0.2 ** (1 / 3), rel=1e-15)


@pytest.mark.parametrize("kw, field", [
    ({"detail_category": 0.0}, "detail_category"), ({"detail_category": math.nan},
                                                   "detail_category"),
    ({"m1": 0.5}, "m1"), ({"m2": math.inf}, "m2"), ({"N_C": -1.0}, "N_C"),
    ({"N_knee": 2e8}, "N_knee"), ({"N_cutoff": 0.0}, "N_cutoff"), ({"knee": "yes"}, "knee")])
def test_sn_validation_names_the_field(kw, field):
    args = {"detail_category": DS_C} | kw
    with pytest.raises(ValueError, match=field):
        fat.SNCurve(**args)


def test_sn_rejects_nan_and_negative_ranges():
    c = fat.SNCurve(DS_C)
    for bad in ([np.nan], [-1.0]):
        with pytest.raises(ValueError, match="delta_sigma"):
            c.cycles_to_failure(bad)


# ------------------------------------------------------------------ rainflow

def test_astm_e1049_example():
    """ASTM E1049-85 (2011) section 5.4.4, Fig. 6 / Table 4: history A..I = -2, 1, -3, 5, -1,
    3, -4, 4, -2. Published counts: range 3: 0.5 (A-B), 4: 1.5 (B-C half, E-F full),
    6: 0.5 (H-I), 8: 1.0 (C-D and G-H halves), 9: 0.5 (D-G); none of 1, 2, 5, 7, 10.
    Means by hand: A-B -0.5, B-C -1, E-F 1, C-D 1, D-G 0.5, G-H 0, H-I 1."""
    r, m, n = fat.rainflow_cycles([-2, 1, -3, 5, -1, 3, -4, 4, -2])
    table = {3.0: 0.5, 4.0: 1.5, 6.0: 0.5, 8.0: 1.0, 9.0: 0.5}
    got = {}
    for ri, ni in zip(r, n):
        got[ri] = got.get(ri, 0.0) + ni
    assert got == table  # small integers: exact
    assert sorted(zip(r, m, n)) == sorted([(3, -0.5, 0.5), (4, -1, 0.5), (4, 1, 1.0),
                                           (8, 1, 0.5), (9, 0.5, 0.5), (8, 0, 0.5),
                                           (6, 1, 0.5)])


def test_rainflow_edge_cases():
    # 2 samples: one half cycle (rainflow 3.2.0 alone counts nothing); constant: no cycle
    r, m, n = fat.rainflow_cycles([1.0, 4.0])
    assert (r.tolist(), m.tolist(), n.tolist()) == ([3.0], [2.5], [0.5])
    assert fat.rainflow_cycles([2.0, 2.0, 2.0])[0].size == 0
    # exactly equal ranges a, -a, ..., a (k = 4 periods): X >= Y with the starting point in Y
    # at every step, so each range is a half cycle: 8 halves of range 2, none full
    r, m, n = fat.rainflow_cycles([1.0, -1.0] * 4 + [1.0])
    assert r.tolist() == [2.0] * 8 and n.tolist() == [0.5] * 8 and m.tolist() == [0.0] * 8
    with pytest.raises(ValueError, match="non-finite.*index 1"):
        fat.rainflow_cycles([0.0, np.nan, 1.0])


# ------------------------------------------------------------------ constant amplitude

@pytest.mark.parametrize("ds, N_hand", [(200.0, 2.5e5),  # 2e6 (100/200)^3
                                        (DS_MID, 1e7),  # 5e6 (ds_D/ds)^5 = 5e6 * 2
                                        (30.0, math.inf)])  # 30 < ds_L = 40.47
def test_constant_amplitude_cosine(ds, N_hand):
    """k periods of (ds/2) cos, starting and ending at a peak: reversals +a, -a, ..., +a, 2k
    equal ranges, k cycles of range ds: ASTM counts exactly equal ranges as half cycles (see
    test_rainflow_edge_cases); the 1-ulp rounding of the sampled peaks pairs some of them
    into full cycles, the total stays k. D = k / N(ds)."""
    k = 7
    r, _, n = fat.rainflow_cycles(5.0 + cos_history(ds / 2, k))  # a mean: no influence
    np.testing.assert_allclose(r, ds, rtol=RTOL)
    assert n.sum() == k
    D = fat.miner_damage(r, n, fat.SNCurve(DS_C))
    if N_hand == math.inf:
        assert D == 0.0  # below the cut-off: exactly no damage
    else:
        assert D == pytest.approx(k / N_hand, rel=RTOL)


def test_constant_amplitude_sine_has_half_cycles_at_the_ends():
    """a sin over k periods: reversals 0, a, -a, ..., a, -a, 0. The two end ranges (0 -> a and
    -a -> 0) are half cycles of range a; the 2k - 1 ranges between are half cycles of 2a,
    k - 1/2 cycles (some paired into full cycles by rounding: the total is what counts).
    D = (k - 1/2)/N(2a) + 2 (1/2)/N(a); ds = 2a = 200: N(200) = 2.5e5, N(100) = 2e6."""
    k = 5
    r, _, n = fat.rainflow_cycles(100.0 * np.sin(2 * np.pi * np.arange(40 * k + 1) / 40))
    assert summed(r, n, 200.0) == k - 0.5 and summed(r, n, 100.0) == 1.0
    assert n.sum() == k + 0.5
    D = fat.miner_damage(r, n, fat.SNCurve(DS_C))
    assert D == pytest.approx((k - 0.5) / 2.5e5 + 1.0 / 2e6, rel=RTOL)


# ------------------------------------------------------------------ blocks, Miner, equivalent

def test_two_level_block_loading_miner():
    """Cycles given directly: D = n1/N1 + n2/N2 = 10/2.5e5 + 400/1e7 = 4e-5 + 4e-5 = 8e-5."""
    D = fat.miner_damage([200.0, DS_MID], [10, 400], fat.SNCurve(DS_C))
    assert D == pytest.approx(8e-5, rel=1e-14)  # rounding of the 1/5 powers in N(DS_MID)


def test_two_level_block_history():
    """n1 = 3 periods of 100 cos (range 200), then n2 = 6 periods of a2 cos (range 2 a2 =
    DS_MID) from the next sample on. Reversals: 100, -100, ..., 100, -a2, a2, ..., a2. Hand
    rainflow: block 1 gives 2 n1 halves of 200 (n1 cycles); in block 2 each -a2 after the first
    closes a full cycle of 2 a2 (n2 - 1), the residue is 200 (-100 -> 100, half), 100 + a2
    (100 -> -a2, half) and 2 a2 (half): n2 - 1/2 cycles of 2 a2 in all.
    D = n1/2.5e5 + (n2 - 1/2)/1e7 + (1/2)/N(100 + a2) with N(100 + a2) = 2e6 (100/(100+a2))^3
    (100 + a2 = 132.1 is above the knee)."""
    n1, n2, a2 = 3, 6, DS_MID / 2
    blk2 = cos_history(a2, n2)[1:]
    r, _, n = fat.rainflow_cycles(np.r_[cos_history(100.0, n1), blk2])
    assert summed(r, n, 200.0) == n1
    assert summed(r, n, DS_MID) == n2 - 0.5
    assert summed(r, n, 100.0 + a2) == 0.5
    assert n.sum() == n1 + n2  # (reversals - 1)/2 = (2 n1 + 1 + 2 n2 - 1)/2, halves: exact
    D = fat.miner_damage(r, n, fat.SNCurve(DS_C))
    hand = n1 / 2.5e5 + (n2 - 0.5) / 1e7 + 0.5 / (2e6 * (DS_C / (DS_C + a2)) ** 3)
    assert D == pytest.approx(hand, rel=RTOL)


def test_equivalent_stress_range():
    """n = (2, 6) cycles of (30, 10), m = 3: sum n ds^3 = 2*27000 + 6*1000 = 60000.
    Over the 8 cycles: 7500^(1/3) = 19.574; over 2e6: (0.03)^(1/3) = 0.3107."""
    ranges, counts = [30.0, 10.0], [2.0, 6.0]
    assert fat.equivalent_stress_range(ranges, counts, 3) == pytest.approx(7500 ** (1 / 3),
                                                                           rel=1e-15)
    e2 = fat.equivalent_stress_range(ranges, counts, 3, n_ref=2e6)
    assert e2 == pytest.approx(0.03 ** (1 / 3), rel=1e-15)
    # single slope: D = sum n ds^m / (N_C ds_C^m) = (ds_E,2e6 / ds_C)^m, here with ds_C = 0.5
    D = fat.miner_damage(ranges, counts, fat.SNCurve(0.5, knee=False))
    assert D == pytest.approx((e2 / 0.5) ** 3, rel=1e-14)
    assert fat.equivalent_stress_range([], [], 3) == 0.0


def test_time_to_failure():
    assert fat.time_to_failure(0.25, 30.0) == 120.0  # 30 / 0.25, exact in binary
    assert fat.time_to_failure(0.0, 30.0) == math.inf
    with pytest.raises(ValueError, match="D"):
        fat.time_to_failure(-1.0, 30.0)
    with pytest.raises(ValueError, match="duration"):
        fat.time_to_failure(0.1, 0.0)


def test_miner_refuses_nan():
    with pytest.raises(ValueError, match="ranges.*non-finite"):
        fat.miner_damage([np.nan], [1.0], fat.SNCurve(DS_C))
    with pytest.raises(ValueError, match="differ in length"):
        fat.miner_damage([1.0, 2.0], [1.0], fat.SNCurve(DS_C))


# ------------------------------------------------------------------ stresses

def test_solid_circle_and_stress():
    s = fat.StressSection.solid_circle(0.02)
    # A = pi 0.02^2/4 = pi 1e-4 = 3.14159e-4; W = pi 0.02^3/32 = pi 2.5e-7 = 7.85398e-7
    assert s.area == pytest.approx(3.141592653589793e-4, rel=1e-15)
    assert s.modulus == pytest.approx(7.853981633974483e-7, rel=1e-15)
    # T = 1000, M = 10: 1000/(pi 1e-4) + 10/(pi 2.5e-7) = (1e7 + 4e7)/pi = 5e7/pi
    sig, ok = fat.anchor_stress([1000.0, 1000.0, 1000.0], [10.0, np.nan, 10.0], [1, 1, 0], s)
    assert sig[0] == pytest.approx(5e7 / np.pi, rel=1e-15)
    assert ok.tolist() == [True, False, False] and np.isnan(sig[1:]).all()  # never zero
    # moment vectors: only the valid (0, 10, 0) defines the plane (the valid = 0 row along x is
    # left out), so fibre 0 = +y gets M . w = 10: the same 5e7/pi; invalid rows: NaN
    Mv = [[0.0, 10.0, 0.0], [np.nan, 0.0, 0.0], [10.0, 0.0, 0.0]]
    sig, ok = fat.anchor_stress([1000.0] * 3, Mv, [1, 1, 0], s, fibres=36)
    assert sig.shape == (3, 36) and ok.tolist() == [True, False, False]
    assert sig[0, 0] == pytest.approx(5e7 / np.pi, rel=1e-15) and np.isnan(sig[1:]).all()
    assert fat.axial_stress(1000.0, s) == pytest.approx(1e7 / np.pi, rel=1e-15)
    assert fat.bending_stress(10.0, s) == pytest.approx(4e7 / np.pi, rel=1e-15)
    for bad, field in ((lambda: fat.StressSection.solid_circle(-1), "diameter"),
                       (lambda: fat.StressSection.effective(0.0, 1.0), "area"),
                       (lambda: fat.StressSection.effective(1.0, "x"), "modulus")):
        with pytest.raises(ValueError, match=field):
            bad()


def test_moment_vector_fibres_vs_magnitude():
    """Moment M = (M0 cos, 0.5 M0 sin, 0) over k periods, T = 0, A = W = 1. The fibre along
    x (e1: the larger axis) sees M0 cos: k cycles of range 2 M0 (as 2k halves, see the cosine
    test), the largest of all fibres (amplitude M0 sqrt(cos^2 + sin^2/4) <= M0). |M| swings
    between M0 and M0/2 twice per period: 2k cycles of range M0/2. Single slope m = 3:
    D_vector = k/N(2 M0), D_|M| = 2k/N(M0/2) = D_vector * 2 * (1/4)^3 = D_vector / 32."""
    k, M0 = 4, 50.0
    t = np.arange(40 * k + 1) / 40
    M = M0 * np.column_stack([np.cos(2 * np.pi * t), 0.5 * np.sin(2 * np.pi * t), 0 * t])
    c = fat.SNCurve(DS_C, knee=False)
    rep = fat.fatigue_report(t, 0 * t, M, None, UNIT, c)
    assert rep["damage"] == pytest.approx(k / (2e6 * (DS_C / (2 * M0)) ** 3), rel=RTOL)
    assert abs(rep["fibre"]["direction"][0]) == pytest.approx(1.0, abs=1e-12)
    mag = fat.fatigue_report(t, 0 * t, np.linalg.norm(M, axis=1), None, UNIT, c)
    assert mag["damage"] == pytest.approx(rep["damage"] / 32, rel=RTOL)
    assert mag["cycles"] == 2 * k and rep["cycles"] == k


# ------------------------------------------------------------------ invalid samples

def _history_with_invalid(k=5):
    """100 cos over k periods + T = 10; samples 3 and 50 (not reversals: 40 per period,
    reversals at multiples of 20) invalid: one by valid = 0, one by an empty (NaN) moment."""
    t = np.arange(40 * k + 1) / 40
    M = cos_history(100.0, k)
    valid = np.ones_like(t)
    valid[3] = 0
    M[50] = np.nan
    return t, np.full_like(t, 10.0), M, valid


def test_invalid_samples_raise_by_default():
    t, T, M, v = _history_with_invalid()
    with pytest.raises(ValueError, match=r"anchor 'p': 2 of 201 samples invalid.*t = 0.075"):
        fat.fatigue_report(t, T, M, v, UNIT, fat.SNCurve(DS_C), anchor="p")
    with pytest.raises(ValueError, match="non-finite"):  # the NaN reaches no counter
        fat.rainflow_cycles(fat.anchor_stress(T, M, v, UNIT)[0])


def test_invalid_samples_dropped_on_request():
    """Dropping two non-reversal samples keeps all reversals: k = 5 cycles of range 200,
    D = 5/2.5e5 = 2e-5; the duration stays 5 (the window's time span)."""
    t, T, M, v = _history_with_invalid()
    rep = fat.fatigue_report(t, T, M, v, UNIT, fat.SNCurve(DS_C), invalid="drop")
    assert rep["dropped_invalid_samples"] == 2 and rep["samples"] == 201
    assert rep["damage"] == pytest.approx(2e-5, rel=RTOL)
    assert rep["cycles"] == 5 and rep["duration"] == 5.0
    with pytest.raises(ValueError, match="invalid must be"):
        fat.fatigue_report(t, T, M, v, UNIT, fat.SNCurve(DS_C), invalid="zero")


# ------------------------------------------------------------------ report

def test_report_numbers_and_window():
    """20 periods of 100 cos (range 200, t = 0..20), then 10 periods of a2 cos (range 2 a2 =
    DS_MID) from the next sample to t = 30. Whole series (as in the block test): D =
    20/2.5e5 + 9.5/1e7 + 0.5/N(100 + a2), time to failure 30/D. Steady window = last third =
    t >= 20: it starts at block 1's last peak 100, then the reversals -a2, a2, ..., a2: the
    same hand rainflow without block 1: D = 9.5/1e7 + 0.5/N(100 + a2), duration 10.
    Window (0, 20): block 1 alone, 20 cycles of 200: D = 20/2.5e5 = 8e-5.
    Axial part alone (T constant): no cycle, D = 0; stress = T + M: max 110, min -90."""
    a2 = DS_MID / 2
    M = np.r_[cos_history(100.0, 20), cos_history(a2, 10)[1:]]
    t = np.arange(M.size) / 40
    T = np.full_like(t, 10.0)
    c = fat.SNCurve(DS_C)
    rep = fat.fatigue_report(t, T, M, np.ones_like(t), UNIT, c)
    hand = 20 / 2.5e5 + 9.5 / 1e7 + 0.5 / (2e6 * (DS_C / (DS_C + a2)) ** 3)
    assert rep["damage"] == pytest.approx(hand, rel=RTOL)
    assert rep["time_to_failure"] == pytest.approx(30.0 / hand, rel=RTOL)
    assert rep["stress"]["max"] == 110.0 and rep["stress"]["min"] == -90.0
    assert rep["damage_axial_only"] == 0.0
    assert rep["damage_bending_only"] == pytest.approx(hand, rel=RTOL)  # = total: T constant
    assert sum(rep["histogram"]["counts"]) == pytest.approx(rep["cycles"], abs=1e-12)
    steady = fat.fatigue_report(t, T, M, None, UNIT, c, window="steady")
    assert steady["window"] == [20.0, 30.0] and steady["duration"] == 10.0
    tail = 9.5 / 1e7 + 0.5 / (2e6 * (DS_C / (DS_C + a2)) ** 3)
    assert steady["damage"] == pytest.approx(tail, rel=RTOL)
    assert steady["time_to_failure"] == pytest.approx(10.0 / tail, rel=RTOL)
    # equivalent range: the 10 cycles (all damaging: DS_MID and 100 + a2 >= ds_L) of one range
    # giving D = tail: N(eq) = 10/tail = 6.55e6 > N_knee, on the m2 = 5 slope:
    # eq = ds_D (5e6 tail/10)^(1/5) (the first-slope moment ((9.5 DS_MID^3 + 0.5 (100 +
    # a2)^3)/10)^(1/3) = 71.5 gave 10/N(71.5) = 1.72e-6, 13 % above D); at N_C: 100 tail^(1/3)
    assert steady["damaging_cycles"] == 10.0
    assert steady["equivalent_range"] == pytest.approx(DS_D * (5e6 * tail / 10) ** 0.2,
                                                       rel=RTOL)
    assert steady["equivalent_range_N_C"] == pytest.approx(DS_C * tail ** (1 / 3), rel=RTOL)
    first = fat.fatigue_report(t, T, M, None, UNIT, c, window=(0.0, 20.0))
    assert first["damage"] == pytest.approx(8e-5, rel=RTOL) and first["cycles"] == 20
    # below the cut-off: D = 0, time to failure infinite -> None with the flag
    low = fat.fatigue_report(t, T, 0.1 * M, None, UNIT, c)
    assert low["damage"] == 0.0 and low["time_to_failure"] is None
    assert low["time_to_failure_infinite"] is True
    with pytest.raises(ValueError, match="window"):
        fat.fatigue_report(t, T, M, None, UNIT, c, window="last")


def test_write_report_files(tmp_path):
    t = np.arange(201) / 40
    c, s = fat.SNCurve(DS_C), fat.StressSection.solid_circle(0.02)
    M = cos_history(0.3, 5)
    reports = {"p": fat.fatigue_report(t, 1000 + 0 * t, M, None, s, c, anchor="p"),
               "q": fat.fatigue_report(t, 1000 + 0 * t, 1e-6 * M, None, s, c, anchor="q")}
    names = write_report(tmp_path, reports, c, s, units="Pa")
    data = json.loads((tmp_path / "fatigue.json").read_text())
    assert data["anchors"]["p"]["damage"] == pytest.approx(reports["p"]["damage"], rel=1e-15)
    assert data["anchors"]["q"]["time_to_failure"] is None  # inf -> null, flagged
    assert data["sn_curve"]["delta_sigma_D"] == pytest.approx(DS_D, rel=1e-15)
    md = (tmp_path / "fatigue.md").read_text()
    assert "## Anchor p" in md and "## Anchor q" in md and "| damage D |" in md
    assert (tmp_path / "fatigue_histogram.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(names)  # no temporary left
    assert data["section"] == {"area": s.area, "modulus": s.modulus}  # common to p and q
    assert "| damage per year | - |" in md  # no year given: not defined, not 0
    # locations of different sections (a network): no top-level section, each its own
    other = fat.StressSection.solid_circle(0.03)
    reports["r"] = fat.fatigue_report(t, 1000 + 0 * t, M, None, other, c, anchor="r")
    write_report(tmp_path, reports, c, units="Pa")
    data = json.loads((tmp_path / "fatigue.json").read_text())
    assert data["section"] is None and data["anchors"]["r"]["section"]["area"] == other.area


# ------------------------------------------------------------------ CSV

# the columns cablefem wrote before error_estimate (optional: older files still read)
HEADER = ",".join(c for c in ANCHOR_COLUMNS + MOMENT_COLUMNS if c != "error_estimate")


def test_read_anchor_csv(tmp_path):
    p = tmp_path / "anchors.csv"
    p.write_text(HEADER + "\n"
                 "0.0,p,1,0,0,25.0,0.02,0.002,0,0.002,0,3.14,0.004,0.002,1\n"
                 "0.0,q,-1,0,0,26.0,,,,,,,,,0\n"
                 "0.5,p,1,0,0,25.5,0.02,0.003,0,0.003,0,3.14,0.004,0.003,1\n"
                 "0.5,q,-1,0,0,26.5,,,,,,,,,0\n")
    d = read_moments(p)
    assert d["p"]["time"].tolist() == [0.0, 0.5] and d["p"]["moment"].tolist() == [0.002, 0.003]
    assert d["p"]["moment_vector"].tolist() == [[0, 0.002, 0], [0, 0.003, 0]]
    assert np.isnan(d["q"]["moment"]).all() and d["q"]["valid"].tolist() == [0, 0]
    assert d["q"]["tension"].tolist() == [26.0, 26.5]


@pytest.mark.parametrize("row, match", [
    ("0.5,p,1,0,0,abc,0.02,0.003,0,0.003,0,3.14,0.004,0.003,1", r":3: column 'tension'"),
    ("0.5,p,1,0,0,25", r":3: 6 fields"),
    (",p,1,0,0,25,0.02,0.003,0,0.003,0,3.14,0.004,0.003,1", r":3: column 'time'"),
    ("0.5,p,1,0,0,25,0.02,0.003,0,0.003,0,3.14,0.004,0.003,2", r":3: column 'valid'"),
    ("0.0,p,1,0,0,25,0.02,0.003,0,0.003,0,3.14,0.004,0.003,1", "not strictly increasing")])
def test_read_anchor_csv_errors(tmp_path, row, match):
    p = tmp_path / "anchors.csv"
    p.write_text(HEADER + "\n0.0,p,1,0,0,25,0.02,0.002,0,0.002,0,3.14,0.004,0.002,1\n"
                 + row + "\n")
    with pytest.raises(ValueError, match=match) as e:
        read_moments(p)
    assert str(p) in str(e.value)
    p.write_text("time,anchor,Nx\n0,p,1\n")
    with pytest.raises(ValueError, match="lacks column.*tension, moment"):
        read_moments(p)


# ------------------------------------------------------------------ properties

def _reversal_count(x: np.ndarray) -> int:
    """Reversals counted independently: drop repeated values, then the end points and every
    interior point where the slope changes sign."""
    y = x[np.r_[True, np.diff(x) != 0]]
    if y.size < 2:
        return y.size
    d = np.diff(y)
    return 2 + int(np.count_nonzero(d[1:] * d[:-1] < 0))


knots = st.lists(st.integers(-1000, 1000), min_size=2, max_size=25)
fill = st.lists(st.integers(0, 6), min_size=24, max_size=24)


def _piecewise_linear(k: list[int], f: list[int]) -> np.ndarray:
    """Integer knots joined by straight segments with f[i] interior samples each."""
    parts = [np.linspace(a, b, n + 2)[:-1] for a, b, n in zip(k[:-1], k[1:], f)]
    return np.r_[np.concatenate(parts), k[-1]]


@settings(max_examples=200, deadline=None)
@given(knots, fill, st.integers(-10**4, 10**4), st.integers(1, 50))
def test_rainflow_properties(k, f, shift, scale):
    """(1) rainflow consumes every range between consecutive reversals once: a half cycle takes
    one range, a full cycle two, so the total count is (reversals - 1)/2 exactly.
    (2) Adding a constant changes no range (integer knots: the reversals and their ranges
    are exact), so the damage is unchanged (mean-insensitive S-N curve).
    (3) Multiplying by c >= 1 multiplies every range by c; with ds_C = 1 every nonzero range
    (>= 1, integer knots) lies above the knee ds_D = 0.74, so D scales as c^m1 = c^3
    (tolerance: rounding of c * range, relative 1e-16 per range, times m1 = 3)."""
    x = _piecewise_linear(k, f)
    r, _, n = fat.rainflow_cycles(x)
    assert n.sum() == (_reversal_count(x) - 1) / 2
    c = fat.SNCurve(1.0)
    D = fat.miner_damage(r, n, c)
    assert fat.miner_damage(*fat.rainflow_cycles(x + shift)[::2], c) == D
    Dc = fat.miner_damage(*fat.rainflow_cycles(scale * x)[::2], c)
    assert Dc == pytest.approx(scale**3 * D, rel=1e-13, abs=0)


# ------------------------------------------------------------------ window after the start-up

def test_default_window_leaves_out_the_start_up(mpi_tmp_path):
    """A case whose anchor motion has the default ramp (3 periods = 19.99 s here) and an
    anchors.csv of test_report_numbers_and_window's history: 20 periods of 100 cos during
    the start-up, then 10 of a2 cos. The default fatigue window ('after_startup') starts at
    the first sample after the ramp, t = 20: the same hand rainflow as that test's steady
    window, D = 9.5/1e7 + 0.5/N(100 + a2) over 10 time units; fatigue.json says which
    window and why. window = 'all' counts the start-up: D = 20/2.5e5 + ... A run that ends
    within the start-up is refused with a message naming the window."""
    from conftest import level_case
    from mpi4py import MPI

    from cablefem.app.fatigue import run_fatigue
    from cablefem.case import parse_case

    comm = MPI.COMM_WORLD
    ramp = 19.99
    w = 3 * 2 * np.pi / ramp  # the default ramp: 3 periods of the motion
    a2 = DS_MID / 2
    M = np.r_[cos_history(100.0, 20), cos_history(a2, 10)[1:]]
    t = np.arange(M.size) / 40

    def write(folder, n):
        if comm.rank == 0:
            folder.mkdir(parents=True, exist_ok=True)
            lines = ["time,anchor,tension,moment,valid"]
            lines += [f"{t[i]!r},{a},10.0,{M[i]!r},1" for i in range(n) for a in ("p", "q")]
            (folder / "anchors.csv").write_text("\n".join(lines) + "\n")
        comm.Barrier()

    def case(**fatigue):
        return parse_case(level_case(
            motion={"type": "harmonic", "amplitude": [2e-4, 0, 0], "omega": w},
            dynamics={"t_end": 30.0, "dt": 0.025},
            fatigue={"detail_category": DS_C, "area": 1.0, "modulus": 1.0, **fatigue}))

    write(mpi_tmp_path / "run", t.size)
    reps = run_fatigue(case(), mpi_tmp_path / "run", comm=comm)
    tail = 9.5 / 1e7 + 0.5 / (2e6 * (DS_C / (DS_C + a2)) ** 3)
    whole = 20 / 2.5e5 + tail
    for name in ("p", "q"):
        assert reps[name]["window"] == [20.0, 30.0]
        assert reps[name]["damage"] == pytest.approx(tail, rel=RTOL)
        assert reps[name]["window_rule"]["rule"] == "after_startup"
        assert reps[name]["window_rule"]["start"] == pytest.approx(ramp, rel=1e-15)
        # an SI case: a year of 365.25 d in s; damage per year over the window's 10 s
        assert reps[name]["year"] == 31557600.0
        assert reps[name]["damage_per_year"] == pytest.approx(tail * 3155760.0, rel=RTOL)
    saved = json.loads((mpi_tmp_path / "run" / "fatigue.json").read_text())
    assert saved["anchors"]["q"]["window_rule"]["rule"] == "after_startup"
    assert saved["units"]["time"] == "s" and saved["section"] == {"area": 1.0, "modulus": 1.0}
    assert "ramp" in saved["anchors"]["q"]["window_rule"]["reason"]
    reps = run_fatigue(case(window="all"), mpi_tmp_path / "run", mpi_tmp_path / "all",
                       comm=comm)
    assert reps["q"]["damage"] == pytest.approx(whole, rel=RTOL)
    assert reps["q"]["window_rule"]["rule"] == "all"
    # 'steady' follows the run's own statistics window, dynamics.statistics_start, when
    # the case sets it (it took the last third, t >= 20, whatever the run's window was):
    # from t = 15 five periods of the start-up's 100 cos count, D = 5/2.5e5 + tail
    reps = run_fatigue(parse_case(level_case(
        motion={"type": "harmonic", "amplitude": [2e-4, 0, 0], "omega": w},
        dynamics={"t_end": 30.0, "dt": 0.025, "statistics_start": 15.0},
        fatigue={"detail_category": DS_C, "area": 1.0, "modulus": 1.0, "window": "steady"})),
        mpi_tmp_path / "run", mpi_tmp_path / "steady", comm=comm)
    assert reps["q"]["window"] == [15.0, 30.0]
    assert reps["q"]["window_rule"] == {"rule": "steady", "start": 15.0,
                                        "reason": "dynamics.statistics_start"}
    assert reps["q"]["damage"] == pytest.approx(5 / 2.5e5 + tail, rel=RTOL)
    write(mpi_tmp_path / "short", 400)  # t <= 9.975: within the start-up
    with pytest.raises(ValueError, match="after_startup"):
        run_fatigue(case(), mpi_tmp_path / "short", comm=comm)


# ------------------------------------------------------------------ the worst direction

def _spatial_history(k=6, per=40):
    """A non-planar moment vector with a mean, and a tension partly in phase with the
    bending: sigma at a direction is not the mirror image of the opposite one's, so an
    uneven set of directions sees the two differently."""
    t = np.arange(per * k + 1) / per
    th = 2 * np.pi * t
    T = 100 + 30 * np.cos(th) + 20 * np.cos(2 * th)
    u, v = np.array([0.3, 1.0, 0.2]), np.array([0.9, -0.25, 0.4])
    M = np.array([5.0, -40.0, 12.0]) + np.outer(60 * np.cos(th), u / np.linalg.norm(u)) \
        + np.outer(25 * np.sin(3 * th + 0.4), v / np.linalg.norm(v))
    return t, T, M


def test_mirror_anchors_equal_damage_for_every_count():
    """Anchor q is the mirror image of anchor p (reflection R = I - 2 n n^T; a moment is an
    axial vector: M_q = -R M_p), so the damage at direction R w of q is that at w of p. The
    scanned set (2 pi k/N and opposites, about the principal axes) is its own mirror image,
    so its best damage agrees to round-off (1e-12: eigenvectors to 1e-15 times m = 4 and
    the sums); the refined worst direction is the same maximum found from mirrored brackets,
    to the search's bracket of 1e-7 rad: this maximum is smooth (no two samples tie there),
    so D is found to ~(1e-7)^2 m: 1e-12 covers it at every count, and for every count.
    Before: the N fibres 2 pi k/N from a signed e1; for odd N the anchors differed."""
    t, T, Mp = _spatial_history()
    n = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    c = fat.SNCurve(160.0, m1=4, knee=False)
    damages = []
    for N in range(4, 38):
        p = fat.fatigue_report(t, T, Mp, None, UNIT, c, fibres=N)
        for sign in (-1, 1):  # -R M: an axial vector's image; R M: the other convention
            Mq = sign * (Mp - 2 * np.outer(Mp @ n, n))
            q = fat.fatigue_report(t, T, Mq, None, UNIT, c, fibres=N)
            assert q["damage"] == pytest.approx(p["damage"], rel=1e-12), (N, sign)
            if "damage_scan" in p["fibre"]:
                assert q["fibre"]["damage_scan"] == pytest.approx(p["fibre"]["damage_scan"],
                                                                  rel=1e-12), (N, sign)
        damages.append(p["damage"])
    np.testing.assert_allclose(damages, max(damages), rtol=1e-12)


def test_count_within_its_bound_of_the_worst_direction():
    """A constant moment M0 (any direction: it moves no range) plus a bending B cos(2 pi t)
    along u in another direction, constant tension: the stress at direction w has the
    ranges |w . u| 2B, so D(w) = |w . u|^m D*, D* = k/N(2B) = k/(2e6 (ds_C/2B)^m) the worst
    (w = u). The reported damage is D* (smooth maximum: the search's 1e-7 rad gives
    1e-14; RTOL); the scan's best is |cos d|^m D*, d the smallest angle from u to a
    scanned direction, and d <= pi/n (n scanned directions) gives D_scan >= cos(pi/n)^m D*
    (fat.scan_bound). Before, the damage reported was that of the best of the N fibres."""
    k, B, m = 5, 70.0, 4.0
    t = np.arange(40 * k + 1) / 40
    u = np.array([np.cos(0.37), np.sin(0.37), 0.0])
    M = np.array([30.0, -10.0, 0.0]) + np.outer(B * np.cos(2 * np.pi * t), u)
    c = fat.SNCurve(160.0, m1=m, knee=False)
    worst = k / (2e6 * (160.0 / (2 * B)) ** m)
    for N in range(4, 38):
        rep = fat.fatigue_report(t, 0 * t + 50.0, M, None, UNIT, c, fibres=N)
        assert rep["damage"] == pytest.approx(worst, rel=RTOL), N
        assert abs(np.dot(rep["fibre"]["direction"], u)) == pytest.approx(1.0, abs=1e-12)
        w = fat.fibre_directions(M, None, N)
        scan = worst * np.max(np.abs(w @ u)) ** m
        assert rep["fibre"]["damage_scan"] == pytest.approx(scan, rel=RTOL), N
        bound = math.cos(math.pi / (N if N % 2 == 0 else 2 * N)) ** m
        assert fibres_bound(N, m) == pytest.approx(bound, rel=1e-15)
        assert rep["fibre"]["damage_scan"] >= bound * worst * (1 - RTOL), N


def fibres_bound(N, m):
    from cablefem.fibres import scan_bound

    return scan_bound(N, m)


def test_equivalent_range_reproduces_the_damage_with_knee_and_cut_off():
    """Cycles 10 x 200 (N = 2.5e5), 400 x DS_MID (N = 1e7), 1000 x 30 (below ds_L = 40.5: no
    damage): D = 4e-5 + 4e-5 = 8e-5 over n_d = 410 damaging cycles; N(ds_eq) = 410/8e-5 =
    5.125e6 > N_knee: ds_eq = ds_D (5e6/5.125e6)^(1/5) on the m2 slope, and 410 cycles of it
    give D again (1e-14: rounding of the powers). At N_C: ds_C D^(1/3) = 100 * 0.0431."""
    c = fat.SNCurve(DS_C)
    r, n = [200.0, DS_MID, 30.0], [10.0, 400.0, 1000.0]
    eq, nd = fat.damage_equivalent_range(r, n, c)
    assert nd == 410.0
    assert eq == pytest.approx(DS_D * (5e6 / 5.125e6) ** 0.2, rel=1e-14)
    assert 410 / c.cycles_to_failure(eq) == pytest.approx(8e-5, rel=1e-14)
    # single slope: the m-th moment over the cycles, as equivalent_stress_range
    one = fat.SNCurve(DS_C, knee=False)
    assert fat.damage_equivalent_range(r, n, one)[0] == pytest.approx(
        fat.equivalent_stress_range(r, n, 3), rel=1e-14)
    assert fat.damage_equivalent_range([30.0], [5.0], c) == (None, 0.0)  # D = 0: none
    # the same in a report: 3 blocks of cosines (their transitions add half cycles); the
    # report's equivalent range reproduces its damage over its damaging cycles
    M = np.r_[cos_history(100.0, 10), cos_history(DS_MID / 2, 40)[1:],
              cos_history(15.0, 100)[1:]]
    t = np.arange(M.size) / 40
    rep = fat.fatigue_report(t, 0 * t, M, None, UNIT, c)
    rr, _, cc = fat.rainflow_cycles(M)
    nd = float(np.sum(cc[rr >= c.delta_sigma_L]))
    # 10 of 200, 39.5 of DS_MID, the halves 100 + DS_MID/2 and DS_MID/2 + 15 = 51.8 >= ds_L
    assert nd == pytest.approx(10 + 39.5 + 0.5 + 0.5, abs=1e-12)
    assert nd / c.cycles_to_failure(rep["equivalent_range"]) == pytest.approx(
        rep["damage"], rel=1e-13)
    assert (rep["equivalent_range_N_C"] / DS_C) ** 3 == pytest.approx(rep["damage"], rel=1e-13)


def test_report_definitions_duration_samples_window_year():
    """docs/fatigue.md's definitions. 100 cos over 5 periods (t = 0..5, 40 per period) with
    the last 11 samples (t = 4.75..5) invalid and dropped: `duration` is still the window's
    last minus first sample time, 5 - 1 = 4 for the window (1, 5) (its start is a sample:
    in); `samples` counts the dropped rows (161 in the window, 11 invalid, 150 valid). The
    valid history 1..4.725 holds the peaks at t = 1, 1.5, ..., 4.5: 7 halves of 200
    (3.5 cycles: D = 3.5/2.5e5) and the half -100 -> 100 cos(2 pi 4.725) = -15.6 at the end.
    Damage per year: D times 365.25 * 86400 / duration. The error message names the
    command line's --invalid drop."""
    t = np.arange(201) / 40
    M = cos_history(100.0, 5)
    v = np.where(t >= 4.75, 0.0, 1.0)
    c = fat.SNCurve(DS_C, knee=False)
    rep = fat.fatigue_report(t, 0 * t, M, v, UNIT, c, window=(1.0, 5.0), invalid="drop",
                             year=fat.YEAR_SECONDS)
    assert rep["window"] == [1.0, 5.0] and rep["duration"] == 4.0
    assert (rep["samples"], rep["valid_samples"], rep["dropped_invalid_samples"]) == \
        (161, 150, 11)
    last = 100 + 100 * np.cos(2 * np.pi * 4.725)  # the final half from the trough -100
    hand = 3.5 / 2.5e5 + 0.5 / (2e6 * (DS_C / last) ** 3)
    assert rep["damage"] == pytest.approx(hand, rel=RTOL)
    assert fat.YEAR_SECONDS == 31557600.0  # 365.25 * 86400, exact
    assert rep["year"] == 31557600.0
    assert rep["damage_per_year"] == pytest.approx(hand * 31557600.0 / 4.0, rel=RTOL)
    assert rep["section"] == {"area": 1.0, "modulus": 1.0}
    plain = fat.fatigue_report(t, 0 * t, M, None, UNIT, c)
    assert plain["year"] is None and plain["damage_per_year"] is None  # no year given
    with pytest.raises(ValueError, match="--invalid drop"):
        fat.fatigue_report(t, 0 * t, M, v, UNIT, c)


def test_dropped_samples_are_joined_into_one_history():
    """0 -> 100 (valid), gap, -100 -> 0 (valid): joined, the reversals 0, 100, -100, 0 give
    the halves 100, 200, 100 (1.5 cycles, D = 0.5/N(200) + 2 * 0.5/N(100), single slope
    100, m = 3); the pieces counted apart would give two halves of 100 and miss the 200."""
    t = np.arange(5.0)
    M = np.array([0.0, 100.0, np.nan, -100.0, 0.0])
    rep = fat.fatigue_report(t, 0 * t, M, None, UNIT, fat.SNCurve(DS_C, knee=False),
                             invalid="drop")
    assert rep["max_range"] == 200.0 and rep["cycles"] == 1.5
    assert rep["damage"] == pytest.approx(0.5 / 2.5e5 + 2 * 0.5 / 2e6, rel=1e-15)
