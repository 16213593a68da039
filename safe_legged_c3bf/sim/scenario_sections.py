"""The sections of the scenario file as pydantic models (one model per mapping).

Every model forbids unknown keys and treats a null value as "default"; :meth:`Section.given`
returns the keys the file really gave. The override sections (``filter``, ``tracker``,
``controller``, ``planner``) are built by :func:`override_model` from the parameters the
receiving node declares (:mod:`safe_legged_c3bf.interfaces.node_parameters`). Units: m, s, rad, m/s;
positions in odom (the world frame). The whole document is
:func:`safe_legged_c3bf.sim.scenario_schema.scenario_model`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Annotated, Any, ClassVar

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PlainValidator,
    PrivateAttr,
    create_model,
    model_validator,
)

from safe_legged_c3bf.interfaces.node_parameters import (
    OVERRIDE_NODES,
    override_fixed_parameters,
    override_parameter_defaults,
    override_refuses_integers,
)
from safe_legged_c3bf.sim.range_sensors import (
    FULL_CIRCLE,
    FULL_CIRCLE_TOLERANCE,
    MAX_RAYS,
    DepthConfig,
    LidarConfig,
)
from safe_legged_c3bf.sim.robots import ROBOTS
from safe_legged_c3bf.sim.scenario_fields import (
    NonNeg,
    Num,
    PosNum,
    Probability,
    angle_within,
    choice,
    fail,
    fail_missing,
    fail_unknown,
    integer_within,
    number,
    obstacle_id,
    override_value,
    scalar_or_xyz,
    vector,
    waypoint_list,
)

PLANES = ("vertical", "horizontal")
MOTION_TYPES = ("static", "constant_velocity", "waypoints")
WAYPOINT_MODES = ("pingpong", "cycle", "stop")
PLANNER_MODES = ("goal", "constant_velocity")
#: Where the obstacle detections come from (``perception.source``).
PERCEPTION_SOURCES = ("oracle", "sensors")
#: Keys of the planner section that are the scenario's own, not planner node parameters.
PLANNER_FIELDS = ("mode", "speed", "velocity")


class Section(BaseModel):
    """A mapping of the scenario: unknown keys are errors; a null value means "default"."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    _keys_in_order: tuple[str, ...] = PrivateAttr(default=())

    @model_validator(mode="wrap")
    @classmethod
    def _drop_nulls(cls, data: Any, handler: Any) -> Any:
        if isinstance(data, Mapping):
            data = {k: v for k, v in data.items() if v is not None}
        model = handler(data)
        if isinstance(data, Mapping):
            model._keys_in_order = tuple(str(k) for k in data)
        return model

    def given(self) -> dict[str, Any]:
        """The keys given in the file (by their YAML names, in its order) and their values."""
        values = {}
        for name in self.model_fields_set:
            info = type(self).model_fields[name]
            values[info.alias or name] = getattr(self, name)
        order = {key: i for i, key in enumerate(self._keys_in_order)}
        return dict(sorted(values.items(), key=lambda item: order.get(item[0], len(order))))



class RobotSection(Section):
    """``robot:``."""

    kind: Annotated[str, choice(tuple(sorted(ROBOTS)))] = "quadruped"
    position: Annotated[tuple[float, float], vector((2,))] = (0.0, 0.0)
    yaw: Num = 0.0


class GoalSection(Section):
    """``goal:``; the position defaults to the robot's start."""

    position: Annotated[tuple[float, float], vector((2,))] | None = None
    tolerance: PosNum = 0.3


_LIDAR, _DEPTH = LidarConfig(), DepthConfig()
_Rays = Annotated[int, integer_within(1, MAX_RAYS)]
_HalfTurn = Annotated[float, angle_within(math.pi, False, "(0, pi)")]


class _RangeSection(Section):
    """What the two range sensors share: range_min < range_max (m)."""

    @model_validator(mode="after")
    def _range_order(self) -> _RangeSection:
        low, high = self.range_min, self.range_max  # type: ignore[attr-defined]
        if low >= high:
            fail(f"must be less than range_max ({high!r}), got {low!r}", ".range_min")
        return self


class LidarSection(_RangeSection):
    """``perception.lidar:`` (:class:`~safe_legged_c3bf.sim.range_sensors.LidarConfig`)."""

    rate: PosNum = _LIDAR.rate
    beams: _Rays = _LIDAR.beams
    fov: Annotated[float, angle_within(
        FULL_CIRCLE + FULL_CIRCLE_TOLERANCE, True, "(0, 2 pi]")] = _LIDAR.fov
    range_min: NonNeg = _LIDAR.range_min
    range_max: PosNum = _LIDAR.range_max
    range_noise_std: NonNeg = _LIDAR.range_noise_std
    dropout_probability: Probability = _LIDAR.dropout_probability


class DepthSection(_RangeSection):
    """``perception.depth:`` (:class:`~safe_legged_c3bf.sim.range_sensors.DepthConfig`)."""

    rate: PosNum = _DEPTH.rate
    columns: _Rays = _DEPTH.columns
    rows: _Rays = _DEPTH.rows
    horizontal_fov: _HalfTurn = _DEPTH.horizontal_fov
    vertical_fov: _HalfTurn = _DEPTH.vertical_fov
    range_min: NonNeg = _DEPTH.range_min
    range_max: PosNum = _DEPTH.range_max
    range_noise_std: NonNeg = _DEPTH.range_noise_std
    dropout_probability: Probability = _DEPTH.dropout_probability

    @model_validator(mode="after")
    def _ray_count(self) -> DepthSection:
        if self.columns * self.rows > MAX_RAYS:
            fail(f"columns x rows must be at most {MAX_RAYS}, got {self.columns} x "
                 f"{self.rows}", ".rows")
        return self


class PerceptionSection(Section):
    """``perception:``; ``lidar`` and ``depth`` are used with ``source: sensors``."""

    source: Annotated[str, choice(PERCEPTION_SOURCES)] = "oracle"
    rate: PosNum = 20.0
    position_noise_std: Annotated[tuple, scalar_or_xyz(non_negative=True)] = (0.02, 0.02, 0.02)
    position_noise_bias: Annotated[tuple, scalar_or_xyz()] = (0.0, 0.0, 0.0)
    size_noise_std: NonNeg = 0.0
    dropout_probability: Probability = 0.0
    max_range: Annotated[float, number(positive=True, allow_inf=True)] = math.inf
    lidar: LidarSection = Field(default_factory=LidarSection)
    depth: DepthSection = Field(default_factory=DepthSection)


_MOTION_KEYS = {
    "static": ("type", "start_time"),
    "constant_velocity": ("type", "start_time", "velocity"),
    "waypoints": ("type", "start_time", "waypoints", "speed", "mode"),
}


class MotionSection(Section):
    """``obstacles[i].motion:``; which keys apply depends on ``type``."""

    type: Annotated[str, choice(MOTION_TYPES)] = "static"
    start_time: NonNeg = 0.0
    velocity: Annotated[tuple, vector((2, 3))] | None = None
    waypoints: Annotated[list, PlainValidator(waypoint_list)] | None = None
    speed: PosNum | None = None
    mode: Annotated[str, choice(WAYPOINT_MODES)] = "pingpong"

    @model_validator(mode="after")
    def _fields_of_type(self) -> MotionSection:
        allowed = _MOTION_KEYS[self.type]
        for key in sorted(self.model_fields_set - set(allowed)):
            fail_unknown(key, allowed)
        if self.type == "constant_velocity" and self.velocity is None:
            fail_missing("velocity")
        if self.type == "waypoints":
            if self.waypoints is None:
                fail_missing("waypoints")
            if self.speed is None:
                fail_missing("speed")
        return self


class ObstacleSection(Section):
    """``obstacles[i]:`` (the position's meaning depends on ``plane``)."""

    id: Annotated[str, PlainValidator(obstacle_id)] | None = None
    plane: Annotated[str, choice(PLANES)] = "vertical"
    position: Annotated[tuple, vector((2, 3))]
    semi_axes: Annotated[
        tuple[float, float], vector((2,), positive=True, what="must be two positive numbers")
    ]
    orientation: Num = 0.0
    extent: PosNum | None = None
    color: Annotated[tuple, vector((3, 4), non_negative=True)] = (0.8, 0.3, 0.2, 1.0)
    motion: MotionSection = Field(default_factory=MotionSection)

    @model_validator(mode="after")
    def _position_and_path(self) -> ObstacleSection:
        if self.plane == "horizontal":
            if len(self.position) != 3:
                fail("must be [x, y, z] (x, middle of the bar along y, height of the bar "
                      f"axis), got {list(self.position)!r}", ".position")
            if self.position[2] <= 0:
                fail("the bar's height z must be positive", ".position")
        start = self.start_position()
        previous = start
        for i, point in enumerate(self.waypoints()):
            if math.dist(point, previous) < 1e-6:
                fail("must differ from the previous point (the obstacle's position for the "
                      "first waypoint)", f".motion.waypoints[{i}]")
            previous = point
        if self.motion.mode == "cycle" and self.waypoints() and math.dist(
            self.waypoints()[-1], start
        ) < 1e-6:
            fail("in cycle mode the last waypoint must not repeat the start position",
                  ".motion.waypoints")
        return self

    def extent_or_default(self) -> float:
        """Extent (m): given, or 1.5 for a vertical obstacle, 4.0 for a bar."""
        if self.extent is not None:
            return self.extent
        return 1.5 if self.plane == "vertical" else 4.0

    def start_position(self) -> tuple[float, float, float]:
        """(x, y, z) at t = 0: a vertical obstacle given as [x, y] stands on the ground."""
        p = self.position
        return (p[0], p[1], p[2] if len(p) == 3 else self.extent_or_default() / 2.0)

    def waypoints(self) -> tuple[tuple[float, float, float], ...]:
        """The waypoints with z filled in (an [x, y] point keeps the start height)."""
        if self.motion.type != "waypoints" or not self.motion.waypoints:
            return ()
        z = self.start_position()[2]
        return tuple((p[0], p[1], p[2] if len(p) == 3 else z) for p in self.motion.waypoints)


class GroundTruthSection(Section):
    """``ground_truth:``; the fall bounds default per robot kind (scenario.FALL_DEFAULTS)."""

    fall_min_height: NonNeg | None = None
    fall_max_tilt: Annotated[float, number(positive=True, maximum=math.pi)] | None = None
    collision_debounce: NonNeg = 0.1
    contact_tolerance: NonNeg = 0.001
    distance_cutoff: PosNum = 1.0
    exact_distance_below: NonNeg = 0.3
    max_closing_speed: PosNum = 4.0
    max_check_interval: PosNum = 0.02


class PhysicsSection(Section):
    """``physics:``."""

    lateral_friction: PosNum = 1.0
    gravity: PosNum = 9.81


class OverrideSection(Section):
    """Parameter overrides of one node: the keys are that node's parameter names."""

    #: Scenario section name ('filter', ...) and the node it configures.
    section: ClassVar[str] = ""
    node: ClassVar[str] = ""


_PLANNER_VELOCITY = vector(
    (1, 2, 3, 4), what="must be a list of 1 to 4 numbers: vx, vy, vz, yaw_rate (m/s, rad/s)"
)


def _check_planner(self: BaseModel) -> BaseModel:
    if self.mode == "constant_velocity" and self.velocity is None:  # type: ignore[attr-defined]
        fail_missing("velocity", "in constant_velocity mode ([vx, vy, vz, yaw_rate])")
    return self


def override_model(section: str) -> type[OverrideSection]:
    """A model whose fields are the parameters of the node a section configures."""
    node = OVERRIDE_NODES[section]
    strict = override_refuses_integers(section)
    # The planner applies its section after it started: its parameters fixed at start-up
    # (the scenario itself, which the bringup sets, and diagnostics_period) are not there.
    left_out = (*PLANNER_FIELDS, *override_fixed_parameters(section)) if section == "planner" \
        else ()
    defaults = {
        name: default for name, default in override_parameter_defaults(section).items()
        if name not in left_out
    }
    # Fields get neutral names and the parameter name as alias: a parameter may be called
    # like a BaseModel attribute.
    fields: dict[str, Any] = {
        f"p_{i}": (
            Annotated[Any, override_value(name, default, node, strict)] | None,
            Field(default=None, alias=name),
        )
        for i, (name, default) in enumerate(defaults.items())
    }
    validators = {}
    if section == "planner":
        fields.update(
            mode=(Annotated[str, choice(PLANNER_MODES)], "goal"),
            speed=(PosNum | None, None),
            velocity=(Annotated[tuple, _PLANNER_VELOCITY] | None, None),
        )
        validators["_constant_velocity"] = model_validator(mode="after")(_check_planner)
    model = create_model(
        f"{section.capitalize()}Overrides", __base__=OverrideSection,
        __validators__=validators, **fields,
    )
    model.section = section
    model.node = node
    return model
