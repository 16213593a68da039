"""Readable lines for the validation errors of a scenario file.

Pydantic collects every error of the document; :func:`format_errors` turns them into lines
like::

    obstacles[1].semi_axes: must be two positive numbers
    obstacles[0].colour: unknown field (did you mean 'color'?)
    filter.gama: unknown key 'gama' under filter (did you mean 'gamma'?)

with the unknown keys first: a misspelt required field is reported by its misspelt name, and
the "is required" error of the field it was meant to be is dropped. The error kinds are those
of :mod:`safe_legged_c3bf.sim.scenario_fields`; the models those of
:mod:`safe_legged_c3bf.sim.scenario_sections`.
"""

from __future__ import annotations

import difflib
from typing import Any, get_args

from pydantic import BaseModel, ValidationError

from safe_legged_c3bf.sim.scenario_fields import ERROR_INVALID, ERROR_MISSING, ERROR_UNKNOWN
from safe_legged_c3bf.sim.scenario_sections import OverrideSection

#: Most error lines in one message.
MAX_LINES = 10


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
