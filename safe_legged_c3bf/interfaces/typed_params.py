"""Typed parameter classes: every field carries its unit, description and rule (no ROS).

A node's parameters are one frozen dataclass deriving from :class:`TypedParams` whose fields
are made with :func:`param`::

    @dataclass(frozen=True)
    class ExampleParams(TypedParams):
        rate: float = param(50.0, "Hz", "cycles per second (sim time)", POSITIVE)
        frame_id: str = param("odom", "-", "frame of the output (unitless)", NON_EMPTY,
                              fixed=True)

:meth:`TypedParams.validate` is the one place the values are checked: each field against its
:class:`Rule` (messages like ``rate: must be a finite number > 0, got -1.0``), then the rules
between fields (:meth:`TypedParams.check_together`). A field made with :func:`group` nests
another parameter class whose fields are parameters of the same node: the node sees them
flattened (:meth:`TypedParams.specs`, :meth:`TypedParams.flat`, :meth:`TypedParams.from_flat`).
``fixed=True`` marks a parameter read at start-up only (read-only on the node).
:mod:`safe_legged_c3bf.nodes.parameters` declares such a class on an rclpy node.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cache
from numbers import Integral, Real
from typing import Any, ClassVar, Self

__all__ = [
    "FINITE", "FINITE_OR_NAN", "FLAG", "INTEGER", "NON_EMPTY", "NON_NEGATIVE", "POSITIVE",
    "POSITIVE_OR_INF", "TEXT", "ParamSpec", "Rule", "TypedParams", "at_least", "group",
    "interval", "one_of", "optional", "param", "param_like", "vector",
]


# --------------------------------------------------------------------------- rules


@dataclass(frozen=True)
class Rule:
    """What a parameter value must be.

    Attributes:
        expected: the words after "must be" in an error message ("a finite number > 0").
        accepts: True for a valid value (of any type: it checks the type too).
        invalid: an example of a value the rule refuses (used by the tests).

    """

    expected: str
    accepts: Callable[[Any], bool]
    invalid: Any


def _number(value: Any) -> bool:
    return isinstance(value, Real) and not isinstance(value, bool)


def _finite(value: Any) -> bool:
    return _number(value) and math.isfinite(value)


def _integer(value: Any) -> bool:
    return isinstance(value, Integral) and not isinstance(value, bool)


POSITIVE = Rule("a finite number > 0", lambda v: _finite(v) and v > 0, -1.0)
POSITIVE_OR_INF = Rule(
    "a number > 0 (inf = no limit)", lambda v: _number(v) and v > 0, -1.0
)
NON_NEGATIVE = Rule("a finite number >= 0", lambda v: _finite(v) and v >= 0, -1.0)
FINITE = Rule("a finite number", _finite, math.inf)
FINITE_OR_NAN = Rule(
    "a finite number or NaN (unset)", lambda v: _number(v) and not math.isinf(v), math.inf
)
INTEGER = Rule("an integer", _integer, 0.5)
FLAG = Rule("true or false", lambda v: isinstance(v, bool), "yes")
TEXT = Rule("a string", lambda v: isinstance(v, str), 1.0)
NON_EMPTY = Rule("a non-empty string", lambda v: isinstance(v, str) and v != "", "")


def at_least(minimum: int) -> Rule:
    """An integer >= ``minimum`` (a count)."""
    return Rule(f"an integer >= {minimum}", lambda v: _integer(v) and v >= minimum, minimum - 1)


def interval(low: float, high: float, closed_high: bool = False, high_text: str = "") -> Rule:
    """A finite number in (low, high), or in (low, high] with ``closed_high``.

    ``high_text`` names the upper bound in messages ("pi/2" rather than 1.5707963267948966).
    """
    bracket = "]" if closed_high else ")"

    def accepts(v: Any) -> bool:
        return _finite(v) and low < v and (v <= high if closed_high else v < high)

    return Rule(f"a number in ({low}, {high_text or high}{bracket}", accepts, high + 1.0)


def one_of(*choices: str) -> Rule:
    """One of the strings ``choices``."""
    return Rule(
        "one of " + ", ".join(repr(str(c)) for c in choices),
        lambda v: isinstance(v, str) and v in choices,
        "no-such-choice",
    )


def vector(size: int, each: Rule) -> Rule:
    """A list or tuple of ``size`` values, each accepted by ``each``."""
    words = {2: "two", 3: "three", 4: "four"}.get(size, str(size))
    return Rule(
        f"{words} values, each {each.expected}",
        lambda v: isinstance(v, list | tuple) and len(v) == size and all(map(each.accepts, v)),
        [each.invalid] * size,
    )


def optional(rule: Rule) -> Rule:
    """None or a value ``rule`` accepts."""
    return Rule(f"None or {rule.expected}", lambda v: v is None or rule.accepts(v), rule.invalid)


# --------------------------------------------------------------------------- fields


def param(
    default: Any, unit: str, description: str, rule: Rule, *, fixed: bool = False
) -> Any:
    """A parameter field.

    Args:
        default: the default value (immutable: a tuple for a list parameter).
        unit: SI unit ("m", "s", "Hz", "m/s^2", ...); "-" for a unitless value.
        description: what the parameter does, in a sentence or a few.
        rule: what a valid value is.
        fixed: read at start-up only (read-only on the node; a restart changes it).

    """
    meta = {"unit": unit, "description": description, "rule": rule, "fixed": fixed}
    return field(default=default, metadata=meta)


def param_like(cls: type, name: str, default: Any = dataclasses.MISSING, **changes: Any) -> Any:
    """A field like ``cls``'s field ``name`` (same unit, description, rule), changed as given."""
    original = next(f for f in dataclasses.fields(cls) if f.name == name)
    meta = {**original.metadata, **changes}
    value = original.default if default is dataclasses.MISSING else default
    return param(value, meta["unit"], meta["description"], meta["rule"], fixed=meta["fixed"])


def group(cls: type[TypedParams]) -> Any:
    """A nested parameter class whose fields are parameters of the same node (flattened)."""
    return field(default_factory=cls, metadata={"group": cls})


@dataclass(frozen=True)
class ParamSpec:
    """One parameter as a node declares it (see :func:`param`)."""

    name: str
    default: Any
    unit: str
    description: str
    rule: Rule
    fixed: bool
    int_for_float: bool  #: an integer is accepted where the default is a float

    @property
    def invalid(self) -> Any:
        """An example of a value this parameter refuses."""
        return self.rule.invalid

    def check(self, value: Any) -> None:
        """Raise ValueError naming the parameter, the value and what was expected."""
        if not self.int_for_float and _has_int_for_float(self.default, value):
            raise ValueError(
                f"{self.name}: must be a floating-point number (1.0, not 1), got {value!r}"
            )
        if not self.rule.accepts(value):
            raise ValueError(f"{self.name}: must be {self.rule.expected}, got {value!r}")


def _has_int_for_float(default: Any, value: Any) -> bool:
    if isinstance(default, float):
        return _integer(value)
    if isinstance(default, tuple) and default and isinstance(default[0], float):
        return isinstance(value, list | tuple) and any(_integer(v) for v in value)
    return False


# --------------------------------------------------------------------------- base class


class TypedParams:
    """Base of frozen dataclasses of parameters made with :func:`param` and :func:`group`."""

    #: False: a float parameter refuses an integer (``1`` instead of ``1.0``).
    int_for_float: ClassVar[bool] = True

    @classmethod
    def specs(cls) -> tuple[ParamSpec, ...]:
        """Every parameter, nested groups flattened, in declaration order."""
        return _specs(cls)

    @classmethod
    def defaults(cls) -> dict[str, Any]:
        """Parameter name -> default (nested groups flattened)."""
        return {s.name: s.default for s in cls.specs()}

    @classmethod
    def from_flat(cls, values: Mapping[str, Any]) -> Self:
        """A validated instance from flat parameter values (others take their defaults)."""
        names = {s.name for s in cls.specs()}
        for name in values:
            if name not in names:
                raise ValueError(f"{name}: unknown parameter of {cls.__name__}")
        for spec in cls.specs():
            if spec.name in values:
                spec.check(values[spec.name])
        return cls._build(values).validate()

    @classmethod
    def _build(cls, values: Mapping[str, Any]) -> Self:
        kwargs: dict[str, Any] = {}
        for f in dataclasses.fields(cls):
            nested = f.metadata.get("group")
            if nested is not None:
                kwargs[f.name] = nested._build(values)
            elif f.name in values:
                value = values[f.name]
                kwargs[f.name] = tuple(value) if isinstance(value, list) else value
        return cls(**kwargs)

    def flat(self) -> dict[str, Any]:
        """Parameter name -> value (nested groups flattened)."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.metadata.get("group") is not None:
                out.update(value.flat())
            else:
                out[f.name] = value
        return out

    def updated(self, **changes: Any) -> Self:
        """A validated copy with ``changes`` (flat names) applied; ValueError on a bad one."""
        return type(self).from_flat({**self.flat(), **changes})

    def validate(self) -> Self:
        """Return self if valid, else raise ValueError naming the bad parameter."""
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            nested = f.metadata.get("group")
            if nested is not None:
                if not isinstance(value, nested):
                    raise ValueError(f"{f.name}: must be a {nested.__name__}, got {value!r}")
                value.validate()
            elif "rule" in f.metadata:
                _own_specs(type(self))[f.name].check(value)
        self.check_together()
        return self

    def check_together(self) -> None:
        """Raise ValueError naming the parameters when they do not fit together."""


@cache
def _own_specs(cls: type[TypedParams]) -> dict[str, ParamSpec]:
    """The specs of ``cls``'s own parameter fields (not of its groups), by name."""
    return {
        f.name: ParamSpec(
            f.name, f.default, f.metadata["unit"], f.metadata["description"],
            f.metadata["rule"], f.metadata["fixed"], cls.int_for_float,
        )
        for f in dataclasses.fields(cls) if "rule" in f.metadata
    }


@cache
def _specs(cls: type[TypedParams]) -> tuple[ParamSpec, ...]:
    out: list[ParamSpec] = []
    for f in dataclasses.fields(cls):
        nested = f.metadata.get("group")
        if nested is not None:
            out.extend(_specs(nested))
        elif "rule" in f.metadata:
            out.append(_own_specs(cls)[f.name])
    names = [s.name for s in out]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise TypeError(f"{cls.__name__}: parameter names used twice: {duplicates}")
    return tuple(out)
