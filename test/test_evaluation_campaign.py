"""Resumable campaigns (fake runs, no ROS), progress, the orphan guard, --ray without Ray."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from test_evaluation import fake_python, make_report  # noqa: F401 - fixture

from safe_legged_c3bf import evaluate
from safe_legged_c3bf.evaluation import campaign_state, orphan_guard, ray_pool
from safe_legged_c3bf.evaluation.campaign import run_campaign
from safe_legged_c3bf.evaluation.campaign_state import (
    ROW_FILE,
    CampaignMismatchError,
    CampaignState,
)
from safe_legged_c3bf.evaluation.progress import Progress, duration_text
from safe_legged_c3bf.evaluation.results import read_csv, write_results
from safe_legged_c3bf.evaluation.runner import Runner, RunSpec, record_from_report

REPO = Path(__file__).resolve().parents[1]

SETTINGS = {"in_process": False, "full_duration": False}


def specs(n=4):
    out = []
    for i in range(n):
        out.append(RunSpec(f"case{i}__filter", f"case{i}", "quadruped_ci", "quadruped", "random",
                           seed=i))
        out.append(RunSpec(f"case{i}__nofilter", f"case{i}", "quadruped_ci", "quadruped",
                           "random", filter_enabled=False, seed=i))
    return out


class FakePool:
    """Finishes runs from synthetic reports; optionally 'is killed' after some runs."""

    def __init__(self, stop_after=None, outcome=None):
        self.asked = []
        self.stop_after = stop_after
        self.outcome = outcome

    def run(self, todo, durations=None, on_result=None):
        self.asked.append([s.run_id for s in todo])
        rows = []
        for k, spec in enumerate(todo):
            if self.stop_after is not None and k >= self.stop_after:
                raise KeyboardInterrupt
            rec = record_from_report(spec, make_report(collision=not spec.filter_enabled),
                                     0, 1.0)
            if self.outcome:
                rec["outcome"] = self.outcome
            rows.append(rec)
            on_result(rec)
        return rows


def quiet(_line):
    pass


def test_a_killed_campaign_continues_where_it_stopped(tmp_path):
    plan = specs()
    state = CampaignState(tmp_path, SETTINGS)
    first = run_campaign(plan, {}, FakePool(stop_after=3), state, say=quiet)
    assert first.interrupted and first.ran == 3 and first.resumed == 0
    assert all((tmp_path / "runs" / s.run_id / ROW_FILE).is_file() for s in plan[:3])
    assert [r["run_id"] for r in read_csv(tmp_path / "results.csv")] == [
        s.run_id for s in plan[:3]]

    pool = FakePool()
    lines = []
    second = run_campaign(plan, {}, pool, CampaignState(tmp_path, SETTINGS), say=lines.append)
    assert pool.asked == [[s.run_id for s in plan[3:]]]  # only what was left
    assert not second.interrupted and second.resumed == 3 and second.ran == len(plan) - 3
    assert [r["run_id"] for r in second.records] == [s.run_id for s in plan]
    assert lines[0].startswith(f"evaluate: continuing {tmp_path}: 3 of {len(plan)} run(s)")
    assert lines[-1].startswith(f"evaluate: {len(plan)}/{len(plan)} done (5 this session)")

    # Nothing left: a third session runs nothing and returns every row.
    pool = FakePool()
    third = run_campaign(plan, {}, pool, CampaignState(tmp_path, SETTINGS), say=quiet)
    assert pool.asked == [] and len(third.records) == len(plan)


def test_interrupted_and_unstarted_runs_are_run_again(tmp_path):
    plan = specs(1)
    run_campaign(plan, {}, FakePool(outcome="interrupted"), CampaignState(tmp_path, SETTINGS),
                 say=quiet)
    pool = FakePool()
    run_campaign(plan, {}, pool, CampaignState(tmp_path, SETTINGS), say=quiet)
    assert pool.asked == [[s.run_id for s in plan]]
    # A half-written run folder (no row.json: the driver died during the run) is run again.
    (tmp_path / "runs" / plan[0].run_id / ROW_FILE).unlink()
    pool = FakePool()
    run_campaign(plan, {}, pool, CampaignState(tmp_path, SETTINGS), say=quiet)
    assert pool.asked == [[plan[0].run_id]]


def test_a_folder_of_another_campaign_is_refused_and_restart_runs_all(tmp_path):
    plan = specs(1)
    run_campaign(plan, {}, FakePool(), CampaignState(tmp_path, SETTINGS), say=quiet)
    other = SETTINGS | {"full_duration": True}
    with pytest.raises(CampaignMismatchError, match="full_duration"):
        run_campaign(plan, {}, FakePool(), CampaignState(tmp_path, other), say=quiet)
    changed = [RunSpec(s.run_id, s.case, s.scenario, s.robot, s.kind, s.filter_enabled,
                       seed=99) for s in plan]
    with pytest.raises(CampaignMismatchError, match="seed"):
        run_campaign(changed, {}, FakePool(), CampaignState(tmp_path, SETTINGS), say=quiet)
    pool = FakePool()
    run_campaign(plan, {}, pool, CampaignState(tmp_path, other), restart=True, say=quiet)
    assert pool.asked == [[s.run_id for s in plan]]


def test_an_edited_scenario_file_is_another_campaign(tmp_path):
    scenario = tmp_path / "mine.yaml"
    scenario.write_text("name: mine\n")
    plan = [RunSpec("mine__filter", "mine", str(scenario), "quadruped", "custom")]
    out = tmp_path / "ev"
    run_campaign(plan, {}, FakePool(), CampaignState(out, SETTINGS), say=quiet)
    scenario.write_text("name: mine\nduration: 3.0\n")
    with pytest.raises(CampaignMismatchError, match="scenario_sha256"):
        CampaignState(out, SETTINGS).split(plan)


def test_rows_of_a_folder_without_row_files_are_reused(tmp_path):
    """Folders from before row.json: their results.csv rows that match the plan count."""
    plan = specs(2)
    rows = [record_from_report(s, make_report(), 0, 1.0) for s in plan[:3]]
    rows[2]["outcome"] = "interrupted"
    write_results(rows, tmp_path, figures=False)
    done, todo = CampaignState(tmp_path, SETTINGS).split(plan)
    assert [r["run_id"] for r in done] == [s.run_id for s in plan[:2]]
    assert [s.run_id for s in todo] == [s.run_id for s in plan[2:]]


def test_row_file_is_atomic_and_unreadable_rows_are_ignored(tmp_path):
    spec = specs(1)[0]
    print_ = campaign_state.fingerprint(spec, SETTINGS)
    path = campaign_state.write_row(tmp_path, {"run_id": spec.run_id, "outcome": "ok"}, print_)
    assert json.loads(path.read_text())["fingerprint"] == print_
    assert [p.name for p in tmp_path.iterdir()] == [ROW_FILE]  # no temporary file left
    path.write_text('{"row": {"run_id"')  # torn write
    assert campaign_state.read_row(tmp_path) is None


def test_campaign_with_the_local_runner(tmp_path, fake_python):  # noqa: F811 - fixture
    """The real Runner as the pool: rows saved as runs end, a second session reuses them."""
    plan = [RunSpec("ok", "a", "a", "quadruped", "static"),
            RunSpec("off", "a", "a", "quadruped", "static", filter_enabled=False)]
    runner = Runner(tmp_path / "ev", jobs=2, python=fake_python, progress=quiet)
    first = run_campaign(plan, {}, runner, CampaignState(tmp_path / "ev", SETTINGS), say=quiet)
    assert {r["outcome"] for r in first.records} == {"ok", "collided"}
    second_runner = Runner(tmp_path / "ev", jobs=2, python=fake_python, progress=quiet)
    second = run_campaign(plan, {}, second_runner, CampaignState(tmp_path / "ev", SETTINGS),
                          say=quiet)
    assert second.ran == 0 and second.records == first.records


# ------------------------------------------------------------------------------ progress


def test_progress_line_counts_rates_and_eta():
    now = [0.0]
    before = [{"run_id": "x", "filter": "on", "outcome": "ok", "collision": False,
               "goal_reached": True, "fallen": False}]
    p = Progress(10, before, clock=lambda: now[0])
    assert p.eta() is None and "ETA" not in p.line()
    now[0] = 120.0
    line = p.add({"run_id": "y", "filter": "off", "outcome": "collided", "collision": True})
    assert line.startswith("evaluate: 2/10 done (1 this session)")
    assert "filter on: collision 0/1 (< 95.0 %), success 1/1" in line
    assert "filter off: collision 1/1;" in line
    assert "2.0 min/run, ETA 16 min" in line  # 8 left at 120 s each
    now[0] = 180.0
    line = p.add({"run_id": "z", "filter": "on", "outcome": "node_died"})
    assert "1 run failure" in line and "filter on: collision 0/1" in line
    assert duration_text(3 * 86400 + 7200) == "3 d 2 h" and duration_text(5000) == "1 h 23 min"


# ------------------------------------------------------------------------------ Ray pieces


def test_ray_missing_gives_the_install_hint(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError
    with pytest.raises(ray_pool.RayUnavailableError, match=r"pip install '\.\[cluster\]'"):
        ray_pool.import_ray()
    code = evaluate.main(["--scenario", "test_minimal", "--no-baseline", "--no-free", "--ray",
                          "--out", str(tmp_path / "ev"), "--no-figures"])
    assert code == evaluate.EXIT_USAGE
    err = capsys.readouterr().err
    assert "--ray needs Ray" in err and "pip install '.[cluster]'" in err
    assert not (tmp_path / "ev" / "runs").exists()  # nothing ran


def test_ray_options_are_checked(tmp_path, capsys):
    for args in (["--ray-cpus", "0"], ["--shared-dir", str(tmp_path)]):
        assert evaluate.main(["--suite", "ci", "--out", str(tmp_path / "x"), *args]) == 2
    assert "--shared-dir needs --ray" in capsys.readouterr().err


def test_run_folder_travels_as_bytes(tmp_path):
    src = tmp_path / "src"
    (src / "logs").mkdir(parents=True)
    (src / "report.json").write_text("{}")
    (src / "logs" / "sim.log").write_text("x" * 1000)
    dst = tmp_path / "dst"
    dst.mkdir()
    (dst / "stale.txt").write_text("old")
    ray_pool.unpack(ray_pool.pack(src), dst)
    assert sorted(p.relative_to(dst).as_posix() for p in dst.rglob("*")) == [
        "logs", "logs/sim.log", "report.json"]


def _closed_link(text: str) -> int:
    """The read end of a pipe that carried ``text`` and whose writer has closed it."""
    read_fd, write_fd = os.pipe()
    os.write(write_fd, text.encode())
    os.close(write_fd)  # what the kernel does when the task's worker dies
    return read_fd


def test_orphan_guard_stops_the_whole_group_of_a_dead_task(tmp_path):
    scratch = tmp_path / "c3bf-run-x"
    (scratch / "runs").mkdir(parents=True)
    group = subprocess.Popen(["sh", "-c", "sleep 60 & sleep 60; wait"], start_new_session=True)
    try:
        time.sleep(0.2)
        t0 = time.monotonic()
        link = _closed_link(f"dir {scratch}\ngroup {group.pid}\n")
        assert orphan_guard.guard(link, grace=2.0, period=0.05) is True
        assert time.monotonic() - t0 < 10.0
        assert not scratch.exists()
        group.wait(timeout=5)
        deadline = time.monotonic() + 5.0  # the background sleep (SIGINT-immune) goes too
        while orphan_guard.group_alive(group.pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not orphan_guard.group_alive(group.pid)
    finally:
        if group.poll() is None:
            os.killpg(group.pid, signal.SIGKILL)


def test_orphan_guard_removes_the_scratch_of_a_dead_task_whose_run_ended(tmp_path):
    group = subprocess.Popen(["true"], start_new_session=True)
    group.wait()
    link = _closed_link(f"dir {tmp_path}\ngroup {group.pid}\n")
    assert orphan_guard.guard(link, period=0.05) is False
    assert not tmp_path.exists()


def _link_guard(lines: str, tmp_path):
    """Run guard() on a link that said ``lines`` and then closed; (result, folder, group)."""
    folder = tmp_path / "scratch"
    folder.mkdir()
    group = subprocess.Popen(["sleep", "60"], start_new_session=True)
    link = _closed_link(lines.format(dir=folder, group=group.pid))
    try:
        return orphan_guard.guard(link, grace=2.0, period=0.05), folder, group
    finally:
        if group.poll() is None:
            time.sleep(0.5)  # let a stopped sleep be reaped before the caller looks
        group.poll()


def test_orphan_guard_link_closed_without_release_stops_and_removes(tmp_path):
    stopped, folder, group = _link_guard("dir {dir}\ngroup {group}\n", tmp_path)
    try:
        assert stopped is True and not folder.exists()
        assert group.wait(timeout=5) is not None
    finally:
        if group.poll() is None:
            group.kill()


def test_orphan_guard_link_released_touches_nothing(tmp_path):
    stopped, folder, group = _link_guard("dir {dir}\ngroup {group}\nend\n", tmp_path)
    try:
        assert stopped is False and folder.exists() and group.poll() is None
    finally:
        group.kill()
        group.wait()


def test_a_link_whose_guard_is_gone_does_not_fail_the_task(tmp_path):
    read_fd, write_fd = os.pipe()
    os.close(read_fd)  # the guard died
    link = orphan_guard.GuardLink(write_fd)
    link.remove_on_orphan(tmp_path)
    link.stop_on_orphan(12345)
    link.release()
    link.release()  # twice is harmless


OWNER = """
import subprocess, sys, tempfile, time
from safe_legged_c3bf.evaluation.orphan_guard import GuardLink
link = GuardLink.start(grace=2.0)
folder = tempfile.mkdtemp(dir=sys.argv[1])
link.remove_on_orphan(folder)
group = subprocess.Popen(["sleep", "60"], start_new_session=True)
link.stop_on_orphan(group.pid)
print(folder, group.pid, flush=True)
time.sleep(60)
"""


def test_a_task_killed_just_after_starting_its_bringup_leaves_nothing(tmp_path):
    """The guard exists before the task's folder and bringup: a kill at any moment is covered.

    (It used to be started after the bringup, so a worker killed in between left both.)
    """
    owner = subprocess.Popen([sys.executable, "-c", OWNER, str(tmp_path)], cwd=REPO,
                             stdout=subprocess.PIPE, text=True)
    try:
        folder, pgid = owner.stdout.readline().split()
        owner.kill()  # at once: the moment the old guard did not exist yet
        owner.wait()
        deadline = time.monotonic() + 30.0
        while ((orphan_guard.group_alive(int(pgid)) or Path(folder).exists())
               and time.monotonic() < deadline):
            time.sleep(0.1)
        assert not orphan_guard.group_alive(int(pgid)) and not Path(folder).exists()
    finally:
        if owner.poll() is None:
            owner.kill()


def test_orphan_guard_command_line_needs_a_link():
    for args in (["x"], ["123", "456"], ["--fd"], ["--fd", "x"], ["--detach", "--fd"],
                 ["--fd", "3", "2", "extra"]):
        assert orphan_guard.main(args) == 2, args


class FakeRay:
    """The few calls of the ray module that the pool's checks and collection use."""

    def __init__(self, nodes, result=None, error=None):
        self._nodes, self._result, self._error = nodes, result, error

    def nodes(self):
        return self._nodes

    def get(self, ref):
        if self._error:
            raise self._error
        return self._result


def test_capacity_check_refuses_tasks_no_node_can_hold(monkeypatch):
    fake = FakeRay([{"Alive": True, "Resources": {"CPU": 1.0, "memory": 2.0 * 2**30}},
                    {"Alive": False, "Resources": {"CPU": 8.0, "memory": 64.0 * 2**30}}])
    monkeypatch.setattr(ray_pool, "import_ray", lambda: fake)
    ray_pool.check_capacity(1.0, 2**30)
    with pytest.raises(ray_pool.RayConnectError, match="lower --ray-cpus"):
        ray_pool.check_capacity(2.0)  # the 8-CPU node is dead
    with pytest.raises(ray_pool.RayConnectError, match="4.0 GiB"):
        ray_pool.check_capacity(1.0, 4 * 2**30)


def test_a_failed_task_is_a_startup_failure_row_and_results_are_unpacked(tmp_path):
    spec = specs(1)[0]
    pool = ray_pool.RayPool(tmp_path, progress=quiet)
    rec, host = pool._collect(FakeRay([], error=RuntimeError("node died")), None, spec)
    assert rec["outcome"] == "startup_failed" and "node died" in rec["reason"] and host == "?"

    src = tmp_path / "worker"
    src.mkdir()
    (src / "report.json").write_text("{}")
    row = record_from_report(spec, make_report(), 0, 1.0, run_dir=src)
    result = {"row": row, "archive": ray_pool.pack(src), "run_dir": str(src), "host": "h/n"}
    rec, host = pool._collect(FakeRay([], result=result), None, spec)
    target = tmp_path / "runs" / spec.run_id
    assert host == "h/n" and rec["run_dir"] == str(target.resolve())
    assert (target / "report.json").is_file() and rec["outcome"] == row["outcome"]
