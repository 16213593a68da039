"""Shapes of clusters: the ellipses of Obstacle.msg fitted to points (no ROS).

A range sensor sees only the near side of an obstacle, so every fit says what it assumes of
the far side:

* **Vertical, round** (pillars, people): a geometric circle fit (Gauss-Newton on the
  distances to the circle, started from the algebraic Kasa fit) puts the centre behind the
  visible arc. It is used when the radius is at most ``circle_max_radius``, the RMS distance
  to the circle at most ``circle_max_rms``, the points cover at least ``circle_min_arc`` of
  it and the centre lies on the far side of the points. The radius grows to the farthest
  point.
* **Vertical, compact** (other shapes up to ``max_piece_length`` long): the points are
  mirrored about the plane through their farthest point across the viewing direction (the
  object is assumed as deep as twice what is seen of it), then the enclosing ellipse of the
  principal-axes bounding box is taken (the box's ellipse scaled until every point is in).
* **Vertical, elongated** (walls, benches): split along the major axis into pieces of at
  most ``max_piece_length``, cut on lines fixed in odom (x = k c, or y = k c when the axis is
  nearer y; c = ``max_piece_length`` / sqrt 2) so that the pieces stay put from frame to frame
  whatever the fitted axis (recursively, so that an L-shaped wall follows its legs); each
  piece is the enclosing ellipse of the box that spans its whole interval along the cut axis
  (consecutive pieces meet even where the returns are sparse) and its points across it,
  without mirroring (the depth of a wall behind its face is unknown; the face is what the
  robot can hit).
* **Horizontal** (bars, table edges): an ellipse in x-z, axis-aligned (a along x, b along
  z), whose lowest point is the underside the robot ducks under: the highest height the
  detector saw free beneath the cluster (``free_space.py``), never above the lowest return.
  The depth along x is mirrored like a compact cluster's. The extent is the span along odom
  y. A cluster deeper along x than ``max_piece_length`` (a bar across the path at an angle)
  is split into pieces along y.

Vertical obstacles stand on the ground: centre z is half the height of the highest return
and the extent is that height (a scan-only obstacle reaches at least up to its scan plane).

Covariances (m^2, odom x y z): for a circle, the Gauss-Newton covariance of its centre; for
the other fits, the standard error of the points' mean per principal axis plus, along the
viewing direction, (depth / 4)^2 for the mirrored far side, and along a wall piece's axis
(max_piece_length / 4)^2 for each end where the returns stop instead of a cut (its centre
moves as more of the wall comes into view). ``position_std^2`` is added to every axis. The
tracker can weigh each detection by it (``TrackConfig.use_detection_covariance``, off: it
measured no gain).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from safe_legged_c3bf.perception.detector_config import DetectorConfig
from safe_legged_c3bf.perception.track import ObstaclePlane

__all__ = [
    "DetectedObstacle", "Ellipse2D", "Piece", "enclosing_ellipse", "fit_circle",
    "fit_horizontal", "fit_vertical", "split_pieces",
]

#: Obstacle.msg VELOCITY_UNKNOWN: a raw detection has no velocity.
VELOCITY_UNKNOWN = 0
#: Deepest recursion when splitting an elongated cluster into pieces.
MAX_SPLIT_DEPTH = 4


@dataclass(frozen=True)
class DetectedObstacle:
    """One detected obstacle, as Obstacle.msg carries it (odom frame, SI units).

    Attributes:
        plane: ObstaclePlane.VERTICAL (ellipse in x-y) or HORIZONTAL (ellipse in x-z).
        center: (3,) centre of the elliptic cylinder (m).
        semi_axes: (a, b) semi-axes in the ellipse's plane (m).
        orientation: angle of axis a from odom x within the plane (rad).
        extent: length along the extrusion axis, z or y (m).
        position_covariance: (3, 3) covariance of ``center`` (m^2).
        points: how many returns the fit used.
        id: always empty (the tracker gives ids).
        velocity: zeros (m/s): a detection does not observe velocity.
        velocity_covariance: zeros (m^2/s^2).
        velocity_source: VELOCITY_UNKNOWN.

    """

    plane: ObstaclePlane
    center: np.ndarray
    semi_axes: tuple[float, float]
    orientation: float
    extent: float
    position_covariance: np.ndarray
    points: int
    id: str = ""
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    velocity_covariance: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    velocity_source: int = VELOCITY_UNKNOWN


@dataclass(frozen=True)
class Ellipse2D:
    """A planar fit: centre (2,), semi-axes, orientation of a (rad), covariance (2, 2)."""

    center: np.ndarray
    semi_axes: tuple[float, float]
    orientation: float
    covariance: np.ndarray


def _principal_axes(xy: np.ndarray) -> np.ndarray:
    """(2, 2) columns: the major then the minor principal axis of the points."""
    if xy.shape[0] < 2:
        return np.eye(2)
    _, vectors = np.linalg.eigh(np.cov(xy.T))
    return vectors[:, ::-1]


def _wrap_half(angle: float) -> float:
    """Angle of an undirected axis, wrapped to [-pi/2, pi/2)."""
    return (angle + 0.5 * math.pi) % math.pi - 0.5 * math.pi


def fit_circle(xy: np.ndarray, viewpoint: np.ndarray, config: DetectorConfig) -> Ellipse2D | None:
    """A circle through the points (n, 2) seen from ``viewpoint`` (2,), or None (module doc)."""
    n = xy.shape[0]
    if n < 5:
        return None
    mean = xy.mean(axis=0)
    u = xy - mean
    A = np.column_stack([u, np.ones(n)])
    sol, _, rank, _ = np.linalg.lstsq(A, -(u * u).sum(axis=1), rcond=None)
    r2 = 0.25 * (sol[0] ** 2 + sol[1] ** 2) - sol[2]
    if rank < 3 or not r2 > 0.0:
        return None
    c, radius = -0.5 * sol[:2], math.sqrt(r2)
    for _ in range(5):  # Gauss-Newton on the geometric distances
        diff = u - c
        dist = np.maximum(np.hypot(diff[:, 0], diff[:, 1]), 1e-9)
        J = np.column_stack([-diff / dist[:, None], -np.ones(n)])
        step, *_ = np.linalg.lstsq(J, -(dist - radius), rcond=None)
        c, radius = c + step[:2], radius + step[2]
    diff = u - c
    dist = np.hypot(diff[:, 0], diff[:, 1])
    resid = dist - radius
    rms = math.sqrt(float(np.mean(resid**2)))
    angles = np.sort(np.arctan2(diff[:, 1], diff[:, 0]))
    gaps = np.diff(np.concatenate([angles, angles[:1] + 2.0 * math.pi]))
    arc = 2.0 * math.pi - float(gaps.max())
    behind = float(np.dot(c, mean - viewpoint)) > 0.0  # centre beyond the points
    if not (0.0 < radius <= config.circle_max_radius and rms <= config.circle_max_rms
            and arc >= config.circle_min_arc and behind):
        return None
    J = np.column_stack([-diff / np.maximum(dist, 1e-9)[:, None], -np.ones(n)])
    sigma2 = float(resid @ resid) / max(n - 3, 1)
    try:
        cov = sigma2 * np.linalg.inv(J.T @ J)[:2, :2]
    except np.linalg.LinAlgError:
        return None
    r = max(radius, float(dist.max())) + config.size_margin
    floor = config.position_std**2 * np.eye(2)
    return Ellipse2D(mean + c, (r, r), 0.0, cov + floor)


@dataclass(frozen=True)
class Piece:
    """Part of an elongated cluster: its points and its interval along an axis.

    Attributes:
        index: indices of the piece's points in the cluster.
        axis: (2,) unit axis along which the cluster was cut (x-y).
        low, high: the piece's interval along ``axis`` (m, as ``xy @ axis``).
        open_low, open_high: that end is where the returns stop (the wall's end, an
            occlusion, the edge of the view), not a cut: it moves as more is seen.

    """

    index: np.ndarray
    axis: np.ndarray
    low: float
    high: float
    open_low: bool = True
    open_high: bool = True


def enclosing_ellipse(
    xy: np.ndarray,
    config: DetectorConfig,
    view: np.ndarray | None = None,
    piece: Piece | None = None,
) -> Ellipse2D:
    """Enclosing ellipse of the points (n, 2) of a bounding box in principal axes.

    ``view``: unit viewing direction (2,); the points are mirrored along it first (module
    doc). ``piece``: the box spans the piece's interval along its axis instead of the points'
    own range, so that consecutive pieces of a wall meet.
    """
    n = xy.shape[0]
    pts, extra = xy, np.zeros((2, 2))
    if view is not None and n > 0:
        depth = xy @ view
        far = float(depth.max())
        pts = np.vstack([xy, xy + 2.0 * (far - depth)[:, None] * view])
        extra = (0.25 * float(far - depth.min())) ** 2 * np.outer(view, view)
    if piece is None:
        axes = _principal_axes(pts)
    else:
        axes = np.column_stack([piece.axis, [-piece.axis[1], piece.axis[0]]])
    local = pts @ axes
    lo, hi = local.min(axis=0), local.max(axis=0)
    if piece is not None:
        lo[0], hi[0] = piece.low, piece.high
    mid = 0.5 * (lo + hi)
    half = np.maximum(0.5 * (hi - lo), config.min_semi_axis)
    scale = max(1.0, float(np.sqrt((((local - mid) / half) ** 2).sum(axis=1)).max()))
    a, b = scale * half + config.size_margin
    orientation = math.atan2(axes[1, 0], axes[0, 0])
    if b > a:
        a, b, orientation = b, a, orientation + 0.5 * math.pi
    spread = np.cov(xy.T) / n if n > 1 else np.zeros((2, 2))
    if piece is not None:
        extra = _open_end_variance(piece, config.max_piece_length)
    cov = spread + extra + config.position_std**2 * np.eye(2)
    return Ellipse2D(axes @ mid, (float(a), float(b)), _wrap_half(orientation), cov)


def _open_end_variance(piece: Piece, cell: float) -> np.ndarray:
    """(2, 2) variance (m^2) of a piece's centre along its axis from its open ends.

    A cut end stays put; an end where the returns stop (the wall's end, an occlusion, the
    edge of the field of view) may move anywhere within its cell (``cell``, m) as the robot
    sees more or less of the wall, and the centre with half of it: (cell / 4)^2 per open end.
    """
    open_ends = int(piece.open_low) + int(piece.open_high)
    return open_ends * (0.25 * cell) ** 2 * np.outer(piece.axis, piece.axis)


def split_pieces(xy: np.ndarray, max_length: float, depth: int = 0) -> list[Piece]:
    """Pieces at most ``max_length`` (m) long along the major axis, cut on a grid fixed in odom.

    The cuts are the lines x = k c (y = k c when the major axis is nearer y than x), k an
    integer, c = ``max_length`` / sqrt 2: between two of them a straight wall is at most
    c / cos 45 deg = ``max_length`` long. The lines do not depend on the fitted axis, so as
    the robot walks along a wall and sees more or less of it, and as the axis fitted to a
    partly seen cluster turns with the returns' noise, only the end pieces change and the
    tracker keeps its tracks of the others (cuts at multiples along the fitted axis moved by
    the distance from the odom origin times the axis' error: 0.2 rad at 1.2 m swapped a
    bench's pieces between frames and gave their tracks phantom speeds, #19). A piece still
    longer along its own major axis (a corner) is cut again the same way.
    """
    n = xy.shape[0]
    axis = _principal_axes(xy)[:, 0]
    s = xy @ axis
    lo, hi = (float(s.min()), float(s.max())) if n else (0.0, 0.0)
    if n < 2 or hi - lo <= max_length or depth >= MAX_SPLIT_DEPTH:
        return [Piece(np.arange(n), axis, lo, hi)]
    dim = 0 if abs(axis[0]) >= abs(axis[1]) else 1
    spacing = max_length / math.sqrt(2.0)
    cell = np.floor(xy[:, dim] / spacing).astype(np.int64)
    normal = np.array([-axis[1], axis[0]])
    offset = float(np.mean(xy @ normal)) * normal[dim]  # x (or y) of the mid-line at s = 0
    out: list[Piece] = []
    for k in np.unique(cell):  # a few pieces, each handled whole
        members = np.flatnonzero(cell == k)
        # where the two cut lines cross the cluster's mid-line, along the axis
        a, b = sorted(((k + j) * spacing - offset) / axis[dim] for j in (0, 1))
        sub = split_pieces(xy[members], max_length, depth + 1)
        if len(sub) == 1:
            out.append(Piece(members, axis, float(max(a, lo)), float(min(b, hi)),
                             bool(a <= lo), bool(b >= hi)))
        else:
            out.extend(Piece(members[p.index], p.axis, p.low, p.high, p.open_low, p.open_high)
                       for p in sub)
    return out


def _vertical(fit: Ellipse2D, top: float, n: int, config: DetectorConfig) -> DetectedObstacle:
    height = max(top, config.ground_height)
    cov = np.zeros((3, 3))
    cov[:2, :2] = fit.covariance
    cov[2, 2] = config.position_std**2
    center = np.array([fit.center[0], fit.center[1], 0.5 * height])
    return DetectedObstacle(
        ObstaclePlane.VERTICAL, center, fit.semi_axes, fit.orientation, height, cov, n
    )


def fit_vertical(
    points: np.ndarray, viewpoint: np.ndarray, config: DetectorConfig
) -> list[DetectedObstacle]:
    """Vertical obstacles (one, or pieces) from a cluster (n, 3) seen from ``viewpoint``.

    Args:
        points: the cluster's returns in odom (m).
        viewpoint: (2,) x, y of the sensors that saw them (odom, m).
        config: shape parameters.

    """
    xy = np.asarray(points, dtype=float)[:, :2]
    top = float(np.max(points[:, 2]))
    vp = np.asarray(viewpoint, dtype=float).reshape(-1)[:2]
    circle = fit_circle(xy, vp, config)
    if circle is not None:
        return [_vertical(circle, top, xy.shape[0], config)]
    s = xy @ _principal_axes(xy)[:, 0]
    if float(s.max() - s.min()) > config.max_piece_length:
        out = []
        for piece in split_pieces(xy, config.max_piece_length):
            fit = enclosing_ellipse(xy[piece.index], config, piece=piece)
            top_piece = float(points[piece.index, 2].max())
            out.append(_vertical(fit, top_piece, piece.index.size, config))
        return out
    to_cluster = xy.mean(axis=0) - vp
    norm = float(np.hypot(*to_cluster))
    view = to_cluster / norm if norm > 1e-6 else None
    return [_vertical(enclosing_ellipse(xy, config, view), top, xy.shape[0], config)]


def _horizontal_piece(
    points: np.ndarray, viewpoint_x: float, config: DetectorConfig, underside: float
) -> DetectedObstacle:
    """One x-z ellipse extruded along y, its lowest point at ``underside`` (m, odom)."""
    x, y, z = points[:, 0], points[:, 1], points[:, 2]
    near, far = float(x.min()), float(x.max())
    depth = far - near
    if x.mean() >= viewpoint_x:  # seen from -x: the unseen side is at +x
        far += depth
    else:
        near -= depth
    # No size margin on the depth (x): the filter covers a bar's x-z ellipse with one circle of
    # its larger semi-axis, so 2 cm more depth would lower a round bar by 2 cm and close a
    # passage the robot ducks through (quadruped_horizontal stalled at it); the filter's own
    # safety_margin grows the bar, and the underside already errs low (free_space.underside).
    a = max(0.5 * (far - near), config.min_semi_axis)
    bottom = min(float(z.min()), underside) if math.isfinite(underside) else float(z.min())
    b = max(0.5 * (float(z.max()) - bottom), config.min_semi_axis)
    extent = max(float(y.max() - y.min()) + 2.0 * config.size_margin, 2.0 * config.min_semi_axis)
    center = np.array([0.5 * (near + far), 0.5 * float(y.max() + y.min()), bottom + b])
    floor = config.position_std**2
    cov = np.diag([floor + (0.25 * depth) ** 2, floor, floor])
    return DetectedObstacle(
        ObstaclePlane.HORIZONTAL, center, (a, b), 0.0, extent, cov, points.shape[0]
    )


def fit_horizontal(
    points: np.ndarray,
    viewpoint: np.ndarray,
    config: DetectorConfig,
    underside: float = math.nan,
) -> list[DetectedObstacle]:
    """Horizontal obstacles (one, or pieces along y) from a floating cluster (n, 3), odom m.

    ``viewpoint`` (2 or 3,) is where the sensors were (odom, m): its x tells the seen side.
    ``underside`` (m, odom): the ellipses' lowest point; the lowest return when NaN or
    higher than it.
    """
    p = np.asarray(points, dtype=float)
    vx = float(np.asarray(viewpoint, dtype=float).reshape(-1)[0])
    x_span = float(p[:, 0].max() - p[:, 0].min())
    if x_span <= config.max_piece_length:
        return [_horizontal_piece(p, vx, config, underside)]
    k = math.ceil(x_span / config.max_piece_length)
    y = p[:, 1]
    y_span = max(float(y.max() - y.min()), 1e-9)
    piece = np.minimum(((y - y.min()) / y_span * k).astype(np.int64), k - 1)
    return [_horizontal_piece(p[piece == j], vx, config, underside) for j in np.unique(piece)]
