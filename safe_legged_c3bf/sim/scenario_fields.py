"""Validators of the scenario file's leaf values, and the errors they raise.

Each validator is a pydantic ``PlainValidator`` that accepts exactly the YAML values the
format allows (doc/scenario_format.md: numbers are never bools or strings, vectors have fixed
lengths) and raises a ``PydanticCustomError`` of kind :data:`ERROR_INVALID` with a readable
message otherwise. :func:`fail_unknown` and :func:`fail_missing` raise the kinds a model
validator uses for keys that do not apply or are missing;
:func:`safe_legged_c3bf.sim.scenario_errors.format_errors` turns all three into lines. Units
are those of the field (m, s, rad; see the section models in
:mod:`safe_legged_c3bf.sim.scenario_sections`).
"""

from __future__ import annotations

import math
from typing import Annotated, Any

from pydantic import PlainValidator
from pydantic_core import PydanticCustomError

#: Kinds of the errors raised here (a bad value, a key that does not apply, a missing key).
ERROR_INVALID, ERROR_UNKNOWN, ERROR_MISSING = (
    "scenario_invalid", "scenario_unknown", "scenario_missing"
)


def fail(message: str, suffix: str = "") -> None:
    """Raise a validation error; ``suffix`` extends the field path ('.speed', '[0]')."""
    raise PydanticCustomError(ERROR_INVALID, "{message}", {"message": message, "suffix": suffix})


def fail_unknown(key: str, allowed: tuple[str, ...]) -> None:
    """Raise "unknown field" for ``key`` (``allowed``: the keys that apply there)."""
    raise PydanticCustomError(ERROR_UNKNOWN, "unknown field", {"key": key, "allowed": allowed})


def fail_missing(key: str, note: str = "") -> None:
    """Raise "is required" for ``key``; ``note`` is appended to the message."""
    raise PydanticCustomError(ERROR_MISSING, "is required", {"key": key, "note": note})


# --------------------------------------------------------------------------- leaf values


def as_number(value: Any, allow_inf: bool = False) -> float | None:
    """``value`` as a float, or None if it is not a finite number (bools are not numbers)."""
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


def as_vector(value: Any, sizes: tuple[int, ...]) -> tuple[float, ...] | None:
    """``value`` as a tuple of finite floats of one of ``sizes`` lengths, or None."""
    if not isinstance(value, list | tuple) or len(value) not in sizes:
        return None
    out = [as_number(v) for v in value]
    return None if any(x is None for x in out) else tuple(out)  # type: ignore[arg-type]


def number(*, positive=False, minimum=None, maximum=None, allow_inf=False) -> PlainValidator:
    """A number (never a bool or a string), optionally > 0 or within [minimum, maximum]."""

    def check(value: Any) -> float:
        x = as_number(value, allow_inf)
        if x is None:
            fail(f"must be a number, got {value!r}")
        if positive and not x > 0:
            fail(f"must be a positive number, got {value!r}")
        if minimum is not None and x < minimum:
            fail(f"must be >= {minimum}, got {value!r}")
        if maximum is not None and x > maximum:
            fail(f"must be <= {maximum}, got {value!r}")
        return x

    return PlainValidator(check)


def angle_within(maximum: float, inclusive: bool, text: str) -> PlainValidator:
    """An angle (rad) > 0 and <= ``maximum`` (< with ``inclusive`` False); ``text``: the range."""

    def check(value: Any) -> float:
        x = as_number(value)
        if x is None or not x > 0 or x > maximum or (not inclusive and x == maximum):
            fail(f"must be an angle within {text} (rad), got {value!r}")
        return x

    return PlainValidator(check)


def integer_within(minimum: int, maximum: int) -> PlainValidator:
    """An integer (not a bool, not a float) within [minimum, maximum]."""

    def check(value: Any) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            fail(f"must be an integer, got {value!r}")
        if not minimum <= value <= maximum:
            fail(f"must be an integer within [{minimum}, {maximum}], got {value!r}")
        return int(value)

    return PlainValidator(check)


def non_negative_integer(value: Any) -> int:
    """An integer >= 0 (not a bool, not a float)."""
    if isinstance(value, bool) or not isinstance(value, int):
        fail(f"must be an integer, got {value!r}")
    if value < 0:
        fail(f"must be >= 0, got {value!r}")
    return int(value)


def choice(options: tuple[str, ...]) -> PlainValidator:
    """One of ``options`` (strings)."""

    def check(value: Any) -> str:
        if not isinstance(value, str) or value not in options:
            fail(f"must be one of {', '.join(options)}; got {value!r}")
        return value

    return PlainValidator(check)


def non_empty_string(value: Any) -> str:
    """A string with something other than white space."""
    if not isinstance(value, str) or not value.strip():
        fail(f"must be a non-empty string, got {value!r}")
    return value


def string(value: Any) -> str:
    """Any string."""
    if not isinstance(value, str):
        fail(f"must be a string, got {value!r}")
    return value


def obstacle_id(value: Any) -> str:
    """An obstacle id: a string, or an integer taken as its text."""
    if not isinstance(value, str | int) or isinstance(value, bool):
        fail(f"must be a string, got {value!r}")
    return str(value)


def vector(sizes: tuple[int, ...], *, positive=False, non_negative=False, what=None):
    """A list of ``sizes`` numbers (any of those lengths), optionally > 0 or >= 0."""

    def check(value: Any) -> tuple[float, ...]:
        vec = as_vector(value, sizes)
        ok = vec is not None
        if ok and positive:
            ok = all(v > 0 for v in vec)
        if ok and non_negative:
            ok = all(v >= 0 for v in vec)
        if not ok:
            if what is None:
                count = " or ".join(str(s) for s in sizes)
                kind = ("positive numbers" if positive else
                        "non-negative numbers" if non_negative else "numbers")
                fail(f"must be a list of {count} {kind}, got {value!r}")
            fail(what)
        return vec

    return PlainValidator(check)


def scalar_or_xyz(non_negative: bool = False) -> PlainValidator:
    """One number for x, y and z, or a list of 3."""

    def check(value: Any) -> tuple[float, float, float]:
        vec = as_vector(value, (3,)) if isinstance(value, list | tuple) else None
        if vec is None:
            x = None if isinstance(value, list | tuple) else as_number(value)
            if x is None:
                fail(f"must be a number or a list of 3 numbers (x, y, z), got {value!r}")
            vec = (x, x, x)
        if non_negative and any(v < 0 for v in vec):
            fail(f"must be non-negative, got {value!r}")
        return vec  # type: ignore[return-value]

    return PlainValidator(check)


def waypoint_list(value: Any) -> list[tuple[float, ...]]:
    """A non-empty list of [x, y] or [x, y, z] points (m, odom)."""
    if not isinstance(value, list) or not value:
        fail("must be a non-empty list of [x, y] or [x, y, z] points")
    points = []
    for i, p in enumerate(value):
        vec = as_vector(p, (2, 3))
        if vec is None:
            fail(f"must be [x, y] or [x, y, z] numbers, got {p!r}", f"[{i}]")
        points.append(vec)
    return points


def _is_float(value: Any) -> bool:
    return isinstance(value, float) and not math.isnan(value)


def _is_number(value: Any) -> bool:
    return _is_float(value) or (isinstance(value, int) and not isinstance(value, bool))


def override_value(name: str, default: Any, node: str, strict_double: bool) -> PlainValidator:
    """A parameter override of the type of the node's default for it.

    ``strict_double``: the node's parameter class refuses an integer for a float (the node
    would fail to start).
    """

    def check(value: Any) -> Any:
        if isinstance(default, bool):
            if not isinstance(value, bool):
                fail(f"must be true or false, got {value!r}")
        elif isinstance(default, int):
            if isinstance(value, bool) or not isinstance(value, int):
                fail(f"must be an integer, got {value!r}")
        elif isinstance(default, float):
            if not _is_number(value):
                fail(f"must be a number, got {value!r}")
            if strict_double and not _is_float(value):
                fail(f"must be a floating-point number, got {value!r} (write {value}.0: the "
                      f"{node} node declares {name} as a double and refuses an integer)")
        elif isinstance(default, str):
            if not isinstance(value, str):
                fail(f"must be a string, got {value!r}")
        elif isinstance(default, list | tuple):
            ok = _is_float if strict_double else _is_number
            if not isinstance(value, list) or not value or not all(ok(v) for v in value):
                kind = "floating-point numbers (1.0, not 1)" if strict_double else "numbers"
                fail(f"must be a list of {kind}, got {value!r}")
        return value

    return PlainValidator(check)


Num = Annotated[float, number()]
PosNum = Annotated[float, number(positive=True)]
NonNeg = Annotated[float, number(minimum=0.0)]
Probability = Annotated[float, number(minimum=0.0, maximum=1.0)]
