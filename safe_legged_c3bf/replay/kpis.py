"""Scores of a replayed safety filter against ground truth (no ROS).

The replay plays a recording's sensor, odometry and reference topics into the safety pipeline
and collects what the filter did each cycle. Ground truth (the recording's robot pose and its
true obstacles) says when the reference command put the robot on a collision course: the
reference velocity, relative to a vertical obstacle within ``sensing_range`` (8 m, the
LiDAR's range), points into the obstacle's collision cone (the paper's barrier ``h < 0`` with
the obstacle's radius grown by the filter's inflation ``pad``). Per such **cone entry**:

- ``reaction``: s from the entry to the first cycle the filter acts (status ACTIVE, RELAXED,
  EMERGENCY_BRAKE or STALE_INPUT); 0 when it was already acting;
- ``cone_exit``: s from the entry to the first cycle whose filtered command is out of every
  cone (``h >= 0``), the filter's answer to the threat, like a time to stop;
- missed when neither happens within ``horizon`` s.

On a **free path** (every obstacle surface farther than ``free_clearance``, and neither the
reference nor the robot's own velocity in a cone), ``false_intervention_share`` is the share
of cycles in which the filter acted. Units: s, m, m/s;
positions and velocities in odom.

Horizontal obstacles (bars) are not scored: their cone lives in x-z and the reference has no
vertical component to test.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from safe_legged_c3bf.c3bf.barrier import c3bf_value

#: SafetyFilterState statuses that change the reference (see SafetyFilterState.msg).
ACTING = (2, 3, 4, 5, 6)


@dataclass(frozen=True)
class KpiLimits:
    """Pass limits (s, share) and scoring geometry (m, s)."""

    reaction: float = 0.3
    cone_exit: float = 0.6
    false_intervention_share: float = 0.05
    sensing_range: float = 8.0
    free_clearance: float = 2.0
    horizon: float = 3.0
    warm_up: float = 1.0


@dataclass
class FilterCycles:
    """What the filter did, one row per cycle (sim time order).

    Attributes:
        t: (n,) sim time of the cycle (s).
        status: (n,) SafetyFilterState status.
        reference: (n, 3) reference vx, vy (m/s, base_link) and yaw rate (rad/s).
        filtered: (n, 3) filtered command, same layout.

    """

    t: np.ndarray
    status: np.ndarray
    reference: np.ndarray
    filtered: np.ndarray


@dataclass
class GroundTruth:
    """The recording's truth: robot pose track and vertical obstacles over time.

    Attributes:
        pose_t: (m,) sim times of the poses (s).
        pose: (m, 5) x, y (m, odom), yaw (rad) and the body-frame velocity vx, vy (m/s).
        obstacle_t: (k,) sim times of the obstacle frames (s).
        obstacles: per frame, an (j, 5) array of centre x, y, velocity x, y (odom) and radius.

    """

    pose_t: np.ndarray
    pose: np.ndarray
    obstacle_t: np.ndarray
    obstacles: list[np.ndarray]


@dataclass
class KpiReport:
    """The scores and whether they pass."""

    entries: int = 0
    missed: int = 0
    reaction: list[float] = field(default_factory=list)
    cone_exit: list[float] = field(default_factory=list)
    free_cycles: int = 0
    false_intervention_share: float = 0.0
    cycles: int = 0
    failures: list[str] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        """True when every KPI is within its limit and there was something to score."""
        return not self.failures

    def as_dict(self) -> dict:
        """JSON-ready figures (max and median of the per-entry times)."""
        out = asdict(self)
        for key in ("reaction", "cone_exit"):
            values = getattr(self, key)
            out[f"{key}_max"] = max(values) if values else None
            out[f"{key}_median"] = float(np.median(values)) if values else None
        out["passed"] = self.passed
        return out


def _in_cone(p: np.ndarray, yaw: float, cmd: np.ndarray, obs: np.ndarray, lim: KpiLimits,
             pad: float) -> bool:
    """True when the command's velocity points into some obstacle's grown collision cone."""
    if obs.size == 0:
        return False
    c, s = np.cos(yaw), np.sin(yaw)
    v = np.array([c * cmd[0] - s * cmd[1], s * cmd[0] + c * cmd[1]])
    p_rel = obs[:, :2] - p
    near = np.hypot(p_rel[:, 0], p_rel[:, 1]) - obs[:, 4] <= lim.sensing_range
    if not near.any():
        return False
    h = c3bf_value(p_rel[near], obs[near, 2:4] - v, obs[near, 4] + pad)
    return bool((h < 0).any())


def _clearance(p: np.ndarray, obs: np.ndarray) -> float:
    if obs.size == 0:
        return np.inf
    return float((np.hypot(*(obs[:, :2] - p).T) - obs[:, 4]).min())


def score(cycles: FilterCycles, truth: GroundTruth, pad: float,
          limits: KpiLimits | None = None) -> KpiReport:
    """Score the filter's cycles against the truth (see the module docstring)."""
    lim = limits or KpiLimits()
    rep = KpiReport()
    t0 = cycles.t[0] if cycles.t.size else 0.0
    keep = cycles.t >= t0 + lim.warm_up
    t, status = cycles.t[keep], cycles.status[keep]
    ref, safe = cycles.reference[keep], cycles.filtered[keep]
    rep.cycles = int(t.size)
    if t.size == 0 or truth.pose_t.size == 0 or truth.obstacle_t.size == 0:
        rep.failures.append("nothing to score: no filter cycles or no ground truth")
        return rep
    x = np.interp(t, truth.pose_t, truth.pose[:, 0])
    y = np.interp(t, truth.pose_t, truth.pose[:, 1])
    yaw = np.interp(t, truth.pose_t, np.unwrap(truth.pose[:, 2]))
    frame = np.clip(np.searchsorted(truth.obstacle_t, t, side="right") - 1, 0, None)
    acting = np.isin(status, ACTING)
    vel = np.stack([np.interp(t, truth.pose_t, truth.pose[:, 3]),
                    np.interp(t, truth.pose_t, truth.pose[:, 4]), np.zeros(t.size)], axis=1) \
        if truth.pose.shape[1] >= 5 else np.zeros((t.size, 3))
    ref_in = np.zeros(t.size, bool)
    safe_in = np.zeros(t.size, bool)
    moving_in = np.zeros(t.size, bool)
    clear = np.zeros(t.size)
    for k in range(t.size):
        p, obs = np.array([x[k], y[k]]), truth.obstacles[frame[k]]
        ref_in[k] = _in_cone(p, yaw[k], ref[k], obs, lim, pad)
        safe_in[k] = _in_cone(p, yaw[k], safe[k], obs, lim, pad)
        moving_in[k] = _in_cone(p, yaw[k], vel[k], obs, lim, pad)
        clear[k] = _clearance(p, obs)
    _score_entries(rep, t, acting, ref_in, safe_in, lim)
    free = (~ref_in) & (~moving_in) & (clear > lim.free_clearance)
    rep.free_cycles = int(free.sum())
    rep.false_intervention_share = float(acting[free].mean()) if free.any() else 0.0
    _judge(rep, lim)
    return rep


def _score_entries(rep: KpiReport, t: np.ndarray, acting: np.ndarray, ref_in: np.ndarray,
                   safe_in: np.ndarray, lim: KpiLimits) -> None:
    """Reaction and cone-exit times of every cone entry."""
    starts = np.flatnonzero(ref_in & ~np.concatenate(([False], ref_in[:-1])))
    for k in starts:
        rep.entries += 1
        window = (t >= t[k]) & (t <= t[k] + lim.horizon)
        act = np.flatnonzero(window & acting)
        out = np.flatnonzero(window & ~safe_in)
        if act.size == 0 and out.size == 0:
            rep.missed += 1
            continue
        if act.size:
            rep.reaction.append(float(t[act[0]] - t[k]))
        rep.cone_exit.append(float(t[out[0]] - t[k]) if out.size else lim.horizon)


def _judge(rep: KpiReport, lim: KpiLimits) -> None:
    if rep.missed:
        rep.failures.append(f"{rep.missed} cone entr(y/ies) with no reaction in {lim.horizon:g} s")
    if rep.reaction and max(rep.reaction) > lim.reaction:
        rep.failures.append(f"reaction {max(rep.reaction):.3f} s > {lim.reaction:g} s")
    if rep.cone_exit and max(rep.cone_exit) > lim.cone_exit:
        rep.failures.append(f"cone exit {max(rep.cone_exit):.3f} s > {lim.cone_exit:g} s")
    if rep.false_intervention_share > lim.false_intervention_share:
        rep.failures.append(
            f"false interventions {rep.false_intervention_share:.1%} of free-path cycles > "
            f"{lim.false_intervention_share:.0%}"
        )
