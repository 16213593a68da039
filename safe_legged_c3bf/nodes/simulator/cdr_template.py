"""Publish a message at a high rate by patching its serialized bytes in place.

``publisher.publish(msg)`` converts the Python message to its C struct and serializes that
(strings, covariance arrays and all) on every call; for the simulator's 250 Hz state
messages that costs more than handing the bytes to DDS. A :class:`CdrTemplate` serializes
a prototype message once (``rclpy.serialization``, i.e. the bytes ``publish`` would send)
and then only overwrites the fixed-size fields that change, in groups of contiguous
fields, with ``struct.pack_into``; ``publisher.publish(template.bytes())`` sends the result
as a serialized message. Every other field (frame ids, joint names, covariances, sequence
lengths) keeps the prototype's value, so the layout never changes.

Where each field sits is not computed from CDR rules: the prototype is serialized once
more with a distinct sentinel value in every patched field and the sentinels are looked
up in the bytes. A group whose fields are not adjacent (alignment padding in between) is
rejected.

Example::

    template = CdrTemplate(Odometry(header=Header(frame_id="odom")), {
        "stamp": ["header.stamp.sec", "header.stamp.nanosec"],
        "position": ["pose.pose.position.x", "pose.pose.position.y", "pose.pose.position.z"],
    })
    template.set("stamp", 12, 500_000_000)
    template.set("position", 1.0, 2.0, 0.3)
    publisher.publish(template.bytes())
"""

from __future__ import annotations

import copy
import struct
from collections.abc import Sequence
from typing import Any

from rclpy.serialization import serialize_message

#: struct codes of the field types a template can patch.
_CODES = {
    "double": "d", "float": "f", "int8": "b", "uint8": "B", "int16": "h", "uint16": "H",
    "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q",
}


#: Field paths of a message header's stamp (sec, nanosec), the usual first group.
STAMP = ["header.stamp.sec", "header.stamp.nanosec"]


def vector_fields(prefix: str, axes: str = "xyz") -> list[str]:
    """Field paths of a vector's or quaternion's components: ``prefix.x``, ``prefix.y``..."""
    return [f"{prefix}.{a}" for a in axes]


def _walk(msg: Any, path: str) -> tuple[Any, str, int | None]:
    """(parent message, field name, element index or None) of the field at ``path``.

    ``path`` is dotted; any component may index an array or sequence: ``"a.b[2].c"``.
    """
    *parents, last = path.split(".")
    obj = msg
    for part in parents:
        name, _, index = part.partition("[")
        obj = getattr(obj, name)
        if index:
            obj = obj[int(index[:-1])]
    name, _, index = last.partition("[")
    return obj, name, int(index[:-1]) if index else None


def _field_code(msg: Any, path: str) -> str:
    """The struct code of the (element) type of the field at ``path``."""
    parent, name, index = _walk(msg, path)
    kind = parent.get_fields_and_field_types()[name]
    if index is not None:  # sequence<double>, sequence<double, N> or double[N]
        kind = kind.removeprefix("sequence<").split(",")[0].split("[")[0].rstrip(">")
    try:
        return _CODES[kind]
    except KeyError:
        raise ValueError(f"field {path!r} of type {kind!r} cannot be patched") from None


def _set_field(msg: Any, path: str, value: float | int) -> None:
    parent, name, index = _walk(msg, path)
    if index is None:
        setattr(parent, name, value)
    else:
        getattr(parent, name)[index] = value


def _sentinel(code: str, k: int) -> float | int:
    """A value unlikely to occur anywhere else in a message, distinct for each k."""
    if code in "df":
        return -9.75e5 - 0.5 * k if code == "d" else -3.5e4 - 0.5 * k
    if code in "bB":
        raise ValueError("8-bit fields cannot be located reliably")
    if code in "hH":
        return 0x5A00 + k
    return 0x5A5A0000 + k  # fits every 32 and 64-bit integer type


class CdrTemplate:
    """Serialized bytes of a message, with groups of fixed-size fields to overwrite."""

    def __init__(self, prototype: Any, groups: dict[str, Sequence[str]]) -> None:
        """Serialize ``prototype``; locate the fields of each group (name -> field paths).

        A field path is dotted (``"header.stamp.sec"``), with ``[i]`` for an element of an
        array or sequence (``"position[3]"``, ``"obstacles[1].center.x"``; the prototype's
        sequences must be that long).
        """
        self._buffer = bytearray(serialize_message(prototype))
        if self._buffer[:2] != b"\x00\x01":
            raise ValueError("expected little-endian CDR")
        marked = copy.deepcopy(prototype)
        codes: dict[str, str] = {}
        values: dict[str, float | int] = {}
        for k, path in enumerate(p for paths in groups.values() for p in paths):
            codes[path] = _field_code(prototype, path)
            values[path] = _sentinel(codes[path], k)
            _set_field(marked, path, values[path])
        data = serialize_message(marked)
        if len(data) != len(self._buffer):
            raise ValueError("the sentinels changed the serialized size")
        self._groups: dict[str, tuple[struct.Struct, int]] = {}
        for name, paths in groups.items():
            layout = struct.Struct("<" + "".join(codes[p] for p in paths))
            offsets = []
            for p in paths:
                packed = struct.pack("<" + codes[p], values[p])
                offset = data.find(packed)
                if offset < 0 or data.find(packed, offset + 1) >= 0:
                    raise ValueError(f"cannot locate field {p!r} in the serialized message")
                offsets.append(offset)
            start = offsets[0]
            expected = [start + struct.calcsize("<" + "".join(codes[p] for p in paths[:j]))
                        for j in range(len(paths))]
            if offsets != expected:
                raise ValueError(f"the fields of group {name!r} are not adjacent")
            self._groups[name] = (layout, start)

    def set(self, group: str, *values: float | int) -> None:
        """Overwrite the fields of ``group`` with ``values`` (in the group's order)."""
        layout, offset = self._groups[group]
        layout.pack_into(self._buffer, offset, *values)

    def bytes(self) -> bytes:
        """The serialized message now (for ``publisher.publish``)."""
        return bytes(self._buffer)
