"""The main job, ``lwrlab``, run as a user runs it: a subprocess, real Hydra, real MLflow SQLite store."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mlflow.tracking import MlflowClient

from lwrlab.tracking.job_config.metric_sections import plain_metrics

REPO_ROOT = Path(__file__).resolve().parents[1]


def run_lwrlab(tmp_path: Path, *overrides: str, tracked: bool = True) -> subprocess.CompletedProcess[str]:
    """``lwrlab`` with its run folder and MLflow store under ``tmp_path``."""
    store = [
        f"hydra.callbacks.mlflow.tracking_uri=sqlite:///{tmp_path / 'mlflow.db'}",
        f"hydra.callbacks.mlflow.artifact_location={tmp_path / 'artifacts'}",
    ]
    command = [
        sys.executable,
        "-m",
        "lwrlab.cli",
        f"hydra.run.dir={tmp_path / 'run'}",
        "plant.show_progress=false",
        *(store if tracked else []),
        *overrides,
    ]
    environment = {k: v for k, v in os.environ.items() if k != "MLFLOW_TRACKING_URI"}
    return subprocess.run(
        command, cwd=REPO_ROOT, env=environment, capture_output=True, text=True, timeout=600
    )


def only_run(tmp_path: Path, experiment: str):
    client = MlflowClient(tracking_uri=f"sqlite:///{tmp_path / 'mlflow.db'}")
    found = client.get_experiment_by_name(experiment)
    assert found is not None, f"experiment {experiment!r} missing"
    runs = client.search_runs([found.experiment_id])
    assert len(runs) == 1
    return runs[0]


@pytest.mark.slow
def test_main_job_runs_the_whole_chain_and_leaves_one_finished_run(tmp_path: Path) -> None:
    """The default job: identification at the noise floor, then painting with a sensorless force estimate."""
    completed = run_lwrlab(tmp_path)
    assert completed.returncode == 0, completed.stderr[-3000:]
    assert "Validation torque error per joint" in completed.stdout and "Table IV" in completed.stdout
    run = only_run(tmp_path, "paper_chain")
    assert run.info.status == "FINISHED"
    metrics = plain_metrics(run.data.metrics)  # the names of metrics.json, without their MLflow sections
    rms = np.array([metrics[f"rms_joint{j}"] for j in range(1, 8)])
    np.testing.assert_allclose(rms, 0.1, rtol=0.10)  # σ_τ = 0.1 N·m: the raw measurement's noise floor
    identified = metrics["rms_large_roller_identified_estimate_estimated_vs_measured"]
    cad = metrics["rms_large_roller_cad_estimate_estimated_vs_measured"]
    assert identified <= 1.0 and identified < cad  # N: the identified model estimates the force better
    assert metrics["coverage_large_roller_identified_estimate"] > 0.98
    for name in (
        "summary.md",
        "base_parameters.csv",
        "identified_model.yaml",
        "torque_overlay.png",
        "exciting_motion.parquet",
        "painting/table4_force.csv",
        "painting/fig12_large_roller.png",
        "painting/fig13_large_roller.png",
    ):
        assert (tmp_path / "run" / name).is_file(), name


@pytest.mark.slow
def test_noiseless_data_give_the_true_base_parameters(tmp_path: Path) -> None:
    completed = run_lwrlab(tmp_path, "experiment=noiseless", "tracking=none", tracked=False)
    assert completed.returncode == 0, completed.stderr[-3000:]
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert metrics["base_parameter_error"] < 1e-6


def test_a_poorly_exciting_motion_is_warned_and_tagged_in_mlflow(tmp_path: Path) -> None:
    """A tiny motion still gives numbers: they come with a printed warning and the run's tags say so."""
    completed = run_lwrlab(
        tmp_path,
        "task=identification",
        "trajectory=multisine",
        "trajectory.duration=4",
        "trajectory.harmonics=2",
        "trajectory.limit_fraction=0.001",
        "validation.duration=4",
    )
    assert completed.returncode == 0, completed.stderr[-3000:]
    assert "WARNING: identifiability poor" in completed.stdout
    run = only_run(tmp_path, "identification")  # the experiment is named after the task
    assert run.info.status == "FINISHED"
    assert (
        run.data.tags["identifiability"] == "poor"
        and int(run.data.tags["warnings"]) >= 1
        and run.data.tags["data"] == "simulation"
    )
    assert run.data.metrics["diagnostics/cond_W_b_scaled"] > 500


def test_unknown_robot_lists_the_available_ones(tmp_path: Path) -> None:
    completed = run_lwrlab(tmp_path, "robot=nonexistent", "tracking=none", tracked=False)
    assert completed.returncode != 0
    for name in ("kuka_lwr4", "panda", "urdf", "mdh_file", "identified"):
        assert name in completed.stderr


@pytest.mark.slow
def test_a_run_that_raises_is_failed_in_mlflow_with_its_error(tmp_path: Path) -> None:
    completed = run_lwrlab(tmp_path, "robot=mdh_file", f"robot.path={tmp_path / 'missing.yaml'}")
    assert completed.returncode != 0
    run = only_run(tmp_path, "paper_chain")
    assert run.info.status == "FAILED"
    assert "missing.yaml" in json.dumps(run.data.tags)
