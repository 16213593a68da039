"""Ground truth for evaluation: contacts, minimum distance, collision events and falls.

Evaluated after every physics step:

* contact: PyBullet contact points between any robot link and any obstacle body with a
  distance <= ``contact_tolerance``, read with one ``getContactPoints`` call per
  robot-obstacle pair whose cheap lower bound (below) is at most ``contact_tolerance`` +
  ``CONTACT_MARGIN``: beyond that no contact is possible;
* collision events: rising edges of contact per obstacle, debounced: touching an obstacle
  counts as a new event only if the robot had not touched that obstacle for at least
  ``collision_debounce`` s (contacts flicker while a foot scrapes along a pillar);
* minimum distance between any robot link and any obstacle. A cheap lower bound (robot
  bounding sphere vs. the obstacle's circumscribed cylinder, never more than the true
  distance) is evaluated for every obstacle at every step; when it is below
  ``distance_cutoff`` the exact distance is computed with ``getClosestPoints`` (negative when
  penetrating), otherwise the bound is reported. The exact query is the expensive part
  (one GJK query per robot link whose bounding box is within the query's search distance of
  the obstacle's), so it is repeated at every step only while the distance is below
  ``exact_distance_below``; farther away it is repeated after the number of steps in which
  the distance could, at ``max_closing_speed`` plus the obstacle's speed, fall to
  ``exact_distance_below`` (at most ``max_check_interval``), and the last value is held in
  between. The run's minimum distance is therefore exact whenever it is below
  ``exact_distance_below`` (given that speed bound), and never over-estimated when it is
  beyond ``distance_cutoff``. Each exact query searches only as far as the distance can have
  grown since the previous one at that speed (plus ``SEARCH_SLACK``), which skips the links
  that are farther away; PyBullet returns every link pair closer than the search distance,
  each with its exact distance, so the minimum is the same as with a search to
  ``distance_cutoff``. Should the speed bound not hold and nothing be found, the query is
  repeated out to ``distance_cutoff``: the result never depends on the bound;
* fall: base height below ``fall_min_height`` or base z axis tilted more than
  ``fall_max_tilt`` from vertical (flat ground at z = 0).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pybullet

from safe_legged_c3bf.sim.obstacles import VERTICAL, KinematicObstacle
from safe_legged_c3bf.sim.robots import RobotHandle
from safe_legged_c3bf.sim.scenario import GroundTruthConfig

#: Contact points of an obstacle are read while its distance lower bound is at most
#: ``contact_tolerance`` + this (m): a margin for the bodies' motion within one physics step
#: (contact points come from the step's collision detection, the bound from its end).
CONTACT_MARGIN = 0.05
#: Added to the search distance of an exact distance query beyond the speed bound (m).
SEARCH_SLACK = 0.01


@dataclass(frozen=True)
class CollisionEvent:
    """Start of a contact between the robot and an obstacle.

    Attributes:
        time: sim time (s).
        obstacle_id: the obstacle touched.
        links: robot links in contact at that time.

    """

    time: float
    obstacle_id: str
    links: tuple[str, ...] = ()


@dataclass(frozen=True)
class GroundTruthSample:
    """Ground truth after one physics step.

    Attributes:
        time: sim time (s).
        in_collision: a robot link touches an obstacle now.
        collision_count: collision events since the start.
        min_distance: min distance between any robot link and any obstacle (m); a lower
            bound when ``min_distance_exact`` is False; inf without obstacles.
        min_distance_exact: whether ``min_distance`` was computed exactly.
        closest_obstacle_id: obstacle at ``min_distance`` ('' without obstacles).
        contact_obstacle_ids: obstacles touched now.
        fallen: the base is too low or too tilted now.
        base_height: base height (m).
        tilt: angle between the base z axis and vertical (rad).

    """

    time: float
    in_collision: bool
    collision_count: int
    min_distance: float
    min_distance_exact: bool
    closest_obstacle_id: str
    contact_obstacle_ids: tuple[str, ...]
    fallen: bool
    base_height: float
    tilt: float


@dataclass
class RunStatistics:
    """What the monitor accumulated over the run (for the summary)."""

    collision_events: list[CollisionEvent] = field(default_factory=list)
    steps_in_collision: int = 0
    time_in_collision: float = 0.0
    min_distance: float = math.inf
    min_distance_time: float | None = None
    min_distance_obstacle: str = ""
    fell: bool = False
    fall_time: float | None = None
    max_tilt: float = 0.0
    min_base_height: float = math.inf


def robot_bounding_radius(client: int, robot: RobotHandle, scale: float = 1.5) -> float:
    """Radius (m) of a sphere about the base origin that contains the robot in any posture.

    The farthest corner of the link bounding boxes in the current (standing) posture, times
    ``scale`` to cover leg motion.
    """
    base, _ = pybullet.getBasePositionAndOrientation(robot.body_id, physicsClientId=client)
    base = np.asarray(base)
    radius = 0.0
    for link in robot.link_ids.values():
        lo, hi = pybullet.getAABB(robot.body_id, link, physicsClientId=client)
        for corner in np.array(np.meshgrid(*zip(lo, hi, strict=True))).T.reshape(-1, 3):
            radius = max(radius, float(np.linalg.norm(corner - base)))
    return scale * radius


class GroundTruthMonitor:
    """Evaluates contacts, distances and falls after each physics step."""

    def __init__(
        self,
        client: int,
        robot: RobotHandle,
        obstacles: Sequence[KinematicObstacle],
        config: GroundTruthConfig,
        dt: float,
    ) -> None:
        """Monitor ``robot`` against ``obstacles`` in ``client`` (robot in its spawn posture).

        ``dt`` is the physics step (s): :meth:`update` is called once per step.
        """
        self.client = client
        self.robot = robot
        self.obstacles = list(obstacles)
        self.config = config
        self.robot_radius = robot_bounding_radius(client, robot)
        self._by_body = {obs.body_id: obs for obs in self.obstacles}
        self._link_names = {index: name for name, index in robot.link_ids.items()}
        self._dt = float(dt)
        self._updates = 0
        self._next_check = [0] * len(self.obstacles)
        self._held = [(math.inf, False)] * len(self.obstacles)
        self._checked_at = [0] * len(self.obstacles)  # update of the last exact query
        #: Exact distance queries made, and how many had to be repeated out to the cutoff.
        self.distance_queries = 0
        self.distance_requeries = 0
        self._closing_speed = [config.max_closing_speed + o.max_speed for o in self.obstacles]
        self._max_interval = max(1, int(config.max_check_interval / self._dt))
        self._geometry = [
            (o.plane == VERTICAL, o.bounding_radius, o.extent / 2.0) for o in self.obstacles
        ]
        self._last_contact: dict[str, float] = {}
        self._in_contact: set[str] = set()
        self.stats = RunStatistics()
        self._fields: tuple | None = None
        self._sample: GroundTruthSample | None = None
        pos, quat = pybullet.getBasePositionAndOrientation(robot.body_id, physicsClientId=client)
        #: PyBullet base (centre-of-mass frame) position (m) and quaternion at the latest update.
        self.last_base_position: tuple[float, float, float] = tuple(pos)
        self.last_base_quaternion: tuple[float, float, float, float] = tuple(quat)

    @property
    def last(self) -> GroundTruthSample | None:
        """The sample of the latest :meth:`update` (None before the first one)."""
        if self._sample is None and self._fields is not None:
            self._sample = GroundTruthSample(*self._fields)
        return self._sample

    @property
    def collision_count(self) -> int:
        """Collision events so far."""
        return len(self.stats.collision_events)

    def _contacts(self, bounds: Sequence[float]) -> dict[str, set[str]]:
        """Obstacle id -> robot links in contact, for the obstacles that can be touched."""
        found: dict[str, set[str]] = {}
        tolerance = self.config.contact_tolerance
        gate = tolerance + CONTACT_MARGIN
        robot, client, names = self.robot.body_id, self.client, self._link_names
        for obstacle, bound in zip(self.obstacles, bounds, strict=True):
            if bound > gate:
                continue
            points = pybullet.getContactPoints(
                bodyA=robot, bodyB=obstacle.body_id, physicsClientId=client
            )
            for point in points:
                if point[8] <= tolerance:
                    found.setdefault(obstacle.id, set()).add(names.get(point[3], "?"))
        return found

    def _lower_bounds(
        self, base: Sequence[float], centers: Sequence[Sequence[float]]
    ) -> list[float]:
        """Per obstacle, a lower bound of the robot-obstacle distance (m, >= 0).

        The same bound as :meth:`KinematicObstacle.distance_lower_bound` minus the robot's
        bounding radius, inlined because it runs for every obstacle at every step.
        """
        px, py, pz = base
        radius = self.robot_radius
        hypot = math.hypot
        out = []
        for (vertical, r, half), c in zip(self._geometry, centers, strict=True):
            dx, dy, dz = px - c[0], py - c[1], pz - c[2]
            if vertical:
                radial, axial = hypot(dx, dy) - r, abs(dz) - half
            else:
                radial, axial = hypot(dx, dz) - r, abs(dy) - half
            bound = hypot(radial if radial > 0.0 else 0.0, axial if axial > 0.0 else 0.0)
            out.append(bound - radius if bound > radius else 0.0)
        return out

    def _min_distance(self, bounds: Sequence[float]) -> tuple[float, bool, str]:
        cfg = self.config
        cutoff = cfg.distance_cutoff
        best, best_exact, best_id = math.inf, False, ""
        for i, (obs, bound) in enumerate(zip(self.obstacles, bounds, strict=True)):
            if bound >= cutoff:
                distance, exact = bound, False
                self._next_check[i] = 0  # check at once when it comes within the cutoff
            elif self._updates >= self._next_check[i]:
                distance, exact = self._query_distance(i, obs.body_id, cutoff)
                # The distance cannot fall below exact_distance_below before this many steps.
                margin = distance - cfg.exact_distance_below
                steps = int(margin / (self._closing_speed[i] * self._dt)) if margin > 0 else 1
                self._next_check[i] = self._updates + min(max(steps, 1), self._max_interval)
                self._held[i] = (distance, exact)
            else:
                distance, exact = self._held[i]
            if distance < best:
                best, best_exact, best_id = distance, exact, obs.id
        return best, best_exact, best_id

    def _query_distance(self, i: int, body: int, cutoff: float) -> tuple[float, bool]:
        """Exact distance to obstacle ``i`` (or (cutoff, False) when at least that far)."""
        self.distance_queries += 1
        known, exact = self._held[i]
        search = cutoff
        if exact:  # how far it can be now, at the speed bound, since the last query
            elapsed = (self._updates - self._checked_at[i]) * self._dt
            grown = known + self._closing_speed[i] * elapsed + SEARCH_SLACK
            if grown < cutoff:
                search = max(grown, SEARCH_SLACK)
        self._checked_at[i] = self._updates
        robot, client = self.robot.body_id, self.client
        points = pybullet.getClosestPoints(robot, body, search, physicsClientId=client)
        if not points and search < cutoff:  # moved faster than the bound: search it all
            self.distance_requeries += 1
            points = pybullet.getClosestPoints(robot, body, cutoff, physicsClientId=client)
        if points:
            return min(p[8] for p in points), True
        return cutoff, False  # no link pair closer than the cutoff

    def update(self, t: float, centers: Sequence[Sequence[float]]) -> None:
        """Evaluate the world after the physics step that ended at sim time ``t``.

        The result is available as :attr:`last` (built on demand: this runs at every physics
        step and is kept lean).

        Args:
            t: sim time (s).
            centers: obstacle centres at ``t`` (m), in the order of ``obstacles``.

        """
        cfg, stats = self.config, self.stats
        self._updates += 1
        pos, quat = pybullet.getBasePositionAndOrientation(
            self.robot.body_id, physicsClientId=self.client
        )
        self.last_base_position, self.last_base_quaternion = pos, quat
        x, y = quat[0], quat[1]
        tilt = math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y))))
        height = pos[2]
        fallen = height < cfg.fall_min_height or tilt > cfg.fall_max_tilt
        if fallen and not stats.fell:
            stats.fell, stats.fall_time = True, t
        if tilt > stats.max_tilt:
            stats.max_tilt = tilt
        if height < stats.min_base_height:
            stats.min_base_height = height

        bounds = self._lower_bounds(pos, centers)
        contacts = self._contacts(bounds)
        if contacts or self._in_contact:
            for obstacle_id, links in contacts.items():
                if obstacle_id not in self._in_contact:
                    last = self._last_contact.get(obstacle_id)
                    if last is None or t - last > cfg.collision_debounce:
                        stats.collision_events.append(
                            CollisionEvent(t, obstacle_id, tuple(sorted(links)))
                        )
                self._last_contact[obstacle_id] = t
            self._in_contact = set(contacts)
            if contacts:
                stats.steps_in_collision += 1
                stats.time_in_collision += self._dt

        distance, exact, closest = self._min_distance(bounds)
        if distance < stats.min_distance:
            stats.min_distance, stats.min_distance_time = distance, t
            stats.min_distance_obstacle = closest
        self._fields = (
            t, bool(contacts), len(stats.collision_events), distance, exact, closest,
            tuple(sorted(contacts)), fallen, height, tilt,
        )
        self._sample = None
