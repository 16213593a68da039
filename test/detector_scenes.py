"""Synthetic range data for the detector tests and benchmark: an analytic ray caster.

A scene is a flat ground (z = 0) with upright circular cylinders (pillars, people),
horizontal cylinders along y (bars) and boxes with a yaw (walls, benches).
:func:`scan` and :func:`cloud` cast a 2-D LiDAR and a pinhole 3-D sensor from a base pose
and a mount (REP-103 body axes) and return what the sensors would publish, in their frames.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.interfaces.sensor_mounts import SensorMount, rpy_to_matrix


@dataclass(frozen=True)
class Pillar:
    x: float
    y: float
    radius: float
    height: float = 1.2


@dataclass(frozen=True)
class Bar:
    """A cylinder along y: axis at (x, z), from y0 to y1."""

    x: float
    z: float
    radius: float = 0.05
    y0: float = -2.0
    y1: float = 2.0


@dataclass(frozen=True)
class Box:
    """A box centred at (x, y) on the ground, size (length, width, height), yaw about z."""

    x: float
    y: float
    length: float
    width: float
    height: float
    yaw: float = 0.0


def _circle_hits(o2, d2, c2, r):
    """Ray parameters (n, 2) where rays o2 + t d2 cross a circle (NaN when they miss)."""
    oc = o2 - c2
    a = np.sum(d2 * d2, axis=1)
    b = 2.0 * np.sum(oc * d2, axis=1)
    c = np.sum(oc * oc, axis=1) - r * r
    disc = b * b - 4.0 * a * c
    ok = (disc >= 0.0) & (a > 1e-12)
    sq = np.sqrt(np.where(ok, disc, 0.0))
    safe_a = np.where(ok, a, 1.0)
    t1 = np.where(ok, (-b - sq) / (2.0 * safe_a), np.nan)
    t2 = np.where(ok, (-b + sq) / (2.0 * safe_a), np.nan)
    return np.column_stack([t1, t2])


def _first(t, valid):
    t = np.where(valid & (t > 1e-6), t, np.inf)
    return t.min(axis=1) if t.ndim == 2 else t


def _hit_cylinder(o, d, axis_dims, c2, r, along_dim, lo, hi):
    """Distance to a capped cylinder whose axis is along ``along_dim``."""
    t = _circle_hits(o[:, axis_dims], d[:, axis_dims], np.asarray(c2), r)
    along = o[:, [along_dim]] + t * d[:, [along_dim]]
    side = _first(t, (along >= lo) & (along <= hi))
    caps = []
    for plane in (lo, hi):
        with np.errstate(divide="ignore", invalid="ignore"):
            tc = (plane - o[:, along_dim]) / d[:, along_dim]
            q = o[:, axis_dims] + tc[:, None] * d[:, axis_dims]
        inside = np.sum((q - np.asarray(c2)) ** 2, axis=1) <= r * r
        caps.append(_first(tc, inside & np.isfinite(tc)))
    return np.minimum(side, np.minimum(*caps))


def _hit_box(o, d, box: Box):
    c, s = math.cos(-box.yaw), math.sin(-box.yaw)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    ol = (o - [box.x, box.y, 0.0]) @ R.T
    dl = d @ R.T
    lo = np.array([-box.length / 2, -box.width / 2, 0.0])
    hi = np.array([box.length / 2, box.width / 2, box.height])
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (lo - ol) / dl
        t2 = (hi - ol) / dl
    tmin = np.nanmax(np.minimum(t1, t2), axis=1)
    tmax = np.nanmin(np.maximum(t1, t2), axis=1)
    hit = (tmax >= tmin) & (tmax > 1e-6)
    return np.where(hit, np.where(tmin > 1e-6, tmin, tmax), np.inf)


def cast(o: np.ndarray, d: np.ndarray, scene: list, ground: bool = True) -> np.ndarray:
    """Distance along unit rays (n, 3) from origins (n, 3) to the first hit; inf if none."""
    best = np.full(len(d), np.inf)
    if ground:
        with np.errstate(divide="ignore", invalid="ignore"):
            tg = -o[:, 2] / d[:, 2]
        best = np.minimum(best, np.where((d[:, 2] < 0) & (tg > 0), tg, np.inf))
    for item in scene:
        if isinstance(item, Pillar):
            t = _hit_cylinder(o, d, [0, 1], (item.x, item.y), item.radius, 2, 0.0, item.height)
        elif isinstance(item, Bar):
            t = _hit_cylinder(o, d, [0, 2], (item.x, item.z), item.radius, 1, item.y0, item.y1)
        else:
            t = _hit_box(o, d, item)
        best = np.minimum(best, t)
    return best


@dataclass(frozen=True)
class Pose:
    """Base pose in odom: position (m) and roll, pitch, yaw (rad)."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.28
    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0

    def rotation(self) -> np.ndarray:
        return rpy_to_matrix(self.roll, self.pitch, self.yaw)

    def quaternion(self) -> tuple[float, float, float, float]:
        from safe_legged_c3bf.interfaces.rotations import matrix_to_quaternion

        return matrix_to_quaternion(self.rotation())


def _world_rays(pose: Pose, mount: SensorMount, dirs_sensor: np.ndarray):
    R = pose.rotation() @ mount.rotation()
    origin = pose.rotation() @ np.asarray(mount.xyz) + [pose.x, pose.y, pose.z]
    return np.broadcast_to(origin, dirs_sensor.shape), dirs_sensor @ R.T


def scan_angles(beams: int = 360) -> tuple[float, float]:
    """angle_min and angle_increment of a full turn of ``beams`` beams."""
    return -math.pi, 2.0 * math.pi / beams


def scan(pose, mount, scene, beams=360, range_max=10.0, noise=0.0, seed=0):
    """LaserScan ranges (beams,) in the sensor frame: +inf for no return."""
    angle_min, inc = scan_angles(beams)
    a = angle_min + inc * np.arange(beams)
    dirs = np.column_stack([np.cos(a), np.sin(a), np.zeros(beams)])
    o, d = _world_rays(pose, mount, dirs)
    r = cast(o, d, scene)
    if noise:
        r = r + np.random.default_rng(seed).normal(0.0, noise, r.shape)
    return np.where(r <= range_max, r, np.inf)


HFOV, VFOV = math.radians(60.0), math.radians(45.0)


def cloud_dirs(width=64, height=48, hfov=HFOV, vfov=VFOV):
    """Unit ray directions (height, width, 3) of a pinhole sensor looking along +x."""
    u = np.tan(hfov / 2) * np.linspace(1.0, -1.0, width)  # left (+y) to right
    v = np.tan(vfov / 2) * np.linspace(1.0, -1.0, height)  # up (+z) to down
    uu, vv = np.meshgrid(u, v)
    d = np.stack([np.ones_like(uu), uu, vv], axis=-1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def cloud(pose, mount, scene, width=64, height=48, range_max=10.0, noise=0.0, seed=0):
    """Organised cloud (height, width, 3) in the sensor frame; NaN where no return."""
    dirs = cloud_dirs(width, height).reshape(-1, 3)
    o, d = _world_rays(pose, mount, dirs)
    r = cast(o, d, scene)
    if noise:
        r = r + np.random.default_rng(seed).normal(0.0, noise, r.shape)
    pts = dirs * np.where(r <= range_max, r, np.nan)[:, None]
    return pts.reshape(height, width, 3)
