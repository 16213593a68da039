"""The tracker's and the filter's parameters follow where obstacles come from: config/sensors/
is layered on config/<node>.yaml when the obstacle detector feeds them (sensors, deploy)."""

from __future__ import annotations

from safe_legged_c3bf.bringup import build_parser
from safe_legged_c3bf.run.deploy import deploy_specs
from safe_legged_c3bf.run.parameters import config_files, merged_parameters
from safe_legged_c3bf.run.plan import make_plan
from safe_legged_c3bf.run.supervisor import NodeSpec


def _tracker(files) -> dict:
    return merged_parameters(NodeSpec(name="obstacle_tracker", module="m", params_files=files))


def test_the_sensors_layer_comes_after_the_nodes_own_file():
    oracle = config_files("obstacle_tracker")
    sensors = config_files("obstacle_tracker", "sensors")
    assert [p.name for p in oracle] == ["obstacle_tracker.yaml"]
    assert sensors[0] == oracle[0]
    assert sensors[1].parent.name == "sensors" and sensors[1].name == "obstacle_tracker.yaml"
    assert config_files("gait_controller", "sensors") == config_files("gait_controller")


def test_with_sensors_the_filter_judges_bars_only_near_the_robot():
    def merged(files):
        return merged_parameters(NodeSpec(name="safety_filter", module="m", params_files=files))

    assert merged(config_files("safety_filter"))["bar_wall_range"] == 0.0
    assert merged(config_files("safety_filter", "sensors"))["bar_wall_range"] == 1.0


def test_the_manoeuvre_detector_is_on_for_both_sources():
    """On with sensors too since session 17 (config/sensors/obstacle_tracker.yaml says why)."""
    oracle = _tracker(config_files("obstacle_tracker"))
    sensors = _tracker(config_files("obstacle_tracker", "sensors"))
    assert oracle["maneuver_detection"] is True and oracle["accel_psd"] == 0.0001
    assert sensors["maneuver_detection"] is True and sensors["accel_psd"] == 0.0001


def test_a_sensors_run_and_deploy_mode_give_the_nodes_the_sensors_layer(tmp_path):
    sensors = make_plan(build_parser().parse_args(
        ["--perception", "sensors", "--out", str(tmp_path / "s")]))
    oracle = make_plan(build_parser().parse_args(["--out", str(tmp_path / "o")]))
    deploy = {s.name: s for s in deploy_specs(build_parser().parse_args(["--deploy"]))}
    layer = config_files("obstacle_tracker", "sensors")[-1]
    assert layer in sensors.spec("obstacle_tracker").params_files
    assert layer in deploy["obstacle_tracker"].params_files
    assert layer not in oracle.spec("obstacle_tracker").params_files
    assert merged_parameters(sensors.spec("safety_filter"))["bar_wall_range"] == 1.0
    assert merged_parameters(deploy["safety_filter"])["bar_wall_range"] == 1.0
    assert merged_parameters(oracle.spec("safety_filter"))["bar_wall_range"] == 0.0


def test_a_replays_params_files_reach_the_pipeline_built_in_process(tmp_path):
    """The replay builds its pipeline in this process: the user's files must win there too."""
    from safe_legged_c3bf.replay.run import pipeline_parameters

    mine = tmp_path / "mine.yaml"
    mine.write_text("obstacle_tracker:\n  ros__parameters:\n    maneuver_detection: false\n"
                    "obstacle_detector:\n  ros__parameters:\n    cloud_row_spacing: 0.045\n")
    _, merged = pipeline_parameters("quadruped", [mine])
    assert merged["obstacle_tracker"]["maneuver_detection"] is False
    assert merged["obstacle_detector"]["cloud_row_spacing"] == 0.045
    _, plain = pipeline_parameters("quadruped")
    assert plain["obstacle_tracker"]["maneuver_detection"] is True
    assert plain["obstacle_detector"]["cloud_row_spacing"] != 0.045


def test_scan_clearing_is_on_with_sensors_and_the_tracker_gets_the_robots_lidar(tmp_path):
    """The tracker reads /scan with sensors (config/sensors/obstacle_tracker.yaml says why)."""
    assert _tracker(config_files("obstacle_tracker"))["scan_clearing"] is False
    assert _tracker(config_files("obstacle_tracker", "sensors"))["scan_clearing"] is True
    biped = make_plan(build_parser().parse_args(
        ["--perception", "sensors", "--scenario", "biped_default", "--out", str(tmp_path / "b")]))
    assert merged_parameters(biped.spec("obstacle_tracker"))["robot_kind"] == "biped"
    deploy = {s.name: s for s in deploy_specs(build_parser().parse_args(
        ["--deploy", "--robot", "biped"]))}
    merged = merged_parameters(deploy["obstacle_tracker"])
    assert merged["robot_kind"] == "biped" and merged["scan_clearing"] is True
