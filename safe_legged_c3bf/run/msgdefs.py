"""ROS 2 message definitions as rosbag2 embeds them in MCAP files.

rosbag2 stores, as the schema of each channel, the full ``.msg`` text of the topic type
followed by the text of every message type it depends on (recursively, each once), each
introduced by a line of 80 ``=`` and a ``MSG: pkg/Type`` line. Foxglove and ``ros2 bag`` need
exactly that to decode the CDR payloads.

The ``.msg`` files are looked up in the ``share/<package>/msg`` directory of the install
prefixes (the venv for the PyPI wheels, an ament prefix for a ROS install). When a file cannot
be found the definition is rebuilt from the generated Python class (field names and types;
constants and comments are lost, decoding still works).
"""

from __future__ import annotations

import importlib
import os
import re
import sys
from functools import cache
from pathlib import Path

SEPARATOR = "=" * 80
PRIMITIVES = frozenset(
    {
        "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
        "int32", "uint32", "int64", "uint64", "string", "wstring",
    }
)
# IDL names used by rosidl-generated Python classes -> .msg names.
_IDL_TO_MSG = {
    "boolean": "bool", "octet": "byte", "char": "char", "float": "float32", "double": "float64",
    "int8": "int8", "uint8": "uint8", "int16": "int16", "uint16": "uint16", "int32": "int32",
    "uint32": "uint32", "int64": "int64", "uint64": "uint64", "string": "string",
    "wstring": "wstring",
}
_REPO_MSGS = Path(__file__).resolve().parents[2] / "safe_legged_c3bf_msgs" / "msg"


def split_type(type_name: str) -> tuple[str, str]:
    """('pkg', 'Type') from 'pkg/msg/Type' or 'pkg/Type'."""
    parts = type_name.split("/")
    if len(parts) == 3 and parts[1] == "msg":
        return parts[0], parts[2]
    if len(parts) == 2:
        return parts[0], parts[1]
    raise ValueError(f"not a message type name: {type_name!r}")


def _share_dirs(package: str) -> list[Path]:
    dirs: list[Path] = []
    try:
        from ament_index_python.packages import get_package_share_directory

        dirs.append(Path(get_package_share_directory(package)))
    except Exception:  # noqa: BLE001 - ament index absent or package not registered there
        pass
    dirs.append(Path(sys.prefix) / "share" / package)
    for prefix in filter(None, os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep)):
        dirs.append(Path(prefix) / "share" / package)
    try:
        module = importlib.import_module(package)
        if module.__file__:
            # <prefix>/lib/pythonX.Y/site-packages/<package>/__init__.py
            dirs.append(Path(module.__file__).resolve().parents[4] / "share" / package)
    except (ImportError, IndexError):
        pass
    return dirs


def find_msg_file(type_name: str) -> Path | None:
    """Path of the ``.msg`` file of a message type, or None."""
    package, name = split_type(type_name)
    candidates = [d / "msg" / f"{name}.msg" for d in _share_dirs(package)]
    if package == "safe_legged_c3bf_msgs":
        candidates.append(_REPO_MSGS / f"{name}.msg")
    for path in candidates:
        if path.is_file():
            return path
    return None


def _idl_to_msg_type(idl: str) -> str:
    """A .msg field type from the type string of ``get_fields_and_field_types()``."""
    m = re.fullmatch(r"sequence<(.+?)(?:,\s*(\d+))?>", idl)
    if m:
        inner = _idl_to_msg_type(m.group(1))
        return f"{inner}[<={m.group(2)}]" if m.group(2) else f"{inner}[]"
    m = re.fullmatch(r"(.+)\[(\d+)\]", idl)
    if m:
        return f"{_idl_to_msg_type(m.group(1))}[{m.group(2)}]"
    m = re.fullmatch(r"(w?string)<(\d+)>", idl)
    if m:
        return f"{m.group(1)}<={m.group(2)}"
    if idl in _IDL_TO_MSG:
        return _IDL_TO_MSG[idl]
    if "/" in idl:
        return idl
    raise ValueError(f"unknown field type {idl!r}")


def _text_from_class(type_name: str) -> str:
    package, name = split_type(type_name)
    cls = getattr(importlib.import_module(f"{package}.msg"), name)
    lines = [
        f"{_idl_to_msg_type(t)} {field}" for field, t in cls.get_fields_and_field_types().items()
    ]
    return "\n".join(lines) + "\n"


@cache
def msg_text(type_name: str) -> str:
    """The ``.msg`` text of a type (from its file, else rebuilt from its Python class)."""
    path = find_msg_file(type_name)
    if path is not None:
        return path.read_text(encoding="utf-8")
    return _text_from_class(type_name)


def field_types(package: str, text: str) -> list[str]:
    """Non-primitive field types ('pkg/Type') used in a ``.msg`` text, in order, unique."""
    found: list[str] = []
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        type_token = line.split()[0]  # constants have primitive types: skipped below
        base = re.sub(r"\[.*\]$", "", type_token)
        base = re.sub(r"<=\d+$", "", base)
        if base in PRIMITIVES:
            continue
        if "/" in base:
            dep = "/".join(split_type(base))
        elif base == "Header":
            dep = "std_msgs/Header"
        else:
            dep = f"{package}/{base}"
        if dep not in found:
            found.append(dep)
    return found


@cache
def rosbag2_definition(type_name: str) -> str:
    """Full message definition of ``type_name`` with its dependencies, rosbag2 style."""
    package, name = split_type(type_name)
    root = f"{package}/{name}"
    order: list[str] = []
    texts: dict[str, str] = {}
    pending = [root]
    while pending:
        current = pending.pop(0)
        if current in texts:
            continue
        text = msg_text(current)
        texts[current] = text
        if current != root:
            order.append(current)
        pkg = current.split("/")[0]
        pending.extend(d for d in field_types(pkg, text) if d not in texts)
    parts = [texts[root].rstrip("\n")]
    for dep in order:
        parts.append(f"{SEPARATOR}\nMSG: {dep}\n{texts[dep].rstrip(chr(10))}")
    return "\n".join(parts) + "\n"
