"""Sample instances of every custom message, with every field set to a non-default value."""

from __future__ import annotations

from safe_legged_c3bf_msgs.msg import (
    GroundTruthSafety,
    MotorCommand,
    Obstacle,
    ObstacleArray,
    SafetyFilterState,
)


def obstacle(i: int = 0) -> Obstacle:
    o = Obstacle()
    o.id = f"pillar_{i}"
    o.plane = Obstacle.HORIZONTAL
    o.center.x, o.center.y, o.center.z = 3.0 + i, -0.5, 0.45
    o.velocity.x, o.velocity.y, o.velocity.z = -0.5, 0.25, 0.0
    o.semi_axis_a, o.semi_axis_b, o.orientation, o.extent = 0.3, 0.05, 0.1, 2.0
    o.position_covariance = [float(k) * 1e-3 for k in range(9)]
    o.velocity_covariance = [float(k) * 1e-2 for k in range(9)]
    o.velocity_source = Obstacle.VELOCITY_ESTIMATED
    return o


def samples() -> dict[str, object]:
    arr = ObstacleArray()
    arr.header.frame_id = "odom"
    arr.header.stamp.sec, arr.header.stamp.nanosec = 12, 500
    arr.obstacles = [obstacle(0), obstacle(1)]

    cmd = MotorCommand()
    cmd.header.frame_id = "base_link"
    cmd.name = ["FR_hip_joint", "FR_upper_joint"]
    cmd.q, cmd.dq, cmd.kp, cmd.kd, cmd.tau = [0.1, 0.8], [0.0, 1.5], [60.0, 60.0], [2.0, 2.0], [
        0.5,
        -3.25,
    ]

    state = SafetyFilterState()
    state.header.frame_id = "base_link"
    state.status = SafetyFilterState.RELAXED
    state.status_text = "relaxed"
    state.reference_stale = True
    state.reference.linear.x, state.filtered.linear.x, state.filtered.linear.z = 0.5, 0.2, -0.1
    state.u_reference, state.u_safe = [0.5, 0.0, 0.0], [-1.0, 0.3, -0.2]
    state.obstacle_ids = ["a", "b"]
    state.h, state.constraint_value, state.slack = [0.1, -0.2], [0.0, 0.5], [0.0, 0.01]
    state.constraint_active = [True, False]
    state.min_h = -0.2
    state.solver = "osqp"
    state.solve_time = 1.5e-4
    state.dropped_messages = 3

    truth = GroundTruthSafety()
    truth.header.frame_id = "odom"
    truth.in_collision, truth.collision_count, truth.min_distance = True, 2, 0.0
    truth.closest_obstacle_id, truth.contact_obstacle_ids, truth.fallen = "a", ["a"], True

    return {
        "Obstacle": obstacle(3),
        "ObstacleArray": arr,
        "MotorCommand": cmd,
        "SafetyFilterState": state,
        "GroundTruthSafety": truth,
    }
