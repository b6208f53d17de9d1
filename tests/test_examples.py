"""The scripts of examples/ run end to end, each in a temporary folder, and produce what they say.

Each example is a ``run.sh`` taking its output folder as ``$1`` and the ``lwrlab`` command as
``$LWRLAB`` (here the console script beside this Python); every run tracks into a SQLite store inside
that folder, never into the repository's ``outputs/``. Slow: each takes 10-60 s.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

REPOSITORY = Path(__file__).resolve().parents[1]
EXAMPLES = REPOSITORY / "examples"
LWRLAB = Path(sys.executable).with_name("lwrlab")

pytestmark = pytest.mark.slow


def run_example(name: str, output: Path) -> str:
    """``examples/<name>/run.sh output`` with this environment's lwrlab and Python; its stdout."""
    if not LWRLAB.is_file():
        pytest.skip(f"no lwrlab console script beside {sys.executable}")
    environment = {**os.environ, "LWRLAB": str(LWRLAB), "PYTHON": sys.executable}
    completed = subprocess.run(
        ["bash", str(EXAMPLES / name / "run.sh"), str(output)],
        cwd=output.parent,
        env=environment,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert completed.returncode == 0, (
        f"examples/{name}/run.sh failed ({completed.returncode}):\n"
        f"{completed.stdout[-3000:]}\n{completed.stderr[-3000:]}"
    )
    return completed.stdout


def logged_run(store: Path, run_folder: Path) -> Any:
    """The MLflow run of ``run_folder``, read from the example's own store (it must be there)."""
    from mlflow.tracking import MlflowClient

    run_id = (run_folder / "mlflow_run_id.txt").read_text().strip()
    return MlflowClient(tracking_uri=f"sqlite:///{store}").get_run(run_id)


def test_own_robot_motion_is_accepted_and_exported_for_ros2(tmp_path: Path) -> None:
    output = tmp_path / "own_robot"
    stdout = run_example("own_robot", output)
    run = output / "excitation"
    metrics = json.loads((run / "metrics.json").read_text())
    assert metrics["accepted"] == 1.0 and metrics["violated_families"] == 0.0
    clearance = 0.01  # m, conf/trajectory/optimal.yaml
    assert metrics["closest_self_m"] >= clearance and metrics["closest_world_m"] >= clearance
    assert 1.0 < metrics["cond_W_b"] < 100.0
    goal = (run / "exciting_motion_goal.yaml").read_text()
    assert "control_msgs/action/FollowJointTrajectory" in goal and "shoulder_pan_joint" in goal
    assert (run / "exciting_motion_bag" / "metadata.yaml").is_file()
    assert (run / "exciting_motion_preview.png").stat().st_size > 20_000
    motion = pd.read_csv(run / "exciting_motion.csv")
    assert motion["t"].iloc[-1] == pytest.approx(4.0) and len(motion) == 4001  # 4 s at 1 kHz
    assert "pillar" in (run / ".hydra" / "config.yaml").read_text()  # the obstacle reached the config
    assert "accepted: True" in stdout
    assert logged_run(output / "mlflow.db", run).info.status == "FINISHED"


def test_logs_identified_joint_side_and_motor_side_alike(tmp_path: Path) -> None:
    output = tmp_path / "logs"
    stdout = run_example("logs", output)
    assert (output / "logs" / "csv" / "identification.csv").is_file()
    assert (output / "logs" / "parquet" / "validation.parquet").is_file()
    joint, motor = output / "runs" / "joint_side", output / "runs" / "motor_side"
    for run in (joint, motor):
        assert (run / "predicted_torque.parquet").is_file() and (run / "friction_choice.csv").is_file()
        assert logged_run(output / "mlflow.db", run).info.status == "FINISHED"
    metrics = json.loads((joint / "metrics.json").read_text())
    errors = pd.read_csv(joint / "errors_per_log.csv").set_index("role")
    # read_results.py recomputes the run's own figure from predicted_torque.parquet
    assert errors.loc["validation", "rel_error_%"] == pytest.approx(100 * metrics["validation_rel_error"])
    assert metrics["validation_rel_error"] < 0.02  # 0.8 % measured: the sensor noise of the simulator
    # the 95 % interval allows for friction drifting between motions, which a simulator's never does
    assert 95.0 <= errors.loc["validation", "interval_coverage_%"] <= 100.0
    choice = pd.read_csv(joint / "friction_choice.csv")
    assert choice["chosen"].sum() == 1 and len(choice) > 10
    # the motor-side logs are the joint-side ones through the gears: read back, the same fit
    joint_log = pd.read_csv(output / "logs" / "csv" / "identification.csv")
    motor_log = pd.read_csv(output / "logs" / "motor" / "identification.csv")
    np.testing.assert_allclose(motor_log["q1"], 160 * joint_log["q1"], rtol=1e-12)
    np.testing.assert_allclose(motor_log["tau7"], joint_log["tau7"] / 100, rtol=1e-12)
    motor_metrics = json.loads((motor / "metrics.json").read_text())
    assert motor_metrics["validation_rel_error"] == pytest.approx(metrics["validation_rel_error"], rel=1e-3)
    assert "positions measured at the motors, torques at the motors" in (motor / "summary.md").read_text()
    assert "friction law chosen among" in stdout


def test_sweep_compared_and_read_as_a_table(tmp_path: Path) -> None:
    output = tmp_path / "sweep"
    stdout = run_example("sweep_and_compare", output)
    assert "estimator=ols" in stdout and "estimator=sdp" in stdout  # lwrlab compare's table
    for name in ("compare.md", "compare.csv", "compare.html", "rms_per_joint.png"):
        assert (output / "compare" / name).is_file(), name
    runs = pd.read_csv(output / "runs.csv")
    assert sorted(runs["estimator"]) == ["ols", "ols", "sdp", "sdp"]
    assert sorted(runs["seed"]) == [0, 0, 1, 1]
    assert runs["RMS mean [N·m]"].between(0.09, 0.3).all()  # σ_τ = 0.1 N·m on a 4 s motion
    assert (runs["‖β̂−β‖/‖β‖"] < 0.05).all()
    from mlflow.tracking import MlflowClient

    client = MlflowClient(tracking_uri=f"sqlite:///{output / 'mlflow.db'}")
    experiment = client.get_experiment_by_name("example_sweep")
    assert experiment is not None
    logged = client.search_runs([experiment.experiment_id])
    names = [run.info.run_name for run in logged]
    assert sum(name.startswith("compare") for name in names) == 1
    assert sum(run.info.status == "FINISHED" for run in logged) == len(logged) == 6  # parent, 4 jobs, compare


def test_plugin_outside_the_package_is_found_and_fitted(tmp_path: Path) -> None:
    output = tmp_path / "plugin"
    stdout = run_example("custom_plugin", output)
    assert "_target_: my_friction.QuadraticDrag" in stdout  # --cfg job: the YAML on the search path
    run = output / "identification"
    parameters = pd.read_csv(run / "base_parameters.csv").set_index("parameter")
    drag = parameters.loc[[f"FD{j}" for j in range(1, 8)]]
    assert (drag["truth"] == 0).all()
    assert (np.abs(drag["estimate"]) < 5 * drag["std"]).all()  # no drag in the simulated arm
    metrics = json.loads((run / "metrics.json").read_text())
    assert metrics["rms_mean"] < 0.12 and metrics["base_parameter_error"] < 0.02
    assert logged_run(output / "mlflow.db", run).info.status == "FINISHED"
