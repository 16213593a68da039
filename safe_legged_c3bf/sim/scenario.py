"""Scenario files: what the simulator builds and what the rest of the graph is told to do.

A scenario is a YAML mapping (format: ``doc/scenario_format.md``) with the robot and its start
pose, the goal, the run duration, the random seed, the simulated perception's noise, the
obstacles and their motion, what the reference planner should do, optional parameter
overrides for the other nodes, and ground-truth (fall / collision) settings.

:func:`load_scenario` finds a scenario by name (``quadruped_default`` ->
``config/scenarios/quadruped_default.yaml``) or by path and validates it completely;
:class:`ScenarioError` names the first bad field, e.g.
``obstacles[1].semi_axes: must be two positive numbers``. Units are SI (m, s, rad, m/s, Hz).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from safe_legged_c3bf.run.config import config_path
from safe_legged_c3bf.sim.range_sensors import DepthConfig, LidarConfig
from safe_legged_c3bf.sim.robots import robot_spec
from safe_legged_c3bf.sim.scenario_clearance import clearance_problems, filter_params
from safe_legged_c3bf.sim.scenario_schema import (
    MOTION_TYPES,
    PERCEPTION_SOURCES,
    PLANES,
    PLANNER_FIELDS,
    PLANNER_MODES,
    WAYPOINT_MODES,
    validate_document,
)

#: Default fall bounds per robot kind: minimum base height (m) and maximum tilt (rad).
FALL_DEFAULTS = {"quadruped": (0.12, 0.8), "biped": (0.45, 0.8)}

#: Sections of parameter overrides for other nodes (the planner's are in ``planner:``).
OVERRIDE_SECTIONS = ("filter", "tracker", "controller", "detector")
__all__ = [
    "FALL_DEFAULTS", "MOTION_TYPES", "OVERRIDE_SECTIONS", "PERCEPTION_SOURCES", "PLANES",
    "PLANNER_MODES", "WAYPOINT_MODES", "DepthConfig", "GoalConfig", "GroundTruthConfig",
    "LidarConfig", "MotionConfig", "ObstacleConfig", "PerceptionConfig", "PhysicsConfig",
    "PlannerConfig", "RobotConfig", "Scenario",
    "ScenarioError", "available_scenarios", "load_scenario", "parse_scenario",
    "resolve_scenario", "scenarios_dir",
]


class ScenarioError(ValueError):
    """A scenario file is missing, unreadable or invalid; the message names the bad field."""


# --------------------------------------------------------------------------- dataclasses


@dataclass(frozen=True)
class RobotConfig:
    """Which robot to load and where.

    Attributes:
        model: robot name known to :mod:`safe_legged_c3bf.sim.robots` ('a1', 'quadruped',
            'biped').
        kind: 'quadruped' or 'biped' (derived from the model).
        position: (x, y) start position of the base in odom (m).
        yaw: start heading (rad).

    """

    model: str = "quadruped"
    kind: str = "quadruped"
    position: tuple[float, float] = (0.0, 0.0)
    yaw: float = 0.0


@dataclass(frozen=True)
class GoalConfig:
    """Navigation goal.

    Attributes:
        position: (x, y) goal in odom (m).
        tolerance: distance (m) at which the goal counts as reached.

    """

    position: tuple[float, float] = (0.0, 0.0)
    tolerance: float = 0.3


@dataclass(frozen=True)
class PerceptionConfig:
    """Simulated obstacle perception.

    With ``source`` 'oracle' the simulator publishes detections drawn from the true obstacles
    (the fields from ``rate`` to ``max_range``); with 'sensors' it publishes the raw data of
    the range sensors ``lidar`` and ``depth`` instead, and an obstacle detector node makes the
    detections.

    Attributes:
        source: 'oracle' or 'sensors'.
        rate: detection rate (Hz, sim time).
        position_noise_std: (3,) standard deviation of the Gaussian centre noise, x y z (m).
        position_noise_bias: (3,) mean of the centre noise, x y z (m); 0 for an unbiased sensor.
        size_noise_std: standard deviation of the Gaussian semi-axis noise (m).
        dropout_probability: probability that an obstacle is missing from one detection frame.
        max_range: obstacles farther than this from the robot base are not seen (m).
        lidar: the 2-D LiDAR (/scan), used with source 'sensors'.
        depth: the forward 3-D sensor (/points), used with source 'sensors'.

    """

    source: str = "oracle"
    rate: float = 20.0
    position_noise_std: tuple[float, float, float] = (0.02, 0.02, 0.02)
    position_noise_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    size_noise_std: float = 0.0
    dropout_probability: float = 0.0
    max_range: float = math.inf
    lidar: LidarConfig = field(default_factory=LidarConfig)
    depth: DepthConfig = field(default_factory=DepthConfig)


@dataclass(frozen=True)
class MotionConfig:
    """Motion script of an obstacle (see :mod:`safe_legged_c3bf.sim.obstacles`).

    Attributes:
        type: 'static', 'constant_velocity' or 'waypoints'.
        velocity: (3,) velocity for 'constant_velocity' (m/s, odom).
        waypoints: points visited after the start position, each (x, y, z) (m, odom).
        speed: travel speed along the waypoints (m/s).
        mode: 'pingpong' (back and forth), 'cycle' (closed loop back to the start) or 'stop'
            (stay at the last waypoint).
        start_time: the obstacle stays at its start position until this sim time (s).

    """

    type: str = "static"
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    waypoints: tuple[tuple[float, float, float], ...] = ()
    speed: float = 0.0
    mode: str = "pingpong"
    start_time: float = 0.0


@dataclass(frozen=True)
class ObstacleConfig:
    """An obstacle: an elliptic cylinder, upright (vertical) or lying across the path.

    Attributes:
        id: unique name, used in messages and summaries.
        plane: 'vertical' (ellipse in x-y, extruded along z) or 'horizontal' (ellipse in
            x-z, extruded along odom y: a bar across the path).
        position: (3,) centre at t = 0 (m, odom). Vertical obstacles stand on the ground by
            default (z = extent / 2); for a horizontal bar z is the height of its axis and y
            the middle of its length.
        semi_axes: (a, b) semi-axes of the ellipse (m).
        orientation: angle of axis a from odom x (rad): about +z from +x towards +y for
            vertical, about y from +x towards +z for horizontal obstacles.
        extent: length along the extrusion axis (m): height of a vertical obstacle, length of
            a bar.
        color: RGBA colour used by the renderers.
        motion: the motion script.

    """

    id: str
    plane: str
    position: tuple[float, float, float]
    semi_axes: tuple[float, float]
    orientation: float = 0.0
    extent: float = 1.5
    color: tuple[float, float, float, float] = (0.8, 0.3, 0.2, 1.0)
    motion: MotionConfig = field(default_factory=MotionConfig)


@dataclass(frozen=True)
class PlannerConfig:
    """What the reference planner should do (read by the bringup / planner node).

    Attributes:
        mode: 'goal' (drive to :attr:`Scenario.goal`) or 'constant_velocity'.
        speed: cruise speed in goal mode (m/s); None = the planner's default.
        velocity: (vx, vy, vz, yaw_rate) for constant_velocity mode (m/s, rad/s, base_link).
        params: any other planner parameter overrides (name -> value).

    """

    mode: str = "goal"
    speed: float | None = None
    velocity: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    params: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class GroundTruthConfig:
    """Ground-truth evaluation settings.

    Attributes:
        fall_min_height: the robot has fallen when its base is lower than this (m).
        fall_max_tilt: ... or when its base z axis is tilted more than this from vertical (rad).
        collision_debounce: a contact with an obstacle counts as a new collision event only
            if the robot was free of that obstacle for at least this long (s).
        contact_tolerance: contact points with a distance up to this count as contact (m).
        distance_cutoff: min distance is computed exactly below this value; above it a
            lower bound is reported (m).
        exact_distance_below: below this distance (m) the exact distance is recomputed at
            every physics step; above it only as often as needed to notice an approach.
        max_closing_speed: bound on how fast a robot link can approach a static obstacle
            (m/s), used to schedule the exact distance queries.
        max_check_interval: longest interval between two exact distance queries (s).

    """

    fall_min_height: float = 0.12
    fall_max_tilt: float = 0.8
    collision_debounce: float = 0.1
    contact_tolerance: float = 0.001
    distance_cutoff: float = 1.0
    exact_distance_below: float = 0.3
    max_closing_speed: float = 4.0
    max_check_interval: float = 0.02


@dataclass(frozen=True)
class PhysicsConfig:
    """Physics settings of the world.

    Attributes:
        lateral_friction: friction coefficient of the ground plane.
        gravity: gravitational acceleration (m/s^2, positive number, along -z).

    """

    lateral_friction: float = 1.0
    gravity: float = 9.81


@dataclass(frozen=True)
class Scenario:
    """A complete, validated scenario.

    Attributes:
        name: scenario name (the file stem unless given).
        description: free text.
        robot, goal, perception, planner, ground_truth, physics: the sections above.
        duration: run length (s, sim time).
        seed: seed of every random draw of the simulator (perception noise, drop-outs).
        obstacles: the obstacles.
        overrides: section ('filter', 'tracker', 'controller') -> parameter overrides.
        source: path of the file it was loaded from ('' when built in code).

    """

    name: str
    robot: RobotConfig = field(default_factory=RobotConfig)
    goal: GoalConfig = field(default_factory=GoalConfig)
    duration: float = 30.0
    seed: int = 0
    perception: PerceptionConfig = field(default_factory=PerceptionConfig)
    obstacles: tuple[ObstacleConfig, ...] = ()
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    ground_truth: GroundTruthConfig = field(default_factory=GroundTruthConfig)
    physics: PhysicsConfig = field(default_factory=PhysicsConfig)
    overrides: dict[str, dict[str, Any]] = field(default_factory=dict)
    description: str = ""
    source: str = ""

    @property
    def filter_overrides(self) -> dict[str, Any]:
        """Safety-filter parameter overrides (empty when the scenario gives none)."""
        return dict(self.overrides.get("filter", {}))

    def obstacle(self, obstacle_id: str) -> ObstacleConfig:
        """Return the obstacle with id ``obstacle_id`` (KeyError if absent)."""
        for obs in self.obstacles:
            if obs.id == obstacle_id:
                return obs
        raise KeyError(obstacle_id)


# --------------------------------------------------------------------------- validation


def _build(doc: Any, name: str, source: str) -> Scenario:
    """The dataclasses of a validated document (see :mod:`.scenario_schema`)."""
    r = doc.robot
    robot = RobotConfig(model=r.kind, kind=robot_spec(r.kind).kind, position=r.position,
                        yaw=r.yaw)
    goal = GoalConfig(position=doc.goal.position or robot.position,
                      tolerance=doc.goal.tolerance)
    pe = doc.perception
    perception = PerceptionConfig(
        pe.source, pe.rate, pe.position_noise_std, pe.position_noise_bias, pe.size_noise_std,
        pe.dropout_probability, pe.max_range, LidarConfig(**pe.lidar.model_dump()),
        DepthConfig(**pe.depth.model_dump()),
    )
    obstacles = []
    seen: set[str] = set()
    for i, o in enumerate(doc.obstacles):
        obstacle_id = o.id if o.id is not None else f"obstacle_{i}"
        if obstacle_id in seen:
            raise ScenarioError(f"obstacles[{i}].id: duplicate id {obstacle_id!r}")
        seen.add(obstacle_id)
        m = o.motion
        velocity = (0.0, 0.0, 0.0)
        if m.type == "constant_velocity":
            velocity = (m.velocity[0], m.velocity[1], m.velocity[2] if len(m.velocity) == 3
                        else 0.0)
        motion = MotionConfig(type=m.type, velocity=velocity, waypoints=o.waypoints(),
                              speed=m.speed or 0.0, mode=m.mode, start_time=m.start_time)
        color = o.color if len(o.color) == 4 else (*o.color, 1.0)
        obstacles.append(ObstacleConfig(
            id=obstacle_id, plane=o.plane, position=o.start_position(), semi_axes=o.semi_axes,
            orientation=o.orientation, extent=o.extent_or_default(), color=color, motion=motion,
        ))
    pl = doc.planner
    velocity = tuple(pl.velocity or (0.0,))
    params = {k: v for k, v in pl.given().items() if k not in PLANNER_FIELDS}
    planner = PlannerConfig(mode=pl.mode, speed=pl.speed,
                            velocity=velocity + (0.0,) * (4 - len(velocity)), params=params)
    gt = doc.ground_truth
    min_height, max_tilt = FALL_DEFAULTS[robot.kind]
    ground_truth = GroundTruthConfig(
        fall_min_height=min_height if gt.fall_min_height is None else gt.fall_min_height,
        fall_max_tilt=max_tilt if gt.fall_max_tilt is None else gt.fall_max_tilt,
        collision_debounce=gt.collision_debounce, contact_tolerance=gt.contact_tolerance,
        distance_cutoff=gt.distance_cutoff, exact_distance_below=gt.exact_distance_below,
        max_closing_speed=gt.max_closing_speed, max_check_interval=gt.max_check_interval,
    )
    physics = PhysicsConfig(lateral_friction=doc.physics.lateral_friction,
                            gravity=doc.physics.gravity)
    overrides = {
        key: getattr(doc, key).given() for key in OVERRIDE_SECTIONS
        if getattr(doc, key) is not None
    }
    return Scenario(
        name=doc.name or name, description=doc.description, robot=robot, goal=goal,
        duration=doc.duration, seed=doc.seed, perception=perception,
        obstacles=tuple(obstacles), planner=planner, ground_truth=ground_truth,
        physics=physics, overrides=overrides, source=source,
    )


def parse_scenario(
    data: Any, name: str = "scenario", source: str = "", *, check_clearance: bool = False
) -> Scenario:
    """Validate a scenario mapping (as loaded from YAML) and return a :class:`Scenario`.

    Checks, in this order: the structure and every value (unknown keys first, then missing
    and invalid ones, all of them; override keys against the nodes' real parameter names);
    the safety filter's parameters with the scenario's ``filter:`` overrides applied; with
    ``check_clearance`` (always done by :func:`load_scenario`), that neither the start nor the
    goal is inside an obstacle as the filter inflates it (:mod:`.scenario_clearance`). Code
    may leave that last check out, e.g. to put an obstacle right at the robot in a simulator
    test; a scenario file never can.

    Raises:
        ScenarioError: one line per problem, each naming the field.

    """
    if data is None or (isinstance(data, Mapping) and not data):
        raise ScenarioError(
            "scenario: is empty; a scenario needs at least its goal (and its obstacles), "
            "see doc/scenario_format.md"
        )
    doc, errors = validate_document(data)
    if errors:
        raise ScenarioError("\n".join(errors))
    scenario = _build(doc, name, source)
    try:
        params = filter_params(scenario)
    except ValueError as err:
        raise ScenarioError(f"filter.{err}" if ":" in str(err) else f"filter: {err}") from None
    problems = clearance_problems(scenario, params) if check_clearance else []
    if problems:
        raise ScenarioError("\n".join(problems))
    return scenario


# --------------------------------------------------------------------------- lookup and loading


def scenarios_dir() -> Path:
    """Directory of the packaged scenarios (``config/scenarios``)."""
    return config_path("scenarios")


def available_scenarios() -> list[str]:
    """Names of the packaged scenarios."""
    try:
        return sorted(p.stem for p in scenarios_dir().glob("*.yaml"))
    except FileNotFoundError:
        return []


def resolve_scenario(name_or_path: str | os.PathLike[str]) -> Path:
    """Path of a scenario given by file path or by name (``quadruped_default``).

    Raises:
        ScenarioError: if no such file exists (the message lists the known names).

    """
    text = str(name_or_path)
    if not text:
        raise ScenarioError("scenario: empty name")
    path = Path(text).expanduser()
    if path.is_file():
        return path.resolve()
    looks_like_path = os.sep in text or text.endswith((".yaml", ".yml"))
    if not looks_like_path:
        try:
            candidate = scenarios_dir() / f"{text}.yaml"
        except FileNotFoundError as exc:
            raise ScenarioError(f"scenario {text!r}: {exc}") from None
        if candidate.is_file():
            return candidate
    known = ", ".join(available_scenarios()) or "none"
    raise ScenarioError(f"scenario {text!r}: no such file or scenario name (known: {known})")


def load_scenario(name_or_path: str | os.PathLike[str] | Scenario) -> Scenario:
    """Load and validate a scenario by name or path (a :class:`Scenario` passes through).

    Raises:
        ScenarioError: the file is missing, is not YAML, or a field is invalid; the message
            starts with the file path and names the field.

    """
    if isinstance(name_or_path, Scenario):
        return name_or_path
    path = resolve_scenario(name_or_path)
    try:
        with open(path, encoding="utf-8") as f:
            data = yaml.safe_load(f)
    except (OSError, yaml.YAMLError) as exc:
        raise ScenarioError(f"{path}: cannot read scenario: {exc}") from None
    if data is None or data == {}:
        raise ScenarioError(
            f"{path}: the file is empty; a scenario needs at least its goal (and its "
            "obstacles), see doc/scenario_format.md"
        )
    try:
        return parse_scenario(data, name=path.stem, source=str(path), check_clearance=True)
    except ScenarioError as exc:
        lines = str(exc).splitlines()
        raise ScenarioError("\n".join(f"{path}: {line}" for line in lines)) from None
