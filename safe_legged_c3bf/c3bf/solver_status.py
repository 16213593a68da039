"""OSQP status codes in words, for the filter's messages.

OSQP 1.x reports a number (``res.info.status_val``, :class:`osqp.SolverStatus`); a bare
number in a message tells the reader nothing, so every message names the status in words
and keeps the code and enum name in brackets for searching, e.g.
``"the problem looks non-convex: huge or non-finite numbers in the data (OSQP status 9,
OSQP_NON_CVX)"``.
"""

from __future__ import annotations

import osqp

__all__ = ["OSQP_STATUS_WORDS", "describe_osqp_status"]

_S = osqp.SolverStatus

OSQP_STATUS_WORDS: dict[int, str] = {
    int(_S.OSQP_SOLVED): "solved to tolerance",
    int(_S.OSQP_SOLVED_INACCURATE): "solved, but not to the requested tolerance",
    int(_S.OSQP_PRIMAL_INFEASIBLE): "infeasible: the constraints cannot all hold",
    int(_S.OSQP_PRIMAL_INFEASIBLE_INACCURATE): (
        "probably infeasible: the constraints cannot all hold (not certified to tolerance)"
    ),
    int(_S.OSQP_DUAL_INFEASIBLE): (
        "unbounded (dual infeasible): impossible with a positive definite weight, so the "
        "data are numerically broken"
    ),
    int(_S.OSQP_DUAL_INFEASIBLE_INACCURATE): (
        "probably unbounded (dual infeasible, inaccurate): the data are numerically broken"
    ),
    int(_S.OSQP_MAX_ITER_REACHED): "stopped at the iteration limit before converging",
    int(_S.OSQP_TIME_LIMIT_REACHED): "stopped at the time limit before converging",
    int(_S.OSQP_NON_CVX): (
        "the problem looks non-convex: huge or non-finite numbers in the data"
    ),
    int(_S.OSQP_SIGINT): "interrupted (SIGINT)",
    int(_S.OSQP_UNSOLVED): "not solved (the solver did not run to completion)",
}
"""Every :class:`osqp.SolverStatus` code, in words."""


def describe_osqp_status(code) -> str:
    """``"<words> (OSQP status <code>, <ENUM_NAME>)"`` for an OSQP status code (any int)."""
    try:
        code = int(code)
        name = _S(code).name
    except (TypeError, ValueError):
        return f"unknown OSQP status {code!r}"
    return f"{OSQP_STATUS_WORDS.get(code, 'undocumented status')} (OSQP status {code}, {name})"
