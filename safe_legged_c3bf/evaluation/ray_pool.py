"""Run an evaluation's bringups as Ray tasks, on a local Ray or on a cluster (``evaluate --ray``).

Every :class:`~safe_legged_c3bf.evaluation.runner.RunSpec` becomes one Ray task that reserves
``cpus`` CPUs (default 2: a bringup is 5-6 busy processes) and optionally ``memory`` bytes, and
runs exactly one bringup through a one-job :class:`~safe_legged_c3bf.evaluation.runner.Runner`
on the node Ray picks, so a task inherits the runner's wall-clock limit, its SIGINT -> SIGKILL
escalation on its process group and its result row. Per task:

* **ROS domain:** the bringup leases a private ROS domain on its host
  (:mod:`safe_legged_c3bf.run.ros_domain`: an exclusive ``flock`` per domain id in the host's
  temporary folder, held for the run's life) and talks over localhost only, so concurrent runs
  on a host never share a domain, whichever Ray node (raylet) started them.
* **Scenario:** the driver ships the scenario file's text, so every node runs exactly the
  scenario the driver planned (random scenarios exist only in the driver's output folder).
* **Cancel:** ``ray.cancel`` raises KeyboardInterrupt in the task, and the runner stops the
  bringup's group (SIGINT, SIGKILL after 15 s). If the worker itself dies (its driver was
  killed, a force-cancel, the node stops), Ray kills the worker's children (the bringup; its
  nodes follow by their parent-death signal) and :mod:`.orphan_guard` (a detached watcher the
  task starts before it creates anything, told of each folder and of the bringup as they
  appear) stops whatever of the group still runs and removes the task's scratch folders, so
  nothing outlives the task, whenever the worker dies.
* **Results:** the run folder (report.json, logs, time series, figures; 0.5-1 MB) comes back
  to the driver as a tar.gz in the task's return value and is unpacked into
  ``<out>/runs/<run_id>``; with ``shared_dir`` (a folder every node mounts at the same path)
  tasks write their run folders to ``<shared_dir>/runs/<run_id>`` and only the row comes back.

Ray is optional (``pip install '.[cluster]'``); :func:`import_ray` says so when it is missing.
"""

from __future__ import annotations

import io
import os
import shutil
import socket
import tarfile
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

from safe_legged_c3bf.evaluation import orphan_guard
from safe_legged_c3bf.evaluation.runner import (
    STOP_GRACE,
    Runner,
    RunSpec,
    describe,
    record_from_report,
    run_label,
)

INSTALL_HINT = "pip install '.[cluster]'"
#: CPUs a task reserves by default (a bringup: simulator, filter, tracker, planner, gait).
DEFAULT_CPUS = 2.0
#: Object store of a Ray started on demand (bytes): run folders are ~1 MB each.
LOCAL_OBJECT_STORE = 200 * 2**20
#: Ray retries a task whose worker or node died this often (a run is repeatable: same seed).
MAX_RETRIES = 2


class RayUnavailableError(RuntimeError):
    """Ray is not installed (or not usable) in this environment."""


class RayConnectError(RuntimeError):
    """Ray could not be started or reached, or it cannot run a task of this size."""


def import_ray():  # noqa: ANN201 - the ray module
    """The ray module, or RayUnavailableError naming the extra to install."""
    try:
        import ray
    except ImportError as err:
        raise RayUnavailableError(
            f"--ray needs Ray, which is not installed here ({err}). Install the cluster "
            f"extra: {INSTALL_HINT} (from the repository; or pip install 'ray>=2.9')"
        ) from None
    return ray


def connect(address: str | None = None, num_cpus: float | None = None) -> str:
    """Start a local Ray (``address`` None or 'local') or join a cluster; describe it.

    ``address`` is 'auto' (the cluster this machine belongs to), 'host:port' or
    'ray://host:10001'. ``num_cpus`` limits a Ray started here (default: every core).
    """
    ray = import_ray()
    if not ray.is_initialized():
        try:
            if address in (None, "", "local"):
                ray.init(address="local", num_cpus=num_cpus, include_dashboard=False,
                         object_store_memory=LOCAL_OBJECT_STORE)
            else:
                ray.init(address=address)
        except Exception as err:  # noqa: BLE001 - Ray raises many kinds; all mean "no Ray"
            where = "a local Ray" if address in (None, "", "local") else f"Ray at {address}"
            raise RayConnectError(f"could not start or reach {where}: {err}") from None
    nodes = [n for n in ray.nodes() if n.get("Alive")]
    cpus = sum(n.get("Resources", {}).get("CPU", 0.0) for n in nodes)
    return f"{len(nodes)} node(s), {cpus:g} CPUs"


def check_capacity(cpus: float, memory: int | None = None) -> None:
    """RayConnectError unless some alive node can hold one task (else it would wait forever)."""
    ray = import_ray()
    nodes = [n.get("Resources", {}) for n in ray.nodes() if n.get("Alive")]
    fits = [r for r in nodes if r.get("CPU", 0.0) >= cpus
            and (not memory or r.get("memory", 0.0) >= memory)]
    if not fits:
        largest = max((r.get("CPU", 0.0) for r in nodes), default=0.0)
        raise RayConnectError(
            f"no Ray node can run a task of {cpus:g} CPUs"
            f"{f' and {memory / 2**30:.1f} GiB' if memory else ''} (the largest node has "
            f"{largest:g} CPUs): lower --ray-cpus / --ray-memory or add bigger nodes")


# ------------------------------------------------------------------------------ the task


def execute_run(spec_fields: dict[str, Any], scenario_text: str | None, duration: float,
                options: dict[str, Any]) -> dict[str, Any]:
    """The body of one Ray task: run one bringup; return its row and its run folder.

    Returns {'row', 'archive' (tar.gz bytes of the run folder, None with a shared folder),
    'run_dir' (on the worker), 'host' ('<hostname>/<Ray node id>')}.
    """
    spec = RunSpec(**spec_fields)
    _mirror_driver_env(options.get("env") or {})
    shared = options.get("shared_dir")
    guard = orphan_guard.GuardLink.start(grace=STOP_GRACE)  # before anything it must clean up
    try:
        base = Path(shared) if shared else _scratch("c3bf-run-", guard)
        inputs = _scratch("c3bf-scenario-", guard)
        try:
            local = spec
            if scenario_text is not None:
                path = inputs / f"{_stem(spec.scenario)}.yaml"
                path.write_text(scenario_text, encoding="utf-8")
                local = replace(spec, scenario=str(path))
            runner = Runner(base, jobs=1, in_process=bool(options.get("in_process")),
                            full_duration=bool(options.get("full_duration")),
                            progress=lambda _line: None,
                            on_start=lambda _spec, proc: guard.stop_on_orphan(proc.pid))
            rec = runner.run([local], {spec.run_id: duration})[0]
            run_dir = (base / "runs" / spec.run_id).resolve()
            archive = None if shared else pack(run_dir)
            return {"row": rec, "archive": archive, "run_dir": str(run_dir),
                    "host": f"{socket.gethostname()}/{_node_id()}"}
        finally:
            shutil.rmtree(inputs, ignore_errors=True)
            if not shared:
                shutil.rmtree(base, ignore_errors=True)
    finally:
        guard.release()


def _scratch(prefix: str, guard: orphan_guard.GuardLink) -> Path:
    """A new temporary folder that ``guard`` removes if this worker dies."""
    folder = Path(tempfile.mkdtemp(prefix=prefix))
    guard.remove_on_orphan(folder)
    return folder


def _node_id() -> str:
    """The first 8 hex digits of this Ray node's id ('' outside Ray)."""
    try:
        import ray

        return ray.get_runtime_context().get_node_id()[:8]
    except Exception:  # noqa: BLE001 - only for the progress line
        return ""


def _mirror_driver_env(env: dict[str, str | None]) -> None:
    """Give the bringup the driver's value of the variables Ray sets for its workers.

    Ray sets OMP_NUM_THREADS to a task's CPUs; the local pool's bringups inherit the
    driver's value (usually unset), and runs should not depend on the pool.
    """
    for key, value in env.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value


def pack(folder: Path) -> bytes:
    """A tar.gz of ``folder``'s content (bytes)."""
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz") as tar:
        tar.add(folder, arcname=".")
    return buf.getvalue()


def unpack(archive: bytes, folder: Path) -> None:
    """Replace ``folder`` by the content of a :func:`pack` archive."""
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    with tarfile.open(fileobj=io.BytesIO(archive), mode="r:gz") as tar:
        tar.extractall(folder, filter="data")


def _stem(scenario: str) -> str:
    return Path(scenario).stem if scenario.endswith((".yaml", ".yml")) else scenario


# ------------------------------------------------------------------------------ the driver


def scenario_text(scenario: str) -> str | None:
    """The text of the scenario file of ``scenario`` (name or path), None if unreadable."""
    from safe_legged_c3bf.sim.scenario import ScenarioError, resolve_scenario

    try:
        return resolve_scenario(scenario).read_text(encoding="utf-8")
    except (ScenarioError, OSError):
        return None  # the bringup on the node reports it (start-up failure)


class RayPool:
    """Runs :class:`RunSpec` s as Ray tasks: :class:`Runner` under ``--ray``.

    Call :func:`connect` and :func:`check_capacity` first (a task no node can hold would wait
    forever).

    Args:
        out_dir: evaluation folder; run folders are unpacked into ``out_dir/runs/<run_id>``.
        cpus: CPUs each task reserves.
        memory: bytes of memory each task reserves (None: no reservation).
        in_process: pass ``--in-process`` to every bringup.
        full_duration: run every scenario to its end.
        shared_dir: a folder every node mounts at the same path; tasks write their run
            folders there instead of sending them back.
        progress: called with each progress line (default: print to stdout).

    """

    def __init__(self, out_dir: str | Path, cpus: float = DEFAULT_CPUS, memory: int | None = None,
                 in_process: bool = False, full_duration: bool = False,
                 shared_dir: str | Path | None = None,
                 progress: Callable[[str], None] | None = None) -> None:
        """Prepare the pool (Ray must be connected before :meth:`run`)."""
        self.out_dir = Path(out_dir)
        self.cpus = float(cpus)
        self.memory = memory
        self.shared_dir = str(Path(shared_dir).resolve()) if shared_dir else None
        self.options = {"in_process": in_process, "full_duration": full_duration,
                        "shared_dir": self.shared_dir,
                        "env": {"OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS")}}
        self._print = progress or (lambda line: print(line, flush=True))
        self._t0 = time.monotonic()

    def run(
        self,
        specs: Sequence[RunSpec],
        durations: dict[str, float] | None = None,
        on_result: Callable[[dict[str, Any]], None] | None = None,
    ) -> list[dict[str, Any]]:
        """Run every spec as a task; return the rows in the order of ``specs``.

        ``on_result`` gets each row as its task ends (in the calling thread). A
        KeyboardInterrupt cancels the tasks (their bringups are stopped) and re-raises.
        """
        ray = import_ray()
        ids = [s.run_id for s in specs]
        if len(set(ids)) != len(ids):
            raise ValueError("run ids must be unique")
        durations = durations or {}
        task = ray.remote(execute_run)
        resources = {"num_cpus": self.cpus, "max_retries": MAX_RETRIES}
        if self.memory:
            resources["memory"] = int(self.memory)
        self._t0 = time.monotonic()
        pending = {
            task.options(name=f"evaluate:{s.run_id}", **resources).remote(
                asdict(s), scenario_text(s.scenario), float(durations.get(s.run_id, 30.0)),
                self.options): s
            for s in specs
        }
        results: dict[str, dict[str, Any]] = {}
        try:
            while pending:
                ready, _ = ray.wait(list(pending), num_returns=1, timeout=0.5)
                for ref in ready:
                    spec = pending.pop(ref)
                    rec, host = self._collect(ray, ref, spec)
                    results[spec.run_id] = rec
                    self._say(len(results), len(specs),
                              f"done  {run_label(spec)} on {host} in "
                              f"{rec.get('wall_time') or 0.0:.0f} s: {describe(rec)}")
                    if on_result is not None:
                        on_result(rec)
        except KeyboardInterrupt:
            self._cancel(ray, list(pending))
            raise
        return [results[i] for i in ids]

    def _collect(self, ray, ref, spec: RunSpec) -> tuple[dict[str, Any], str]:  # noqa: ANN001
        """(row, host) of a finished task; a failed task is a start-up failure row."""
        target = (self.out_dir / "runs" / spec.run_id).resolve()
        try:
            out = ray.get(ref)
        except Exception as err:  # noqa: BLE001 - task error, worker or node died, cancelled
            rec = record_from_report(spec, None, None, 0.0, False, target)
            rec["reason"] = f"Ray task failed: {type(err).__name__}: {str(err)[:300]}"
            return rec, "?"
        rec = dict(out["row"])
        if out.get("archive") is not None:
            unpack(out["archive"], target)
            rec["run_dir"] = str(target)
        else:
            rec["run_dir"] = out.get("run_dir", "")
        return rec, str(out.get("host", "?"))

    def _cancel(self, ray, refs: list) -> None:  # noqa: ANN001
        """Cancel ``refs`` and give their bringups the time to stop."""
        self._print("evaluate: cancelling the Ray tasks (their bringups get SIGINT, then "
                    f"SIGKILL after {STOP_GRACE:g} s)")
        for ref in refs:
            try:
                ray.cancel(ref, force=False)
            except Exception:  # noqa: BLE001 - already finished or gone
                pass
        try:
            ray.wait(refs, num_returns=len(refs), timeout=STOP_GRACE + 10.0)
        except (KeyboardInterrupt, Exception):  # noqa: BLE001 - leaving anyway
            pass

    def _say(self, done: int, total: int, text: str) -> None:
        elapsed = time.monotonic() - self._t0
        self._print(f"[{done:>3}/{total}] {elapsed:6.0f} s  {text}")
