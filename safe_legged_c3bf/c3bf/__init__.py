"""C3BF core: collision-cone control barrier functions and the safety-filter QP.

Pure numpy/scipy/osqp/daqp (no rclpy). SI units, odom frame, REP-103 (x forward, z up).
See ``doc/c3bf_api.md`` for the API and an example.
"""

from .barrier import DEFAULT_V_EPS, c3bf_gradient, c3bf_value, regularized_speed
from .body import BodyPoint, RobotBody, robot_body
from .errors import InvalidInputError
from .filter import SafetyFilter, cbf_closed_form
from .geometry import EllipseObstacle, Obstacles, Plane, inflated_radius
from .lateral_models import UnicycleLateralHeightModel, UnicycleLateralModel
from .lie import PLANE_AXES, BarrierTerms, barrier_terms, c3bf_lie_derivatives
from .models import (
    HolonomicHeightModel,
    HolonomicModel,
    PointKinematics,
    RobotModel,
    UnicycleHeightModel,
    UnicycleModel,
    XZDoubleIntegratorModel,
)
from .result import FilterResult, FilterStatus

__all__ = [
    "DEFAULT_V_EPS",
    "PLANE_AXES",
    "BarrierTerms",
    "BodyPoint",
    "EllipseObstacle",
    "FilterResult",
    "FilterStatus",
    "HolonomicHeightModel",
    "HolonomicModel",
    "InvalidInputError",
    "Obstacles",
    "Plane",
    "PointKinematics",
    "RobotBody",
    "RobotModel",
    "SafetyFilter",
    "UnicycleHeightModel",
    "UnicycleLateralHeightModel",
    "UnicycleLateralModel",
    "UnicycleModel",
    "XZDoubleIntegratorModel",
    "barrier_terms",
    "c3bf_gradient",
    "c3bf_lie_derivatives",
    "c3bf_value",
    "cbf_closed_form",
    "inflated_radius",
    "regularized_speed",
    "robot_body",
]
