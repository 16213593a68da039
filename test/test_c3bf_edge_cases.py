"""Edge cases of the C3BF library (issue #14): solver statuses, extreme inputs, inside an
obstacle, validation of ellipses, and the documented defaults."""

import numpy as np
import osqp
import pytest

from safe_legged_c3bf.c3bf import (
    FilterStatus,
    Obstacles,
    SafetyFilter,
    UnicycleHeightModel,
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
