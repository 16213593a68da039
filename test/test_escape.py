"""The unicycle emergency escape (filtering/escape.py): pure roll-out choice, no ROS."""

from __future__ import annotations

import math

import numpy as np
import pytest

from safe_legged_c3bf.filtering.escape import unicycle_escape

LIMITS = dict(
    offset=0.2, max_speed=0.2, max_reverse_speed=0.08, max_yaw_rate=0.4, max_accel=0.3,
    max_yaw_accel=1.0, horizon=2.0,
)


def choose(center, velocity=(0.0, 0.0), radius=0.6, pose=(0.0, 0.0, 0.0), v=(0.0, 0.0)):
    return unicycle_escape(
        pose, v, np.array([center], float), np.array([velocity], float), np.array([radius]),
        **LIMITS,
    )


def test_static_obstacle_ahead_is_left_backwards():
    choice = choose((0.5, 0.0))
    assert choice.speed < 0.0


def test_static_obstacle_behind_is_left_forwards():
    choice = choose((-0.4, 0.0))
    assert choice.speed == pytest.approx(LIMITS["max_speed"])
    assert choice.yaw_rate == 0.0  # straight away: turning would swing the body point back


def test_walker_faster_than_the_reverse_limit_is_escaped_forwards_out_of_its_path():
    # A walker ahead-left coming at the robot at 0.16 m/s, twice the reverse limit: backing
    # off loses ground, turning right and walking forward leaves its path.
    choice = choose((0.45, 0.25), velocity=(-0.14, -0.08))
    assert choice.speed == pytest.approx(LIMITS["max_speed"])
    assert choice.yaw_rate < 0.0


def test_score_is_the_clearance_summed_over_the_roll_out():
    # Far from everything, standing still: clearance constant = distance - radius.
    choice = choose((10.0, 0.0), radius=1.0, v=(0.0, 0.0))
    steps = math.ceil(LIMITS["horizon"] / 0.1)
    assert choice.score >= 0.1 * steps * (10.0 - 0.2 - 1.0) - 1e-9


def test_ties_keep_the_current_motion():
    # Nothing near: every candidate keeps ample clearance, moving away scores more, but in
    # a symmetric case (obstacle far behind and ahead equally) the current motion is kept.
    choice = unicycle_escape(
        (0.0, 0.0, 0.0), (0.0, 0.0), np.array([[0.2, 50.0], [0.2, -50.0]]), np.zeros((2, 2)),
        np.array([0.5, 0.5]), **LIMITS,
    )
    assert choice.yaw_rate == 0.0
