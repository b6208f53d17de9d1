"""Every stop ends runs in a final state: real signals sent to real processes, checked in a real store.

SIGTERM (``kill``, ``timeout``, Slurm pre-emption) and SIGINT (Ctrl-C) to a single job and to a joblib
sweep: the in-flight runs end KILLED with what their job wrote uploaded (and a tag saying so), the
sweep's parent run ends KILLED, and no worker process outlives the sweep. A sweep whose processes
were killed outright (SIGKILL, nothing can run) is finalised when it is resumed.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import signal
import subprocess
import tempfile
import time
from pathlib import Path

import pytest
from mlflow.tracking import MlflowClient
from tracking_apps import (
    TOY_APP,
    jobs_and_parents,
    runs_of,
    start_app,
    wait_for_files,
    wait_for_held_jobs,
)

from lwrlab.tracking.runs.finalise import KILLED_BY_TAG, OUTPUTS_TAG
from lwrlab.tracking.runs.processes import descendant_pids, process_alive, wait_until
from lwrlab.tracking.runs.run_logging import RUN_ID_FILE

# The paper's whole chain (identification, tool, painting in MuJoCo): ~10 s on one core, of which
# the run's start takes ~3 s (MLflow loads in the tracking companion), so a signal finds it busy.
CHAIN_JOB = ["task=paper_chain", "plant.show_progress=false"]
# A real identification job that runs ~3.5 s on one core (a 30 s motion), for the sweep's jobs.
LONG_JOB = [
    "task=identification",
    "trajectory=multisine",
    "trajectory.duration=30",
    "validation.duration=2",
    "plant.show_progress=false",
]


def wait_for_runs(
    folder: Path, count: int, process: subprocess.Popen[str], timeout: float = 120
) -> list[Path]:
    """Wait until ``count`` jobs under ``folder`` have started their MLflow run (their run id file)."""
    return wait_for_files(folder, RUN_ID_FILE, count, process, timeout)


def stop(process: subprocess.Popen[str], signum: int, whole_group: bool = False, timeout: float = 120) -> str:
    """Send ``signum`` to the process (or, like Ctrl-C in a terminal, to its whole group); its output."""
    if whole_group:
        os.killpg(process.pid, signum)
    else:
        process.send_signal(signum)
    try:
        return process.communicate(timeout=timeout)[0]
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        raise


def artifact_paths(client: MlflowClient, run_id: str, path: str | None = None) -> set[str]:
    found = set()
    for entry in client.list_artifacts(run_id, path):
        found |= artifact_paths(client, run_id, entry.path) if entry.is_dir else {entry.path}
    return found


def assert_killed_with_outputs(client: MlflowClient, run_id: str, signal_name: str, written: str) -> None:
    run = client.get_run(run_id)
    assert run.info.status == "KILLED" and run.info.end_time is not None
    assert signal_name in run.data.tags[KILLED_BY_TAG]
    assert "uploaded" in run.data.tags[OUTPUTS_TAG], run.data.tags[OUTPUTS_TAG]
    assert {written, ".hydra/config.yaml"} <= artifact_paths(client, run_id)


@pytest.mark.parametrize(
    "signum", [signal.SIGTERM, pytest.param(signal.SIGINT, marks=pytest.mark.slow)], ids=["SIGTERM", "SIGINT"]
)
def test_a_stopped_toy_job_ends_killed_with_its_outputs(tmp_path: Path, signum: int) -> None:
    process = start_app(
        TOY_APP,
        "experiment_name=stop_toy",
        f"hydra.run.dir={tmp_path / 'run'}",
        store=tmp_path,
        env={"TOY_SLEEP_S": "60"},
    )
    wait_for_runs(tmp_path / "run", 1, process)
    while not (tmp_path / "run" / "table.csv").exists():
        time.sleep(0.1)
    output = stop(process, signum)
    assert process.returncode != 0
    (run,) = runs_of(f"sqlite:///{tmp_path / 'mlflow.db'}", "stop_toy")
    assert_killed_with_outputs(
        MlflowClient(f"sqlite:///{tmp_path / 'mlflow.db'}"),
        run.info.run_id,
        signal.Signals(signum).name,
        "table.csv",
    )
    assert "ended KILLED" in output and "uploaded" in output  # said so


@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_a_stopped_lwrlab_job_ends_killed_with_exit_status_128_plus_signal(
    tmp_path: Path, signum: int
) -> None:
    process = start_app(
        None, "experiment_name=stop_job", f"hydra.run.dir={tmp_path / 'run'}", *CHAIN_JOB, store=tmp_path
    )
    wait_for_runs(tmp_path / "run", 1, process)
    time.sleep(1.0)
    output = stop(process, signum)
    assert process.returncode == 128 + signum, output[-3000:]
    (run,) = runs_of(f"sqlite:///{tmp_path / 'mlflow.db'}", "stop_job")
    assert_killed_with_outputs(
        MlflowClient(f"sqlite:///{tmp_path / 'mlflow.db'}"),
        run.info.run_id,
        signal.Signals(signum).name,
        "cli.log",
    )
    assert "Traceback" not in output and "runs in flight ended KILLED" in output


def _sweep_and_stop(
    tmp_path: Path,
    app: Path | None,
    overrides: list[str],
    signum: int,
    whole_group: bool,
    env: dict[str, str] | None = None,
):
    sweep_dir = tmp_path / "sweep"
    process = start_app(
        app,
        "hydra/launcher=parallel",
        f"hydra.sweep.dir={sweep_dir}",
        *overrides,
        store=tmp_path,
        multirun=True,
        env=env,
    )
    wait_for_runs(sweep_dir, 2, process)  # two workers busy
    time.sleep(0.5)
    workers = descendant_pids(process.pid)
    assert workers, "the joblib launcher started no worker process"
    output = stop(process, signum, whole_group)
    return process, output, workers


@pytest.mark.slow  # ~15 s each: Python, MLflow and two loky workers start on a small machine
@pytest.mark.parametrize(
    ("signum", "whole_group"),
    [(signal.SIGTERM, False), (signal.SIGINT, True)],
    ids=["SIGTERM-to-parent", "SIGINT-to-group"],
)
def test_a_stopped_joblib_sweep_leaves_no_run_running_and_no_worker_alive(
    tmp_path: Path, signum: int, whole_group: bool
) -> None:
    process, output, workers = _sweep_and_stop(
        tmp_path,
        TOY_APP,
        ["experiment_name=stop_sweep", "x=1,2,3,4"],
        signum,
        whole_group,
        env={"TOY_SLEEP_S": "60"},
    )
    assert process.returncode != 0
    time.sleep(0.5)
    assert not [pid for pid in workers if process_alive(pid)], f"orphaned workers:\n{output[-3000:]}"
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    jobs, parents = jobs_and_parents(runs_of(uri, "stop_sweep"))
    assert len(parents) == 1 and parents[0].info.status == "KILLED" and len(jobs) == 2, output[-3000:]
    client = MlflowClient(uri)
    for run in jobs:
        assert_killed_with_outputs(client, run.info.run_id, signal.Signals(signum).name, "table.csv")


@pytest.mark.slow
def test_a_sigterm_to_an_lwrlab_joblib_sweep_ends_every_run(tmp_path: Path) -> None:
    process, output, workers = _sweep_and_stop(
        tmp_path,
        None,
        ["experiment_name=stop_lwrlab_sweep", "seed=0,1,2,3", *LONG_JOB],
        signal.SIGTERM,
        False,
    )
    assert process.returncode == 128 + signal.SIGTERM, output[-3000:]
    time.sleep(0.5)
    assert not [pid for pid in workers if process_alive(pid)]
    jobs, parents = jobs_and_parents(runs_of(f"sqlite:///{tmp_path / 'mlflow.db'}", "stop_lwrlab_sweep"))
    assert [run.info.status for run in parents] == ["KILLED"] and {run.info.status for run in jobs} == {
        "KILLED"
    }


@pytest.mark.slow
def test_a_resumed_sweep_finalises_runs_whose_processes_were_killed_outright(tmp_path: Path) -> None:
    sweep = ["experiment_name=stale", "x=1,2,3"]
    process = start_app(
        TOY_APP,
        "hydra/launcher=parallel",
        f"hydra.sweep.dir={tmp_path / 'a'}",
        *sweep,
        store=tmp_path,
        multirun=True,
        env={"TOY_SLEEP_S": "60"},
    )
    wait_for_runs(tmp_path / "a", 2, process)
    wait_for_files(tmp_path / "a", "table.csv", 2, process, 120)  # what the killed jobs wrote, kept
    workers = descendant_pids(process.pid)
    os.killpg(process.pid, signal.SIGKILL)  # nothing in these processes can run
    process.communicate(timeout=30)
    for pid in workers:  # loky workers are in the same group; wait until they are gone
        while process_alive(pid):
            time.sleep(0.1)
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    jobs, parents = jobs_and_parents(runs_of(uri, "stale"))
    assert {run.info.status for run in jobs + parents} == {"RUNNING"}  # what a kill -9 leaves

    resumed = start_app(
        TOY_APP,
        "hydra/launcher=parallel",
        f"hydra.sweep.dir={tmp_path / 'b'}",
        *sweep,
        store=tmp_path,
        multirun=True,
    )
    output = resumed.communicate(timeout=300)[0]
    assert resumed.returncode == 0, output[-3000:]
    jobs, parents = jobs_and_parents(runs_of(uri, "stale"))
    stale = [run for run in jobs if run.info.status == "KILLED"]
    assert len(stale) == 2 and all("no longer exists" in run.data.tags[KILLED_BY_TAG] for run in stale)
    assert all(
        "table.csv" in artifact_paths(MlflowClient(uri), run.info.run_id) for run in stale
    )  # what they wrote
    finished = [run for run in jobs if run.info.status == "FINISHED"]
    assert sorted(run.data.params["x"] for run in finished) == ["1", "2", "3"]
    assert all(run.data.tags.get("retried_by") for run in stale)
    assert len(parents) == 1 and parents[0].info.status == "FINISHED"  # the same parent, reopened and ended


RAY_MISSING = importlib.util.find_spec("hydra_plugins.hydra_ray_launcher") is None


@pytest.mark.slow
@pytest.mark.skipif(
    RAY_MISSING, reason="optional extra [ray] (hydra-ray-launcher) not installed: pip install -e '.[ray]'"
)
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_a_stopped_ray_sweep_leaves_no_run_running_and_no_ray_process_alive(
    tmp_path: Path, signum: int
) -> None:
    ray_temp_dir = tempfile.mkdtemp(prefix="ray", dir="/tmp")  # Ray's socket paths must stay short
    hold_dir = tmp_path / "hold"
    hold_dir.mkdir()
    env = {"TOY_HOLD_DIR": str(hold_dir), "RAY_USAGE_STATS_ENABLED": "0", "RAY_TMPDIR": ray_temp_dir}
    process = start_app(
        TOY_APP,
        "hydra/launcher=ray_local",
        "experiment_name=stop_ray",
        f"hydra.sweep.dir={tmp_path / 'sweep'}",
        "x=1,2,3,4",
        store=tmp_path,
        multirun=True,
        env=env,
    )
    try:
        wait_for_held_jobs(hold_dir, 2, process, timeout=180)  # both busy, their table.csv written
        ray_processes = descendant_pids(process.pid)  # raylet, GCS, workers…
        output = stop(process, signum)
    finally:
        shutil.rmtree(ray_temp_dir, ignore_errors=True)
    # Ray's C++ crash handler arms a 3 s abort on SIGTERM; the runs must be ended before it fires.
    assert process.returncode != -signal.SIGABRT, f"aborted while ending the runs:\n{output[-3000:]}"
    wait_until(
        lambda: not any(process_alive(pid) for pid in ray_processes), 20.0
    )  # Ray's clean-up is asynchronous
    assert not [pid for pid in ray_processes if process_alive(pid)], f"Ray processes left:\n{output[-3000:]}"
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    jobs, parents = jobs_and_parents(runs_of(uri, "stop_ray"))
    assert [run.info.status for run in parents] == ["KILLED"], output[-3000:]
    assert len(jobs) >= 2 and {run.info.status for run in jobs} == {"KILLED"}
    client = MlflowClient(uri)
    # Ray's driver handles SIGTERM itself (it exits): the exit ends the runs. SIGINT reaches lwrlab's handler.
    reason = "exited before this job ended" if signum == signal.SIGTERM else "SIGINT"
    for run in jobs:
        assert_killed_with_outputs(client, run.info.run_id, reason, "table.csv")
