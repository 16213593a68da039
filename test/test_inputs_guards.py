"""Stamp gate and flood cap: the shared guards of untrusted inputs."""

import math

import numpy as np
import pytest

from safe_legged_c3bf.safety import StampGate, StampVerdict, cap_nearest


def test_stamp_gate_accepts_only_the_window_around_the_receivers_clock():
    gate = StampGate(max_future=0.1, max_age=0.5)
    now = 10.0
    assert gate.check(now, now) is StampVerdict.OK
    assert gate.check(now + 0.1, now) is StampVerdict.OK
    assert gate.check(now + 0.1 + 1e-6, now) is StampVerdict.FUTURE
    assert gate.check(now - 0.5, now) is StampVerdict.OK
    assert gate.check(now - 0.5 - 1e-6, now) is StampVerdict.STALE
    assert gate.check(1.79e9, now) is StampVerdict.FUTURE  # a wall-clock stamp in sim time
    assert gate.check(10.0, 1.79e9) is StampVerdict.STALE  # a sim stamp on a wall clock
    assert gate.check(math.nan, now) is StampVerdict.NON_FINITE
    assert gate.check(math.inf, now) is StampVerdict.NON_FINITE
    assert gate.counts == {"future_stamp": 2, "stale_stamp": 2, "non_finite_stamp": 2}
    assert gate.rejected == 6
    # verdict() judges without counting
    assert gate.verdict(now + 5.0, now) is StampVerdict.FUTURE
    assert gate.rejected == 6


@pytest.mark.parametrize("kwargs", [
    {"max_future": -0.1, "max_age": 1.0}, {"max_future": math.inf, "max_age": 1.0},
    {"max_future": 0.1, "max_age": 0.0}, {"max_future": 0.1, "max_age": math.nan},
])
def test_stamp_gate_rejects_invalid_bounds_by_name(kwargs):
    with pytest.raises(ValueError, match="max_"):
        StampGate(**kwargs)


def test_cap_nearest_keeps_the_nearest_in_order():
    rng = np.random.default_rng(3)
    centers = rng.uniform(-50, 50, size=(10000, 3))
    robot = np.array([1.0, -2.0])
    keep = cap_nearest(centers, robot, 32)
    assert len(keep) == 32 and np.all(np.diff(keep) > 0)
    d = np.linalg.norm(centers[:, :2] - robot, axis=1)
    assert d[keep].max() <= np.sort(d)[31] + 1e-12
    # short lists are kept whole; no reference keeps the first ones; NaN rows count as far
    assert cap_nearest(centers[:5], robot, 32).tolist() == [0, 1, 2, 3, 4]
    assert cap_nearest(centers, None, 3).tolist() == [0, 1, 2]
    bad = np.array([[np.nan, 0.0, 0.0], [5.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    assert cap_nearest(bad, np.zeros(2), 2).tolist() == [1, 2]
