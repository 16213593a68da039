"""The scenario file's structure as a pydantic model, and its validation.

:mod:`safe_legged_c3bf.sim.scenario` validates a loaded YAML mapping with
:func:`validate_document` and builds its frozen dataclasses from the result. Every mapping
forbids unknown keys, including the parameter override sections (``filter``, ``tracker``,
``controller``, ``planner``), whose keys are the parameters the receiving node really declares
(:mod:`safe_legged_c3bf.interfaces.node_parameters`). Parts: the leaf-value validators are in
:mod:`.scenario_fields`, the section models in :mod:`.scenario_sections`, the error lines
(unknown keys first, with "did you mean") in :mod:`.scenario_errors`.
"""

from __future__ import annotations

from functools import cache
from typing import Annotated, Any

from pydantic import Field, PlainValidator, ValidationError, create_model

from safe_legged_c3bf.sim.scenario_errors import MAX_LINES, format_errors
from safe_legged_c3bf.sim.scenario_fields import (
    PosNum,
    non_empty_string,
    non_negative_integer,
    string,
)
from safe_legged_c3bf.sim.scenario_sections import (
    MOTION_TYPES,
    PERCEPTION_SOURCES,
    PLANES,
    PLANNER_FIELDS,
    PLANNER_MODES,
    WAYPOINT_MODES,
    GoalSection,
    GroundTruthSection,
    ObstacleSection,
    PerceptionSection,
    PhysicsSection,
    RobotSection,
    Section,
    override_model,
)

__all__ = [  # re-exported from scenario_sections and scenario_errors
    "MAX_LINES", "MOTION_TYPES", "PERCEPTION_SOURCES", "PLANES", "PLANNER_FIELDS",
    "PLANNER_MODES", "WAYPOINT_MODES", "format_errors", "scenario_model", "validate_document",
]


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
        planner=(override_model("planner"), Field(default_factory=override_model("planner"))),
        ground_truth=(GroundTruthSection, Field(default_factory=GroundTruthSection)),
        physics=(PhysicsSection, Field(default_factory=PhysicsSection)),
        filter=(override_model("filter") | None, None),
        tracker=(override_model("tracker") | None, None),
        controller=(override_model("controller") | None, None),
        detector=(override_model("detector") | None, None),
    )


def validate_document(data: Any) -> tuple[Section | None, list[str]]:
    """(validated document, []) or (None, error lines)."""
    model = scenario_model()
    try:
        return model.model_validate(data), []
    except ValidationError as err:
        return None, format_errors(err, model)

