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
from functools import cache
from typing import Annotated, Any, get_args

from pydantic import BaseModel, Field, PlainValidator, ValidationError, create_model

from safe_legged_c3bf.sim.scenario_fields import (
    ERROR_INVALID,
    ERROR_MISSING,
    ERROR_UNKNOWN,
    PosNum,
    non_empty_string,
    non_negative_integer,
    string,
)
from safe_legged_c3bf.sim.scenario_sections import (
    MOTION_TYPES,
    PLANES,
    PLANNER_FIELDS,
    PLANNER_MODES,
    WAYPOINT_MODES,
    GoalSection,
    GroundTruthSection,
    ObstacleSection,
    OverrideSection,
    PerceptionSection,
    PhysicsSection,
    RobotSection,
    Section,
    override_model,
)

__all__ = [  # the constants are re-exported from scenario_sections
    "MAX_LINES", "MOTION_TYPES", "PLANES", "PLANNER_FIELDS", "PLANNER_MODES", "WAYPOINT_MODES",
    "format_errors", "scenario_model", "validate_document",
]

#: Most error lines in one message.
MAX_LINES = 10


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

