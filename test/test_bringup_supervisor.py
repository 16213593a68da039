"""Process supervision: stop escalation, exit descriptions, no orphans when the parent dies."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

from safe_legged_c3bf.run.supervisor import STOP_TIMEOUT, NodeSpec, Supervisor

TEST_DIR = Path(__file__).resolve().parent


def _env() -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=str(TEST_DIR))


def _wait_ready(proc, timeout: float = 30) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if any("ready" in line for line in proc.tail):
            return
        assert proc.poll() is None, list(proc.tail)
        time.sleep(0.05)
    raise AssertionError(f"{proc.name} never became ready: {list(proc.tail)}")


def _gone(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] in ("Z", "X")
    except OSError:
        return True


def test_stop_escalates_to_sigkill_within_the_timeout(tmp_path):
    sup = Supervisor(tmp_path / "logs", _env())
    polite = sup.start(NodeSpec("polite", "fake_idle_node"))
    stubborn = sup.start(NodeSpec("stubborn", "fake_idle_node", args=["--ignore-signals"]))
    _wait_ready(polite)
    _wait_ready(stubborn)
    start = time.monotonic()
    escalated = sup.stop()
    assert time.monotonic() - start < STOP_TIMEOUT + 0.5
    assert escalated == [stubborn]
    assert polite.poll() == 0
    assert stubborn.poll() == -signal.SIGKILL
    assert "killed by SIGKILL" in stubborn.describe_exit()
    assert os.getpgid(os.getpid()) not in (polite.pid, stubborn.pid)  # own process groups


def test_a_dead_child_is_reported_with_its_stderr(tmp_path):
    sup = Supervisor(tmp_path / "logs", _env())
    proc = sup.start(NodeSpec("crasher", "fake_idle_node", args=["--crash"]))
    deadline = time.monotonic() + 30
    exited = []
    while not exited and time.monotonic() < deadline:
        exited = sup.newly_exited()
        time.sleep(0.05)
    assert exited == [proc]
    assert proc.describe_exit() == f"crasher (pid {proc.pid}) exited with code 3"
    assert "about to fail" in proc.last_lines()
    assert sup.newly_exited() == []  # reported once
    log = (tmp_path / "logs" / "crasher.log").read_text()
    assert log.startswith("$ ") and "about to fail" in log


def test_children_die_with_a_killed_supervisor(tmp_path):
    script = textwrap.dedent(f"""
        import os, sys, time
        from pathlib import Path
        from safe_legged_c3bf.run.supervisor import NodeSpec, Supervisor
        env = dict(os.environ, PYTHONPATH={str(TEST_DIR)!r})
        sup = Supervisor(Path({str(tmp_path)!r}) / "logs", env)
        proc = sup.start(NodeSpec("idle", "fake_idle_node"))
        print(proc.pid, flush=True)
        time.sleep(120)
    """)
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    child = None
    try:
        child = int(parent.stdout.readline())
        time.sleep(1.0)
        assert not _gone(child)
        parent.send_signal(signal.SIGKILL)
        parent.wait(timeout=10)
        deadline = time.monotonic() + 10
        while not _gone(child) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _gone(child)
    finally:
        if parent.poll() is None:
            parent.kill()
            parent.wait()
        if child is not None and not _gone(child):
            os.killpg(child, signal.SIGKILL)


def test_a_frozen_child_is_seen_and_still_stopped_politely(tmp_path):
    sup = Supervisor(tmp_path / "logs", _env())
    proc = sup.start(NodeSpec("sleeper", "fake_idle_node"))
    _wait_ready(proc)
    assert not proc.frozen()
    os.kill(proc.pid, signal.SIGSTOP)
    deadline = time.monotonic() + 5
    while not proc.frozen() and time.monotonic() < deadline:
        time.sleep(0.02)
    assert proc.frozen()
    escalated = sup.stop()
    assert escalated == []  # continued, then stopped by SIGINT: no SIGKILL needed
    assert proc.poll() == 0
    assert not proc.frozen()
