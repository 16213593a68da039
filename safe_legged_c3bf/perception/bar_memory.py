"""The bars the detector saw, remembered for a while in odom (no ROS).

A bar is HORIZONTAL only while the 3-D sensor sees it with free space beneath
(``free_space.py``). Close to it, ducking under it and just past it, the forward sensor no
longer sees it (it is above or behind its view) while the 2-D LiDAR, at about the bar's
height on a ducked body, still cuts it: alone, those scan returns would be a wall on top of
the robot. So the detector remembers each HORIZONTAL obstacle it detected, with the stamp of
the last frame the 3-D sensor confirmed it, for ``bar_memory`` s:

* **Absorbing** (:meth:`BarMemory.absorb`). A candidate point the current frame would make
  VERTICAL is attributed to a remembered bar when it lies in the bar's volume grown by
  ``bar_memory_tolerance`` (``tol``): ``|x - cx| <= a + tol``, ``|z - cz| <= b + tol`` and
  ``|y - cy| <= extent / 2 + tol``, and only when its column does NOT reach the ground (the
  column test wins: a pillar or a walker standing under the bar, whose foot a sensor sees,
  stays VERTICAL). Three more tests keep what stands there VERTICAL when its foot is out of
  view in this frame:

  - *standing columns* (:meth:`BarMemory.stand`): grounded points that rise into a
    remembered bar's band, under or beside it, are remembered as standing columns for as
    long as the bars; a point in such a column (3 x 3 cells of ``column_cell``) is not
    absorbed (the posts holding a bar, seen down to the ground on the way to it);
  - *the line* (:func:`on_line`): the points a bar takes lie within ``tol`` (along x) of
    one line: a scan plane cuts a bar along a line, a pillar or a walker along an arc;
  - *the guard*: a point within ``guard`` (x-y) of a vertical point that is not absorbed
    (grounded, standing, outside every volume or off the line) is not absorbed either, so
    that what stands under or beside a bar keeps all its points, even those in the band.

* **Reporting** (:meth:`BarMemory.obstacles`). Every remembered bar is reported (HORIZONTAL)
  while it is within memory, with the points that confirmed it in this frame; a bar the
  3-D sensor detects again is reported once, as remembered (its x-z ellipse from the new
  detection, its extent along y the union of what was seen).
* **Bounded** (:meth:`BarMemory.update`). A new detection of the same bar (x centres within
  ``tol``, y and z intervals overlapping within ``tol``) merges into its entry; an entry
  whose centre lies inside a new detection's grown volume otherwise (a piece of a bar at an
  angle, cut elsewhere this time) is replaced by it; at most :data:`MAX_REMEMBERED_BARS`
  are kept (the most recently seen). Entries older than ``bar_memory`` (unless the sensors
  are within ``bar_memory_keep_near`` of them: close to a bar the forward sensor may not see
  it, and a robot stopped before a bar it cannot pass must not walk on when the memory times
  out), or stamped more than that after the frame (the clock went back: a new run), are
  forgotten, and so are standing
  columns (at most :data:`MAX_STANDING_CELLS`, only near remembered bars); ``clear``
  forgets everything.

Only the 3-D sensor's detections refresh an entry: points seen by the scan alone cannot tell
a bar from something standing whose foot is out of view, so they may lean on a bar for at
most ``bar_memory`` s after the 3-D sensor last saw it. With no memory (the first frames, or a
robot with a LiDAR only) a scan-only floating cluster is VERTICAL: the safe default. A bar
moved or removed is still reported until it is forgotten (conservative: the robot ducks).
Limits: a post no thicker than ``tol`` on the bar's line, never seen down to the ground and
seen by the scan alone, is absorbed; a bar at an angle to odom y is remembered as pieces, each
a box around its part of the bar.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from safe_legged_c3bf.perception.shapes import DetectedObstacle
from safe_legged_c3bf.perception.track import ObstaclePlane

__all__ = [
    "MAX_REMEMBERED_BARS", "MAX_STANDING_CELLS", "BarMemory", "RememberedBar", "on_line",
]

#: Most bars remembered at once (the most recently seen are kept).
MAX_REMEMBERED_BARS = 32
#: Most standing columns remembered at once (the most recently seen are kept).
MAX_STANDING_CELLS = 8192
_J_OFFSET = 2**31  # cell keys: i * 2**32 + j + 2**31, unique for |j| < 2**31 cells


def _cell_keys(xy: np.ndarray, cell: float) -> np.ndarray:
    """(n,) int64 key of each point's x-y cell of edge ``cell`` (m)."""
    ij = np.floor(np.asarray(xy, dtype=float).reshape(-1, 2) / cell).astype(np.int64)
    return ij[:, 0] * 2**32 + ij[:, 1] + _J_OFFSET


@dataclass(frozen=True)
class RememberedBar:
    """One remembered HORIZONTAL obstacle.

    Attributes:
        obstacle: the bar as last detected (odom, m), its extent the union seen along y.
        last_seen: stamp (s) of the last frame in which the 3-D sensor detected it.

    """

    obstacle: DetectedObstacle
    last_seen: float

    def bounds(self, tolerance: float = 0.0) -> np.ndarray:
        """(3, 2) low and high x, y, z (m, odom) of its volume grown by ``tolerance``."""
        o = self.obstacle
        half = np.array([o.semi_axes[0], 0.5 * o.extent, o.semi_axes[1]]) + tolerance
        return np.column_stack([o.center - half, o.center + half])


def _same_bar(old: np.ndarray, new: np.ndarray, tolerance: float) -> bool:
    """True when two volumes (3, 2) are one bar along y: x centres close, y and z overlapping."""
    same_x = abs(old[0].mean() - new[0].mean()) <= tolerance
    overlap = (old[1:, 0] <= new[1:, 1] + tolerance) & (new[1:, 0] <= old[1:, 1] + tolerance)
    return bool(same_x and overlap.all())


def _merged(old: RememberedBar, new: DetectedObstacle, now: float) -> DetectedObstacle:
    """``new`` with its extent along y grown to the union of ``old``'s and its own.

    Its ``points`` add ``old``'s when both were detected in this frame (at ``now``).
    """
    y = np.array([old.bounds()[1], RememberedBar(new, now).bounds()[1]])
    low, high = float(y[:, 0].min()), float(y[:, 1].max())
    center = np.array([new.center[0], 0.5 * (low + high), new.center[2]])
    points = new.points + (old.obstacle.points if old.last_seen == now else 0)
    return replace(new, center=center, extent=high - low, points=points)


def on_line(xy: np.ndarray, tolerance: float) -> np.ndarray:
    """(n,) True for the points (n, 2) within ``tolerance`` (m, along x) of their line.

    The line ``x = alpha + beta * y`` is what a scan plane cuts out of a bar along (or
    slanted to) y. It is fitted resistantly: through the medians (x and y) of the lower and
    of the upper half of the points in y (a pillar among the bar's returns moves it little),
    then by least squares on the points within ``tolerance`` of it. With fewer than three
    points every point is on it.
    """
    p = np.asarray(xy, dtype=float).reshape(-1, 2)
    if p.shape[0] < 3:
        return np.ones(p.shape[0], dtype=bool)
    x, y = p[:, 0], p[:, 1]
    low = y <= np.median(y)
    beta = 0.0
    if np.any(~low):
        dy = float(np.median(y[~low]) - np.median(y[low]))
        if dy > 1e-6:
            beta = float(np.median(x[~low]) - np.median(x[low])) / dy
    alpha = float(np.median(x - beta * y))
    near = np.abs(x - alpha - beta * y) <= tolerance
    if np.count_nonzero(near) >= 2 and float(np.ptp(y[near])) > 1e-6:
        beta, alpha = np.polyfit(y[near], x[near], 1)
    return np.abs(x - alpha - beta * y) <= tolerance


class BarMemory:
    """HORIZONTAL obstacles detected in past frames (see the module doc)."""

    def __init__(self) -> None:
        """An empty memory."""
        self._bars: list[RememberedBar] = []
        self._cells = np.zeros(0, dtype=np.int64)  # standing columns near bars (keys)
        self._cells_seen = np.zeros(0)  # stamp (s) each was last seen grounded

    def __len__(self) -> int:
        return len(self._bars)

    @property
    def bars(self) -> tuple[RememberedBar, ...]:
        """The remembered bars, most recently seen first."""
        return tuple(self._bars)

    def clear(self) -> None:
        """Forget every bar and standing column (a reset, a clock that went back)."""
        self._bars = []
        self._cells, self._cells_seen = np.zeros(0, dtype=np.int64), np.zeros(0)

    def update(
        self, fresh: list[DetectedObstacle], now: float, duration: float, tolerance: float,
        near: np.ndarray | None = None, keep_near: float = 0.0,
    ) -> None:
        """Forget old bars, remember ``fresh`` HORIZONTAL detections made at ``now`` (s).

        Args:
            fresh: this frame's HORIZONTAL obstacles (confirmed by the 3-D sensor).
            now: the frame's stamp (s).
            duration: ``bar_memory`` (s); 0 keeps only this frame's detections.
            tolerance: ``bar_memory_tolerance`` (m).
            near: x, y (m, odom) of the sensors in this frame, or None.
            keep_near: ``bar_memory_keep_near`` (m): a bar whose x-y box is within this of
                ``near`` is kept however old (see :meth:`_kept`).

        """
        self._bars = [b for b in self._bars if self._kept(b, now, duration, near, keep_near)]
        age = now - self._cells_seen
        live = (-duration <= age) & (age <= duration)
        self._cells, self._cells_seen = self._cells[live], self._cells_seen[live]
        for new in fresh:
            if new.plane != ObstaclePlane.HORIZONTAL:
                continue
            box = RememberedBar(new, now).bounds()
            grown = RememberedBar(new, now).bounds(tolerance)
            merged, kept = new, []
            for old in self._bars:
                centre = old.obstacle.center
                if _same_bar(old.bounds(), box, tolerance):
                    merged = _merged(old, merged, now)
                elif old.last_seen == now or not np.all(
                    (grown[:, 0] <= centre) & (centre <= grown[:, 1])
                ):
                    kept.append(old)  # not replaced by a piece cut elsewhere this time
            self._bars = [RememberedBar(merged, now), *kept]
        self._bars.sort(key=lambda b: -b.last_seen)
        del self._bars[MAX_REMEMBERED_BARS:]

    @staticmethod
    def _kept(bar: RememberedBar, now: float, duration: float, near: np.ndarray | None,
              keep_near: float) -> bool:
        """Whether ``bar`` is still remembered at ``now`` (s).

        Seen within ``duration``, or older but with the sensors within ``keep_near`` (m,
        x-y) of its box: close to a bar the forward sensor may no longer see it (above or
        before its view), and a robot that stopped there before a bar it cannot pass must
        not walk into it because the memory timed out. A stamp ahead by more than
        ``duration`` (the clock went back) forgets it; ``duration`` 0 remembers nothing.
        """
        age = now - bar.last_seen
        if duration <= 0.0:
            return age == 0.0
        if age < -duration:
            return False
        if age <= duration:
            return True
        if near is None:
            return False
        box = bar.bounds()[:2]
        gap = np.maximum(np.maximum(box[:, 0] - near, near - box[:, 1]), 0.0)
        return float(np.hypot(*gap)) <= keep_near

    def stand(
        self, points: np.ndarray, now: float, cell: float, tolerance: float, reach: float
    ) -> None:
        """Remember the columns of grounded ``points`` (n, 3) that rise into a bar's band.

        A grounded point counts when it lies within a remembered bar's x-y footprint grown by
        ``reach`` (m) and its z band grown by ``tolerance`` (m): something standing under or
        beside the bar, up to its height (the posts that hold it), not a low box under it.
        ``cell``: edge (m) of the columns' x-y cells (``column_cell``). They are forgotten
        with the bars (:meth:`update`).
        """
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        if not self._bars or p.shape[0] == 0:
            return
        box = np.stack([b.bounds(reach) for b in self._bars])  # (m, 3, 2)
        box[:, 2] = np.stack([b.bounds(tolerance)[2] for b in self._bars])
        q = p[:, None, :]
        near = np.all((box[None, :, :, 0] <= q) & (q <= box[None, :, :, 1]), axis=2).any(axis=1)
        keys = np.concatenate([self._cells, np.unique(_cell_keys(p[near, :2], cell))])
        seen = np.concatenate([self._cells_seen, np.full(keys.size - self._cells.size, now)])
        order = np.lexsort((-seen, keys))  # by key, the latest sighting first
        first = np.ones(order.size, dtype=bool)
        first[1:] = keys[order][1:] != keys[order][:-1]
        keep = order[first]
        keep = keep[np.argsort(-seen[keep], kind="stable")][:MAX_STANDING_CELLS]
        self._cells, self._cells_seen = keys[keep], seen[keep]

    def standing(self, xy: np.ndarray, cell: float) -> np.ndarray:
        """(n,) True for the points (n, 2) whose column (3 x 3 cells) was seen standing."""
        p = np.asarray(xy, dtype=float).reshape(-1, 2)
        out = np.zeros(p.shape[0], dtype=bool)
        if self._cells.size == 0 or p.shape[0] == 0:
            return out
        keys = _cell_keys(p, cell)
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                out |= np.isin(keys + di * 2**32 + dj, self._cells)
        return out

    def absorb(
        self,
        points: np.ndarray,
        candidate: np.ndarray,
        anchor: np.ndarray,
        tolerance: float,
        guard: float,
        cell: float,
    ) -> np.ndarray:
        """(n,) index of the remembered bar each point is attributed to, -1 for none.

        Args:
            points: (n, 3) candidate points of the frame (odom, m).
            candidate: (n,) True for the points that may be absorbed: VERTICAL so far and
                not grounded.
            anchor: (n,) True for the VERTICAL points that stay VERTICAL whatever the memory
                (grounded ones); a candidate outside every volume becomes one too.
            tolerance: growth of the bars' volumes (m).
            guard: no point within this (m, x-y) of an anchor is absorbed.
            cell: edge (m) of the columns' cells; a point whose column was seen standing
                (:meth:`stand`) is an anchor.

        """
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        out = np.full(p.shape[0], -1, dtype=np.int64)
        chosen = np.flatnonzero(candidate)
        if not self._bars or chosen.size == 0:
            return out
        box = np.stack([b.bounds(tolerance) for b in self._bars])  # (m, 3, 2)
        q = p[chosen, None, :]
        inside = np.all((box[None, :, :, 0] <= q) & (q <= box[None, :, :, 1]), axis=2)
        hit = inside.any(axis=1) & ~self.standing(p[chosen, :2], cell)  # (k,)
        owner = np.argmax(inside, axis=1)
        for j in np.unique(owner[hit]):  # each bar's returns lie on its cut by the scan plane
            mine = np.flatnonzero(hit & (owner == j))
            hit[mine] = on_line(p[chosen[mine], :2], tolerance)
        anchors = np.concatenate([np.flatnonzero(anchor), chosen[~hit]])
        if anchors.size and np.any(hit):
            near, _ = cKDTree(p[anchors, :2]).query(
                p[chosen[hit], :2], distance_upper_bound=guard
            )
            hit[np.flatnonzero(hit)[np.isfinite(near)]] = False
        out[chosen[hit]] = owner[hit]
        return out

    def obstacles(self, now: float, absorbed: np.ndarray) -> list[DetectedObstacle]:
        """Every remembered bar as a HORIZONTAL obstacle, as of the frame at ``now`` (s).

        ``absorbed``: (len(self),) points each bar absorbed in this frame. A bar's
        ``points`` are those, plus its fresh detection's returns when seen at ``now``.
        """
        counts = np.asarray(absorbed, dtype=np.int64)
        return [
            replace(b.obstacle, points=int(n) + (b.obstacle.points if b.last_seen == now else 0))
            for b, n in zip(self._bars, counts, strict=True)
        ]
