"""ZMP and DCM references from the footstep plan (odom frame, REP-103; m, s).

The ZMP reference is piecewise linear: during a double support it moves from the previous
support foot's ZMP point to the new support foot's, during a single support it stays there.
Over the preview horizon the footsteps ahead come from the planner and the current command;
with a zero command the walk finishes the current step (and one aligning step if the feet are
not side by side) and the ZMP returns between the feet.
"""

from __future__ import annotations

import math

import numpy as np

from safe_legged_c3bf.gait.biped.command_filter import CommandFilter
from safe_legged_c3bf.gait.biped.footstep_planner import Footstep, FootstepPlanner
from safe_legged_c3bf.gait.biped.gait_schedule import GaitMode, GaitSchedule


def zmp_reference(schedule: GaitSchedule, command: CommandFilter, times: np.ndarray) -> np.ndarray:
    """ZMP reference (len(times), 2) at ``times`` (s) from the current step and the plan."""
    if schedule.mode is GaitMode.STAND:
        return schedule.stand_zmp_at(times)
    gait, planner = schedule.gait, schedule.planner
    step = schedule.step
    zp = planner.zmp_point
    knot_t = [step.t_start, step.t_start + step.hold, step.t_lift]
    knot_p = [step.zmp_start, step.zmp_start, zp(step.support)]
    t_end = step.t_end
    horizon_end = times[-1]
    if not command.moving:
        # finish the current step (and one aligning step if needed), then stand
        last, prev = step.target, step.support
        if not planner.is_aligned(prev, last):
            nxt = planner.aligned_step(last)
            knot_t += [t_end, t_end + gait.double_support]
            knot_p += [zp(prev), zp(last)]
            t_end += gait.step_period
            prev, last = last, nxt
        knot_t += [t_end, t_end + gait.stop_double_support]
        mid = 0.5 * (zp(prev) + zp(last))
        knot_p += [zp(prev), mid]
    else:
        footsteps = [step.target]
        n_more = int(np.ceil((horizon_end - t_end) / gait.step_period)) + 1
        footsteps += planner.plan(step.target, command.velocity, max(n_more, 0))
        prev = step.support
        for f in footsteps:
            knot_t += [t_end, t_end + gait.double_support]
            knot_p += [zp(prev), zp(f)]
            t_end += gait.step_period
            prev = f
            if t_end - gait.single_support > horizon_end:
                break
    knot_t = np.asarray(knot_t)
    knot_p = np.asarray(knot_p)
    out = np.empty((times.size, 2))
    out[:, 0] = np.interp(times, knot_t, knot_p[:, 0])
    out[:, 1] = np.interp(times, knot_t, knot_p[:, 1])
    return out


def nominal_dcm_at_touchdown(
    planner: FootstepPlanner,
    command: CommandFilter,
    omega: float,
    step_period: float,
    support: Footstep,
    target: Footstep,
) -> np.ndarray:
    """Capture point (2,) the footstep plan expects when ``target`` touches down (odom, m).

    Backward recursion over the planned footsteps with the ZMP at each sole centre for a
    whole step period (Englsberger's DCM plan): xi_k = z_k + (xi_{k+1} - z_k) e^(-omega T),
    ending at the last footstep (or between the feet when stopping). ``omega`` is the LIPM
    frequency (1/s), ``step_period`` T (s).
    """
    zp = planner.zmp_point
    if command.moving:
        future = [target, *planner.plan(target, command.velocity, 3)]
        xi = zp(future[-1])
    else:
        future = [target]
        xi = 0.5 * (zp(support) + zp(target))
    decay = math.exp(-omega * step_period)
    for f in reversed(future[:-1]):
        z = zp(f)
        xi = z + (xi - z) * decay
    return xi
