"""Node processes spin rclpy's EventsExecutor unless told otherwise (issue 18: CPU).

The graph's CPU per sim second fell by about a quarter with it; ``--executor single`` (or
``$SAFE_LEGGED_C3BF_EXECUTOR=single``) gives back rclpy's SingleThreadedExecutor. The
bringup's own process (its monitor) keeps the SingleThreadedExecutor; every node with
``--in-process`` spins the EventsExecutor too since session 19 (0.63 of the single-threaded
one's CPU with sensors).
"""

from __future__ import annotations

import os

import pytest
from conftest import run_node_probe

from safe_legged_c3bf.bringup import build_parser
from safe_legged_c3bf.nodes.ros_common import EXECUTOR_VARIABLE, make_executor
from safe_legged_c3bf.run.launcher import make_launcher
from safe_legged_c3bf.run.outcome import StartupError
from safe_legged_c3bf.run.plan import make_plan


def _kind(executor) -> str:  # noqa: ANN001 - an rclpy executor
    return type(executor).__name__


def test_the_events_executor_is_the_default_and_single_is_the_fallback(monkeypatch, ros_executor):
    context = ros_executor.context_for_nodes
    monkeypatch.delenv(EXECUTOR_VARIABLE, raising=False)
    made = [make_executor(context=context), make_executor("single", context=context)]
    monkeypatch.setenv(EXECUTOR_VARIABLE, "single")
    made.append(make_executor(context=context))
    for executor in made:
        executor.shutdown(timeout_sec=1.0)
    assert [_kind(e) for e in made] == \
        ["EventsExecutor", "SingleThreadedExecutor", "SingleThreadedExecutor"]
    monkeypatch.setenv(EXECUTOR_VARIABLE, "fast")
    with pytest.raises(ValueError, match="events, single"):
        make_executor(context=context)


def test_the_bringup_passes_its_executor_to_the_node_processes(monkeypatch, tmp_path):
    monkeypatch.setenv(EXECUTOR_VARIABLE, "unset")  # restored after the test
    for choice in ("single", "events"):
        opts = build_parser().parse_args(["--executor", choice, "--out", str(tmp_path / choice)])
        make_launcher(opts, make_plan(opts).run_dir)
        assert os.environ[EXECUTOR_VARIABLE] == choice
    default = build_parser().parse_args(["--out", str(tmp_path / "d")])
    make_launcher(default, make_plan(default).run_dir)
    assert os.environ[EXECUTOR_VARIABLE] == "events"
    for choice, kind in ((None, "events"), ("single", "single"), ("multi", "multi")):
        args = ["--in-process", "--out", str(tmp_path / "i")]
        opts = build_parser().parse_args(args + (["--executor", choice] if choice else []))
        assert make_launcher(opts, tmp_path).executor_kind == kind


def test_a_multi_threaded_executor_needs_in_process(tmp_path):
    opts = build_parser().parse_args(["--executor", "multi", "--out", str(tmp_path / "x")])
    with pytest.raises(StartupError, match="--in-process"):
        make_plan(opts)


def test_a_node_process_spins_the_events_executor_and_stops_cleanly_on_sigint():
    env = {k: v for k, v in os.environ.items() if k != EXECUTOR_VARIABLE}
    proc = run_node_probe('"executor", type(self.executor).__name__', env)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "EventsExecutor" in proc.stdout, proc.stdout
