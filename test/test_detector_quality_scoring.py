"""benchmarks/detector_quality.py: what it counts as occluded, and the recall it prints."""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

import numpy as np

_PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "detector_quality.py"
_spec = importlib.util.spec_from_file_location("detector_quality", _PATH)
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)


def pillar(name, x, y, a=0.25, b=0.25, th=0.0):
    """A true vertical obstacle as the benchmark reads it."""
    return (name, 0, np.array([x, y, 0.5]), a, b, th, 1.0)


EYE = np.zeros(2)


def test_an_obstacle_right_behind_another_is_occluded_and_one_beside_it_is_not():
    front = pillar("front", 2.0, 0.0, 0.4, 0.4)
    behind = pillar("behind", 4.0, 0.0)
    beside = pillar("beside", 4.0, 1.5)
    assert bench.occluded(EYE, behind, [front])
    assert not bench.occluded(EYE, beside, [front])
    assert not bench.occluded(EYE, front, [behind, beside])  # the nearer one is never hidden


def test_a_half_hidden_obstacle_is_still_visible():
    """A thin post covering less than half of the near side leaves it visible."""
    post = pillar("post", 2.0, 0.0, 0.05, 0.05)
    assert not bench.occluded(EYE, pillar("target", 4.0, 0.0, 0.4, 0.4), [post])


def test_a_rotated_ellipse_blocks_the_lines_of_sight_it_crosses():
    wall = pillar("wall", 2.0, 0.0, 1.0, 0.1, th=np.pi / 2)  # 2 m long across the view
    targets = np.array([[4.0, 0.0], [4.0, 0.9], [4.0, 3.0]])
    assert bench._sight_blocked(EYE, targets, wall).tolist() == [True, True, False]


def test_occluded_pairs_are_counted_apart_from_the_recall():
    front, behind = pillar("front", 2.0, 0.0, 0.4, 0.4), pillar("behind", 4.0, 0.0)
    detected_front = (("", 0, np.array([2.0, 0.0, 0.5]), 0.4, 0.4, 0.0, 1.0),)
    det = [(0.0, list(detected_front))]
    truth = [(0.0, [front, behind])]
    odom = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    s = bench.score(det, truth, odom, argparse.Namespace(range=5.0, match=0.3))
    assert s["recall"] == 0.5  # the hidden one is a miss ...
    assert s["visible"] == 1 and s["visible_recall"] == 1.0  # ... not held against the detector
