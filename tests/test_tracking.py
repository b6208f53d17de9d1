"""MLflow tracking callback: a real Hydra app (tests/apps/toy_app.py) against a real SQLite store.

The toy app includes the repository's own ``conf/tracking`` group through ``hydra.searchpath``, so these
tests exercise the shipped YAML (interpolations, ``_target_``) and not a copy of it.
"""

from __future__ import annotations

import logging
import os
import socket
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from hydra.core.utils import JobReturn, JobStatus
from mlflow.entities import Run
from mlflow.tracking import MlflowClient
from omegaconf import OmegaConf
from tracking_apps import unit_job_config

from lwrlab.tracking import MlflowTracking, runs_table
from lwrlab.tracking.job_config.config_params import (
    PARAM_VALUE_MAX_LENGTH,
    config_hash,
    flatten_config,
    numeric_metrics,
)
from lwrlab.tracking.job_config.metric_sections import plain_name
from lwrlab.tracking.job_config.run_params import MAX_PARAMS, RESOLVED_CONFIG_ARTIFACT
from lwrlab.tracking.runs.run_logging import ERROR_FILE, RUN_ID_FILE
from lwrlab.tracking.store.sqlite import absolute_tracking_uri

REPO_ROOT = Path(__file__).resolve().parents[1]
TOY_APP = REPO_ROOT / "tests" / "apps" / "toy_app.py"
REPO_CONF = REPO_ROOT / "conf"

ToyAppRunner = Callable[..., subprocess.CompletedProcess[str]]


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One SQLite store for the module: creating its schema is the slow part of a first run."""
    return tmp_path_factory.mktemp("mlflow_store")


@pytest.fixture(scope="module")
def tracking_uri(store: Path) -> str:
    return f"sqlite:///{store / 'mlflow.db'}"


@pytest.fixture(scope="module")
def run_toy_app(store: Path, tracking_uri: str) -> ToyAppRunner:
    """Run the toy Hydra app in a subprocess, tracking into ``store``; returns the finished process."""

    def run(
        *overrides: str, multirun: bool = False, cwd: Path = store, tracked: bool = True
    ) -> subprocess.CompletedProcess[str]:
        # Overriding keys of the callback node is an error once `tracking=none` has removed it.
        store_overrides = [
            f"hydra.callbacks.mlflow.tracking_uri={tracking_uri}",
            f"hydra.callbacks.mlflow.artifact_location={store / 'artifacts'}",
        ]
        command = [
            sys.executable,
            str(TOY_APP),
            *(["-m"] if multirun else []),  # Hydra's flags must come before the overrides
            f"hydra.searchpath=[file://{REPO_CONF}]",
            *(store_overrides if tracked else []),
            *overrides,
        ]
        environment = dict(
            os.environ, PYTHONPATH=os.pathsep.join([str(REPO_ROOT), os.environ.get("PYTHONPATH", "")])
        )
        environment.pop("MLFLOW_TRACKING_URI", None)
        return subprocess.run(command, cwd=cwd, env=environment, capture_output=True, text=True, timeout=120)

    return run


def runs_of(tracking_uri: str, experiment: str) -> list[Run]:
    client = MlflowClient(tracking_uri=tracking_uri)
    found = client.get_experiment_by_name(experiment)
    assert found is not None, f"experiment {experiment!r} was not created"
    return list(client.search_runs([found.experiment_id], order_by=["attributes.start_time ASC"]))


def artifact_paths(tracking_uri: str, run_id: str) -> set[str]:
    return {artifact.path for artifact in MlflowClient(tracking_uri=tracking_uri).list_artifacts(run_id)}


def git_head() -> str | None:
    try:
        completed = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=REPO_ROOT, capture_output=True, text=True, timeout=10
        )
    except OSError:
        return None
    return completed.stdout.strip() if completed.returncode == 0 else None


# -- real Hydra app, real store ---------------------------------------------------------------


def test_completed_job_is_a_finished_run_with_params_tags_metrics_and_artifacts(
    run_toy_app: ToyAppRunner, tracking_uri: str, tmp_path: Path
) -> None:
    # Launched from the repository so that the git commit is known; every output goes to tmp_path.
    job_dir = tmp_path / "run"
    finished = run_toy_app("experiment_name=toy_ok", f"hydra.run.dir={job_dir}", "x=3", cwd=REPO_ROOT)
    assert finished.returncode == 0, finished.stderr

    (run,) = runs_of(tracking_uri, "toy_ok")
    assert run.info.status == "FINISHED"
    assert run.info.run_name == "x=3"  # what differs; where it is logged is left out
    assert (job_dir / RUN_ID_FILE).read_text().strip() == run.info.run_id

    params = run.data.params
    assert params["x"] == "3"  # overridden: it tells the run apart
    assert params["seed"] == "7"  # a knob that changes results
    assert params["tracking"] == "sqlite"  # a plugin choice by its short name
    assert "model.gains" not in params and "model.nested.depth" not in params  # neither set nor a knob
    assert not any(key.startswith("hydra") for key in params) and len(params) <= MAX_PARAMS
    assert all("\n" not in value and not value.startswith(("[", "{")) for value in params.values())
    client = MlflowClient(tracking_uri=tracking_uri)
    resolved = OmegaConf.load(
        client.download_artifacts(run.info.run_id, RESOLVED_CONFIG_ARTIFACT, str(tmp_path))
    )
    assert list(resolved.model.gains) == [1.0, 2.0, 3.0] and resolved.model.nested.depth == 2  # all of it

    tags = run.data.tags
    assert tags["overrides"] == "experiment_name=toy_ok x=3"  # the task overrides, not hydra.*
    assert tags["mlflow.source.name"] == "lwrlab experiment_name=toy_ok x=3"  # the UI's Source column
    assert tags["seed"] == "7"
    assert tags["run_kind"] == "job"
    assert tags["lwrlab_version"] and tags["mlflow_version"] and tags["numpy_version"]
    saved_config = OmegaConf.to_container(OmegaConf.load(job_dir / ".hydra" / "config.yaml"), resolve=True)
    assert isinstance(saved_config, dict)
    assert tags["config_hash"] == config_hash(saved_config)
    head = git_head()
    if head is not None:
        assert tags["git_commit"] == head

    # A list item is a joint's figure: filed under `joints/`; `doubled` has no section (MLflow's default).
    assert run.data.metrics == {"doubled": 6.0, "joints/per_joint_rms.0": 0.5, "joints/per_joint_rms.1": 0.25}
    returned = {"doubled": 6.0, "per_joint_rms.0": 0.5, "per_joint_rms.1": 0.25}
    assert {plain_name(key): value for key, value in run.data.metrics.items()} == returned
    assert {"table.csv", ".hydra", RUN_ID_FILE, "toy_app.log"} <= artifact_paths(
        tracking_uri, run.info.run_id
    )
    assert ERROR_FILE not in artifact_paths(tracking_uri, run.info.run_id)

    table = runs_table(tracking_uri, "toy_ok")
    assert list(table["run_id"]) == [run.info.run_id]
    assert table.loc[0, "metrics.doubled"] == 6.0


def test_failed_job_is_a_failed_run_carrying_the_error_and_partial_outputs(
    run_toy_app: ToyAppRunner, tracking_uri: str, tmp_path: Path
) -> None:
    job_dir = tmp_path / "run"
    finished = run_toy_app("experiment_name=toy_fail", f"hydra.run.dir={job_dir}", "fail=true")
    assert finished.returncode != 0  # the callback must not swallow the job's exception
    assert "toy failure requested" in finished.stderr

    (run,) = runs_of(tracking_uri, "toy_fail")
    assert run.info.status == "FAILED"
    assert run.data.tags["error"] == "RuntimeError: toy failure requested with x=1"
    assert run.data.metrics == {}
    # Partial outputs stay on disk and are logged, next to the full traceback.
    assert (job_dir / "table.csv").is_file()
    error_text = (job_dir / ERROR_FILE).read_text()
    assert "Traceback (most recent call last)" in error_text and "toy_app.py" in error_text
    assert {"table.csv", ERROR_FILE, ".hydra"} <= artifact_paths(tracking_uri, run.info.run_id)


def test_multirun_is_a_parent_run_with_one_nested_run_per_job(
    run_toy_app: ToyAppRunner, tracking_uri: str, tmp_path: Path
) -> None:
    finished = run_toy_app(
        "experiment_name=toy_sweep", f"hydra.sweep.dir={tmp_path / 'sweep'}", "x=1,2", multirun=True
    )
    assert finished.returncode == 0, finished.stderr

    runs = runs_of(tracking_uri, "toy_sweep")
    (parent,) = [run for run in runs if run.data.tags["run_kind"] == "sweep"]
    jobs = [run for run in runs if run.data.tags["run_kind"] == "job"]
    assert len(jobs) == 2
    assert sorted(run.data.params["x"] for run in jobs) == ["1", "2"]
    assert sorted(run.data.metrics["doubled"] for run in jobs) == [2.0, 4.0]
    assert all(run.data.tags["mlflow.parentRunId"] == parent.info.run_id for run in jobs)
    assert all(run.info.status == "FINISHED" for run in runs)
    assert parent.data.tags["overrides"] == "experiment_name=toy_sweep x=1,2"
    assert "multirun.yaml" in artifact_paths(tracking_uri, parent.info.run_id)
    assert len(runs_table(tracking_uri, "toy_sweep", "tags.run_kind = 'job'")) == 2


def test_tracking_none_runs_the_job_without_a_run(run_toy_app: ToyAppRunner, tmp_path: Path) -> None:
    job_dir = tmp_path / "run"
    finished = run_toy_app("tracking=none", f"hydra.run.dir={job_dir}", tracked=False)
    assert finished.returncode == 0, finished.stderr
    assert (job_dir / "table.csv").is_file()
    assert not (job_dir / RUN_ID_FILE).exists()


# -- the callback in process ------------------------------------------------------------------


def test_settings_are_re_read_from_eachunit_job_config(tmp_path: Path) -> None:
    # Hydra builds callbacks once from the primary config; a sweep over experiment_name must
    # still send each job to its own experiment, and relative stores stay at the launch folder.
    node = {
        "_target_": "lwrlab.tracking.MlflowTracking",
        "tracking_uri": "sqlite:///outputs/mlflow.db",
        "experiment": "${experiment_name}",
        "artifact_location": "outputs/mlartifacts",
    }
    callback = MlflowTracking("sqlite:///outputs/mlflow.db", "primary_name", None, True, True, True)
    settings = callback.in_process().settings_for(unit_job_config(tmp_path, node))
    assert settings.experiment == "swept_name"
    assert settings.tracking_uri == f"sqlite:///{tmp_path.resolve()}/outputs/mlflow.db"
    assert settings.artifact_location == str(tmp_path.resolve() / "outputs" / "mlartifacts")


def test_unreachable_server_warns_once_and_keeps_the_job_result(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    with socket.socket() as probe:  # a port nobody listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    uri = f"http://127.0.0.1:{port}"
    # Hooks called without on_run_start (no companion): the callback logs from this process.
    callback = MlflowTracking(uri, "unreachable", None, True, True, True)
    config = unit_job_config(
        tmp_path, {"_target_": "lwrlab.tracking.MlflowTracking", "tracking_uri": uri, "experiment": "x"}
    )
    (tmp_path / "job").mkdir()
    with caplog.at_level(logging.DEBUG, logger="lwrlab.tracking.lifecycle.mlflow_callback"):
        for status, value in [
            (JobStatus.COMPLETED, {"metrics": {"a": 1.0}}),
            (JobStatus.FAILED, ValueError("boom")),
        ]:
            callback.on_job_start(config)
            callback.on_job_end(config, JobReturn(status=status, _return_value=value))
    warnings = [record for record in caplog.records if record.levelno == logging.WARNING]
    assert len(warnings) == 1 and "no MLflow server answers" in warnings[0].getMessage()
    assert "ValueError: boom" in (tmp_path / "job" / ERROR_FILE).read_text()


# -- pure helpers -----------------------------------------------------------------------------


def test_flatten_config_joins_keys_stringifies_lists_and_truncates() -> None:
    flat = flatten_config(
        {"a": {"b": {"c": 1}, "empty": {}}, "gains": [1, 2.5], "none": None, "long": "x" * 10_000}
    )
    assert flat["a.b.c"] == "1"
    assert flat["a.empty"] == "{}"
    assert flat["gains"] == "[1, 2.5]"
    assert flat["none"] == "None"
    assert len(flat["long"]) == PARAM_VALUE_MAX_LENGTH and flat["long"].endswith("...")


def test_numeric_metrics_keeps_numbers_only() -> None:
    np = pytest.importorskip("numpy")
    metrics = numeric_metrics(
        {
            "metrics": {
                "rms": np.array([0.1, 0.2]),
                "mean": np.float32(0.5),
                "ok": True,
                "name": "x",
                "per": {"j1": 1},
            }
        }
    )
    assert metrics == pytest.approx({"rms.0": 0.1, "rms.1": 0.2, "mean": 0.5, "per.j1": 1.0})
    assert numeric_metrics({"loss": 2}) == {"loss": 2.0}  # a flat dict of numbers
    assert numeric_metrics(0.25) == {"return_value": 0.25}  # what a sweeper optimises
    assert numeric_metrics(None) == {}


def test_absolute_tracking_uri(tmp_path: Path) -> None:
    assert absolute_tracking_uri("sqlite:///out/m.db", tmp_path) == f"sqlite:///{tmp_path.resolve()}/out/m.db"
    assert absolute_tracking_uri("sqlite:////abs/m.db", tmp_path) == "sqlite:////abs/m.db"
    assert absolute_tracking_uri("http://host:5000", tmp_path) == "http://host:5000"
    assert absolute_tracking_uri("databricks", tmp_path) == "databricks"


@pytest.mark.parametrize("variable", [None, "sqlite:///elsewhere.db"])
def test_mlflows_global_uri_set_for_a_block_leaves_the_environment_as_it_was(
    variable: str | None, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """MLflow's own setter writes MLFLOW_TRACKING_URI (and unsets it when it restores none): the
    fluent calls of model logging and run tables must not leave a job reading another store."""
    import mlflow

    from lwrlab.tracking.store.connection import global_tracking_uri

    if variable is None:
        monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    else:
        monkeypatch.setenv("MLFLOW_TRACKING_URI", variable)
    before = mlflow.get_tracking_uri()
    inside = f"sqlite:///{tmp_path / 'store.db'}"
    with global_tracking_uri(inside):
        assert mlflow.get_tracking_uri() == inside
    assert os.environ.get("MLFLOW_TRACKING_URI") == variable
    assert mlflow.get_tracking_uri() == before
