"""The ranges the random-scenario generator draws from, per robot kind.

:class:`RandomProfile` holds them (SI units: m, s, rad, m/s; positions in odom, the robot
starting at the origin); :data:`PROFILES` are the defaults of the A1 quadruped and the biped,
and :func:`profile_for` returns one with some fields changed. Used by
:mod:`safe_legged_c3bf.evaluation.random_scenario` (drawing) and
:mod:`safe_legged_c3bf.evaluation.random_checks` (re-checking).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

ROBOTS = ("quadruped", "biped")
MOVING_KINDS = ("crossing", "head_on", "oblique")
#: Static shapes: round-ish pillars, benches and wall segments.
SHAPES = ("pillar", "bench", "wall")
#: Filter overrides of biped scenarios (as in config/scenarios/biped_static.yaml): the biped's
#: command range (config/biped_controller.yaml) and body height instead of the A1's.
BIPED_FILTER_OVERRIDES = {
    "max_speed": 0.2, "max_reverse_speed": 0.1, "max_accel": 0.3, "max_yaw_rate": 0.4,
    "max_yaw_accel": 0.8, "min_height": 0.7, "max_height": 0.9,
}


@dataclass(frozen=True)
class RandomProfile:
    """Ranges the generator draws from, per robot kind (SI units: m, s, rad, m/s).

    Attributes:
        robot: 'quadruped' or 'biped'.
        cruise_speed: planner cruise speed (m/s).
        nominal_speed: speed the robot actually walks at without obstacles (m/s), used to
            time the moving obstacles (measured on obstacle-free runs).
        start_delay: time before the robot starts to move (s).
        goal_distance: (min, max) start-goal distance (m).
        duration: run length (s, sim time).
        obstacle_count: (min, max) number of obstacles (inclusive).
        obstacle_radius: (min, max) larger semi-axis a (m).
        aspect: (min, max) ratio b / a of the smaller semi-axis.
        height: (min, max) height of vertical obstacles (m).
        mover_speed: (min, max) speed of moving obstacles (m/s).
        moving_probability: chance that an obstacle moves.
        kind_weights: relative weights of the moving kinds (crossing, head_on, oblique).
        bar_probability: chance that one station holds a bar instead.
        half_width: half the robot's width across the path (m): a vertical obstacle is in
            the way when the straight path passes closer than its smaller semi-axis plus this.
        passage: least surface-to-surface gap (m) between a mover at rest (waiting or
            stopped) and any other obstacle at rest: the filter's inflation diameter (0.98 m
            for the A1, 1.02 m for the biped) plus 0.4 m, so no dead end forms.
        in_way_fraction: the lateral offset of a conflict point is at most this share of
            (smaller semi-axis + half_width).
        start_clearance: least distance (m) between an obstacle's surface where it stands at
            t = 0 and the start (the filter refuses a robot that starts inside an obstacle).
            Its walk may pass through the start.
        goal_clearance: the same between where an obstacle stands at the end and the goal.
        first_station: least distance (m) from the start to a conflict station.
        last_station: least distance (m) from a conflict station to the goal.
        spacing: least distance (m) between two conflict stations along the path.
        pre_travel: (min, max) distance (m) a mover walks before the conflict point.
        post_travel: (min, max) distance (m) it walks after it before stopping: from 0, so
            walkers stop anywhere, on the path and next to the robot too.
        max_movers: most moving obstacles in one scenario.
        shape_weights: relative weights of the static shapes (pillar, bench, wall).
        wall_length, wall_thickness: (min, max) semi-axes a and b of a wall segment (m).
        bench_length, bench_depth: (min, max) semi-axes a and b of a bench (m).
        side_gap: (min, max) distance (m) between the straight path and the surface of an
            obstacle beside it (the obstacles beyond the conflict stations).
        random_heading: draw the robot's heading (else yaw 0).
        trunk_top: top of the robot's body when standing (m); a bar is in the way below it.
        bar_underside: (min, max) height of a bar's underside (m).
        bar_radius: (min, max) radius of a bar's cross-section (m).
        perception: the scenario's perception section.
        filter_overrides: the scenario's ``filter:`` section (the robot's command range and
            height when the filter's defaults, the A1's, do not fit).

    """

    robot: str
    cruise_speed: float
    nominal_speed: float
    start_delay: float
    goal_distance: tuple[float, float]
    duration: float
    obstacle_count: tuple[int, int]
    obstacle_radius: tuple[float, float]
    aspect: tuple[float, float]
    height: tuple[float, float]
    mover_speed: tuple[float, float]
    moving_probability: float
    kind_weights: tuple[float, float, float]
    bar_probability: float
    half_width: float
    in_way_fraction: float
    passage: float
    start_clearance: float
    goal_clearance: float
    first_station: float
    last_station: float
    spacing: float
    pre_travel: tuple[float, float]
    post_travel: tuple[float, float]
    max_movers: int = 4
    shape_weights: tuple[float, float, float] = (0.6, 0.2, 0.2)
    wall_length: tuple[float, float] = (0.8, 2.0)
    wall_thickness: tuple[float, float] = (0.05, 0.12)
    bench_length: tuple[float, float] = (0.4, 0.8)
    bench_depth: tuple[float, float] = (0.15, 0.25)
    side_gap: tuple[float, float] = (0.2, 1.2)
    random_heading: bool = True
    trunk_top: float = 0.337
    bar_underside: tuple[float, float] = (0.295, 0.305)
    bar_radius: tuple[float, float] = (0.04, 0.06)
    perception: dict[str, Any] = field(default_factory=lambda: {
        "rate": 20.0, "position_noise_std": 0.02, "size_noise_std": 0.005,
        "dropout_probability": 0.05, "max_range": 6.0,
    })
    filter_overrides: dict[str, Any] = field(default_factory=dict)


#: Default profiles. Timing measured on obstacle-free runs: the A1 at 0.4 m/s walks
#: x(t) = 0.4 (t - 0.4) m; the biped at 0.2 m/s (the ZMP walker's command limit)
#: x(t) = 0.195 (t - 2.0) m and reaches a goal 3.2 m away in 16.8 s, 3.9 m in 20 s. It is slow
#: to walk around an obstacle (+6-7 s; a slow mover can keep it waiting for 20 s), hence the
#: short goal distances and the 45 s budget. Durations are time budgets: evaluations end a
#: run once its outcome is settled.
PROFILES: dict[str, RandomProfile] = {
    "quadruped": RandomProfile(
        robot="quadruped", cruise_speed=0.4, nominal_speed=0.4, start_delay=0.4,
        goal_distance=(5.5, 7.0), duration=36.0, obstacle_count=(1, 6),
        obstacle_radius=(0.18, 0.35), aspect=(0.6, 1.0), height=(0.8, 1.8),
        mover_speed=(0.15, 0.45), moving_probability=0.5, kind_weights=(0.4, 0.3, 0.3),
        bar_probability=0.25, half_width=0.15, in_way_fraction=0.5, passage=1.4,
        start_clearance=0.7,
        goal_clearance=0.7, first_station=2.0, last_station=1.2, spacing=1.0,
        pre_travel=(0.3, 3.5), post_travel=(0.0, 2.5),
        bar_underside=(0.10, 0.36),
    ),
    "biped": RandomProfile(
        robot="biped", cruise_speed=0.2, nominal_speed=0.195, start_delay=2.0,
        goal_distance=(3.0, 3.6), duration=45.0, obstacle_count=(1, 6),
        obstacle_radius=(0.15, 0.3), aspect=(0.6, 1.0), height=(1.0, 1.8),
        mover_speed=(0.1, 0.25), moving_probability=0.6, kind_weights=(0.4, 0.3, 0.3),
        bar_probability=0.15, half_width=0.15, in_way_fraction=0.5, passage=1.45,
        start_clearance=0.8,
        goal_clearance=0.8, first_station=1.2, last_station=1.0, spacing=0.8,
        pre_travel=(0.3, 2.5), post_travel=(0.0, 2.0), trunk_top=1.1,
        bar_underside=(0.55, 1.15), side_gap=(0.25, 1.2),
        filter_overrides=dict(BIPED_FILTER_OVERRIDES),
    ),
}


def profile_for(robot: str, **changes: Any) -> RandomProfile:
    """The default profile of ``robot`` ('quadruped' / 'biped') with ``changes`` applied."""
    if robot not in PROFILES:
        raise ValueError(f"robot must be one of {', '.join(ROBOTS)}, got {robot!r}")
    return replace(PROFILES[robot], **changes) if changes else PROFILES[robot]
