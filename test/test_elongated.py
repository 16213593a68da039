"""Elongated obstacles become a row of circles that covers the ellipse and opens doorways."""

import math

import numpy as np
import pytest

from safe_legged_c3bf.c3bf.body import robot_body
from safe_legged_c3bf.safety.elongated import ELONGATION, MAX_BULGE, MAX_CIRCLES, ellipse_cover
from safe_legged_c3bf.safety.obstacle_input import ObstacleInput, to_c3bf_obstacles


def _ellipse_points(a, b, th, n=400):
    t = np.linspace(0, 2 * np.pi, n)
    pts = np.stack([a * np.cos(t), b * np.sin(t)], -1)
    c, s = math.cos(th), math.sin(th)
    return pts @ np.array([[c, s], [-s, c]])


@pytest.mark.parametrize("a, b, th", [(1.5, 0.1, 0.0), (0.1, 1.5, 0.3), (0.6, 0.2, 1.0),
                                      (3.0, 0.05, -0.7), (0.3, 0.25, 0.5)])
def test_the_circles_cover_the_ellipse(a, b, th):
    idx, off, r = ellipse_cover([[a, b]], [th])
    assert (idx == 0).all() and len(idx) <= MAX_CIRCLES
    pts = _ellipse_points(a, b, th)
    d = np.linalg.norm(pts[:, None, :] - off[None], axis=-1)
    assert (d <= r[None] + 1e-9).any(axis=1).all()
    if max(a, b) > ELONGATION * min(a, b):
        assert r.max() < max(a, b)  # smaller than the one circle of the major semi-axis
    else:
        assert len(idx) == 1 and r[0] == max(a, b)


@pytest.mark.parametrize("a, b", [(1.5, 0.1), (3.0, 0.05), (0.6, 0.2), (2.0, 0.3)])
def test_the_end_circles_hug_the_ellipse_s_ends(a, b):
    """Each circle covers the ellipse within its cell, not the cell's box: the ends shrink."""
    _, off, r = ellipse_cover([[a, b]], [0.0])
    _, box_off, box_r = ellipse_cover([[a, b]], [0.0], fit="box")
    np.testing.assert_allclose(off, box_off)
    assert (r <= box_r + 1e-12).all() and r[0] < box_r[0] and r[-1] < box_r[-1]
    half = a / len(r)
    # how far the cover reaches beyond the end of the major axis (box cells: hypot(half, b)
    # - half); both ends alike
    reach = off[-1, 0] + r[-1] - a
    assert 0.0 < reach < math.hypot(half, b) - half
    assert off[0, 0] - r[0] == pytest.approx(-a - reach)


def test_a_wall_end_sticks_out_a_centimetre_not_four():
    """The 3 m x 0.2 m walls of ``quadruped_gap``: 4.3 cm beyond each end with box cells."""
    _, off, r = ellipse_cover([[1.5, 0.1]], [0.0])
    assert off[-1, 0] + r[-1] - 1.5 < 0.015


def test_the_box_fit_covers_the_rectangle():
    """Bars' footprints are rectangles: ``fit="box"`` covers their corners too."""
    a, b = 1.2, 0.15
    _, off, r = ellipse_cover([[a, b]], [0.0], fit="box")
    xs, ys = np.meshgrid(np.linspace(-a, a, 121), np.linspace(-b, b, 13))
    pts = np.stack([xs.ravel(), ys.ravel()], -1)
    d = np.linalg.norm(pts[:, None, :] - off[None], axis=-1)
    assert (d <= r[None] + 1e-9).any(axis=1).all()
    with pytest.raises(ValueError, match="fit"):
        ellipse_cover([[a, b]], [0.0], fit="circle")


def test_a_doorway_between_two_walls_stays_open():
    """Two 3 m walls end to end leave a 0.6 m doorway; one circle each would close it."""
    walls = [
        ObstacleInput("left", 0, np.array([3.0, 2.0, 0.5]), np.zeros(3), np.array([0.1, 1.5]), 1.0),
        ObstacleInput("right", 0, np.array([3.0, -1.6, 0.5]), np.zeros(3), np.array([0.1, 1.5]),
                      1.0),
    ]
    circles, ids = to_c3bf_obstacles(walls, 0.0, 0.0, 0.0, 0.0, 0.05, 0.1)
    assert set(ids) == {"left", "right"} and len(ids) > 2
    door = np.array([3.0, 0.2])  # the doorway's middle
    gap = np.linalg.norm(circles.center - door, axis=1) - circles.radius
    assert gap.min() > 0.15  # room for the A1's body half width (0.15 m)


def test_orientation_turns_the_row():
    wall = ObstacleInput("w", 0, np.array([0.0, 0.0, 0.5]), np.zeros(3), np.array([1.0, 0.1]), 1.0,
                         orientation=math.pi / 2)
    circles, _ = to_c3bf_obstacles([wall], 0.0, 0.0, 0.0, 0.0, 0.0, 0.1)
    assert np.ptp(circles.center[:, 0]) < 1e-9 and np.ptp(circles.center[:, 1]) > 1.5


@pytest.mark.parametrize("a, b", [(3.0, 0.1), (1.5, 0.1), (0.6, 0.2), (2.0, 0.02)])
def test_a_long_wall_keeps_its_width(a, b):
    """The circles stick out at most MAX_BULGE beyond the minor semi-axis, up to MAX_CIRCLES."""
    idx, off, r = ellipse_cover([[a, b]], [0.0])
    if len(idx) < MAX_CIRCLES:
        assert r.max() <= b + MAX_BULGE + 1e-12
    assert len(idx) <= MAX_CIRCLES


def test_a_corridor_beside_a_walker_stays_open_to_the_body():
    """Walls 1.6 m apart (3 m long, 0.2 m thick) and a walker (r 0.2 m) in the middle: 0.4 m
    on each side of it: room for the A1's footprint circles (0.2 m) with 0.05 m margins."""
    walls = [
        ObstacleInput(name, 0, np.array([4.0, y, 0.5]), np.zeros(3), np.array([3.0, 0.1]), 1.0)
        for name, y in (("left", 0.9), ("right", -0.9))
    ]
    circles, _ = to_c3bf_obstacles(walls, 0.0, 0.0, 0.0, 0.0, 0.05, 0.1)
    inner = np.abs(circles.center[:, 1]) - circles.radius  # inner edge (margin included)
    assert inner.min() >= 0.8 - MAX_BULGE - 0.05 - 1e-9
    footprint = max(p.radius for p in robot_body("a1").points if p.plane == 0)
    assert inner.min() - (0.2 + 0.05) >= 2 * footprint  # the body passes beside the walker
