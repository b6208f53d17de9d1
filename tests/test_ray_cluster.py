"""`hydra/launcher=ray` on a real two-node Ray cluster (head + worker node) bound to 127.0.0.1 only.

Slow and optional: skipped without the [ray] extra. The cluster is started by the test
(tests/apps/ray_loopback_cluster.py); every listening socket of its processes, and of the sweep's,
is checked to be on loopback with ``ss -tlnp``, and none of its processes outlives it. A sweep
survives the loss of the worker node mid-job: Ray retries the job on the head, which leaves one
FINISHED run per config and the dead attempt's run KILLED (none RUNNING).
"""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from tracking_apps import (
    REPO_ROOT,
    TOY_APP,
    jobs_and_parents,
    release_held_jobs,
    run_app,
    runs_of,
    start_app,
    wait_for_held_jobs,
)

from lwrlab.tracking.runs.finalise import KILLED_BY_TAG
from lwrlab.tracking.runs.processes import descendant_pids, process_alive, send_signal, wait_until
from lwrlab.tracking.runs.run_queries import RETRIED_BY_TAG

RAY_MISSING = importlib.util.find_spec("hydra_plugins.hydra_ray_launcher") is None
CLUSTER_APP = REPO_ROOT / "tests" / "apps" / "ray_loopback_cluster.py"
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(
        RAY_MISSING, reason="optional extra [ray] (hydra-ray-launcher) not installed: pip install -e '.[ray]'"
    ),
    pytest.mark.skipif(shutil.which("ss") is None, reason="needs `ss` (iproute2) to list listening sockets"),
]
RAY_ENV = {"RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0", "RAY_USAGE_STATS_ENABLED": "0"}
LOOPBACK = re.compile(r"^(127\.\d+\.\d+\.\d+|\[::ffff:127\.\d+\.\d+\.\d+\]|\[::1\]):\d+$")


def listening_addresses(pids: set[int]) -> list[str]:
    """Local addresses on which processes ``pids`` listen (TCP)."""
    listing = subprocess.run(["ss", "-tlnpH"], capture_output=True, text=True, check=True).stdout
    found = []
    for line in listing.splitlines():
        owners = {int(pid) for pid in re.findall(r"pid=(\d+)", line)}
        if owners & pids:
            found.append(line.split()[3])
    return found


@dataclass
class LoopbackCluster:
    """The cluster process (its stdin keeps the cluster up), its address and the worker node's raylet."""

    process: subprocess.Popen[str]
    address: str
    worker_raylet: int
    seen: set[int] = field(default_factory=set)
    """Every process of the cluster seen during the test: none may outlive it."""

    def processes(self) -> set[int]:
        """The cluster's processes now (remembered, to check that they all end)."""
        now = {self.process.pid, *descendant_pids(self.process.pid)}
        self.seen |= now
        return now


@pytest.fixture
def cluster():
    temp_dir = tempfile.mkdtemp(prefix="rayc", dir="/tmp")  # Ray's socket paths must stay short
    environment = dict(os.environ, PYTHONPATH=str(REPO_ROOT))
    process = subprocess.Popen(
        [sys.executable, str(CLUSTER_APP), temp_dir],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env=environment,
    )
    try:
        lines = [process.stdout.readline(), process.stdout.readline()]
        assert lines[0].startswith("address ") and lines[1].startswith("worker-raylet "), (
            f"the cluster did not start: {lines!r}"
        )
        started = LoopbackCluster(process, lines[0].split()[1], int(lines[1].split()[1]))
        started.processes()
        yield started
    finally:
        process.stdin.close()
        process.wait(timeout=120)
        shutil.rmtree(temp_dir, ignore_errors=True)
    # Ray's clean-up is asynchronous (a raylet's workers notice it has gone).
    wait_until(lambda: not any(process_alive(pid) for pid in started.seen), 30.0)
    assert not [pid for pid in started.seen if process_alive(pid)], "Ray processes outlived the cluster"


def sweep_overrides(cluster: LoopbackCluster, experiment: str, sweep_dir: Path) -> list[str]:
    """A 6-job toy sweep on the cluster (``x=1,2,3`` × ``seed=0,1``)."""
    return [
        "hydra/launcher=ray",
        f"hydra.launcher.ray.init.address={cluster.address}",
        f"experiment_name={experiment}",
        f"hydra.sweep.dir={sweep_dir}",
        "x=1,2,3",
        "seed=0,1",
    ]


def assert_on_loopback(pids: set[int]) -> None:
    """Every TCP socket on which ``pids`` listen is on 127.0.0.1 (and they listen on some)."""
    addresses = listening_addresses(pids)
    assert addresses and all(LOOPBACK.match(address) for address in addresses), addresses


def test_a_sweep_on_a_two_node_loopback_cluster_finishes_every_run(
    tmp_path: Path, cluster: LoopbackCluster
) -> None:
    assert_on_loopback(cluster.processes())
    finished = run_app(
        TOY_APP,
        *sweep_overrides(cluster, "ray_cluster", tmp_path / "sweep"),
        store=tmp_path,
        multirun=True,
        timeout=600,
        env=RAY_ENV,
    )
    assert finished.returncode == 0, finished.stderr[-4000:]
    assert "object_store_memory must not be provided" not in finished.stderr
    jobs, parents = jobs_and_parents(runs_of(f"sqlite:///{tmp_path / 'mlflow.db'}", "ray_cluster"))
    assert len(parents) == 1 and len(jobs) == 6
    assert all(run.info.status == "FINISHED" for run in jobs + parents)
    assert len({run.data.tags["pid"] for run in jobs}) >= 2  # both nodes' workers ran jobs
    assert_on_loopback(cluster.processes())  # with the job workers now


def test_a_job_whose_node_is_lost_is_retried_and_its_dead_attempt_ends_killed(
    tmp_path: Path, cluster: LoopbackCluster
) -> None:
    hold_dir = tmp_path / "hold"
    hold_dir.mkdir()
    sweep = start_app(
        TOY_APP,
        *sweep_overrides(cluster, "ray_node_lost", tmp_path / "sweep"),
        # The cluster's workers do not inherit this process's environment: Ray passes it to the jobs.
        f"+hydra.launcher.ray.init.runtime_env={{env_vars: {{TOY_HOLD_DIR: '{hold_dir}'}}}}",
        store=tmp_path,
        multirun=True,
        env=RAY_ENV,
    )
    try:
        held = wait_for_held_jobs(hold_dir, 2, sweep, timeout=180)  # one job on each node (1 CPU each)
        worker_node = {cluster.worker_raylet, *descendant_pids(cluster.worker_raylet)}
        (lost,) = [job for job in held if job.pid in worker_node]
        assert_on_loopback(cluster.processes() | {sweep.pid, *descendant_pids(sweep.pid)})
        # The worker node crashes: its raylet and every process under it (the held job's worker too).
        send_signal(worker_node, signal.SIGKILL)
        assert wait_until(lambda: not any(process_alive(pid) for pid in worker_node), 30.0)
        release_held_jobs(hold_dir)  # Ray retries the lost job on the head, after the held one
        output = sweep.communicate(timeout=300)[0]
    finally:
        if sweep.poll() is None:
            os.killpg(sweep.pid, signal.SIGKILL)
            sweep.communicate()
    assert sweep.returncode == 0, output[-4000:]

    runs = runs_of(f"sqlite:///{tmp_path / 'mlflow.db'}", "ray_node_lost")
    assert not [run.info.run_id for run in runs if run.info.status == "RUNNING"], output[-4000:]
    jobs, parents = jobs_and_parents(runs)
    assert [run.info.status for run in parents] == ["FINISHED"]
    finished = {run.data.tags["config_hash"]: run for run in jobs if run.info.status == "FINISHED"}
    assert len(finished) == 6 and len([run for run in jobs if run.info.status == "FINISHED"]) == 6
    (dead,) = [run for run in jobs if run.info.status != "FINISHED"]
    assert dead.info.status == "KILLED" and dead.data.tags["pid"] == str(lost.pid)
    assert "worker was lost" in dead.data.tags[KILLED_BY_TAG]
    retry = finished[dead.data.tags["config_hash"]]
    assert dead.data.tags[RETRIED_BY_TAG] == retry.info.run_id and retry.data.tags["pid"] != str(lost.pid)
    assert {f"x={retry.data.params['x']}", f"seed={retry.data.params['seed']}"} <= set(lost.overrides.split())
