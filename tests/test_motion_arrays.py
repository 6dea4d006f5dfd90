"""The motions' and load laws' values at many times at once (what the anchor moment
columns take for a batch of rows) are the single-time values, to the last bit: the rows of
``anchors.csv`` do not depend on how they were batched."""

import numpy as np
import pytest

from cablefem.motion import (
    EllipseMotion,
    HarmonicMotion,
    TableMotion,
    TimeFunction,
    accelerations,
    factors,
)

# times inside and after the ramps below, and the ramp's end itself
TIMES = np.concatenate([np.linspace(0.0, 3.0, 301), [1.5, 2.0, 17.123456789]])


class _UserMotion:
    """A user's motion with the protocol's single-time methods only."""

    def displacement(self, t):
        return np.array([np.sin(t), 0.0, 0.0])

    def velocity(self, t):
        return np.array([np.cos(t), 0.0, 0.0])

    def acceleration(self, t):
        return np.array([-np.sin(t), 0.0, t * t])

    def describe(self):
        return {"type": "user"}


@pytest.mark.parametrize("motion", [
    EllipseMotion(9.9815, [0, 0, 1e-3], [0, 5e-4, 0]),
    EllipseMotion(3.3, [0.1, 0, 1e-3], [0, 5e-4, 0.2], ramp=1.5),
    HarmonicMotion([0.1, 0.0, 0.3], [1.0, 2.0, 3.5], [0.0, 0.4, -1.0], ramp=2.0),
    TableMotion([0.0, 1.0, 2.0, 4.0], [[0, 0, 0], [0.1, 0, 0], [0.3, 0.1, 0], [0, 0, 0.2]]),
    _UserMotion(),
    None,
], ids=["ellipse", "ellipse-ramp", "harmonic-ramp", "table", "user", "at-rest"])
def test_accelerations_are_the_single_time_values(motion):
    many = accelerations(motion, TIMES)
    one = np.array([np.zeros(3) if motion is None else motion.acceleration(float(t))
                    for t in TIMES])
    assert many.shape == (TIMES.size, 3)
    # bit for bit: the same floating-point operations on the same numbers
    assert np.array_equal(many, one)


@pytest.mark.parametrize("law", [
    TimeFunction.constant(), TimeFunction.harmonic(7.3, 0.25),
    TimeFunction.table([0.0, 1.0, 2.5], [0.0, 1.0, -0.5])],
    ids=["constant", "harmonic", "table"])
def test_load_factors_are_the_single_time_values(law):
    assert np.array_equal(factors(law, TIMES), [law.value(float(t)) for t in TIMES])
