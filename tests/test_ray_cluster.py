"""`hydra/launcher=ray` on a real two-node Ray cluster (head + worker node) bound to 127.0.0.1 only.

Slow and optional: skipped without the [ray] extra. The cluster is started by the test
(tests/apps/ray_loopback_cluster.py); every listening socket of its processes, and of the sweep's,
is checked to be on loopback with ``ss -tlnp``.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from tracking_apps import REPO_ROOT, TOY_APP, jobs_and_parents, run_app, runs_of

from lwrlab.tracking.processes import descendant_pids

RAY_MISSING = importlib.util.find_spec("hydra_plugins.hydra_ray_launcher") is None
CLUSTER_APP = REPO_ROOT / "tests" / "apps" / "ray_loopback_cluster.py"
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(
        RAY_MISSING, reason="optional extra [ray] (hydra-ray-launcher) not installed: pip install -e '.[ray]'"
    ),
    pytest.mark.skipif(shutil.which("ss") is None, reason="needs `ss` (iproute2) to list listening sockets"),
]
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
        line = process.stdout.readline()
        assert line.startswith("address "), f"the cluster did not start: {line!r}"
        yield process, line.split()[1]
    finally:
        process.stdin.close()
        process.wait(timeout=120)
        shutil.rmtree(temp_dir, ignore_errors=True)


def test_a_sweep_on_a_two_node_loopback_cluster_finishes_every_run(tmp_path: Path, cluster) -> None:
    process, address = cluster
    nodes = descendant_pids(process.pid) + [process.pid]
    addresses = listening_addresses(set(nodes))
    assert addresses and all(LOOPBACK.match(address) for address in addresses), addresses

    finished = run_app(
        TOY_APP,
        "hydra/launcher=ray",
        f"hydra.launcher.ray.init.address={address}",
        "experiment_name=ray_cluster",
        f"hydra.sweep.dir={tmp_path / 'sweep'}",
        "x=1,2,3",
        "seed=0,1",
        store=tmp_path,
        multirun=True,
        timeout=600,
        env={"RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0", "RAY_USAGE_STATS_ENABLED": "0"},
    )
    assert finished.returncode == 0, finished.stderr[-4000:]
    assert "object_store_memory must not be provided" not in finished.stderr
    jobs, parents = jobs_and_parents(runs_of(f"sqlite:///{tmp_path / 'mlflow.db'}", "ray_cluster"))
    assert len(parents) == 1 and len(jobs) == 6
    assert all(run.info.status == "FINISHED" for run in jobs + parents)
    assert len({run.data.tags["pid"] for run in jobs}) >= 2  # both nodes' workers ran jobs
    workers = set(descendant_pids(process.pid))
    assert all(LOOPBACK.match(address) for address in listening_addresses(workers)), listening_addresses(
        workers
    )
