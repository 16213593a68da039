"""The bringup as a user runs it: a subprocess on a short scenario, with the real nodes.

Checks the end-of-run summary and run folder, the MCAP recording, that a killed node is
named and ends the run with a non-zero exit, that SIGINT leaves no process behind, that the
echo tool prints /cmd_vel_safe of a running graph, and the in-process composition.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.safety.safety_cycle import CycleStatus

SHORT = "test_minimal"  # config/scenarios/test_minimal.yaml: 2 s of sim time
PLOTS = ("top_view.png", "barrier_h.png", "commands.png", "clearance.png")


# ----------------------------------------------------------------------------- helpers


def _ppid(pid: int) -> int | None:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return int(f.read().rsplit(")", 1)[1].split()[1])
    except (OSError, ValueError, IndexError):
        return None


def _state(pid: int) -> str | None:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return None


def descendants(root: int) -> set[int]:
    """Pids whose parent chain includes ``root`` (a /proc scan, no psutil)."""
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            parent = _ppid(int(entry))
            if parent is not None:
                children.setdefault(parent, []).append(int(entry))
    found, todo = set(), [root]
    while todo:
        for child in children.get(todo.pop(), []):
            if child not in found:
                found.add(child)
                todo.append(child)
    return found


def alive(pids: set[int]) -> set[int]:
    """Those of ``pids`` still running (zombies count as gone)."""
    return {p for p in pids if _state(p) not in (None, "Z", "X")}


def cmdline(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return f.read().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


class Bringup:
    """A bringup subprocess whose stdout/stderr are collected by threads."""

    def __init__(self, *args: str, cwd: Path) -> None:
        env = dict(os.environ)
        env.pop("ROS_DOMAIN_ID", None)  # the bringup leases its own domain
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "safe_legged_c3bf.bringup", "--progress-period", "0.5", *args],
            cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            start_new_session=True,
        )
        self.stdout: list[str] = []
        self.stderr: list[str] = []
        self._threads = [
            threading.Thread(target=self._read, args=(self.proc.stdout, self.stdout), daemon=True),
            threading.Thread(target=self._read, args=(self.proc.stderr, self.stderr), daemon=True),
        ]
        for t in self._threads:
            t.start()

    @staticmethod
    def _read(stream, sink: list[str]) -> None:
        for line in iter(stream.readline, ""):
            sink.append(line)

    @property
    def out(self) -> str:
        return "".join(self.stdout)

    @property
    def err(self) -> str:
        return "".join(self.stderr)

    def domain_id(self, timeout: float = 30) -> int:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            m = re.search(r"ROS domain (\d+)", self.out)
            if m:
                return int(m.group(1))
            time.sleep(0.05)
        raise AssertionError(f"no domain line:\n{self.out}\n{self.err}")

    def wait_for_sim_time(self, minimum: float = 0.0, timeout: float = 90) -> None:
        """Wait until a progress line shows sim time above ``minimum``."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            times = [float(x) for x in re.findall(r"^t\s+([\d.]+)/", self.out, re.M)]
            if times and times[-1] > minimum:
                return
            if self.proc.poll() is not None:
                raise AssertionError(f"bringup ended early:\n{self.out}\n{self.err}")
            time.sleep(0.1)
        raise AssertionError(f"sim time never passed {minimum}:\n{self.out}\n{self.err}")

    def wait(self, timeout: float) -> int:
        try:
            code = self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            raise
        for t in self._threads:
            t.join(timeout=5)
        return code

    def kill(self) -> None:
        """Last resort cleanup: the bringup's group and every descendant."""
        pids = descendants(self.proc.pid)
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        for pid in pids:
            try:
                os.killpg(pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
        self.proc.wait(timeout=10)


@pytest.fixture
def bringups():
    started: list[Bringup] = []
    yield started
    for b in started:
        if b.proc.poll() is None:
            b.kill()


def _node_pid(bringup: Bringup, module: str, timeout: float = 30) -> int:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for pid in descendants(bringup.proc.pid):
            if module in cmdline(pid) and "run.child" in cmdline(pid):
                return pid
        time.sleep(0.1)
    raise AssertionError(f"no process running {module}")


# ----------------------------------------------------------------------------- fast checks


def test_unknown_scenario_fails_fast(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "safe_legged_c3bf.bringup", "--scenario", "no_such_scenario",
         "--out", str(tmp_path / "run")],
        capture_output=True, text=True, timeout=60,
    )
    assert out.returncode == 2
    assert "no_such_scenario" in out.stderr and "start-up failed" in out.stderr


def test_missing_node_module_fails_fast(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "safe_legged_c3bf.bringup", "--scenario", SHORT,
         "--node", "reference_planner=no_such_module_xyz", "--out", str(tmp_path / "run")],
        capture_output=True, text=True, timeout=60,
    )
    assert out.returncode == 2
    assert "reference_planner (no_such_module_xyz)" in out.stderr


def test_list_scenarios():
    out = subprocess.run(
        [sys.executable, "-m", "safe_legged_c3bf.bringup", "--list-scenarios"],
        capture_output=True, text=True, timeout=60,
    )
    assert out.returncode == 0
    assert "quadruped_default" in out.stdout.split()


# ----------------------------------------------------------------------------- full runs


@pytest.mark.slow
def test_short_run_writes_summary_report_plots_and_recording(tmp_path, bringups):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    run_dir, mcap = tmp_path / "run", tmp_path / "run.mcap"
    b = Bringup("--scenario", SHORT, "--out", str(run_dir), "--record", str(mcap),
                cwd=tmp_path)
    bringups.append(b)
    code = b.wait(timeout=120)
    assert code == 0, b.out + b.err
    assert "Run COMPLETED" in b.out
    for label in ("goal reached", "collision", "min clearance", "real-time factor", "cpu",
                  "filter intervened", "filter solve time median"):
        assert label in b.out

    report = json.loads((run_dir / "report.json").read_text())
    s = report["summary"]
    assert s["completed"] is True and s["outcome"] == "completed"
    assert report["exit_code"] == 0
    assert s["scenario"] == SHORT and s["robot"] == "quadruped"
    assert s["sim_time"] == pytest.approx(s["duration"], abs=0.05)
    assert isinstance(s["collision"], bool)
    assert s["collision"] == (s["collision_count"] > 0 or s["collision_time"] > 0)
    assert s["min_clearance"] is None or s["min_clearance"] >= 0
    assert s["real_time_factor"] > 0
    assert s["filter"]["cycles"] > 0
    assert 0.0 <= s["filter"]["intervention_share"] <= 1.0
    solve = s["filter"]["solve_time_ms"]
    assert 0 <= solve["median"] <= solve["p99"]
    assert s["goal"]["position"] == [3.0, 0.0]
    # per-node CPU (core-s per sim s) of every node process and the bringup's own
    per_node = s["cpu"]["per_sim_second"]
    assert set(per_node) >= {"simulator", "obstacle_tracker", "reference_planner",
                             "safety_filter", "gait_controller", "recorder", "bringup"}
    assert all(v >= 0.0 for v in per_node.values()) and per_node["simulator"] > 0.0
    assert s["cpu"]["total_per_sim_second"] == pytest.approx(sum(per_node.values()), abs=0.01)
    # the printed summary and the report agree
    assert ("collision         no" in b.out) == (not s["collision"])
    for name in PLOTS + ("timeseries.npz", "scenario.yaml"):
        assert (run_dir / name).is_file(), name
    assert set(report["files"]) >= set(PLOTS)
    for name in ("simulator", "obstacle_tracker", "reference_planner", "safety_filter",
                 "gait_controller", "recorder"):
        assert (run_dir / "logs" / f"{name}.log").is_file(), name
    assert not alive(descendants(b.proc.pid))

    with open(mcap, "rb") as f:
        reader = make_reader(f)
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
    contract = {t.name: t.type for t in topics.CONTRACT}
    recorded = {}
    for cid, channel in summary.channels.items():
        schema = summary.schemas[channel.schema_id]
        assert channel.message_encoding == "cdr" and schema.encoding == "ros2msg"
        assert contract[channel.topic] == schema.name
        recorded[channel.topic] = summary.statistics.channel_message_counts[cid]
    expected = {"/clock", "/odom", "/joint_states", "/joint_commands", "/obstacles/detections",
                "/obstacles", "/cmd_vel", "/cmd_vel_safe", "/c3bf/state", "/diagnostics",
                "/ground_truth/safety", "/ground_truth/obstacles"}
    assert expected <= set(recorded), sorted(recorded)
    seen = set()
    with open(mcap, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages():
            if channel.topic not in seen:
                seen.add(channel.topic)
                assert type(msg).__name__ == contract[channel.topic].rsplit("/", 1)[1]
    assert seen == set(recorded)


@pytest.mark.slow
def test_killed_node_is_named_and_ends_the_run(tmp_path, bringups):
    b = Bringup("--scenario", SHORT, "--duration", "120", "--out", str(tmp_path / "run"),
                cwd=tmp_path)
    bringups.append(b)
    b.wait_for_sim_time(0.2)
    victim = _node_pid(b, "reference_planner_node")
    children = descendants(b.proc.pid)
    os.kill(victim, signal.SIGKILL)
    code = b.wait(timeout=30)
    assert code == 1, b.out + b.err
    assert re.search(r"node reference_planner \(pid \d+\) killed by SIGKILL", b.err), b.err
    assert "stopped the other nodes" in b.err
    report = json.loads((tmp_path / "run" / "report.json").read_text())
    assert report["summary"]["outcome"] == "node_died"
    assert report["exit_code"] == 1
    assert not alive(children)


@pytest.mark.slow
def test_echo_then_sigint_leaves_no_process(tmp_path, bringups):
    b = Bringup("--scenario", SHORT, "--duration", "120", "--out", str(tmp_path / "run"),
                cwd=tmp_path)
    bringups.append(b)
    domain = b.domain_id()
    b.wait_for_sim_time(0.2)
    echo = subprocess.run(
        [sys.executable, "-m", "safe_legged_c3bf.echo", "/cmd_vel_safe", "--once",
         "--domain-id", str(domain)],
        capture_output=True, text=True, timeout=60,
    )
    assert echo.returncode == 0, echo.stderr
    assert re.fullmatch(
        r"linear:\n  x: \S+\n  y: \S+\n  z: \S+\nangular:\n  x: \S+\n  y: \S+\n  z: \S+\n---\n",
        echo.stdout,
    ), echo.stdout

    children = descendants(b.proc.pid)
    assert len(children) >= 5
    groups = {os.getpgid(p) for p in children if alive({p})}
    start = time.monotonic()
    os.kill(b.proc.pid, signal.SIGINT)
    code = b.wait(timeout=30)
    assert code == 130, b.out + b.err
    # children are stopped within 5 s; the report is written after that
    assert time.monotonic() - start < 15
    assert not alive(children)
    for group in groups:
        with pytest.raises(ProcessLookupError):
            os.killpg(group, 0)
    report = json.loads((tmp_path / "run" / "report.json").read_text())
    assert report["summary"]["outcome"] == "interrupted"


@pytest.mark.slow
def test_sigterm_of_the_bringup_stops_every_child(tmp_path, bringups):
    b = Bringup("--scenario", SHORT, "--duration", "120", "--out", str(tmp_path / "run"),
                cwd=tmp_path)
    bringups.append(b)
    b.wait_for_sim_time(0.0)
    children = descendants(b.proc.pid)
    os.kill(b.proc.pid, signal.SIGTERM)
    assert b.wait(timeout=30) == 143
    assert not alive(children)


@pytest.mark.slow
def test_in_process_run_with_video(tmp_path, bringups):
    import imageio.v2 as iio

    run_dir, video = tmp_path / "run", tmp_path / "run.gif"
    b = Bringup("--scenario", SHORT, "--in-process", "--out", str(run_dir),
                "--video", str(video), "--video-fps", "5", cwd=tmp_path)
    bringups.append(b)
    assert b.wait(timeout=120) == 0, b.out + b.err
    report = json.loads((run_dir / "report.json").read_text())
    assert report["summary"]["mode"] == "in-process"
    assert report["summary"]["completed"] is True
    assert report["summary"]["filter"]["cycles"] > 0
    assert list(report["summary"]["cpu"]["per_sim_second"]) == ["in_process"]
    assert (run_dir / "logs" / "in_process.log").is_file()
    assert report["video"] == str(video)
    frames = [f for f in iio.get_reader(video)]
    assert len(frames) >= 8  # 2 s at 5 frames per sim second (identical frames may merge)


@pytest.mark.slow
def test_sensors_perception_starts_the_detector_and_the_filter_sees_its_obstacles(
        tmp_path, bringups):
    """--perception sensors: /scan and /points, the detector's detections, tracked, filtered."""
    run_dir = tmp_path / "run"
    b = Bringup("--scenario", SHORT, "--perception", "sensors", "--duration", "3",
                "--full-duration", "--out", str(run_dir), cwd=tmp_path)
    bringups.append(b)
    assert b.wait(timeout=180) == 0, b.out + b.err
    assert "perception sensors" in b.out
    report = json.loads((run_dir / "report.json").read_text())
    s = report["summary"]
    assert s["perception"] == "sensors" and s["completed"] is True
    assert "obstacle_detector" in s["cpu"]["per_sim_second"]
    sim = json.loads((run_dir / "simulator_summary.json").read_text())
    assert sim["perception_source"] == "sensors" and sim["lidar_scans"] >= 25
    # The detector's obstacles reached the filter, and once they had it filtered against them
    # nearly to the end. Before the first detection the filter brakes on stale obstacles; how
    # long that lasts in sim time depends on how fast the detector's process starts against
    # physics (wall clock: 5 % of this run on a quiet machine, 45 % with two busy cores
    # beside it), so it is printed, not asserted. Later, a detector starved of CPU can miss
    # the 0.5 s deadline (one cycle at t = 1.4 s in a CI run at RTF 0.76): each such cycle
    # must brake, and they must stay rare.
    with np.load(run_dir / "timeseries.npz") as z:
        state = np.asarray(z["filter_state"])
    stale = state[:, 1] == CycleStatus.STALE_INPUT
    fresh = np.flatnonzero(~stale)
    assert fresh.size, "the filter never had fresh obstacles"
    later = np.flatnonzero(stale[fresh[0]:]) + fresh[0]
    print(f"start-up: stale obstacles until t = {state[fresh[0], 0]:.2f} s; "
          f"{later.size} stale cycles of {len(state) - fresh[0]} after it")
    assert later.size <= 0.05 * (len(state) - fresh[0]), state[later, 0]
    speed = np.abs(state[:, 8])  # commanded forward speed (m/s)
    assert np.all(speed[later] <= speed[later - 1] + 1e-6), "a stale cycle did not brake"
    assert s["filter"]["cycles"] > 100
