"""A follow camera that renders RGB frames headless (PyBullet's TinyRenderer) for videos.

The camera looks at the robot base from ``distance`` m at a fixed azimuth (world frame, or
relative to the robot heading with ``follow_heading``) and elevation. The look-at point is
low-pass filtered so that the gait's body sway does not shake the picture. Rendering works in
DIRECT mode (no display, no OpenGL): about 20-60 ms per 320x240 frame on one core, so render
only every N physics steps (e.g. 33 for 30 frames per sim second).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet

from safe_legged_c3bf.interfaces.rotations import yaw_from_quaternion


@dataclass
class CameraConfig:
    """Follow-camera settings.

    Attributes:
        width, height: image size (pixels).
        distance: distance from the look-at point (m).
        azimuth: camera yaw (deg, PyBullet's convention: -90 looks along +x from behind).
        elevation: camera pitch (deg), negative looks down.
        fov: vertical field of view (deg).
        target_height: height of the look-at point above the ground (m).
        follow_heading: add the robot's heading to ``azimuth``.
        smoothing: time constant of the look-at low-pass filter (s); 0 = none.
        shadows: render shadows (slower).

    """

    width: int = 320
    height: int = 240
    distance: float = 3.0
    azimuth: float = -60.0
    elevation: float = -30.0
    fov: float = 60.0
    target_height: float = 0.25
    follow_heading: bool = False
    smoothing: float = 0.3
    shadows: bool = False


class FollowCamera:
    """Renders frames that follow a body (usually the robot base)."""

    def __init__(self, client: int, body_id: int, config: CameraConfig | None = None) -> None:
        """Follow ``body_id`` in ``client``."""
        self.client = client
        self.body_id = body_id
        self.config = config or CameraConfig()
        if self.config.width <= 0 or self.config.height <= 0:
            raise ValueError("camera width and height must be positive")
        self._target: np.ndarray | None = None
        self._last_time: float | None = None
        self._projection = pybullet.computeProjectionMatrixFOV(
            fov=self.config.fov,
            aspect=self.config.width / self.config.height,
            nearVal=0.05,
            farVal=50.0,
        )

    def _look_at(self, t: float | None) -> tuple[np.ndarray, float]:
        pos, quat = pybullet.getBasePositionAndOrientation(
            self.body_id, physicsClientId=self.client
        )
        target = np.array([pos[0], pos[1], self.config.target_height])
        heading = yaw_from_quaternion(*quat)
        tau = self.config.smoothing
        if self._target is None or t is None or self._last_time is None or tau <= 0:
            self._target = target
        else:
            dt = max(t - self._last_time, 0.0)
            alpha = 1.0 - math.exp(-dt / tau)
            self._target = self._target + alpha * (target - self._target)
        self._last_time = t
        return self._target, heading

    def render(self, t: float | None = None) -> np.ndarray:
        """Render one frame; returns an (height, width, 3) uint8 RGB array.

        ``t`` (sim time, s) drives the look-at filter; without it the camera snaps to the body.
        """
        cfg = self.config
        target, heading = self._look_at(t)
        yaw = cfg.azimuth + (math.degrees(heading) if cfg.follow_heading else 0.0)
        view = pybullet.computeViewMatrixFromYawPitchRoll(
            cameraTargetPosition=target.tolist(),
            distance=cfg.distance,
            yaw=yaw,
            pitch=cfg.elevation,
            roll=0.0,
            upAxisIndex=2,
        )
        _, _, rgba, _, _ = pybullet.getCameraImage(
            cfg.width,
            cfg.height,
            viewMatrix=view,
            projectionMatrix=self._projection,
            renderer=pybullet.ER_TINY_RENDERER,
            shadow=1 if cfg.shadows else 0,
            flags=pybullet.ER_NO_SEGMENTATION_MASK,
            physicsClientId=self.client,
        )
        image = np.asarray(rgba, dtype=np.uint8).reshape(cfg.height, cfg.width, 4)
        return np.ascontiguousarray(image[:, :, :3])
