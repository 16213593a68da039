"""Parameters of the biped controller: defaults, validation, YAML and ROS-style loading."""

import os

import pytest

from safe_legged_c3bf.gait.biped.params import BipedParams, CommandLimits, FeedbackGains, GaitParams

CONFIG = os.path.join(os.path.dirname(os.path.dirname(__file__)), "config", "biped_controller.yaml")


def test_defaults_are_valid():
    params = BipedParams()
    params.validate()
    assert params.gait.step_period == pytest.approx(0.52)


def test_config_file_holds_the_defaults():
    assert BipedParams.from_yaml(CONFIG) == BipedParams()
    # relative names are looked up in the package's config directory
    assert BipedParams.from_yaml("biped_controller.yaml") == BipedParams()


def test_controller_from_config():
    from safe_legged_c3bf.gait.biped.controller import BipedZmpController
    from safe_legged_c3bf.gait.factory import make_gait_controller

    assert BipedZmpController.from_config().params == BipedParams()
    assert isinstance(make_gait_controller("biped"), BipedZmpController)


def test_from_dict_and_flat_names():
    params = BipedParams.from_dict(
        {"gait": {"step_height": 0.04}, "gains": {"stance_kp": {"knee": 500.0}}}
    )
    assert params.gait.step_height == 0.04
    assert params.gains.stance_kp["knee"] == 500.0
    assert params.gains.stance_kp["hip_pitch"] == BipedParams().gains.stance_kp["hip_pitch"]
    flat = BipedParams.from_flat({"biped.gait.step_height": 0.04, "feedback.dcm_gain": 2.0})
    assert flat.gait.step_height == 0.04 and flat.feedback.dcm_gain == 2.0


def test_unknown_keys_are_rejected():
    with pytest.raises(ValueError):
        BipedParams.from_dict({"gait": {"step_hieght": 0.04}})
    with pytest.raises(ValueError):
        BipedParams.from_dict({"gate": {}})


@pytest.mark.parametrize(
    "kwargs",
    [
        {"gait": GaitParams(control_period=0.0)},
        {"gait": GaitParams(step_height=-0.01)},
        {"gait": GaitParams(swing_lift_fraction=0.9, swing_land_fraction=0.5)},
        {"feedback": FeedbackGains(dcm_gain=-1.0)},
        {"command": CommandLimits(vx_max=0.5)},  # longer steps than the step limits allow
        {"command": CommandLimits(yaw_rate_max=1.0)},
    ],
)
def test_invalid_values_raise(kwargs):
    with pytest.raises(ValueError):
        BipedParams(**kwargs)


def test_command_clipping():
    limits = CommandLimits()
    clipped = limits.clip(1.0, -1.0, float("nan"))
    assert clipped.tolist() == [limits.vx_max, -limits.vy_max, 0.0]
