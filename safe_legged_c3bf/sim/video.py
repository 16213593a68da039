"""Write the follow camera's RGB frames to a GIF or MP4 file, headless.

:class:`VideoWriter` takes (H, W, 3) uint8 frames, e.g. those of
:meth:`safe_legged_c3bf.sim.world.Simulation.take_frames`, and writes ``.gif`` (Pillow through
imageio; frames are kept until :meth:`VideoWriter.close`) or ``.mp4`` (H.264 through
imageio-ffmpeg's bundled ffmpeg, streamed: constant memory). Typical use in the simulator::

    sim.record_every(frame_interval_steps(fps, sim.physics_dt))
    writer = VideoWriter(video_path, fps)
    ...                                  # while stepping:
    for frame in sim.take_frames():
        writer.append(frame)
    ...                                  # at the end of the run:
    writer.close()

Rendering (TinyRenderer, CPU) costs 20-60 ms per 320x240 frame, so a 10 fps video costs
roughly 0.2-0.6 s of wall time per simulated second.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

SUFFIXES = (".gif", ".mp4")
DEFAULT_FPS = 10.0


def frame_interval_steps(fps: float, physics_dt: float) -> int:
    """Physics steps between two frames for ``fps`` frames per sim second (at least 1)."""
    if not fps > 0 or not physics_dt > 0:
        raise ValueError("fps and physics_dt must be positive")
    return max(1, round(1.0 / (fps * physics_dt)))


def check_video_path(path: str | Path) -> Path:
    """Return ``path`` as a Path if it ends in .gif or .mp4, else raise ValueError."""
    p = Path(path)
    if p.suffix.lower() not in SUFFIXES:
        raise ValueError(f"video file must end in .gif or .mp4, got {str(path)!r}")
    return p


class VideoWriter:
    """Writes RGB frames (H x W x 3 or 4, uint8) to a GIF or MP4 file."""

    def __init__(self, path: str | Path, fps: float = DEFAULT_FPS) -> None:
        """Open ``path`` (.gif or .mp4) for writing at ``fps`` frames per second."""
        import imageio.v2 as iio

        if not fps > 0:
            raise ValueError(f"fps must be positive, got {fps}")
        self.path = check_video_path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.fps = float(fps)
        self.frames = 0
        self._shape: tuple[int, int] | None = None
        if self.path.suffix.lower() == ".gif":
            self._writer = iio.get_writer(
                self.path, mode="I", duration=1000.0 / self.fps, loop=0
            )
        else:
            self._writer = iio.get_writer(
                self.path, fps=self.fps, codec="libx264", pixelformat="yuv420p",
                macro_block_size=2, ffmpeg_log_level="error",
            )

    def append(self, frame: np.ndarray) -> None:
        """Add one frame; every frame must have the size of the first."""
        img = np.asarray(frame)
        if img.ndim != 3 or img.shape[2] not in (3, 4):
            raise ValueError(f"expected an H x W x 3 (or 4) image, got shape {img.shape}")
        img = img[:, :, :3]
        if img.dtype != np.uint8:
            img = np.clip(img, 0, 255).astype(np.uint8)
        if self._shape is None:
            self._shape = img.shape[:2]
        elif img.shape[:2] != self._shape:
            raise ValueError(f"frame size {img.shape[:2]} differs from the first {self._shape}")
        self._writer.append_data(np.ascontiguousarray(img))
        self.frames += 1

    def close(self) -> None:
        """Finish the file (safe to call twice)."""
        if self._writer is not None:
            self._writer.close()
            self._writer = None

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
