"""The scenario file's structure as pydantic models, and readable messages for its errors.

:mod:`safe_legged_c3bf.sim.scenario` validates a loaded YAML mapping with
:func:`validate_document` and builds its frozen dataclasses from the result. Every mapping
forbids unknown keys, including the parameter override sections (``filter``, ``tracker``,
``controller``, ``planner``), whose keys are the parameters the receiving node really declares
(:mod:`safe_legged_c3bf.node_parameters`). Pydantic collects every error of the document;
:func:`format_errors` turns them into lines like::

    obstacles[1].semi_axes: must be two positive numbers
    obstacles[0].colour: unknown field (did you mean 'color'?)
    filter.gama: unknown key 'gama' under filter (did you mean 'gamma'?)

with the unknown keys first: a misspelt required field is reported by its misspelt name, and
the "is required" error of the field it was meant to be is dropped.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from functools import cache
from typing import Annotated, Any, ClassVar, get_args

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PlainValidator,
    PrivateAttr,
    ValidationError,
    create_model,
    model_validator,
)

from safe_legged_c3bf.node_parameters import (
    OVERRIDE_NODES,
    override_fixed_parameters,
    override_parameter_defaults,
    override_refuses_integers,
)
from safe_legged_c3bf.sim.robots import ROBOTS
from safe_legged_c3bf.sim.scenario_fields import (
    ERROR_INVALID,
    ERROR_MISSING,
    ERROR_UNKNOWN,
    NonNeg,
    Num,
    PosNum,
    choice,
    fail,
    fail_missing,
    fail_unknown,
    non_empty_string,
    non_negative_integer,
    number,
    obstacle_id,
    override_value,
    scalar_or_xyz,
    string,
    vector,
    waypoint_list,
)

PLANES = ("vertical", "horizontal")
MOTION_TYPES = ("static", "constant_velocity", "waypoints")
WAYPOINT_MODES = ("pingpong", "cycle", "stop")
PLANNER_MODES = ("goal", "constant_velocity")
#: Keys of the planner section that are the scenario's own, not planner node parameters.
PLANNER_FIELDS = ("mode", "speed", "velocity")
#: Most error lines in one message.
MAX_LINES = 10


# --------------------------------------------------------------------------- models


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


class PerceptionSection(Section):
    """``perception:``."""

    rate: PosNum = 20.0
    position_noise_std: Annotated[tuple, scalar_or_xyz(non_negative=True)] = (0.02, 0.02, 0.02)
    position_noise_bias: Annotated[tuple, scalar_or_xyz()] = (0.0, 0.0, 0.0)
    size_noise_std: NonNeg = 0.0
    dropout_probability: Annotated[float, number(minimum=0.0, maximum=1.0)] = 0.0
    max_range: Annotated[float, number(positive=True, allow_inf=True)] = math.inf


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


def _override_model(section: str) -> type[OverrideSection]:
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


@cache
def scenario_model() -> type[Section]:
    """The model of a whole scenario file (built once: it reads the nodes' parameter names)."""
    return create_model(
        "ScenarioDocument",
        __base__=Section,
        name=(Annotated[str, PlainValidator(non_empty_string)] | None, None),
        description=(Annotated[str, PlainValidator(string)], ""),
        robot=(RobotSection, Field(default_factory=RobotSection)),
        goal=(GoalSection, Field(default_factory=GoalSection)),
        duration=(PosNum, 30.0),
        seed=(Annotated[int, PlainValidator(non_negative_integer)], 0),
        perception=(PerceptionSection, Field(default_factory=PerceptionSection)),
        obstacles=(list[ObstacleSection], Field(default_factory=list)),
        planner=(_override_model("planner"), Field(default_factory=_override_model("planner"))),
        ground_truth=(GroundTruthSection, Field(default_factory=GroundTruthSection)),
        physics=(PhysicsSection, Field(default_factory=PhysicsSection)),
        filter=(_override_model("filter") | None, None),
        tracker=(_override_model("tracker") | None, None),
        controller=(_override_model("controller") | None, None),
    )


# --------------------------------------------------------------------------- errors


def _path(loc: tuple[Any, ...], suffix: str = "") -> str:
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    text += suffix
    return text.lstrip(".") or "scenario"


def _model_in(annotation: Any) -> type[BaseModel] | None:
    """The pydantic model inside an annotation (X, X | None, list[X], Annotated[X, ...])."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in get_args(annotation):
        found = _model_in(arg)
        if found is not None:
            return found
    return None


def _model_at(root: type[BaseModel], loc: tuple[Any, ...]) -> type[BaseModel] | None:
    """The model that validated the mapping at ``loc`` (None if not a model)."""
    model: type[BaseModel] | None = root
    for part in loc:
        if isinstance(part, int) or model is None:
            continue
        info = next((f for n, f in model.model_fields.items() if (f.alias or n) == part), None)
        model = _model_in(info.annotation) if info is not None else None
    return model


def _keys(model: type[BaseModel] | None) -> tuple[str, ...]:
    if model is None:
        return ()
    return tuple(f.alias or n for n, f in model.model_fields.items())


def _suggest(key: str, allowed: tuple[str, ...]) -> str | None:
    close = difflib.get_close_matches(str(key), allowed, n=1, cutoff=0.6)
    return close[0] if close else None


def _unknown_message(parent: tuple[Any, ...], key: Any, model, allowed) -> tuple[str, str | None]:
    allowed = tuple(allowed)
    guess = _suggest(str(key), allowed)
    hint = f"did you mean {guess!r}?" if guess else "expected one of: " + ", ".join(sorted(allowed))
    if isinstance(model, type) and issubclass(model, OverrideSection):
        where = _path(parent)
        text = f"unknown key {str(key)!r} under {where} ({hint})"
        if not guess:
            text = (f"unknown key {str(key)!r} under {where}: not a parameter of the "
                    f"{model.node} node ({hint})")
        return text, guess
    return f"unknown field ({hint})", guess


def format_errors(error: ValidationError, root: type[BaseModel]) -> list[str]:
    """One line per error, ``path: message``, unknown keys first (see the module docstring)."""
    unknown: list[str] = []
    others: list[tuple[tuple[Any, ...], str]] = []
    meant: set[tuple[Any, ...]] = set()  # fields an unknown key probably stands for
    for err in error.errors(include_url=False):
        loc, kind, ctx = tuple(err["loc"]), err["type"], err.get("ctx") or {}
        if kind == "extra_forbidden":
            parent, key = loc[:-1], loc[-1]
            model = _model_at(root, parent)
            text, guess = _unknown_message(parent, key, model, _keys(model))
            unknown.append(f"{_path(loc)}: {text}")
            if guess:
                meant.add((*parent, guess))
        elif kind == ERROR_UNKNOWN:
            model = _model_at(root, loc)
            text, guess = _unknown_message(loc, ctx["key"], model, ctx["allowed"])
            unknown.append(f"{_path((*loc, ctx['key']))}: {text}")
            if guess:
                meant.add((*loc, guess))
        elif kind == ERROR_MISSING:
            note = f" {ctx['note']}" if ctx.get("note") else ""
            others.append(((*loc, ctx["key"]), f"{_path((*loc, ctx['key']))}: is required{note}"))
        elif kind == "missing":
            others.append((loc, f"{_path(loc)}: is required"))
        elif kind == ERROR_INVALID:
            others.append((loc, f"{_path(loc, ctx.get('suffix', ''))}: {ctx['message']}"))
        elif kind in ("model_type", "model_attributes_type", "dict_type"):
            others.append((loc, f"{_path(loc)}: must be a mapping, got {err['input']!r}"))
        elif kind == "list_type":
            others.append((loc, f"{_path(loc)}: must be a list, got {err['input']!r}"))
        else:  # not expected: every leaf has its own validator
            others.append((loc, f"{_path(loc)}: {err['msg']}"))
    lines = unknown + [text for loc, text in others if loc not in meant]
    if len(lines) > MAX_LINES:
        lines = [*lines[:MAX_LINES], f"... and {len(lines) - MAX_LINES} more errors"]
    return lines


def validate_document(data: Any) -> tuple[Section | None, list[str]]:
    """(validated document, []) or (None, error lines)."""
    model = scenario_model()
    try:
        return model.model_validate(data), []
    except ValidationError as err:
        return None, format_errors(err, model)

