"""The replay test (like Nav2's bag test): a recording from the project's simulator is played
into the safety pipeline without the simulator, and the filter is scored against ground truth.

The recording (test/data/replay_walker.mcap, made by test/data/make_replay_recording.py): the
A1 walks a free path beside a standing walker, which at t = 6 s starts to cross its path. The
KPIs are printed (run pytest with -s to see them). Known shortfalls are expected failures
(issue #19): the tracker's manoeuvre detector (on with sensors since session 17) estimates
the walker's velocity ~0.3 s after three detections at 10 Hz show it moving, so the filter
acts 0.43-0.49 s after the cone entry (strict; 0.65-0.81 s with the detector off); the
filtered command's exit from the true cone was at the 3 s horizon in 8 of 10 replays (0.62
and 0.73 s in the others): a replay is paced in real time and not repeatable to the cycle, so
that one is not strict.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from safe_legged_c3bf.replay.kpis import KpiLimits

DATA = Path(__file__).resolve().parent / "data"
RECORDING = DATA / "replay_walker.mcap"
PARAMS = DATA / "replay_pipeline.yaml"

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def replayed():
    """One replay of the shipped recording, shared by the tests below."""
    from safe_legged_c3bf.replay.run import replay

    result = replay(RECORDING, "quadruped", rate=1.0, params_files=[PARAMS])
    print("\nreplay KPIs:", {k: v for k, v in result.report.as_dict().items()
                             if k not in ("reaction", "cone_exit")})
    return result


def test_the_recording_is_played_whole(replayed):
    counts = replayed.recording.counts
    assert counts["/scan"] >= 120 and counts["/points"] >= 120 and counts["/odom"] >= 1500
    # the filter ran on the replayed topics the whole time (50 Hz of 13 s, after start-up)
    assert replayed.cycles.t.size > 400


def test_every_cone_entry_is_answered_and_the_free_path_is_left_alone(replayed):
    rep = replayed.report
    assert rep.entries >= 1, "the walker's crossing must put the reference in its cone"
    assert rep.missed == 0
    assert rep.free_cycles > 100
    assert rep.false_intervention_share <= KpiLimits().false_intervention_share


@pytest.mark.xfail(strict=True, reason="#19: the tracker's manoeuvre detector needs three "
                   "detections (0.3 s at 10 Hz) after a walker starts to see it moving; the "
                   "filter acts ~0.45 s after the cone entry")
def test_reaction_to_a_cone_entry_within_its_limit(replayed):
    assert max(replayed.report.reaction) <= KpiLimits().reaction


@pytest.mark.xfail(strict=False, reason="#19: the filtered command leaves the true collision "
                   "cone at the 3 s horizon in 8 of 10 replays (0.62 s at best); not "
                   "strict: real-time pacing makes replays differ")
def test_filtered_command_leaves_the_cone_within_its_limit(replayed):
    assert max(replayed.report.cone_exit) <= KpiLimits().cone_exit


def test_replay_command_line_prints_kpis_and_writes_json(tmp_path):
    out = tmp_path / "kpi.json"
    proc = subprocess.run(
        [sys.executable, "-m", "safe_legged_c3bf.replay", str(RECORDING), "--params-file",
         str(PARAMS), "--rate", "2", "--json", str(out)],
        capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "cone entries" in proc.stdout and "false interventions" in proc.stdout
    assert out.is_file()


def test_replay_refuses_a_file_that_is_not_a_recording(tmp_path):
    bad = tmp_path / "x.mcap"
    bad.write_bytes(b"not an mcap file")
    proc = subprocess.run([sys.executable, "-m", "safe_legged_c3bf.replay", str(bad)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and "cannot read the recording" in proc.stderr


def test_deploy_mode_filters_replayed_topics_without_the_simulator(ros_executor, tmp_path):
    """bringup --deploy (one process per node) on the recording's topics: /cmd_vel_safe comes."""
    from rclpy.executors import SingleThreadedExecutor  # noqa: F401 - executor from fixture

    from safe_legged_c3bf.interfaces import topics
    from safe_legged_c3bf.nodes import ros_common
    from safe_legged_c3bf.replay.player import RecordingPlayer
    from safe_legged_c3bf.replay.recording import load_recording

    env = dict(os.environ)
    proc = subprocess.Popen(
        [sys.executable, "-m", "safe_legged_c3bf.bringup", "--deploy", "--use-sim-time",
         "--params-file", str(PARAMS), "--out", str(tmp_path / "deploy")],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        start_new_session=True)
    try:
        context = ros_executor.context_for_nodes
        player = RecordingPlayer(load_recording(RECORDING), rate=1.0, context=context)
        from rclpy.node import Node

        listener = Node("deploy_listener", context=context)
        safe = []
        ros_common.subscription(listener, topics.CMD_VEL_SAFE, safe.append)
        # wait for the four pipeline nodes before playing
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            names = set(listener.get_node_names())
            if {"obstacle_detector", "obstacle_tracker", "safety_filter"} <= names:
                break
            time.sleep(0.2)
        ros_executor.add_node(listener)
        ros_executor.add_node(player)
        deadline = time.monotonic() + 60
        while not player.finished and time.monotonic() < deadline:
            ros_executor.spin_once(timeout_sec=0.01)
        assert player.finished
        assert len(safe) > 200, f"only {len(safe)} /cmd_vel_safe messages"
        assert any(abs(m.linear.x) > 0.1 for m in safe), "the pipeline never let the robot move"
    finally:
        os.killpg(proc.pid, signal.SIGINT)
        out, _ = proc.communicate(timeout=30)
    assert proc.returncode == 0, out[-3000:]
    assert "deploy: obstacle_detector, obstacle_tracker, safety_filter running" in out
