"""The head-on deceleration the C3BF constraint asks for (doc/evaluation.md, "Choosing gamma").

Head-on at distance ``d`` from a static circle of radius ``r``, walking towards it at ``v``,
the body point is inside the collision cone (``h = v (sqrt(d^2 - r^2) - d) < 0``) and
``Lf h + Lg h u + gamma h >= 0`` holds exactly when the deceleration is at least
``gamma v + v^2 / sqrt(d^2 - r^2)``, from any distance: the rule that bounds gamma by the
deceleration limit at the sensing range. Checked against the library's Lie derivatives.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from safe_legged_c3bf.c3bf.geometry import Plane
from safe_legged_c3bf.c3bf.lie import c3bf_lie_derivatives
from safe_legged_c3bf.c3bf.models import XZDoubleIntegratorModel


def head_on_deceleration(gamma: float, v: float, d: float, r: float) -> float:
    """Least deceleration [m/s^2] the constraint allows head-on (the hand derivation)."""
    return gamma * v + v * v / math.sqrt(d * d - r * r)


@pytest.mark.parametrize("gamma", [0.5, 1.0, 2.0, 4.0])
@pytest.mark.parametrize(("v", "d", "r"), [(0.5, 6.0, 0.7), (0.2, 6.0, 0.8), (0.5, 1.5, 0.7),
                                           (0.3, 0.9, 0.7)])
def test_head_on_constraint_is_the_deceleration_rule(gamma, v, d, r):
    model = XZDoubleIntegratorModel()
    state = np.array([0.0, 0.3, v, 0.0])
    t = c3bf_lie_derivatives(model, state, np.array([[d, 0.3]]), np.array([[0.0, 0.0]]),
                             np.array([r]), np.array([Plane.HORIZONTAL]), v_eps=0.0)
    h, lf, lg = float(t.h[0]), float(t.lf_h[0]), t.lg_h[0]
    assert h == pytest.approx(v * (math.sqrt(d * d - r * r) - d))
    assert lg[1] == pytest.approx(0.0, abs=1e-12)  # no vertical authority head-on
    # Lg h = sqrt(d^2 - r^2) - d < 0: braking (u_x < 0) helps, so the row is u_x <= u_max,
    # Lf h + Lg h u_max + gamma h = 0, with -u_max the least deceleration.
    assert lg[0] == pytest.approx(math.sqrt(d * d - r * r) - d)
    u_max = -(lf + gamma * h) / lg[0]
    assert -u_max == pytest.approx(head_on_deceleration(gamma, v, d, r), rel=1e-9)


def test_the_rule_bounds_gamma_by_the_deceleration_limit_at_the_sensing_range():
    # A1: planner speed 0.5 m/s, max_accel 1 m/s^2, obstacles from 6 m: gamma <= 1.9 1/s.
    v, a, big_r, r = 0.5, 1.0, 6.0, 0.7
    bound = (a - v * v / math.sqrt(big_r ** 2 - r ** 2)) / v
    assert head_on_deceleration(bound, v, big_r, r) == pytest.approx(a)
    assert 1.8 < bound < 2.0
