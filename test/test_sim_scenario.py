"""Scenario files: lookup by name or path, validation messages naming the bad field."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from safe_legged_c3bf.sim.scenario import (
    DepthConfig,
    LidarConfig,
    Scenario,
    ScenarioError,
    available_scenarios,
    load_scenario,
    parse_scenario,
    resolve_scenario,
)

BASE = {
    "robot": {"kind": "quadruped"},
    "goal": {"position": [3.0, 0.0]},
    "duration": 1.0,
    "obstacles": [
        {"id": "a", "position": [1.0, 1.0], "semi_axes": [0.2, 0.1]},
        {"id": "b", "position": [2.0, -1.0], "semi_axes": [0.3, 0.3]},
    ],
}


AXES_MESSAGE = "obstacles[1].semi_axes: must be two positive numbers"


def _with(path: str, value):
    """BASE with one field replaced; ``path`` like 'obstacles.1.semi_axes'."""
    data = yaml.safe_load(yaml.safe_dump(BASE))
    node = data
    keys = path.split(".")
    for key in keys[:-1]:
        node = node[int(key)] if key.isdigit() else node.setdefault(key, {})
    last = keys[-1]
    if last.isdigit():
        node[int(last)] = value
    else:
        node[last] = value
    return data


def test_packaged_scenarios_load_by_name():
    names = available_scenarios()
    assert "quadruped_default" in names and "test_minimal" in names
    for name in names:
        assert isinstance(load_scenario(name), Scenario)


def test_quadruped_default_content():
    sc = load_scenario("quadruped_default")
    assert sc.robot.kind == "quadruped" and sc.robot.position == (0.0, 0.0) and sc.robot.yaw == 0.0
    assert 6.0 <= math.dist(sc.goal.position, sc.robot.position) <= 8.0
    static = [o for o in sc.obstacles if o.motion.type == "static"]
    moving = [o for o in sc.obstacles if o.motion.type != "static"]
    assert static and moving
    for obs in sc.obstacles:  # between start and goal along x
        assert 0.0 < obs.position[0] < sc.goal.position[0]
    assert sc.planner.mode == "goal"


def test_lookup_by_path(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text(yaml.safe_dump(BASE))
    sc = load_scenario(str(path))
    assert sc.name == "mine" and sc.source == str(path.resolve())
    assert [o.id for o in sc.obstacles] == ["a", "b"]
    # Vertical obstacles stand on the ground by default.
    assert sc.obstacles[0].position[2] == pytest.approx(sc.obstacles[0].extent / 2)


def test_unknown_name_lists_known():
    with pytest.raises(ScenarioError, match="quadruped_default"):
        resolve_scenario("no_such_scenario")


@pytest.mark.parametrize(
    ("path", "value", "message"),
    [
        ("obstacles.1.semi_axes", [0.2, -1.0], AXES_MESSAGE),
        ("obstacles.1.semi_axes", [0.2], AXES_MESSAGE),
        ("obstacles.0.plane", "diagonal",
         "obstacles[0].plane: must be one of vertical, horizontal"),
        ("obstacles.0.colour", [1, 0, 0], "obstacles[0].colour: unknown field"),
        ("obstacles.1.motion", {"type": "waypoints", "waypoints": [[2.0, 1.0]]},
         "obstacles[1].motion.speed: is required"),
        ("obstacles.1.motion", {"type": "waypoints", "speed": 1.0, "waypoints": [[2.0, -1.0]]},
         "obstacles[1].motion.waypoints[0]: must differ"),
        ("obstacles.1.motion", {"type": "constant_velocity"},
         "obstacles[1].motion.velocity: is required"),
        ("obstacles.1.id", "a", "obstacles[1].id: duplicate id"),
        ("duration", -3, "duration: must be a positive number"),
        ("robot.kind", "hexapod", "robot.kind: must be one of"),
        ("perception.dropout_probability", 1.5, "perception.dropout_probability: must be <= 1"),
        ("perception.position_noise_std", [0.1, 0.1],
         "perception.position_noise_std: must be a number or a list of 3"),
        ("perception.source", "radar", "perception.source: must be one of oracle, sensors"),
        ("perception.lidar", {"range_min": 9.0},
         "perception.lidar.range_min: must be less than range_max (8.0), got 9.0"),
        ("perception.lidar", {"beams": 2.5}, "perception.lidar.beams: must be an integer"),
        ("perception.lidar", {"beams": 0}, "perception.lidar.beams: must be an integer within"),
        ("perception.lidar", {"fov": 7.0}, "perception.lidar.fov: must be an angle within"),
        ("perception.lidar", {"beam": 90}, "perception.lidar.beam: unknown field (did you mean"),
        ("perception.depth", {"vertical_fov": 3.2},
         "perception.depth.vertical_fov: must be an angle within (0, pi)"),
        ("perception.depth", {"columns": 640, "rows": 480},
         "perception.depth.rows: columns x rows must be at most 65536"),
        ("perception.depth", {"range_noise_std": -0.1},
         "perception.depth.range_noise_std: must be >= 0"),
        ("perception.depth", {"dropout_probability": 2}, "perception.depth.dropout_probability"),
        ("perception.depth", [64, 48], "perception.depth: must be a mapping"),
        ("planner.mode", "teleport", "planner.mode: must be one of goal, constant_velocity"),
        ("filter", {"gamma": {"nested": 1}}, "filter.gamma: must be a number"),
        ("speling", 1, "speling: unknown field"),
    ],
)
def test_bad_fields_are_named(tmp_path, path, value, message):
    with pytest.raises(ScenarioError) as err:
        parse_scenario(_with(path, value))
    assert message in str(err.value)
    # From a file the message starts with the file path.
    file = tmp_path / "bad.yaml"
    file.write_text(yaml.safe_dump(_with(path, value)))
    with pytest.raises(ScenarioError) as err:
        load_scenario(str(file))
    assert str(err.value).startswith(str(file.resolve())) and message in str(err.value)


def test_perception_source_and_range_sensors():
    sc = parse_scenario(_with("perception", {}))
    assert sc.perception.source == "oracle"
    assert sc.perception.lidar == LidarConfig() and sc.perception.depth == DepthConfig()
    sc = parse_scenario(_with("perception", {
        "source": "sensors", "lidar": {"beams": 180, "fov": 3.0, "range_max": 5.0},
        "depth": {"columns": 32, "rows": 24, "range_noise_std": 0.0},
    }))
    assert sc.perception.source == "sensors"
    assert sc.perception.lidar == LidarConfig(beams=180, fov=3.0, range_max=5.0)
    assert sc.perception.depth == DepthConfig(columns=32, rows=24, range_noise_std=0.0)
    assert LidarConfig().fov == pytest.approx(2 * math.pi) and DepthConfig().columns == 64


def test_not_yaml(tmp_path):
    file = tmp_path / "broken.yaml"
    file.write_text("robot: [unclosed\n")
    with pytest.raises(ScenarioError, match="cannot read scenario"):
        load_scenario(str(file))


def test_planner_and_overrides():
    data = _with("planner", {"mode": "constant_velocity", "velocity": [0.3, 0.0], "k_z": 1.5})
    data["filter"] = {"enabled": False, "gamma": 2.0}
    sc = parse_scenario(data)
    assert sc.planner.velocity == (0.3, 0.0, 0.0, 0.0)
    assert sc.planner.params == {"k_z": 1.5}
    assert sc.filter_overrides == {"enabled": False, "gamma": 2.0}
    with pytest.raises(ScenarioError, match="planner.velocity: is required"):
        parse_scenario(_with("planner", {"mode": "constant_velocity"}))


def test_horizontal_bar_needs_height():
    data = _with("obstacles.0", {"id": "bar", "plane": "horizontal", "position": [1.0, 0.0],
                                 "semi_axes": [0.05, 0.05]})
    with pytest.raises(ScenarioError, match=r"obstacles\[0\].position: must be \[x, y, z\]"):
        parse_scenario(data)
    data["obstacles"][0]["position"] = [1.0, 0.0, 0.4]
    bar = parse_scenario(data).obstacles[0]
    assert bar.plane == "horizontal" and bar.position == (1.0, 0.0, 0.4)


def test_documented_example_is_valid():
    doc = (Path(__file__).resolve().parents[1] / "doc" / "scenario_format.md").read_text()
    section = doc.split("## Complete example", 1)[1]
    block = section.split("```yaml", 1)[1].split("```", 1)[0]
    sc = parse_scenario(yaml.safe_load(block))
    assert [o.id for o in sc.obstacles] == ["pillar", "walker", "cart", "bar"]
    assert sc.obstacles[3].plane == "horizontal" and sc.filter_overrides == {"gamma": 1.0}


# ------------------------------------------------------------------- issue #14: validation


def _checked(data):
    """parse_scenario with every check a scenario file gets (as load_scenario does)."""
    return parse_scenario(data, check_clearance=True)


def _load_file(tmp_path, data, name="bad.yaml"):
    """load_scenario on ``data`` written to a file; returns the ScenarioError's message."""
    file = tmp_path / name
    file.write_text(data if isinstance(data, str) else yaml.safe_dump(data))
    with pytest.raises(ScenarioError) as err:
        load_scenario(str(file))
    message = str(err.value)
    assert message.startswith(str(file.resolve())), message
    return message


@pytest.mark.parametrize("text", ["", "# only a comment\n", "{}\n", "---\n"])
def test_empty_file_is_refused(tmp_path, text):
    message = _load_file(tmp_path, text, "empty.yaml")
    assert "empty" in message


def test_empty_mapping_is_refused_in_code():
    with pytest.raises(ScenarioError, match="empty"):
        parse_scenario({})


def test_start_inside_an_obstacle_is_refused(tmp_path):
    data = _with("robot.position", [1.0, 1.0])  # on obstacle a
    message = _load_file(tmp_path, data)
    assert "robot.position" in message and "obstacle 'a'" in message
    assert "inside" in message and " m" in message  # the distances, in metres


def test_goal_inside_an_inflated_obstacle_is_refused(tmp_path):
    # 0.6 m from the centre of b (radius 0.3): outside the obstacle itself, but inside it
    # inflated by half the A1's width (0.41 m) and the safety margin (0.05 m).
    data = _with("goal.position", [2.0, -0.4])
    message = _load_file(tmp_path, data)
    assert "goal.position" in message and "obstacle 'b'" in message
    assert "0.600 m" in message and "0.760 m" in message


def test_start_and_goal_clear_of_obstacles_load():
    sc = _checked(_with("goal.position", [2.0, -0.23]))  # 0.77 m from b: just outside
    assert sc.goal.position == (2.0, -0.23)


def test_inflation_follows_the_filter_overrides(tmp_path):
    # With a 0.2 m margin the same goal is inside; with a 0 margin a closer one is outside.
    data = _with("goal.position", [2.0, -0.23])
    data["filter"] = {"safety_margin": 0.2}
    assert "obstacle 'b'" in _load_file(tmp_path, data)
    data = _with("goal.position", [2.0, -0.28])  # 0.72 m from b
    data["filter"] = {"safety_margin": 0.0}
    _checked(data)


def test_biped_inflation_uses_its_robot_profile():
    # The biped's filter is 0.86 m wide (config/robots/biped.yaml): 0.3 + 0.43 + 0.05 = 0.78.
    data = _with("robot.kind", "biped")
    data["goal"]["position"] = [2.0, -1.77]  # 0.77 m from b: outside for the A1 (0.76) ...
    with pytest.raises(ScenarioError, match="obstacle 'b'"):
        _checked(data)  # ... inside for the biped
    data["robot"]["kind"] = "quadruped"
    _checked(data)


def test_moving_obstacles_are_checked_where_they_start():
    # A mover that starts on the robot is refused ...
    data = _with("obstacles.1", {"id": "m", "position": [0.3, 0.0], "semi_axes": [0.2, 0.2],
                                 "motion": {"type": "constant_velocity", "velocity": [0.0, 1.0]}})
    with pytest.raises(ScenarioError, match="robot.position.*obstacle 'm'"):
        _checked(data)
    # ... one that only crosses the goal later is not (the filter handles it) ...
    data = _with("obstacles.1", {"id": "m", "position": [3.0, -2.0], "semi_axes": [0.2, 0.2],
                                 "motion": {"type": "waypoints", "waypoints": [[3.0, 2.0]],
                                            "speed": 0.3}})
    _checked(data)
    # ... but one that stops on the goal for good is.
    data["obstacles"][1]["motion"].update(mode="stop", waypoints=[[3.0, 0.1]])
    with pytest.raises(ScenarioError, match=r"goal.position.*obstacle 'm'.*stops"):
        _checked(data)


def _bar(z, x=0.0, y=0.0, extent=4.0, radius=0.05):
    return {"id": "bar", "plane": "horizontal", "position": [x, y, z],
            "semi_axes": [radius, radius], "extent": extent}


def test_start_under_a_bar_too_low_to_duck_is_refused(tmp_path):
    data = _with("obstacles.0", _bar(0.25))
    message = _load_file(tmp_path, data)
    assert "robot.position" in message and "obstacle 'bar'" in message
    assert "duck" in message


def test_start_under_a_bar_the_robot_can_duck_under_loads():
    # quadruped_horizontal's bar and filter settings: the body may go down to 0.18 m.
    data = _with("obstacles.0", _bar(0.35))
    data["filter"] = {"safety_margin": 0.03, "min_height": 0.18, "max_height": 0.285}
    _checked(data)


def test_a_bar_beside_the_start_does_not_count():
    # 4 m bar centred 3 m to the side: its end is 1 m away, more than half the robot's width
    # plus the filter's horizontal_y_margin.
    _checked(_with("obstacles.0", _bar(0.25, y=3.0)))
    with pytest.raises(ScenarioError, match="obstacle 'bar'"):
        _checked(_with("obstacles.0", _bar(0.25, y=2.3)))


@pytest.mark.parametrize(
    ("section", "key", "message"),
    [
        ("filter", "gama", "unknown key 'gama' under filter (did you mean 'gamma'?)"),
        ("tracker", "max_coast", "unknown key 'max_coast' under tracker (did you mean "
                                 "'max_coast_time'?)"),
        ("controller", "command_timout", "unknown key 'command_timout' under controller "
                                         "(did you mean 'command_timeout'?)"),
        ("planner", "kz", "unknown key 'kz' under planner (did you mean 'k_z'?)"),
        ("controller", "min_body_height", "unknown key 'min_body_height' under controller"),
    ],
)
def test_unknown_override_keys_are_refused_at_load(tmp_path, section, key, message):
    data = _with(section, {key: 1.0})
    assert message in _load_file(tmp_path, data)


def test_real_override_keys_load():
    data = dict(BASE)
    data["filter"] = {"gamma": 2.0, "weights": [1.0, 0.1, 0.5], "enabled": False}
    data["tracker"] = {"rate": 20.0, "max_range": 10.0, "max_coast_time": 0.5,
                       "publish_unestimated_velocity": True}
    data["controller"] = {"command_timeout": 0.3}
    data["planner"] = {"mode": "goal", "k_z": 0.3, "max_yaw_rate": 0.5}
    sc = _checked(data)
    assert sc.overrides["tracker"]["max_coast_time"] == 0.5
    assert sc.planner.params == {"k_z": 0.3, "max_yaw_rate": 0.5}


@pytest.mark.parametrize(
    ("path", "value", "first"),
    [
        # A misspelt required field: the unknown key is named, not "is required".
        ("obstacles.1", {"id": "b", "position": [2.0, -1.0], "semi_axis": [0.3, 0.3]},
         "obstacles[1].semi_axis: unknown field (did you mean 'semi_axes'?"),
        ("obstacles.1.motion", {"type": "waypoints", "waypoints": [[2.0, 1.0]], "sped": 1.0},
         "obstacles[1].motion.sped: unknown field (did you mean 'speed'?"),
        ("obstacles.1.motion", {"type": "constant_velocity", "velocty": [0.0, 1.0]},
         "obstacles[1].motion.velocty: unknown field (did you mean 'velocity'?"),
        ("planner", {"mode": "constant_velocity", "velocit": [0.3]},
         "planner.velocit: unknown key 'velocit' under planner (did you mean 'velocity'?)"),
    ],
)
def test_unknown_keys_are_named_before_missing_ones(tmp_path, path, value, first):
    message = _load_file(tmp_path, _with(path, value))
    assert message.split(": ", 1)[1].startswith(first), message
    assert "is required" not in message


def test_unknown_keys_come_first_across_the_file(tmp_path):
    data = _with("obstacles.0", {"id": "a", "position": [1.0, 1.0]})  # semi_axes missing
    data["obstacles"][1]["colour"] = [1, 0, 0]  # a later typo
    message = _load_file(tmp_path, data)
    assert message.split(": ", 1)[1].startswith("obstacles[1].colour: unknown field"), message
    assert "obstacles[0].semi_axes: is required" in message  # still reported, after it


def test_code_may_put_an_obstacle_at_the_robot():
    # Simulator tests place obstacles right at the robot: parse_scenario checks clearance only
    # when asked (load_scenario always asks).
    data = _with("robot.position", [1.0, 1.0])
    assert parse_scenario(data).robot.position == (1.0, 1.0)
    with pytest.raises(ScenarioError, match="obstacle 'a'"):
        parse_scenario(data, check_clearance=True)


def test_doc_lists_every_packaged_scenario():
    doc = (Path(__file__).resolve().parents[1] / "doc" / "scenario_format.md").read_text()
    table = doc.split("Packaged scenarios:", 1)[1].split("## ", 1)[0]
    listed = [line.split("`")[1] for line in table.splitlines() if line.startswith("| `")]
    assert listed == available_scenarios()
