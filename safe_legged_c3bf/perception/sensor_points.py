"""Range-sensor data as points: a 2-D scan or a 3-D cloud, sensor frame -> base_link -> odom.

No ROS here: the node hands over the fields of ``sensor_msgs/LaserScan`` and
``sensor_msgs/PointCloud2`` (``nodes/messages.py`` does that) and gets numpy arrays back.

* :func:`scan_points`: ranges and angles -> points in the sensor frame (REP-103 body axes,
  angles about the sensor's z from its x axis). REP-117 readings are dropped: NaN (no
  measurement), +inf (no return within ``range_max``), -inf (too close to measure), and
  anything outside ``[range_min, range_max]``.
* :func:`cloud_points`: the x, y, z fields (float32 or float64, either byte order) of a
  packed point cloud -> points in the sensor frame; points with a NaN/Inf coordinate dropped.
* :func:`to_parent`: points from a child frame into its parent with a rotation and a
  translation, one pose for all points or one pose per point (a scan taken while moving).

Malformed input (missing fields, data shorter than its declared layout, non-finite scan
geometry) raises :class:`SensorInputError` with a short ``reason`` the node counts in
``/diagnostics``; it never crashes the caller.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "CloudField",
    "ScanPoints",
    "SensorInputError",
    "cloud_points",
    "scan_points",
    "to_parent",
]

#: sensor_msgs/PointField datatypes this module reads for x, y, z.
FLOAT32, FLOAT64 = 7, 8
#: Most beams a scan may have (a flood guard; real 2-D LiDARs have a few thousand).
MAX_BEAMS = 100_000
#: Longest time a scan may take from its first to its last beam (s).
MAX_SCAN_DURATION = 1.0


class SensorInputError(ValueError):
    """A sensor message that cannot be used; ``reason`` is a short key for diagnostics."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(f"{reason}: {detail}")
        self.reason = reason


@dataclass(frozen=True)
class ScanPoints:
    """The valid returns of a scan.

    Attributes:
        points: (n, 3) points in the sensor frame (m), z = 0.
        beam_times: (n,) time of each return after the scan's stamp (s), from
            ``time_increment``; zeros for a scanner that reports none.
        beams: (n,) index of each return's beam in the scan.
        beam_count: beams in the scan, returns or not.

    """

    points: np.ndarray
    beam_times: np.ndarray
    beams: np.ndarray
    beam_count: int


def scan_points(
    ranges: Sequence[float] | np.ndarray,
    angle_min: float,
    angle_increment: float,
    range_min: float,
    range_max: float,
    time_increment: float = 0.0,
) -> ScanPoints:
    """Points in the sensor frame from a ``LaserScan``'s ranges (m) and angles (rad).

    Beam ``i`` is at angle ``angle_min + i * angle_increment`` about the sensor's z axis and
    was measured ``i * time_increment`` s after the stamp. Raises SensorInputError
    ('malformed') for non-finite geometry, a zero increment with several beams, a range
    window that is empty or negative, or more than MAX_BEAMS beams.
    """
    r = np.asarray(ranges, dtype=float).reshape(-1)
    geometry = (angle_min, angle_increment, range_min, time_increment)
    if not all(math.isfinite(v) for v in geometry) or math.isnan(range_max):
        raise SensorInputError("malformed", "scan angles, range_min or times not finite")
    if r.size > MAX_BEAMS:
        raise SensorInputError("malformed", f"{r.size} beams (at most {MAX_BEAMS})")
    if r.size > 1 and angle_increment == 0.0:
        raise SensorInputError("malformed", "angle_increment is 0 with several beams")
    if not (0.0 <= range_min < range_max):
        raise SensorInputError(
            "malformed", f"range window [{range_min}, {range_max}] is empty or negative"
        )
    if abs(time_increment) * max(r.size - 1, 0) > MAX_SCAN_DURATION:
        raise SensorInputError("malformed", "scan lasts longer than 1 s (time_increment)")
    index = np.flatnonzero(np.isfinite(r) & (r >= range_min) & (r <= range_max))
    rho = r[index]
    angle = angle_min + angle_increment * index
    points = np.column_stack([rho * np.cos(angle), rho * np.sin(angle), np.zeros(index.size)])
    return ScanPoints(points, time_increment * index.astype(float), index, int(r.size))


@dataclass(frozen=True)
class CloudField:
    """One ``sensor_msgs/PointField``: name, byte offset, datatype code, element count."""

    name: str
    offset: int
    datatype: int
    count: int = 1


def _xyz_dtype(
    fields: Sequence[CloudField], point_step: int, big_endian: bool
) -> np.dtype:
    """Structured dtype reading x, y, z of one packed point (SensorInputError if absent)."""
    by_name = {f.name: f for f in fields}
    order = ">" if big_endian else "<"
    formats, offsets = [], []
    for name in ("x", "y", "z"):
        f = by_name.get(name)
        if f is None:
            raise SensorInputError("malformed", f"point cloud has no '{name}' field")
        if f.datatype not in (FLOAT32, FLOAT64) or f.count != 1:
            raise SensorInputError(
                "malformed", f"field '{name}' must be one float32/float64 (datatype {f.datatype})"
            )
        size = 4 if f.datatype == FLOAT32 else 8
        if f.offset < 0 or f.offset + size > point_step:
            raise SensorInputError("malformed", f"field '{name}' lies outside point_step")
        formats.append(f"{order}f{size}")
        offsets.append(f.offset)
    return np.dtype(
        {"names": ["x", "y", "z"], "formats": formats, "offsets": offsets,
         "itemsize": point_step}
    )


def cloud_points(
    data: bytes | bytearray | memoryview | np.ndarray,
    fields: Sequence[CloudField],
    point_step: int,
    row_step: int,
    width: int,
    height: int,
    big_endian: bool = False,
) -> np.ndarray:
    """(n, 3) finite points (m, sensor frame) of a packed ``PointCloud2``.

    ``height`` rows of ``width`` points, ``point_step`` bytes per point and ``row_step``
    bytes per row (padding after a row's points is skipped). Points with a NaN/Inf
    coordinate are dropped (an organised cloud marks missing returns that way). Raises
    SensorInputError ('malformed') when x, y or z is missing or not a float, or when the data
    is shorter than ``row_step * height``.
    """
    width, height, point_step, row_step = int(width), int(height), int(point_step), int(row_step)
    if width < 0 or height < 0 or point_step <= 0:
        raise SensorInputError("malformed", "negative size or point_step <= 0")
    dtype = _xyz_dtype(fields, point_step, big_endian)
    if width * height == 0:
        return np.zeros((0, 3))
    if row_step < width * point_step:
        raise SensorInputError("malformed", "row_step is shorter than width * point_step")
    raw = np.frombuffer(data, dtype=np.uint8) if not isinstance(data, np.ndarray) else data
    raw = raw.reshape(-1).view(np.uint8)
    if raw.size < row_step * height:
        raise SensorInputError(
            "malformed", f"data has {raw.size} bytes, the layout needs {row_step * height}"
        )
    rows = raw[: row_step * height].reshape(height, row_step)[:, : width * point_step]
    packed = np.ascontiguousarray(rows).reshape(-1).view(dtype)
    xyz = np.column_stack([packed["x"], packed["y"], packed["z"]]).astype(float)
    return xyz[np.all(np.isfinite(xyz), axis=1)]


def to_parent(points: np.ndarray, rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """Points (n, 3) of a child frame in its parent: ``R p + t`` (m).

    ``rotation`` is (3, 3) and ``translation`` (3,) for one pose, or (n, 3, 3) and (n, 3)
    for a pose per point.
    """
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    R = np.asarray(rotation, dtype=float)
    t = np.asarray(translation, dtype=float)
    if R.ndim == 2:
        return p @ R.T + t.reshape(3)
    return np.einsum("nij,nj->ni", R, p) + t.reshape(-1, 3)
