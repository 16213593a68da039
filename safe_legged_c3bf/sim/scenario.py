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

from safe_legged_c3bf.config import config_path
from safe_legged_c3bf.sim.robots import ROBOTS, robot_spec

#: Default fall bounds per robot kind: minimum base height (m) and maximum tilt (rad).
FALL_DEFAULTS = {"quadruped": (0.12, 0.8), "biped": (0.45, 0.8)}

PLANES = ("vertical", "horizontal")
MOTION_TYPES = ("static", "constant_velocity", "waypoints")
WAYPOINT_MODES = ("pingpong", "cycle", "stop")
PLANNER_MODES = ("goal", "constant_velocity")
OVERRIDE_SECTIONS = ("filter", "tracker", "controller")


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

    Attributes:
        rate: detection rate (Hz, sim time).
        position_noise_std: (3,) standard deviation of the Gaussian centre noise, x y z (m).
        position_noise_bias: (3,) mean of the centre noise, x y z (m); 0 for an unbiased sensor.
        size_noise_std: standard deviation of the Gaussian semi-axis noise (m).
        dropout_probability: probability that an obstacle is missing from one detection frame.
        max_range: obstacles farther than this from the robot base are not seen (m).

    """

    rate: float = 20.0
    position_noise_std: tuple[float, float, float] = (0.02, 0.02, 0.02)
    position_noise_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    size_noise_std: float = 0.0
    dropout_probability: float = 0.0
    max_range: float = math.inf


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


class _Reader:
    """Typed access to a mapping that raises ScenarioError naming the field path."""

    def __init__(self, data: Any, path: str) -> None:
        if not isinstance(data, Mapping):
            raise ScenarioError(f"{path or 'scenario'}: must be a mapping")
        self.data = dict(data)
        self.path = path
        self.used: set[str] = set()

    def name(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path else key

    def fail(self, key: str, message: str) -> None:
        raise ScenarioError(f"{self.name(key)}: {message}")

    def has(self, key: str) -> bool:
        return key in self.data and self.data[key] is not None

    def raw(self, key: str, default: Any = None) -> Any:
        self.used.add(key)
        value = self.data.get(key, default)
        return default if value is None else value

    def number(
        self,
        key: str,
        default: float | None = None,
        *,
        minimum: float | None = None,
        maximum: float | None = None,
        positive: bool = False,
        required: bool = False,
        allow_inf: bool = False,
    ) -> float:
        if required and not self.has(key):
            self.fail(key, "is required")
        value = self.raw(key, default)
        x = _as_number(value, allow_inf)
        if x is None:
            self.fail(key, f"must be a number, got {value!r}")
        if positive and not x > 0:
            self.fail(key, f"must be a positive number, got {value!r}")
        if minimum is not None and x < minimum:
            self.fail(key, f"must be >= {minimum}, got {value!r}")
        if maximum is not None and x > maximum:
            self.fail(key, f"must be <= {maximum}, got {value!r}")
        return x

    def integer(self, key: str, default: int, *, minimum: int | None = None) -> int:
        value = self.raw(key, default)
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(key, f"must be an integer, got {value!r}")
        if minimum is not None and value < minimum:
            self.fail(key, f"must be >= {minimum}, got {value!r}")
        return int(value)

    def string(self, key: str, default: str | None = None, *, choices=None) -> str:
        if default is None and not self.has(key):
            self.fail(key, "is required")
        value = self.raw(key, default)
        if not isinstance(value, str) or (choices is None and not value.strip()):
            self.fail(key, f"must be a non-empty string, got {value!r}")
        if choices is not None and value not in choices:
            self.fail(key, f"must be one of {', '.join(choices)}; got {value!r}")
        return value

    def boolean(self, key: str, default: bool) -> bool:
        value = self.raw(key, default)
        if not isinstance(value, bool):
            self.fail(key, f"must be true or false, got {value!r}")
        return value

    def vector(
        self,
        key: str,
        sizes: tuple[int, ...],
        default: Any = None,
        *,
        what: str | None = None,
        positive: bool = False,
        non_negative: bool = False,
        required: bool = False,
    ) -> tuple[float, ...]:
        if required and not self.has(key):
            self.fail(key, "is required")
        value = self.raw(key, default)
        vec = _as_vector(value, sizes)
        ok = vec is not None
        if ok and positive:
            ok = all(v > 0 for v in vec)
        if ok and non_negative:
            ok = all(v >= 0 for v in vec)
        if not ok:
            self.fail(key, what or _vector_message(sizes, positive, non_negative, value))
        return vec

    def section(self, key: str) -> _Reader:
        self.used.add(key)
        return _Reader(self.data.get(key) or {}, self.name(key))

    def reject_unknown(self, allowed: tuple[str, ...] | None = None) -> None:
        known = set(allowed) if allowed is not None else self.used
        for key in self.data:
            if key not in known:
                raise ScenarioError(
                    f"{self.name(str(key))}: unknown field (expected one of "
                    f"{', '.join(sorted(known))})"
                )


def _as_number(value: Any, allow_inf: bool = False) -> float | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, str) and allow_inf and value.strip().lower() in ("inf", ".inf"):
        return math.inf
    if not isinstance(value, int | float):
        return None
    x = float(value)
    if math.isnan(x) or (math.isinf(x) and not allow_inf):
        return None
    return x


def _as_vector(value: Any, sizes: tuple[int, ...]) -> tuple[float, ...] | None:
    if not isinstance(value, list | tuple) or len(value) not in sizes:
        return None
    out = []
    for v in value:
        x = _as_number(v)
        if x is None:
            return None
        out.append(x)
    return tuple(out)


def _vector_message(sizes, positive, non_negative, value) -> str:
    count = " or ".join(str(s) for s in sizes)
    kind = "positive numbers" if positive else "non-negative numbers" if non_negative else "numbers"
    return f"must be a list of {count} {kind}, got {value!r}"


def _scalar_or_xyz(reader: _Reader, key: str, default: float) -> tuple[float, float, float]:
    value = reader.raw(key, default)
    if isinstance(value, list | tuple):
        vec = _as_vector(value, (3,))
        if vec is None:
            reader.fail(key, f"must be a number or a list of 3 numbers (x, y, z), got {value!r}")
        return vec  # type: ignore[return-value]
    x = _as_number(value)
    if x is None:
        reader.fail(key, f"must be a number or a list of 3 numbers (x, y, z), got {value!r}")
    return (x, x, x)


def _override_value_ok(value: Any) -> bool:
    if isinstance(value, bool | int | float | str):
        return not (isinstance(value, float) and math.isnan(value))
    if isinstance(value, list):
        return all(isinstance(v, bool | int | float | str) for v in value)
    return False


def _overrides(reader: _Reader, key: str) -> dict[str, Any]:
    section = reader.raw(key, {})
    if not isinstance(section, Mapping):
        reader.fail(key, "must be a mapping of parameter names to values")
    out = {}
    for name, value in section.items():
        if not isinstance(name, str) or not name:
            reader.fail(key, f"parameter names must be strings, got {name!r}")
        if not _override_value_ok(value):
            raise ScenarioError(
                f"{reader.name(key)}.{name}: must be a number, boolean, string or a list of "
                f"them, got {value!r}"
            )
        out[name] = value
    return out


def _parse_robot(r: _Reader) -> RobotConfig:
    model = r.string("kind", "quadruped", choices=tuple(sorted(ROBOTS)))
    pos = r.vector("position", (2,), (0.0, 0.0))
    yaw = r.number("yaw", 0.0)
    r.reject_unknown(("kind", "position", "yaw"))
    return RobotConfig(model=model, kind=robot_spec(model).kind, position=pos, yaw=yaw)


def _parse_goal(r: _Reader, robot: RobotConfig) -> GoalConfig:
    pos = r.vector("position", (2,), robot.position)
    tol = r.number("tolerance", 0.3, positive=True)
    r.reject_unknown(("position", "tolerance"))
    return GoalConfig(position=pos, tolerance=tol)


def _parse_perception(r: _Reader) -> PerceptionConfig:
    rate = r.number("rate", 20.0, positive=True)
    std = _scalar_or_xyz(r, "position_noise_std", 0.02)
    if any(s < 0 for s in std):
        r.fail("position_noise_std", "must be non-negative")
    bias = _scalar_or_xyz(r, "position_noise_bias", 0.0)
    size_std = r.number("size_noise_std", 0.0, minimum=0.0)
    drop = r.number("dropout_probability", 0.0, minimum=0.0, maximum=1.0)
    max_range = r.number("max_range", math.inf, positive=True, allow_inf=True)
    r.reject_unknown()
    return PerceptionConfig(rate, std, bias, size_std, drop, max_range)


def _parse_motion(r: _Reader, start: tuple[float, float, float]) -> MotionConfig:
    kind = r.string("type", "static", choices=MOTION_TYPES)
    start_time = r.number("start_time", 0.0, minimum=0.0)
    if kind == "static":
        r.reject_unknown(("type", "start_time"))
        return MotionConfig(type=kind, start_time=start_time)
    if kind == "constant_velocity":
        v = r.vector("velocity", (2, 3), required=True)
        r.reject_unknown(("type", "start_time", "velocity"))
        vel = (v[0], v[1], v[2] if len(v) == 3 else 0.0)
        return MotionConfig(type=kind, velocity=vel, start_time=start_time)
    # waypoints
    raw = r.raw("waypoints")
    if not isinstance(raw, list) or not raw:
        r.fail("waypoints", "must be a non-empty list of [x, y] or [x, y, z] points")
    points = []
    previous = start
    for i, p in enumerate(raw):
        vec = _as_vector(p, (2, 3))
        if vec is None:
            raise ScenarioError(
                f"{r.name('waypoints')}[{i}]: must be [x, y] or [x, y, z] numbers, got {p!r}"
            )
        point = (vec[0], vec[1], vec[2] if len(vec) == 3 else start[2])
        if math.dist(point, previous) < 1e-6:
            raise ScenarioError(
                f"{r.name('waypoints')}[{i}]: must differ from the previous point "
                "(the obstacle's position for the first waypoint)"
            )
        points.append(point)
        previous = point
    speed = r.number("speed", required=True, positive=True)
    mode = r.string("mode", "pingpong", choices=WAYPOINT_MODES)
    r.reject_unknown(("type", "start_time", "waypoints", "speed", "mode"))
    if mode == "cycle" and math.dist(points[-1], start) < 1e-6:
        r.fail("waypoints", "in cycle mode the last waypoint must not repeat the start position")
    return MotionConfig(
        type=kind, waypoints=tuple(points), speed=speed, mode=mode, start_time=start_time
    )


def _parse_obstacle(r: _Reader, index: int) -> ObstacleConfig:
    obstacle_id = r.raw("id", f"obstacle_{index}")
    if not isinstance(obstacle_id, str | int) or isinstance(obstacle_id, bool):
        r.fail("id", f"must be a string, got {obstacle_id!r}")
    obstacle_id = str(obstacle_id)
    plane = r.string("plane", "vertical", choices=PLANES)
    axes = r.vector(
        "semi_axes", (2,), required=True, positive=True, what="must be two positive numbers"
    )
    extent = r.number("extent", 1.5 if plane == "vertical" else 4.0, positive=True)
    orientation = r.number("orientation", 0.0)
    if plane == "vertical":
        p = r.vector("position", (2, 3), required=True)
        position = (p[0], p[1], p[2] if len(p) == 3 else extent / 2.0)
    else:
        p = r.vector(
            "position", (3,), required=True,
            what="must be [x, y, z] (x, middle of the bar along y, height of the bar axis)",
        )
        position = p
        if position[2] <= 0:
            r.fail("position", "the bar's height z must be positive")
    color = r.vector("color", (3, 4), (0.8, 0.3, 0.2, 1.0), non_negative=True)
    if len(color) == 3:
        color = (*color, 1.0)
    motion = _parse_motion(r.section("motion"), position)
    r.reject_unknown(
        ("id", "plane", "semi_axes", "extent", "orientation", "position", "color", "motion")
    )
    return ObstacleConfig(
        id=obstacle_id,
        plane=plane,
        position=position,
        semi_axes=axes,
        orientation=orientation,
        extent=extent,
        color=color,
        motion=motion,
    )


def _parse_planner(r: _Reader) -> PlannerConfig:
    mode = r.string("mode", "goal", choices=PLANNER_MODES)
    speed = r.number("speed", positive=True) if r.has("speed") else None
    if mode == "constant_velocity" and not r.has("velocity"):
        r.fail("velocity", "is required in constant_velocity mode ([vx, vy, vz, yaw_rate])")
    v = r.vector(
        "velocity", (1, 2, 3, 4), (0.0,),
        what="must be a list of 1 to 4 numbers: vx, vy, vz, yaw_rate (m/s, rad/s)",
    )
    velocity = tuple(v) + (0.0,) * (4 - len(v))
    params = {k: v for k, v in r.data.items() if k not in ("mode", "speed", "velocity")}
    for name, value in params.items():
        if not _override_value_ok(value):
            raise ScenarioError(
                f"{r.name(str(name))}: must be a number, boolean, string or a list of them, "
                f"got {value!r}"
            )
    return PlannerConfig(mode=mode, speed=speed, velocity=velocity, params=params)


def _parse_ground_truth(r: _Reader, kind: str) -> GroundTruthConfig:
    min_height, max_tilt = FALL_DEFAULTS[kind]
    cfg = GroundTruthConfig(
        fall_min_height=r.number("fall_min_height", min_height, minimum=0.0),
        fall_max_tilt=r.number("fall_max_tilt", max_tilt, positive=True, maximum=math.pi),
        collision_debounce=r.number("collision_debounce", 0.1, minimum=0.0),
        contact_tolerance=r.number("contact_tolerance", 0.001, minimum=0.0),
        distance_cutoff=r.number("distance_cutoff", 1.0, positive=True),
        exact_distance_below=r.number("exact_distance_below", 0.3, minimum=0.0),
        max_closing_speed=r.number("max_closing_speed", 4.0, positive=True),
        max_check_interval=r.number("max_check_interval", 0.02, positive=True),
    )
    r.reject_unknown()
    return cfg


def _parse_physics(r: _Reader) -> PhysicsConfig:
    cfg = PhysicsConfig(
        lateral_friction=r.number("lateral_friction", 1.0, positive=True),
        gravity=r.number("gravity", 9.81, positive=True),
    )
    r.reject_unknown()
    return cfg


TOP_LEVEL = (
    "name", "description", "robot", "goal", "duration", "seed", "perception", "obstacles",
    "planner", "ground_truth", "physics", *OVERRIDE_SECTIONS,
)


def parse_scenario(data: Any, name: str = "scenario", source: str = "") -> Scenario:
    """Validate a scenario mapping (as loaded from YAML) and return a :class:`Scenario`.

    Raises:
        ScenarioError: naming the first bad field.

    """
    top = _Reader(data, "")
    top.reject_unknown(TOP_LEVEL)
    name = top.string("name", name)
    description = top.raw("description", "")
    if not isinstance(description, str):
        top.fail("description", "must be a string")
    robot = _parse_robot(top.section("robot"))
    goal = _parse_goal(top.section("goal"), robot)
    duration = top.number("duration", 30.0, positive=True)
    seed = top.integer("seed", 0, minimum=0)
    perception = _parse_perception(top.section("perception"))
    raw_obstacles = top.raw("obstacles", [])
    if not isinstance(raw_obstacles, list):
        top.fail("obstacles", "must be a list")
    obstacles = []
    seen: set[str] = set()
    for i, item in enumerate(raw_obstacles):
        obs = _parse_obstacle(_Reader(item, f"obstacles[{i}]"), i)
        if obs.id in seen:
            raise ScenarioError(f"obstacles[{i}].id: duplicate id {obs.id!r}")
        seen.add(obs.id)
        obstacles.append(obs)
    planner = _parse_planner(top.section("planner"))
    ground_truth = _parse_ground_truth(top.section("ground_truth"), robot.kind)
    physics = _parse_physics(top.section("physics"))
    overrides = {key: _overrides(top, key) for key in OVERRIDE_SECTIONS if top.has(key)}
    return Scenario(
        name=name,
        description=description,
        robot=robot,
        goal=goal,
        duration=duration,
        seed=seed,
        perception=perception,
        obstacles=tuple(obstacles),
        planner=planner,
        ground_truth=ground_truth,
        physics=physics,
        overrides=overrides,
        source=source,
    )


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
    if data is None:
        data = {}
    try:
        return parse_scenario(data, name=path.stem, source=str(path))
    except ScenarioError as exc:
        raise ScenarioError(f"{path}: {exc}") from None
