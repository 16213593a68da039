"""sim/video.py: GIF and MP4 files from RGB frames, readable back with imageio."""

from __future__ import annotations

import imageio.v2 as iio
import numpy as np
import pytest

from safe_legged_c3bf.sim.video import VideoWriter, check_video_path, frame_interval_steps


def _frames(n: int, h: int = 48, w: int = 64) -> list[np.ndarray]:
    frames = []
    for k in range(n):
        img = np.zeros((h, w, 3), dtype=np.uint8)
        img[:, : (k + 1) * w // n] = (200, 40, 40)  # a bar growing frame by frame
        frames.append(img)
    return frames


@pytest.mark.parametrize("suffix", [".gif", ".mp4"])
def test_writes_a_readable_video(tmp_path, suffix):
    path = tmp_path / f"out{suffix}"
    frames = _frames(13)
    with VideoWriter(path, fps=10) as writer:
        for frame in frames[:-1]:
            writer.append(frame)
        alpha = np.full((48, 64, 1), 255, np.uint8)
        writer.append(np.concatenate([frames[-1], alpha], axis=2))  # RGBA: alpha dropped
    assert writer.frames == 13
    read = [frame for frame in iio.get_reader(path)]
    assert len(read) == 13
    assert read[0].shape[:2] == (48, 64)


def test_rejects_bad_input(tmp_path):
    with pytest.raises(ValueError, match=".gif or .mp4"):
        check_video_path(tmp_path / "x.avi")
    writer = VideoWriter(tmp_path / "x.mp4", fps=5)
    writer.append(_frames(1)[0])
    with pytest.raises(ValueError, match="differs from the first"):
        writer.append(_frames(1, h=32)[0])
    with pytest.raises(ValueError, match="H x W x 3"):
        writer.append(np.zeros((4, 4)))
    writer.close()
    writer.close()  # idempotent


def test_frame_interval():
    assert frame_interval_steps(10, 0.001) == 100
    assert frame_interval_steps(30, 0.001) == 33
    assert frame_interval_steps(5000, 0.001) == 1
