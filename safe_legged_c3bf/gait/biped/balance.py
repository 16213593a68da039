"""Balance on the stance feet: ZMP preview reference and DCM tracking (ankle strategy).

The ZMP preview controller (Kajita 2003, :mod:`lipm_preview`) turns the ZMP reference into a
reference CoM, ZMP and DCM. The measured DCM is driven to the reference by the ZMP the stance
feet produce: desired ZMP = preview ZMP + (1 + k / omega) (DCM error), clipped to the support
polygon of the stance soles. At a touchdown the reference is re-anchored on the measured CoM
state when the DCM error has grown beyond ``reference_reset``. All in odom (REP-103; m, s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.gait.biped.footstep_planner import Footstep, clip_to_polygon, convex_hull
from safe_legged_c3bf.gait.biped.lipm_preview import ZmpPreviewController
from safe_legged_c3bf.gait.biped.model import FootGeometry
from safe_legged_c3bf.gait.biped.params import FeedbackGains, GaitParams
from safe_legged_c3bf.gait.biped.state_estimate import BipedEstimate

_CORNER_SIGNS = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float)


@dataclass(frozen=True)
class PreviewReference:
    """The preview model's state after this tick (odom, each (2,)).

    Attributes:
        com: reference CoM (m).
        zmp: the model's ZMP (m).
        dcm: reference DCM com + com_velocity / omega (m).

    """

    com: np.ndarray
    zmp: np.ndarray
    dcm: np.ndarray


class SupportPolygon:
    """Convex hull of the stance soles, cached while the feet stay (to the mm and mrad)."""

    def __init__(self, foot: FootGeometry) -> None:
        """Polygons of soles of size ``foot``."""
        self._center = np.array(foot.center)
        self._half = foot.half_size
        self.reset()

    def reset(self) -> None:
        """Forget the cached polygon."""
        self._cache: tuple | None = None

    def of(self, stance: list[Footstep], margin: float) -> np.ndarray:
        """Counter-clockwise polygon (k, 2) of the ``stance`` soles shrunk by ``margin`` (m)."""
        key = (tuple(f.side for f in stance), margin) + tuple(
            round(v, 3) for f in stance for v in (f.x, f.y, f.yaw)
        )
        if self._cache is not None and self._cache[0] == key:
            return self._cache[1]
        half = np.maximum(self._half - margin, 1e-3)
        corners = self._center + _CORNER_SIGNS * half
        pts = []
        for fs in stance:
            pts.extend(fs.to_world(c) for c in corners)
        polygon = convex_hull(np.array(pts))
        self._cache = (key, polygon)
        return polygon


class Balance:
    """ZMP preview reference and the desired ZMP of the stance feet."""

    def __init__(self, gait: GaitParams, feedback: FeedbackGains, foot: FootGeometry) -> None:
        """Preview over ``gait.preview_horizon`` with the LIPM at ``gait.com_height``."""
        self.preview = ZmpPreviewController(
            gait.control_period,
            gait.com_height,
            gait.preview_horizon,
            q_e=gait.preview_q_e,
            r=gait.preview_r,
        )
        #: LIPM natural frequency sqrt(g / z_c) (1/s)
        self.omega = self.preview.omega
        self.feedback = feedback
        self.support = SupportPolygon(foot)

    def reset(self, com: np.ndarray) -> None:
        """Restart the preview model at rest at the CoM position ``com`` (2,)."""
        self.preview.reset(com)
        self.support.reset()

    def reanchor(self, estimate: BipedEstimate, zmp_start: np.ndarray) -> None:
        """Restart the preview from the measured CoM if its DCM drifted from the reference.

        After a push, a slip or an adjusted step the preview then plans from the measured CoM
        state, with the ZMP at ``zmp_start`` (2,).
        """
        fb = self.feedback
        err = estimate.dcm - self.preview.dcm
        if fb.reference_reset > 0.0 and math.hypot(err[0], err[1]) > fb.reference_reset:
            com, vel = estimate.com[:2], estimate.com_velocity[:2]
            self.preview.reset(com, vel, self.omega**2 * (com - zmp_start))

    def follow(self, zmp_reference: np.ndarray, n_ticks: int) -> PreviewReference:
        """Advance the preview ``n_ticks`` ticks along ``zmp_reference`` (n_preview + 1, 2)."""
        for _ in range(n_ticks):
            self.preview.step(zmp_reference)
        state = self.preview.state.copy()
        return PreviewReference(state[0], self.preview.zmp, state[0] + state[1] / self.omega)

    def desired_zmp(
        self, dcm: np.ndarray, reference: PreviewReference, stance: list[Footstep]
    ) -> tuple[np.ndarray, np.ndarray]:
        """ZMP (2,) the ``stance`` feet must produce, and the DCM error (2,) it corrects.

        ``dcm`` (2,) is the measured DCM; the ZMP is kept ``support_margin`` inside the soles.
        """
        fb = self.feedback
        dcm_error = dcm - reference.dcm
        zmp = reference.zmp + (1.0 + fb.dcm_gain / self.omega) * dcm_error
        return clip_to_polygon(zmp, self.support.of(stance, fb.support_margin)), dcm_error
