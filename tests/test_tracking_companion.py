"""A single run is logged by a companion process: real toy jobs, real processes, a real SQLite store.

The job's process never imports MLflow, the run is complete in the store when the command returns,
the companion's log lines reach the job's log file, and a job's process that dies without a word
(SIGKILL) still leaves its run KILLED, not RUNNING. ``companion=false`` logs from the job's process.
"""

from __future__ import annotations

import json
import os
import pickle
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hydra.core.utils import JobReturn, JobStatus
from mlflow.entities import Run
from mlflow.tracking import MlflowClient
from tracking_apps import TOY_APP, run_app, runs_of, start_app, unit_job_config, wait_for_files

from lwrlab.tracking import MlflowTracking
from lwrlab.tracking.companion import early_companion
from lwrlab.tracking.companion.companion_link import CompanionLink
from lwrlab.tracking.companion.process import GONE_REASON
from lwrlab.tracking.runs.finalise import KILLED_BY_TAG, OUTPUTS_TAG
from lwrlab.tracking.runs.forwarded_error import ForwardedError
from lwrlab.tracking.runs.processes import descendant_pids, process_alive, wait_until
from lwrlab.tracking.runs.run_logging import RUN_ID_FILE

PROCESS_FILE = "job_process.json"  # tests/apps/toy_app.py writes it when TOY_REPORT_PROCESS is set
COMPANION_FLAG = "hydra.callbacks.mlflow.companion"


def job_process(job_dir: Path) -> dict[str, object]:
    return json.loads((job_dir / PROCESS_FILE).read_text(encoding="utf-8"))


def start_sleeping_job(tmp_path: Path, experiment: str) -> tuple[subprocess.Popen[str], int]:
    """A toy job sleeping in its run (started by its companion); the job's process and the companion's pid."""
    job_dir = tmp_path / "run"
    process = start_app(
        TOY_APP,
        f"experiment_name={experiment}",
        f"hydra.run.dir={job_dir}",
        store=tmp_path,
        env={"TOY_SLEEP_S": "60"},
    )
    wait_for_files(job_dir, RUN_ID_FILE, 1, process)
    (companion,) = descendant_pids(process.pid)
    return process, companion


def test_a_single_run_is_logged_by_a_companion_while_the_job_never_imports_mlflow(tmp_path: Path) -> None:
    job_dir = tmp_path / "run"
    finished = run_app(
        TOY_APP,
        "experiment_name=companion",
        f"hydra.run.dir={job_dir}",
        "x=4",
        store=tmp_path,
        env={"TOY_REPORT_PROCESS": "1"},
    )
    assert finished.returncode == 0, finished.stderr
    job = job_process(job_dir)
    assert job["imported_mlflow"] is False

    (run,) = runs_of(f"sqlite:///{tmp_path / 'mlflow.db'}", "companion")  # complete when the command returned
    assert run.info.status == "FINISHED" and run.data.metrics["doubled"] == 8.0
    assert run.data.params["x"] == "4"
    assert run.data.tags["pid"] != str(job["pid"])  # the process that held the run open: the companion
    client = MlflowClient(f"sqlite:///{tmp_path / 'mlflow.db'}")
    logged = {artifact.path for artifact in client.list_artifacts(run.info.run_id)}
    assert {"table.csv", PROCESS_FILE, RUN_ID_FILE} <= logged
    # The companion's log line went through the job's logging, into its log file.
    assert f"MLflow run {run.info.run_id}" in (job_dir / "toy_app.log").read_text(encoding="utf-8")


def test_companion_false_logs_from_the_job_process(tmp_path: Path) -> None:
    job_dir = tmp_path / "run"
    finished = run_app(
        TOY_APP,
        "experiment_name=in_process",
        f"hydra.run.dir={job_dir}",
        f"{COMPANION_FLAG}=false",
        store=tmp_path,
        env={"TOY_REPORT_PROCESS": "1"},
    )
    assert finished.returncode == 0, finished.stderr
    job = job_process(job_dir)
    assert job["imported_mlflow"] is True
    (run,) = runs_of(f"sqlite:///{tmp_path / 'mlflow.db'}", "in_process")
    assert run.info.status == "FINISHED" and run.data.tags["pid"] == str(job["pid"])


def test_a_job_process_killed_outright_leaves_its_run_killed_by_the_companion(tmp_path: Path) -> None:
    process, companion = start_sleeping_job(tmp_path, "killed_outright")
    process.send_signal(signal.SIGKILL)  # only the job's process: nothing in it can run
    process.communicate(timeout=30)
    assert wait_until(lambda: not process_alive(companion), timeout_s=60), "the companion outlived its job"

    (run,) = runs_of(f"sqlite:///{tmp_path / 'mlflow.db'}", "killed_outright")
    assert run.info.status == "KILLED" and run.data.tags[KILLED_BY_TAG].startswith(GONE_REASON)
    assert "uploaded" in run.data.tags[OUTPUTS_TAG]


def test_a_failed_job_error_crosses_to_the_companion_as_text() -> None:
    try:
        raise ValueError("bad gain")
    except ValueError as error:
        forwarded = ForwardedError.of(error)
    again = pickle.loads(pickle.dumps(forwarded))
    assert (again.type_name, str(again)) == ("ValueError", "bad gain")
    assert "Traceback (most recent call last)" in again.traceback_text
    assert "raise ValueError" in again.traceback_text


def test_a_sigterm_during_the_job_ends_the_run_killed_and_the_companion(tmp_path: Path) -> None:
    process, companion = start_sleeping_job(tmp_path, "sigterm_companion")
    started = time.monotonic()
    process.send_signal(signal.SIGTERM)
    output = process.communicate(timeout=60)[0]
    assert process.returncode != 0, output[-3000:]  # (lwrlab's own exit status: test_tracking_signals)
    assert "ended KILLED" in output and time.monotonic() - started < 30
    assert wait_until(lambda: not process_alive(companion), timeout_s=30)
    (run,) = runs_of(f"sqlite:///{tmp_path / 'mlflow.db'}", "sigterm_companion")
    assert run.info.status == "KILLED" and "SIGTERM" in run.data.tags[KILLED_BY_TAG]


def _fail_to_start_companions(monkeypatch: pytest.MonkeyPatch, reason: str) -> None:
    """From now on, CompanionLink.start raises ``OSError(reason)``, as when no process can be started."""

    def cannot_start(cls: type, settings: object) -> None:
        raise OSError(reason)

    monkeypatch.setattr(CompanionLink, "start", classmethod(cannot_start))


def _log_a_unit_run(tmp_path: Path, experiment: str) -> Run:
    """Log one job that returns ``{"rms": 0.5}`` through the callback's hooks (companion on); its run."""
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    node = {"_target_": "lwrlab.tracking.MlflowTracking", "tracking_uri": uri, "experiment": experiment}
    config = unit_job_config(tmp_path, node)
    (tmp_path / "job").mkdir()
    callback = MlflowTracking(uri, experiment, None, True, True, True)
    callback.on_run_start(config)
    callback.on_job_start(config)
    callback.on_job_end(config, JobReturn(status=JobStatus.COMPLETED, _return_value={"rms": 0.5}))
    callback.on_run_end(config)
    (run,) = runs_of(uri, experiment)
    return run


def test_a_companion_that_cannot_start_leaves_the_run_to_the_job_process(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    _fail_to_start_companions(monkeypatch, "no processes left")
    run = _log_a_unit_run(tmp_path, "fallback")
    assert "did not start (OSError: no processes left)" in caplog.text
    assert run.info.status == "FINISHED" and run.data.metrics == {"rms": 0.5}
    assert run.data.tags["pid"] == str(os.getpid())


def _launched_links(monkeypatch: pytest.MonkeyPatch) -> list[CompanionLink]:
    """The companions CompanionLink.launch starts from now on, in order."""
    launched: list[CompanionLink] = []
    launch = CompanionLink.launch.__func__  # type: ignore[attr-defined]

    def recording(cls: type[CompanionLink]) -> CompanionLink:
        launched.append(launch(cls))
        return launched[-1]

    monkeypatch.setattr(CompanionLink, "launch", classmethod(recording))
    return launched


def test_the_single_run_adopts_the_companion_launched_before_hydra_composed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    launched = _launched_links(monkeypatch)
    early_companion.launch()  # as lwrlab does, before the callback exists
    _fail_to_start_companions(monkeypatch, "a second companion was started")
    run = _log_a_unit_run(tmp_path, "early")
    assert "did not start" not in caplog.text and early_companion.take() is None
    assert run.info.status == "FINISHED" and run.data.metrics == {"rms": 0.5}
    (companion,) = launched
    assert run.data.tags["pid"] == str(companion.process.pid) and companion.process.returncode == 0


def test_an_early_companion_is_ended_when_the_run_logs_from_the_job_process(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    launched = _launched_links(monkeypatch)
    early_companion.launch()
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    callback = MlflowTracking(uri, "off", None, True, True, False)  # companion: false in the config
    callback.on_run_start(unit_job_config(tmp_path, {}))
    (companion,) = launched
    assert companion.process.returncode == -signal.SIGKILL and early_companion.take() is None
    assert not (tmp_path / "mlflow.db").exists()  # it touched no store


def test_an_unconfigured_companion_exits_quietly_when_closed_or_left() -> None:
    closed = CompanionLink.launch()
    closed.close()
    assert closed.process.returncode == 0

    left = subprocess.run(  # a job's process that ends before its callback configured the companion
        [
            sys.executable,
            "-c",
            "import os; from lwrlab.tracking.companion.companion_link import CompanionLink; "
            "print(CompanionLink.launch().process.pid, flush=True); os._exit(0)",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    companion = int(left.stdout)
    assert wait_until(lambda: not process_alive(companion), timeout_s=60), "the companion outlived its job"


@pytest.mark.parametrize(
    ("command_line", "may"),
    [
        (["task=identification", "plant=log", "data.path=a.csv"], True),
        ([], True),
        (["-m", "seed=1,2"], False),
        (["--multirun", "seed=1,2"], False),
        (["--cfg", "job"], False),
        (["tracking=none"], False),
        (["hydra.callbacks.mlflow.companion=false"], False),
        (["hydra.mode=MULTIRUN", "seed=1,2"], False),
        (["tracking=server"], True),
    ],
)
def test_lwrlab_launches_a_companion_early_only_for_a_single_tracked_run(
    command_line: list[str], may: bool
) -> None:
    assert early_companion.may_log_a_single_run(command_line) is may
