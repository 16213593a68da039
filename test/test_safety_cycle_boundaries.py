"""Boundaries of the safety filter cycle, one cycle at a time (no ROS, no closed loop).

Each test pins one rule of ``SafetyFilterCycle.step`` at its edge, through the public
interface only (``step``, ``CycleOutput``, ``FilterParams``): the staleness timeouts at
+-epsilon, braking at exactly ``brake_decel``, the dt clamp, obstacle prediction from the
obstacle stamp, the status of every kind of cycle, the velocity limits, anti-windup and the
height range. Every limit is read from the parameters, never hard-coded.

The commanded velocity is "primed" by one fresh cycle whose measured velocity equals the
reference: the first cycle starts the integrator from the measured velocity and, with no
obstacle and nothing to track, passes it on unchanged. Sim times are large (``T0``) so a
mistake in the period arithmetic cannot hide behind t = 0.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from safe_legged_c3bf.c3bf import FilterStatus, InvalidInputError
from safe_legged_c3bf.interfaces.base_state import BaseState, yaw_to_quaternion
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.safety.obstacle_input import ObstacleInput
from safe_legged_c3bf.safety.params import FilterParams
from safe_legged_c3bf.safety.safety_cycle import CycleStatus, SafetyFilterCycle

P = FilterParams()
PERIOD = 1.0 / P.rate
T0 = 10.0
Z_MID = 0.5 * (P.min_height + P.max_height)  # inside the height range: vz is free
# Timeouts that differ from each other and from the defaults: a check reading the wrong
# parameter fails with one of the two sets.
DISTINCT_TIMEOUTS = P.updated(odom_timeout=0.13, obstacles_timeout=0.31, reference_timeout=0.67)
STILL = VelocityCommand()
TIMEOUT_PARAMS = pytest.mark.parametrize(
    "params", [P, DISTINCT_TIMEOUTS], ids=["defaults", "distinct_timeouts"]
)


def base(t, v=STILL, x=0.0, y=0.0, z=Z_MID, yaw=0.0) -> BaseState:
    """Odometry stamped ``t`` moving at ``v`` (body frame; level, so body vz = odom vz)."""
    return BaseState(
        position=(x, y, z),
        orientation=yaw_to_quaternion(yaw),
        linear_velocity=(v.vx, v.vy, v.vz),
        angular_velocity=(0.0, 0.0, v.yaw_rate),
        stamp=t,
    )


def obstacle(center, velocity=(0.0, 0.0, 0.0), radius=0.25, plane=0, extent=1.0, oid="o"):
    return ObstacleInput(
        oid, plane, np.array(center, float), np.array(velocity, float),
        np.array([radius, radius], float), extent,
    )


def primed(v: VelocityCommand, params: FilterParams = P, t: float = T0) -> SafetyFilterCycle:
    """A cycle whose command is ``v`` after one fresh cycle at ``t`` (robot moving at v)."""
    cycle = SafetyFilterCycle(params)
    out = cycle.step(t, v, t, base(t, v), [], t)
    assert out.status is CycleStatus.INACTIVE, out.text
    np.testing.assert_allclose(out.command.as_array(), v.as_array(), atol=1e-12)
    return cycle


def toward_zero(x: float, step: float) -> float:
    return 0.0 if abs(x) <= step else x - math.copysign(step, x)


def assert_braked(before: VelocityCommand, after: VelocityCommand, dt: float, decel: float):
    """Every axis moved towards zero by exactly ``decel * dt``, stopping at zero."""
    want = [toward_zero(x, decel * dt) for x in before.as_array()]
    np.testing.assert_allclose(after.as_array(), want, rtol=0.0, atol=1e-9)


def tracked_vx(params: FilterParams, v: float, ref: float, dt: float) -> float:
    """Forward speed after one unobstructed cycle tracking ``ref`` from ``v``."""
    return v + max(-params.max_accel, min(params.max_accel, params.k_v * (ref - v))) * dt


# --------------------------------------------------------------------------- timeouts
@TIMEOUT_PARAMS
@pytest.mark.parametrize("which", ["odom", "obstacles", "reference"])
@pytest.mark.parametrize("side", ["under", "at", "over"])
def test_each_timeout_at_its_boundary(params, which, side):
    """An input exactly ``timeout`` old is fresh (the rule is "older than"); 1 us older is
    stale: odometry or obstacles then brake at ``brake_decel``, a reference becomes zero and
    is tracked by the filter."""
    timeout = getattr(params, f"{which}_timeout")
    eps = 1e-6
    age = {"under": timeout - eps, "at": timeout, "over": timeout + eps}[side]
    # At t = 2 age the subtraction t - (t - age) is exact (Sterbenz): "at" is exactly on it.
    t = 2.0 * age if side == "at" else T0
    v0 = VelocityCommand(0.4)
    cycle = primed(v0, params, t - PERIOD)
    stamps = {"odom": t, "obstacles": t, "reference": t}
    stamps[which] = t - age
    assert (t - stamps[which] > timeout) == (side == "over")  # the premise, in floats
    ref = VelocityCommand(params.max_speed)
    out = cycle.step(t, ref, stamps["reference"], base(stamps["odom"], v0), [],
                     stamps["obstacles"])
    if side != "over":
        assert out.status is CycleStatus.INACTIVE, out.text
        assert not out.reference_stale
        assert out.command.vx == pytest.approx(tracked_vx(params, 0.4, ref.vx, PERIOD), abs=1e-9)
        assert out.command.vx > v0.vx
    elif which == "reference":
        assert out.status is CycleStatus.INACTIVE, out.text
        assert out.reference_stale and out.reference.is_zero()
        assert "reference stale" in out.text
        assert out.command.vx == pytest.approx(tracked_vx(params, 0.4, 0.0, PERIOD), abs=1e-9)
    else:
        assert out.status is CycleStatus.STALE_INPUT, out.text
        assert ("odometry" if which == "odom" else "obstacles") in out.text
        assert_braked(v0, out.command, PERIOD, params.brake_decel)


# --------------------------------------------------------------------------- braking
STALE_CAUSES = {
    "odom_never": lambda t: (None, [], t),
    "odom_old": lambda t: (base(t - 1.0), [], t),
    "obstacles_never": lambda t: (base(t), None, None),
    "obstacles_old": lambda t: (base(t), [], t - 1.0),
}


@pytest.mark.parametrize("cause", sorted(STALE_CAUSES))
@pytest.mark.parametrize(
    "model, v0",
    [
        # 0.51 and 0.61 are not multiples of brake_decel * period: the last step must stop
        # at zero, not overshoot.
        ("unicycle", VelocityCommand(0.51, 0.0, -0.05, 0.61)),
        ("unicycle", VelocityCommand(-0.25, 0.0, 0.05, -0.61)),
        ("holonomic", VelocityCommand(0.51, -0.23, -0.05, 0.61)),
        ("holonomic", VelocityCommand(-0.25, 0.23, 0.05, -0.61)),
    ],
    ids=["unicycle+", "unicycle-", "holonomic+", "holonomic-"],
)
def test_stale_input_brakes_every_axis_at_exactly_brake_decel(cause, model, v0):
    params = P.updated(model=model, offset=0.0 if model == "holonomic" else P.offset)
    cycle = primed(v0, params)
    step = params.brake_decel * PERIOD
    n = math.ceil(max(abs(x) for x in v0.as_array()) / step) + 3
    prev = v0
    for k in range(1, n + 1):
        t = T0 + k * PERIOD
        b, obs, obs_t = STALE_CAUSES[cause](t)
        out = cycle.step(t, VelocityCommand(params.max_speed), t, b, obs, obs_t)
        assert out.status is CycleStatus.STALE_INPUT
        assert_braked(prev, out.command, PERIOD, params.brake_decel)
        # never past zero: each axis keeps its sign or is exactly zero
        assert np.all(out.command.as_array() * v0.as_array() >= 0.0)
        prev = out.command
    assert prev.is_zero()


# --------------------------------------------------------------------------- dt clamp
def test_first_cycle_integrates_one_nominal_period():
    cycle = SafetyFilterCycle(P)
    out = cycle.step(T0, VelocityCommand(P.max_speed), T0, base(T0, VelocityCommand(0.2)), [],
                     T0)
    assert out.command.vx == pytest.approx(tracked_vx(P, 0.2, P.max_speed, PERIOD), abs=1e-12)


def test_long_gap_brakes_for_at_most_two_periods():
    v0 = VelocityCommand(0.5, 0.0, -0.05, 0.6)
    cycle = primed(v0)
    t = T0 + 1.0  # 50 periods later, odometry lost
    out = cycle.step(t, VelocityCommand(P.max_speed), t, None, [], t)
    assert out.status is CycleStatus.STALE_INPUT
    assert_braked(v0, out.command, 2.0 * PERIOD, P.brake_decel)
    assert out.command.vx > 0.4


def test_long_gap_with_fresh_inputs_integrates_at_most_two_periods():
    gap = 0.75 * P.odom_timeout
    assert gap > 2.0 * PERIOD  # the premise: a gap the clamp shortens, inputs still fresh
    cycle = primed(VelocityCommand(0.2))
    t = T0 + gap
    out = cycle.step(t, VelocityCommand(P.max_speed), t, base(t, VelocityCommand(0.2)), [], t)
    assert out.status is CycleStatus.INACTIVE, out.text
    want = tracked_vx(P, 0.2, P.max_speed, 2.0 * PERIOD)
    assert out.command.vx == pytest.approx(want, abs=1e-12)


@pytest.mark.parametrize("t_next", [T0, T0 - 0.1], ids=["same_stamp", "backwards"])
def test_repeated_or_backward_stamp_integrates_a_quarter_period(t_next):
    # braking
    v0 = VelocityCommand(0.5, 0.0, -0.05, 0.6)
    cycle = primed(v0)
    out = cycle.step(t_next, VelocityCommand(P.max_speed), t_next, None, [], t_next)
    assert out.status is CycleStatus.STALE_INPUT
    assert_braked(v0, out.command, 0.25 * PERIOD, P.brake_decel)
    # tracking
    cycle = primed(VelocityCommand(0.2))
    out = cycle.step(t_next, VelocityCommand(P.max_speed), t_next,
                     base(t_next, VelocityCommand(0.2)), [], t_next)
    assert out.status is CycleStatus.INACTIVE, out.text
    want = tracked_vx(P, 0.2, P.max_speed, 0.25 * PERIOD)
    assert out.command.vx == pytest.approx(want, abs=1e-12)


# --------------------------------------------------------------------------- prediction
def _one_obstacle_cycle(ob: ObstacleInput, stamp: float):
    cycle = primed(VelocityCommand(0.5), t=T0 - PERIOD)
    return cycle.step(T0, VelocityCommand(0.5), T0, base(T0, VelocityCommand(0.5)), [ob], stamp)


def _same_output(a, b):
    assert a.status is b.status, (a.text, b.text)
    assert a.obstacle_ids == b.obstacle_ids
    np.testing.assert_allclose(a.result.h, b.result.h, rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(a.command.as_array(), b.command.as_array(), rtol=0.0, atol=1e-9)


def test_obstacle_from_a_past_stamp_is_predicted_to_now():
    """An obstacle seen ``age`` s ago at c moving at v is filtered where it is now,
    c + v age: the same output as the same obstacle stamped now at c + v age.

    The obstacle recedes ahead of the robot faster than it walks: where it is now it is no
    threat (INACTIVE); where it was when seen (prediction dropped) h is much smaller, and where
    it was twice as long ago (sign flipped) the robot is inside its circle (EMERGENCY_BRAKE).
    """
    age = 0.8 * P.obstacles_timeout
    v = np.array([1.0, 0.0, 0.0])
    now = np.array([1.6, 0.0, 0.5])
    seen = now - age * v
    out = _one_obstacle_cycle(obstacle(seen, v), T0 - age)
    expected = _one_obstacle_cycle(obstacle(now, v), T0)
    _same_output(out, expected)
    assert out.status is CycleStatus.INACTIVE, out.text
    # The scenario is sensitive to both mistakes (the premise of this test):
    dropped = _one_obstacle_cycle(obstacle(seen, v), T0)
    assert abs(float(dropped.result.h[0]) - float(out.result.h[0])) > 0.1
    flipped = _one_obstacle_cycle(obstacle(seen - age * v, v), T0)
    assert flipped.status is CycleStatus.EMERGENCY_BRAKE
    # inside the circle, but the obstacle recedes faster: leaving, so it is not braked
    assert "leaving" in flipped.text and float(flipped.result.h[0]) < 0.0


def test_bar_from_a_past_stamp_is_kept_or_dropped_where_it_is_now():
    """A bar sliding along y: when seen it was beside the robot (ignored), now it is across
    the robot's path (kept)."""
    age = 0.8 * P.obstacles_timeout
    half_span = 0.5 * 1.0 + 0.5 * P.robot_width + P.horizontal_y_margin  # extent 1.0
    v = np.array([0.0, 1.0, 0.0])
    now = np.array([1.5, -(half_span - 0.1), 0.42])  # 0.1 m inside the span
    seen = now - age * v  # age * |v| = 0.4 m further out: beside
    bar = {"radius": 0.05, "plane": 1, "extent": 1.0, "oid": "bar"}
    out = _one_obstacle_cycle(obstacle(seen, v, **bar), T0 - age)
    _same_output(out, _one_obstacle_cycle(obstacle(now, v, **bar), T0))
    assert out.obstacle_ids == ["bar"]
    assert _one_obstacle_cycle(obstacle(seen, v, **bar), T0).obstacle_ids == []  # premise


# --------------------------------------------------------------------------- statuses
def _integrated(before: VelocityCommand, out, dt: float = PERIOD) -> np.ndarray:
    """The unicycle command (vx, vz, wz) expected from integrating ``out.u_safe``."""
    a, alpha, az = out.u_safe
    return np.array([before.vx + a * dt, before.vz + az * dt, before.yaw_rate + alpha * dt])


def _unicycle_axes(cmd: VelocityCommand) -> np.ndarray:
    return np.array([cmd.vx, cmd.vz, cmd.yaw_rate])


def test_inactive_passes_the_tracked_reference():
    cycle = primed(VelocityCommand(0.4), t=T0 - PERIOD)
    out = cycle.step(T0, VelocityCommand(P.max_speed), T0, base(T0, VelocityCommand(0.4)),
                     [obstacle((-3.0, 0.0, 0.5))], T0)  # behind the robot
    assert out.status is CycleStatus.INACTIVE, out.text
    np.testing.assert_array_equal(out.u_safe, out.u_reference)
    assert out.command.vx == pytest.approx(tracked_vx(P, 0.4, P.max_speed, PERIOD), abs=1e-12)


def test_active_changes_the_input_and_integrates_it():
    v0 = VelocityCommand(0.5)
    out = _one_obstacle_cycle(obstacle((1.5, 0.0, 0.5)), T0)  # static, dead ahead
    assert out.status is CycleStatus.ACTIVE, out.text
    assert out.u_safe[0] < out.u_reference[0] - 0.1  # slows down
    np.testing.assert_allclose(_unicycle_axes(out.command), _integrated(v0, out), atol=1e-12)
    assert out.command.vx < v0.vx


def test_relaxed_is_flagged_and_slows_down():
    params = P.updated(max_accel=0.05, max_yaw_accel=0.05, max_vertical_accel=0.05,
                       windup_band=10.0)
    v0 = VelocityCommand(0.8)
    cycle = primed(v0, params, T0 - PERIOD)
    wall = obstacle((1.2, 0.0, 0.5), radius=0.3)
    out = cycle.step(T0, v0, T0, base(T0, v0), [wall], T0)
    assert out.status is CycleStatus.RELAXED, out.text
    assert out.result.slack.max() > 0
    np.testing.assert_allclose(_unicycle_axes(out.command), _integrated(v0, out), atol=1e-12)
    assert out.command.vx < v0.vx


def test_inside_an_obstacle_is_an_emergency_brake():
    v0 = VelocityCommand(0.5)
    out = _one_obstacle_cycle(obstacle((0.35, 0.0, 0.5), radius=0.2), T0)
    assert out.result.status is FilterStatus.EMERGENCY
    assert out.status is CycleStatus.EMERGENCY_BRAKE, out.text
    assert out.command.vx < v0.vx


def test_absurd_obstacle_numbers_are_refused_and_braked_at_brake_decel():
    v0 = VelocityCommand(0.5)
    out = _one_obstacle_cycle(obstacle((2.0, 0.0, 0.5), velocity=(1e200, 0.0, 0.0)), T0)
    assert out.status is CycleStatus.INVALID_INPUT, out.text
    assert "domain" in out.text
    assert out.command.vx == pytest.approx(v0.vx - P.brake_decel * PERIOD, abs=1e-12)
    assert np.all(np.isfinite(out.command.as_array()))


class _StubFilter:
    """Wraps the cycle's QP: runs it, then reports ``status`` with the most braking input
    the bounds allow (what EMERGENCY/FAILSAFE would do), or raises ``raises``."""

    def __init__(self, real, status=None, raises=None):
        self.real, self.status, self.raises = real, status, raises

    def filter(self, *args, **kwargs):
        if self.raises is not None:
            raise self.raises
        res = self.real.filter(*args, **kwargs)
        if self.status in (FilterStatus.EMERGENCY, FilterStatus.FAILSAFE):
            u = np.minimum(np.maximum(-np.abs(res.u_safe) - 0.5, kwargs["u_min"]),
                           kwargs["u_max"])
            return dataclasses.replace(res, status=self.status, u_safe=u)
        return dataclasses.replace(res, status=self.status)


@pytest.mark.parametrize(
    "filter_status, cycle_status",
    [
        (FilterStatus.INACTIVE, CycleStatus.INACTIVE),
        (FilterStatus.ACTIVE, CycleStatus.ACTIVE),
        (FilterStatus.RELAXED, CycleStatus.RELAXED),
        (FilterStatus.EMERGENCY, CycleStatus.EMERGENCY_BRAKE),
        (FilterStatus.FAILSAFE, CycleStatus.EMERGENCY_BRAKE),
    ],
)
def test_every_qp_status_maps_to_its_cycle_status(filter_status, cycle_status):
    v0 = VelocityCommand(0.5)
    cycle = primed(v0, t=T0 - PERIOD)
    cycle.filter = _StubFilter(cycle.filter, status=filter_status)
    out = cycle.step(T0, v0, T0, base(T0, v0), [], T0)
    assert out.status is cycle_status, out.text
    if filter_status is FilterStatus.FAILSAFE:  # the solver failed: brake at brake_decel
        assert out.command.vx == pytest.approx(v0.vx - P.brake_decel * PERIOD, abs=1e-12)
    else:
        np.testing.assert_allclose(
            _unicycle_axes(out.command), _integrated(v0, out), atol=1e-12
        )
    if cycle_status is CycleStatus.EMERGENCY_BRAKE:
        assert out.command.vx < v0.vx


def test_qp_rejecting_its_input_brakes_at_brake_decel():
    v0 = VelocityCommand(0.5, 0.0, -0.05, 0.6)
    cycle = primed(v0, t=T0 - PERIOD)
    cycle.filter = _StubFilter(cycle.filter, raises=InvalidInputError("stub: bad state"))
    prev = v0
    for k in range(3):
        t = T0 + k * PERIOD
        out = cycle.step(t, v0, t, base(t, v0), [], t)
        assert out.status is CycleStatus.INVALID_INPUT
        assert "stub: bad state" in out.text
        assert out.result is None
        assert_braked(prev, out.command, PERIOD, P.brake_decel)
        prev = out.command


def test_invalid_obstacles_brake_at_brake_decel():
    v0 = VelocityCommand(0.5, 0.0, -0.05, 0.6)
    cycle = primed(v0, t=T0 - PERIOD)
    bad = [obstacle((2.0, 0.0, 0.5)), obstacle((float("nan"), 0.0, 0.5), oid="nan")]
    prev = v0
    for k in range(3):
        t = T0 + k * PERIOD
        out = cycle.step(t, v0, t, base(t, v0), bad, t)
        assert out.status is CycleStatus.INVALID_INPUT
        assert "rejected obstacles" in out.text
        assert_braked(prev, out.command, PERIOD, P.brake_decel)
        prev = out.command


def test_pass_through_forwards_the_reference_or_zero_when_stale():
    cycle = SafetyFilterCycle(P.updated(enabled=False))
    ref = VelocityCommand(1.5, 0.4, -0.3, 2.0)  # beyond every limit: not clipped either
    out = cycle.step(T0, ref, T0, None, None, None)
    assert out.status is CycleStatus.PASS_THROUGH
    assert out.command == ref
    t = T0 + P.reference_timeout + 1e-6
    out = cycle.step(t, ref, T0, None, None, None)
    assert out.status is CycleStatus.PASS_THROUGH
    assert out.reference_stale and out.command.is_zero()


# --------------------------------------------------------------------------- limits
def _follow(params, ref: VelocityCommand, cycles: int, v0=STILL):
    """Cycles where the robot follows the command exactly (no windup); the outputs."""
    cycle = SafetyFilterCycle(params)
    v, outs = v0, []
    for k in range(cycles):
        t = T0 + k * PERIOD
        out = cycle.step(t, ref, t, base(t, v), [], t)
        outs.append(out)
        v = out.command
    return outs


def test_reverse_speed_is_limited_by_max_reverse_speed_not_max_speed():
    assert P.max_reverse_speed < P.max_speed  # the premise
    outs = _follow(P, VelocityCommand(-P.max_speed), 60)
    vx = np.array([o.command.vx for o in outs])
    assert vx.min() == pytest.approx(-P.max_reverse_speed, abs=1e-12)
    assert vx[-1] == pytest.approx(-P.max_reverse_speed, abs=1e-12)
    # The limit is a bound of the QP, not a clip after it: the reported input is the one
    # integrated into the command.
    for a, b in zip(outs, outs[1:], strict=False):
        assert b.command.vx - a.command.vx == pytest.approx(b.u_safe[0] * PERIOD, abs=1e-12)
    forward = _follow(P, VelocityCommand(2.0 * P.max_speed), 80)
    assert max(o.command.vx for o in forward) == pytest.approx(P.max_speed, abs=1e-12)


@pytest.mark.parametrize("direction", [-1.0, 1.0], ids=["backward", "forward"])
def test_measured_speed_beyond_a_limit_starts_the_command_at_the_limit(direction):
    limit = P.max_reverse_speed if direction < 0 else P.max_speed
    fast = VelocityCommand(1.5 * direction * limit)
    out = SafetyFilterCycle(P).step(T0, fast, T0, base(T0, fast), [], T0)
    assert direction * out.command.vx <= limit + 1e-12
    # The integrator starts at the limit, not beyond it: the reported input is what moved it.
    assert out.command.vx == pytest.approx(direction * limit + out.u_safe[0] * PERIOD,
                                           abs=1e-12)


@pytest.mark.parametrize(
    "axis, sign", [("vx", 1.0), ("vx", -1.0), ("yaw_rate", 1.0), ("yaw_rate", -1.0)]
)
def test_command_leads_a_stuck_robot_by_at_most_the_windup_band(axis, sign):
    # Reverse limit above the band, so that the band (not the limit) stops a backward lead.
    params = P.updated(max_reverse_speed=2.0 * P.windup_band)
    limit, accel = (
        (params.max_speed, params.max_accel) if axis == "vx"
        else (params.max_yaw_rate, params.max_yaw_accel)
    )
    assert params.windup_band < 0.5 * limit  # the premise: the band binds first
    ref = VelocityCommand(**{axis: sign * limit})
    cycle = SafetyFilterCycle(params)
    cmd = []
    for k in range(60):
        t = T0 + k * PERIOD
        out = cycle.step(t, ref, t, base(t), [], t)  # the robot does not move
        assert out.status is CycleStatus.INACTIVE, out.text
        cmd.append(sign * getattr(out.command, axis))
    assert params.windup_band < cmd[-1] <= params.windup_band + accel * PERIOD + 1e-12
    assert cmd[-1] == cmd[-10]  # integration stopped


@pytest.mark.parametrize("direction", [-1.0, 1.0], ids=["down", "up"])
def test_height_range_stops_vertical_speed_at_its_ends(direction):
    z_end = P.min_height if direction < 0 else P.max_height
    cycle = SafetyFilterCycle(P)
    ref = VelocityCommand(0.0, 0.0, direction * P.max_vertical_speed)
    out = cycle.step(T0, ref, T0, base(T0, z=z_end), [], T0)
    assert direction * out.command.vz <= 1e-12, "asked to leave the height range"
    # Inside the range the same reference moves (the barrier is not a ban) but never past it.
    z, vz, zs = Z_MID, 0.0, []
    cycle = SafetyFilterCycle(P)
    for k in range(150):
        t = T0 + k * PERIOD
        out = cycle.step(t, ref, t, base(t, VelocityCommand(0.0, 0.0, vz), z=z), [], t)
        vz = out.command.vz
        z += vz * PERIOD
        zs.append(z)
    assert direction * (zs[5] - Z_MID) > 0.0
    assert P.min_height - 1e-3 <= min(zs) and max(zs) <= P.max_height + 1e-3
