"""Edge cases of the C3BF library (issue #14): solver statuses, extreme inputs, inside an
obstacle, validation of ellipses, and the documented defaults."""

import numpy as np
import osqp
import pytest

from safe_legged_c3bf.c3bf import (
    EllipseObstacle,
    FilterStatus,
    HolonomicModel,
    InvalidInputError,
    Obstacles,
    Plane,
    SafetyFilter,
    UnicycleHeightModel,
    UnicycleModel,
)
from safe_legged_c3bf.c3bf import filter as filter_mod
from safe_legged_c3bf.c3bf.solver_status import OSQP_STATUS_WORDS, describe_osqp_status

UH_MIN, UH_MAX = [-2.0, -4.0, -3.0], [2.0, 4.0, 3.0]
X_UH = np.array([0.0, 0.0, 0.0, 1.0, 0.5, 0.3, 0.2])


# ---------------------------------------------------------------- OSQP status in words
def test_every_osqp_status_has_words():
    for status in osqp.SolverStatus:
        text = describe_osqp_status(status.value)
        assert OSQP_STATUS_WORDS[int(status)] in text
        assert f"OSQP status {int(status)}, {status.name}" in text
    assert "unknown" in describe_osqp_status("x")


@pytest.mark.parametrize("code", [int(s) for s in osqp.SolverStatus])
def test_filter_messages_name_the_osqp_status_in_words(code, monkeypatch):
    """Whatever OSQP answers, a message that mentions it says what the code means."""
    flt = SafetyFilter(UnicycleHeightModel(0.2), u_min=UH_MIN, u_max=UH_MAX, method="qp")
    obs = Obstacles.vertical([[3.0, 0.1], [3.5, -0.2]], [0.5, 0.5])
    ok = np.array([-0.5, 0.0, 0.0])

    def fake_solve(self, *args, **kwargs):
        return ok.copy(), code

    monkeypatch.setattr(filter_mod._HardQP, "solve", fake_solve)
    monkeypatch.setattr(filter_mod._RelaxedQP, "solve", fake_solve)
    monkeypatch.setattr(SafetyFilter, "_verify", lambda self, *a: False)
    r = flt.filter(X_UH, [1.0, 0.0, 0.0], obs)
    assert np.isfinite(r.u_safe).all()
    if "OSQP" in r.message:
        assert OSQP_STATUS_WORDS[code] in r.message, r.message
    if r.status is FilterStatus.FAILSAFE:
        assert "OSQP" in r.message, r.message


# ---------------------------------------------------------------- the numeric domain
def test_models_validate_offset_state_yaw_and_gain():
    with pytest.raises(InvalidInputError, match="offset"):
        UnicycleModel(offset=np.nan)
    with pytest.raises(InvalidInputError, match="offset"):
        UnicycleHeightModel(offset=1e10)
    assert UnicycleModel(offset=1).offset == 1.0
    with pytest.raises(InvalidInputError, match=r"state\[1, 2\] = inf"):
        UnicycleModel().f(np.array([[0, 0, 0, 1, 0], [0, 0, np.inf, 1, 0]]))
    with pytest.raises(InvalidInputError, match="yaw"):
        HolonomicModel().g([0, 0, 1, 0], yaw=np.nan)
    with pytest.raises(InvalidInputError, match="gain"):
        HolonomicModel().brake_input([0, 0, 1, 0], yaw=0.0, gain=-1.0)


def test_ellipse_obstacle_is_validated_at_construction():
    good = EllipseObstacle(center=(1, 2), semi_axes=(0.3, 0.2), velocity=(0, 1), plane=1)
    assert good.center == (1.0, 2.0) and good.plane is Plane.HORIZONTAL
    bad = [
        (dict(center=(np.nan, 0.0)), r"center\[0\] = nan is not finite"),
        (dict(center=(0.0, 1e300)), r"center\[1\] = 1e\+300 is beyond"),
        (dict(center=(0.0, 0.0, 1.0)), "center must be 2 numbers"),
        (dict(semi_axes=(0.3, 0.0)), r"semi_axes\[1\] = 0.0 must be > 0"),
        (dict(semi_axes=(-0.3, 0.2)), r"semi_axes\[0\] = -0.3 must be > 0"),
        (dict(semi_axes="ab"), "semi_axes must be 2 numbers"),
        (dict(velocity=(np.inf, 0.0)), r"velocity\[0\] = inf is not finite"),
        (dict(plane=2), "plane = 2 is not Plane.VERTICAL"),
    ]
    for kw, message in bad:
        args = dict(center=(1.0, 2.0), semi_axes=(0.3, 0.2)) | kw
        with pytest.raises(InvalidInputError, match=message) as err:
            EllipseObstacle(**args)
        assert "EllipseObstacle(center=" in str(err.value)  # names the obstacle
    with pytest.raises(InvalidInputError, match=r"obstacle 1: .* is not an EllipseObstacle"):
        Obstacles.from_ellipses([good, (1.0, 2.0)], 0.4, 0.3)


def test_obstacle_errors_name_the_obstacle_and_the_value():
    with pytest.raises(InvalidInputError, match=r"obstacle 1: center\[1\] = inf is not finite"):
        Obstacles.vertical([[0.0, 0.0], [1.0, np.inf]], [0.5, 0.5])
    with pytest.raises(InvalidInputError, match=r"obstacle 0: radius = -1.0 must be > 0"):
        Obstacles.vertical([[0.0, 0.0], [1.0, 1.0]], [-1.0, 0.5])
    with pytest.raises(InvalidInputError, match=r"obstacle 1: velocity\[0\] = 1\d+\.0 is beyond"):
        Obstacles.vertical([[0.0, 0.0], [1.0, 1.0]], [0.5, 0.5], [[0.0, 0.0], [1e10, 0.0]])
    with pytest.raises(InvalidInputError, match="obstacle 0: plane = 3"):
        Obstacles([[0.0, 0.0]], [[0.0, 0.0]], [1.0], [3])
    with pytest.raises(InvalidInputError, match="dt"):
        Obstacles.vertical([[0.0, 0.0]], [0.5]).advanced(np.nan)

