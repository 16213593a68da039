"""Registry of gait controllers by robot kind (no ROS).

The gait controller node builds its controller here, so adding a robot touches one place.
"""

from __future__ import annotations

from safe_legged_c3bf.interfaces.gait_controller import GaitController


def make_gait_controller(robot: str, config_file: str | None = None) -> GaitController:
    """Build the gait controller for ``robot`` ('quadruped'/'a1' or 'biped').

    Args:
        robot: robot kind.
        config_file: optional YAML with controller parameters (default: the package's
            ``config/<kind>_controller.yaml``).

    """
    if robot in ("quadruped", "a1"):
        from safe_legged_c3bf.gait.quadruped.controller import QuadrupedMpcController

        return QuadrupedMpcController.from_config(config_file)
    if robot == "biped":
        from safe_legged_c3bf.gait.biped.controller import BipedZmpController

        return BipedZmpController.from_config(config_file)
    raise ValueError(f"unknown robot '{robot}': expected 'quadruped' or 'biped'")
