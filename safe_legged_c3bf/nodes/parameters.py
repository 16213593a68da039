"""Declare a typed parameter class on an rclpy node; validate start-up values and live updates.

Every node of the graph uses :class:`NodeParameters` for its one parameter class
(:class:`~safe_legged_c3bf.interfaces.typed_params.TypedParams`)::

    self.params = NodeParameters(self, FilterParams, apply=self._apply_params)
    rate = self.params.value.rate

* each field becomes a parameter whose descriptor carries the description, the unit and what
  a valid value is; ``fixed`` fields are read-only (set at start-up only);
* the start-up values (defaults, parameter files, overrides) are validated by the class: a
  bad one raises ValueError naming the parameter, the value and what was expected;
* a live change goes through one callback: the whole new set is validated by the class and
  refused with the reason (``successful=False``) or taken, after which ``apply(old, new,
  names)`` lets the node act on it (restart a timer, a tracker...).

Parameters are declared with dynamic typing and typed by the class instead, so a wrong type
is refused with a reason that names the parameter too.
"""

from __future__ import annotations

import array
import math
from collections.abc import Callable
from typing import Any, Generic, TypeVar

from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

from safe_legged_c3bf.interfaces.typed_params import ParamSpec, TypedParams

P = TypeVar("P", bound=TypedParams)

#: ``apply(old, new, names)``: act on a validated change of the parameters ``names``.
ApplyHook = Callable[[Any, Any, frozenset[str]], None]
#: ``prepare(values) -> values``: adjust the start-up values before they are validated.
PrepareHook = Callable[[dict[str, Any]], dict[str, Any]]


def descriptor(spec: ParamSpec) -> ParameterDescriptor:
    """The ROS descriptor of one parameter: description with unit, constraints, read-only."""
    unit = "unitless" if spec.unit == "-" else spec.unit
    fixed = "; fixed at start-up" if spec.fixed else ""
    return ParameterDescriptor(
        description=f"{spec.description} [{unit}]",
        additional_constraints=f"must be {spec.rule.expected}{fixed}",
        read_only=spec.fixed,
        dynamic_typing=True,
    )


def to_ros(value: Any) -> Any:
    """A parameter value as rclpy takes it (a tuple becomes a list)."""
    return list(value) if isinstance(value, tuple) else value


def from_ros(value: Any) -> Any:
    """A parameter value as the parameter class takes it (an array becomes a list)."""
    return list(value) if isinstance(value, array.array) else value


def same_value(a: Any, b: Any) -> bool:
    """Equal parameter values, NaN equal to NaN (in lists too) and a list equal to its tuple."""
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    a, b = from_ros(to_ros(a)), from_ros(to_ros(b))
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same_value(x, y) for x, y in zip(a, b, strict=True))
    return a == b


class NodeParameters(Generic[P]):
    """A node's parameters: declared from ``cls``, validated, updated live (see module doc)."""

    def __init__(
        self,
        node: Node,
        cls: type[P],
        apply: ApplyHook | None = None,
        prepare: PrepareHook | None = None,
    ) -> None:
        """Declare ``cls``'s parameters on ``node`` and validate their start-up values.

        Args:
            node: the node (its parameter overrides give the start-up values).
            cls: the parameter class.
            apply: called after every accepted live change, with the old and new values.
            prepare: adjusts the start-up values after each was checked on its own and before
                the whole set is; the adjusted values are set on the node (the planner
                applies its scenario this way). Must not change a fixed parameter.

        Raises:
            ValueError: naming the parameter, for an invalid start-up value.

        """
        self._node, self._apply = node, apply
        self._specs = {s.name: s for s in cls.specs()}
        for spec in self._specs.values():
            node.declare_parameter(spec.name, to_ros(spec.default), descriptor(spec))
        values = {name: from_ros(node.get_parameter(name).value) for name in self._specs}
        for name, value in values.items():
            self._specs[name].check(value)
        if prepare is not None:
            values = self._prepared(prepare, values)
        self.value: P = cls.from_flat(values)
        node.add_on_set_parameters_callback(self._on_set)

    def _prepared(self, prepare: PrepareHook, values: dict[str, Any]) -> dict[str, Any]:
        """Run ``prepare`` and set the values it changed on the node."""
        adjusted = prepare(dict(values))
        changed = [
            Parameter(name, value=to_ros(value)) for name, value in adjusted.items()
            if not same_value(value, values[name])
        ]
        for param, result in zip(changed, self._node.set_parameters(changed), strict=True):
            if not result.successful:
                raise ValueError(f"{param.name}: cannot be set at start-up: {result.reason}")
        return adjusted

    def _on_set(self, params: list[Parameter]) -> SetParametersResult:
        """The one callback of live changes: validate the whole new set, then apply it."""
        changes = {p.name: from_ros(p.value) for p in params if p.name in self._specs}
        if not changes:
            return SetParametersResult(successful=True)
        try:
            new = self.value.updated(**changes)
        except (ValueError, TypeError) as err:
            return SetParametersResult(successful=False, reason=str(err))
        old, self.value = self.value, new
        if self._apply is not None:
            self._apply(old, new, frozenset(changes))
        self._node.get_logger().info(f"parameters updated: {changes}")
        return SetParametersResult(successful=True)
