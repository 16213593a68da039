"""Locate and load the package's YAML configuration, installed or from the source tree.

Search order for the config directory:
1. ``$SAFE_LEGGED_C3BF_CONFIG`` if set;
2. ``<source tree>/config`` next to the package (source checkout and ``pip install -e``, where
   pip skips ``data_files``);
3. ``<sys.prefix>/share/safe_legged_c3bf/config`` (``pip install .``);
4. the ament index share directory (colcon / ``ros2 run`` installs).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

import yaml

PACKAGE = "safe_legged_c3bf"
_MARKER = "safety_filter.yaml"


def _candidates() -> list[Path]:
    found = []
    env = os.environ.get("SAFE_LEGGED_C3BF_CONFIG")
    if env:
        found.append(Path(env))
    found.append(Path(__file__).resolve().parents[2] / "config")
    found.append(Path(sys.prefix) / "share" / PACKAGE / "config")
    try:
        from ament_index_python.packages import get_package_share_directory

        found.append(Path(get_package_share_directory(PACKAGE)) / "config")
    except Exception:  # noqa: BLE001 - ament index absent or package not registered
        pass
    return found


def config_dir() -> Path:
    """Return the directory holding the package's YAML files (raise FileNotFoundError)."""
    candidates = _candidates()
    for path in candidates:
        if (path / _MARKER).is_file():
            return path
    raise FileNotFoundError(
        "safe_legged_c3bf config directory not found; looked in: "
        + ", ".join(str(p) for p in candidates)
    )


def config_path(*parts: str) -> Path:
    """Path of a file below the config directory, e.g. ``config_path('scenarios', 'x.yaml')``."""
    return config_dir().joinpath(*parts)


def load_yaml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Load a YAML mapping from ``path`` (absolute, or relative to the config directory)."""
    p = Path(path)
    if not p.is_absolute() and not p.exists():
        p = config_path(str(path))
    with open(p, encoding="utf-8") as f:
        data = yaml.safe_load(f)
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ValueError(f"{p}: expected a YAML mapping at top level, got {type(data).__name__}")
    return data
