"""The run summary of a :class:`~safe_legged_c3bf.sim.world.Simulation`, and writing it.

The summary is a JSON-ready dict: sim time (s), collisions and minimum robot-obstacle
distance from the ground-truth monitor (m), falls, goal progress (m, odom x-y), the final
``base_link`` position (m, odom) and the command, perception and range-sensor counters.
Infinite values become None (JSON has no infinity).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from safe_legged_c3bf.sim.world import Simulation


def _json_number(x: float | None) -> float | None:
    if x is None or not math.isfinite(x):
        return None
    return float(x)


def run_summary(
    sim: Simulation, final_base_position: Sequence[float], extra: dict[str, Any] | None = None
) -> dict[str, Any]:
    """The summary of ``sim`` now; ``extra`` entries are merged in at top level."""
    sc, stats = sim.scenario, sim.monitor.stats
    goal = sim.goal_progress
    out: dict[str, Any] = {
        "scenario": sc.name,
        "source": sc.source,
        "robot": sc.robot.model,
        "seed": sim.seed,
        "duration": sc.duration,
        "sim_time": sim.time,
        "physics_steps": sim.step_count,
        "physics_dt": sim.physics_dt,
        "finished": sim.finished,
        "collision_count": len(stats.collision_events),
        "collisions": [
            {"time": e.time, "obstacle_id": e.obstacle_id, "links": list(e.links)}
            for e in stats.collision_events
        ],
        "time_in_collision": stats.time_in_collision,
        "min_distance": _json_number(stats.min_distance),
        "min_distance_time": stats.min_distance_time,
        "min_distance_obstacle": stats.min_distance_obstacle,
        "min_distance_exact": bool(stats.min_distance < sc.ground_truth.distance_cutoff),
        "fell": stats.fell,
        "fall_time": stats.fall_time,
        "max_tilt": stats.max_tilt,
        "min_base_height": _json_number(stats.min_base_height),
        "goal": list(sc.goal.position),
        "goal_reached": goal.reached,
        "goal_reached_time": goal.reached_time,
        "final_goal_distance": goal.distance,
        "min_goal_distance": goal.min_distance,
        "final_base_position": [float(v) for v in final_base_position],
        "commands_received": sim.commands_received,
        "rejected_commands": sim.rejected_commands,
        "driver_timeouts": sim.driver_timeouts,
        "driver_timeout_times": list(sim.driver_timeout_times),
        "driver_mode": sim.driver_mode.value,
        "perception_source": sc.perception.source,
        "detection_frames": sim.perception.frames,
        "detections_dropped": sim.perception.dropped,
        "lidar_scans": sim.lidar.casts,
        "depth_clouds": sim.depth.casts,
    }
    if extra:
        out.update(extra)
    return out


def write_json(path: str | os.PathLike[str], data: dict[str, Any]) -> None:
    """Write ``data`` as indented JSON to ``path`` (directories created; atomic replace)."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.with_name(target.name + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=2, allow_nan=False)
        f.write("\n")
    os.replace(tmp, target)
