"""Simulated range sensors: a 2-D LiDAR and a forward 3-D sensor (a depth-camera-like ray grid).

Both cast their rays with ``pybullet.rayTestBatch`` from their mount
(:mod:`safe_legged_c3bf.interfaces.sensor_mounts`) composed with the pose of ``base_link`` at
the cast, so they see every body with a collision shape (ground, obstacles, the robot) where
it is after the last physics step: moving obstacles are where their script put them then.

Ranges are along each ray, from the sensor origin (m). Values follow REP-117:

* a return within [range_min, range_max] (after noise): the measured range;
* no return within range_max: +inf;
* a return closer than range_min: -inf (too close to measure);
* a dropped ray (probability ``dropout_probability``, independently per ray and cast): NaN.

The measured range is the true one plus N(0, range_noise_std^2); the classification above is
made on the noisy value. A 3-D cast gives a point cloud of the valid returns only, float32
x y z in the sensor frame (x forward, y left, z up; REP-103).

The robot's own body: the rays start at the mount, which lies outside every collision shape
of the robot (the default mounts are above the trunk and in front of it), and a ray that
hits the robot is a real return, as on a real robot: the body hides what is behind it. The
default mounts are placed so that the standing robot is out of their field of view
(``test/test_range_sensors.py`` checks it); :attr:`RangeSensor.self_hits` counts the rays of
the last cast that hit the robot, for diagnosis.

Determinism: each sensor has its own generator seeded from the scenario seed, and a cast
draws the same number of values (one normal and one uniform per ray) whatever it sees, so the
noise is a function of the seed and the number of casts; PyBullet's ray tests are exact and
single-threaded here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet

from safe_legged_c3bf.interfaces.rotations import quaternion_to_matrix
from safe_legged_c3bf.interfaces.sensor_mounts import SensorMount

#: Most rays in one ``rayTestBatch`` call (PyBullet refuses more).
MAX_BATCH = 16384
#: Most rays of one sensor (a cast beyond that would stall the physics thread).
MAX_RAYS = 65536
FULL_CIRCLE = 2.0 * math.pi
#: A LiDAR field of view within this of 2 pi (rad) is a full circle (YAML: 6.2832 is fine).
FULL_CIRCLE_TOLERANCE = 1e-3


def _range_problems(cfg: LidarConfig | DepthConfig) -> list[tuple[str, str]]:
    """(field, message) of the range, noise, drop-out and rate values that are invalid."""
    out = []
    if not (math.isfinite(cfg.rate) and cfg.rate > 0):
        out.append(("rate", f"must be a positive number (Hz), got {cfg.rate!r}"))
    if not (math.isfinite(cfg.range_min) and cfg.range_min >= 0):
        out.append(("range_min", f"must be a number >= 0 (m), got {cfg.range_min!r}"))
    if not (math.isfinite(cfg.range_max) and cfg.range_max > 0):
        out.append(("range_max", f"must be a positive number (m), got {cfg.range_max!r}"))
    elif not out and cfg.range_min >= cfg.range_max:
        out.append(("range_min", f"must be less than range_max ({cfg.range_max!r}), got "
                                 f"{cfg.range_min!r}"))
    if not (math.isfinite(cfg.range_noise_std) and cfg.range_noise_std >= 0):
        out.append(("range_noise_std", f"must be a number >= 0 (m), got {cfg.range_noise_std!r}"))
    if not 0.0 <= cfg.dropout_probability <= 1.0:
        out.append(("dropout_probability",
                    f"must be within [0, 1], got {cfg.dropout_probability!r}"))
    return out


def _count_problem(name: str, value: object, most: int) -> list[tuple[str, str]]:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not 1 <= value <= most:
        return [(name, f"must be an integer within [1, {most}], got {value!r}")]
    return []


def _raise(problems: list[tuple[str, str]], what: str) -> None:
    if problems:
        raise ValueError("; ".join(f"{what}.{field}: {text}" for field, text in problems))


@dataclass(frozen=True)
class LidarConfig:
    """A 2-D LiDAR: ``beams`` rays in the sensor's x-y plane, centred on its x axis.

    Attributes:
        rate: scans per second (Hz, sim time).
        beams: number of rays.
        fov: field of view about the sensor z axis (rad, at most 2 pi); a full circle spaces
            the beams 2 pi / beams apart from -pi, a smaller one puts the first and last beam
            at -fov/2 and +fov/2.
        range_min, range_max: measurable ranges (m).
        range_noise_std: standard deviation of the Gaussian range noise (m).
        dropout_probability: probability that a ray gives NaN, per ray and scan.

    """

    rate: float = 10.0
    beams: int = 360
    fov: float = FULL_CIRCLE
    range_min: float = 0.1
    range_max: float = 8.0
    range_noise_std: float = 0.01
    dropout_probability: float = 0.01

    def problems(self) -> list[tuple[str, str]]:
        """(field, message) of every invalid value (empty when valid)."""
        out = _range_problems(self) + _count_problem("beams", self.beams, MAX_RAYS)
        if not (math.isfinite(self.fov) and 0 < self.fov <= FULL_CIRCLE + FULL_CIRCLE_TOLERANCE):
            out.append(("fov", f"must be within (0, 2 pi] (rad), got {self.fov!r}"))
        return out

    def __post_init__(self) -> None:
        """Raise ValueError naming the invalid fields."""
        _raise(self.problems(), "lidar")

    @property
    def full_circle(self) -> bool:
        """Whether the beams go all around."""
        return self.fov >= FULL_CIRCLE - FULL_CIRCLE_TOLERANCE

    def angles(self) -> tuple[np.ndarray, float]:
        """(beam angles (beams,) about z from x, counter-clockwise (rad); their increment)."""
        n = self.beams
        if self.full_circle:
            increment = FULL_CIRCLE / n
            return -math.pi + increment * np.arange(n), increment
        increment = self.fov / (n - 1) if n > 1 else 0.0
        return -self.fov / 2.0 + increment * np.arange(n), increment


@dataclass(frozen=True)
class DepthConfig:
    """A forward 3-D sensor: a pinhole grid of ``columns`` x ``rows`` rays about its x axis.

    Attributes:
        rate: clouds per second (Hz, sim time).
        columns, rows: rays across the horizontal and the vertical field of view.
        horizontal_fov, vertical_fov: full fields of view (rad, each below pi).
        range_min, range_max: measurable ranges along each ray (m).
        range_noise_std: standard deviation of the Gaussian range noise (m).
        dropout_probability: probability that a ray gives no point, per ray and cloud.

    """

    rate: float = 10.0
    columns: int = 64
    rows: int = 48
    horizontal_fov: float = math.radians(87.0)
    vertical_fov: float = math.radians(58.0)
    range_min: float = 0.2
    range_max: float = 6.0
    range_noise_std: float = 0.01
    dropout_probability: float = 0.01

    def problems(self) -> list[tuple[str, str]]:
        """(field, message) of every invalid value (empty when valid)."""
        counts = _count_problem("columns", self.columns, MAX_RAYS)
        counts += _count_problem("rows", self.rows, MAX_RAYS)
        if not counts and self.columns * self.rows > MAX_RAYS:
            counts.append(("rows", f"columns x rows must be at most {MAX_RAYS}, got "
                                   f"{self.columns} x {self.rows}"))
        out = _range_problems(self) + counts
        for name in ("horizontal_fov", "vertical_fov"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0 < value < math.pi):
                out.append((name, f"must be within (0, pi) (rad), got {value!r}"))
        return out

    def __post_init__(self) -> None:
        """Raise ValueError naming the invalid fields."""
        _raise(self.problems(), "depth")

    def directions(self) -> np.ndarray:
        """(rows * columns, 3) unit ray directions in the sensor frame, through pixel centres.

        Row by row from the top left: y decreases along a row, z from row to row.
        """
        tu = math.tan(self.horizontal_fov / 2.0)
        tv = math.tan(self.vertical_fov / 2.0)
        y = tu * (1.0 - (2.0 * np.arange(self.columns) + 1.0) / self.columns)
        z = tv * (1.0 - (2.0 * np.arange(self.rows) + 1.0) / self.rows)
        yy, zz = np.meshgrid(y, z)  # (rows, columns)
        d = np.column_stack([np.ones(yy.size), yy.ravel(), zz.ravel()])
        return d / np.linalg.norm(d, axis=1)[:, None]


class RangeSensor:
    """Rays from a mount on the robot's base_link, cast into a PyBullet world.

    Attributes:
        mount: where the sensor sits on base_link.
        directions: (n, 3) unit ray directions in the sensor frame.
        casts: casts made so far.
        hit_bodies: (n,) PyBullet body hit first by each ray of the last cast (-1: none).
        self_hits: rays of the last cast whose first hit was the robot itself.

    """

    def __init__(
        self,
        client: int,
        mount: SensorMount,
        directions: np.ndarray,
        config: LidarConfig | DepthConfig,
        seed: int | np.random.SeedSequence,
        robot_id: int = -1,
    ) -> None:
        """Rays ``directions`` (sensor frame) from ``mount``; ``robot_id``: the robot's body."""
        self.client, self.mount, self.config = client, mount, config
        self.directions = np.asarray(directions, dtype=float)
        self._directions_base = self.directions @ mount.rotation().T
        self._origin_base = np.asarray(mount.xyz, dtype=float)
        self._robot_id = int(robot_id)
        self.rng = np.random.default_rng(seed)
        self.casts = 0
        self.hit_bodies = np.full(len(self.directions), -1, dtype=np.int64)
        self.self_hits = 0

    @property
    def ray_count(self) -> int:
        """Rays per cast."""
        return len(self.directions)

    def true_ranges(self, position: np.ndarray, quaternion: np.ndarray) -> np.ndarray:
        """(n,) exact range of each ray's first hit (m; +inf: none within range_max).

        ``position`` (m) and ``quaternion`` (x, y, z, w) are base_link's pose in odom.
        """
        rotation = quaternion_to_matrix(np.asarray(quaternion, dtype=float))
        origin = np.asarray(position, dtype=float) + rotation @ self._origin_base
        reach = self.config.range_max
        ends = origin + (self._directions_base @ rotation.T) * reach
        starts = np.broadcast_to(origin, ends.shape)
        results: list = []
        for i in range(0, len(ends), MAX_BATCH):
            results.extend(pybullet.rayTestBatch(
                starts[i:i + MAX_BATCH], ends[i:i + MAX_BATCH], physicsClientId=self.client
            ))
        # Each result is (body, link, fraction, point, normal); zip transposes them in C.
        columns = tuple(zip(*results, strict=True))
        body = np.array(columns[0], dtype=np.int64)
        fraction = np.array(columns[2], dtype=float)
        self.hit_bodies = body
        self.self_hits = int(np.count_nonzero(body == self._robot_id)) if self._robot_id >= 0 \
            else 0
        return np.where(body >= 0, fraction * reach, np.inf)

    def cast(self, position: np.ndarray, quaternion: np.ndarray) -> np.ndarray:
        """(n,) measured ranges (m, float64) with the REP-117 values of the module docstring."""
        cfg = self.config
        true = self.true_ranges(position, quaternion)
        n = len(true)
        noise = self.rng.standard_normal(n)  # fixed draws per cast, whatever is hit
        drop = self.rng.random(n)
        self.casts += 1
        ranges = true + cfg.range_noise_std * noise  # +inf stays +inf
        ranges[ranges > cfg.range_max] = np.inf
        ranges[ranges < cfg.range_min] = -np.inf
        ranges[drop < cfg.dropout_probability] = np.nan
        return ranges


class Lidar2D(RangeSensor):
    """A 2-D LiDAR (:class:`LidarConfig`); its scan is a LaserScan's ``ranges``.

    Attributes:
        angles: (beams,) beam angles about the sensor z axis from x (rad).
        angle_increment: angle between beams (rad).

    """

    def __init__(
        self,
        client: int,
        config: LidarConfig,
        mount: SensorMount,
        seed: int | np.random.SeedSequence,
        robot_id: int = -1,
    ) -> None:
        """A LiDAR on ``mount`` in ``client`` (the robot's body ``robot_id``)."""
        self.angles, self.angle_increment = config.angles()
        directions = np.column_stack(
            [np.cos(self.angles), np.sin(self.angles), np.zeros(len(self.angles))]
        )
        super().__init__(client, mount, directions, config, seed, robot_id)

    def scan(self, position: np.ndarray, quaternion: np.ndarray) -> np.ndarray:
        """(beams,) float32 ranges (m, REP-117) from base_link's pose in odom."""
        return self.cast(position, quaternion).astype(np.float32)


class DepthSensor(RangeSensor):
    """A forward 3-D sensor (:class:`DepthConfig`); its cloud holds the valid returns."""

    def __init__(
        self,
        client: int,
        config: DepthConfig,
        mount: SensorMount,
        seed: int | np.random.SeedSequence,
        robot_id: int = -1,
    ) -> None:
        """A 3-D sensor on ``mount`` in ``client`` (the robot's body ``robot_id``)."""
        super().__init__(client, mount, config.directions(), config, seed, robot_id)

    def cloud(self, position: np.ndarray, quaternion: np.ndarray) -> np.ndarray:
        """(m, 3) float32 x y z (m, sensor frame) of the valid returns, in ray order."""
        ranges = self.cast(position, quaternion)
        valid = np.isfinite(ranges)
        return (self.directions[valid] * ranges[valid, None]).astype(np.float32)
