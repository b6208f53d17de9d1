"""``task=excitation`` with what is known (a model, logs) and target motions: the report, the safety
check every motion passes, the errors, and a sweep over criteria × conditioning compared from MLflow.

One model (the covariance of a slow motion) serves every test of the module; the rejected motion and
the sweep run whole jobs and are slow.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from composing import compose_config
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf
from tracking_apps import jobs_and_parents, run_app, runs_of

from lwrlab.dynamics.base_parameters import compute_base_parameters, random_states
from lwrlab.dynamics.regressor import regressor
from lwrlab.errors import ConfigError
from lwrlab.excitation.known_information import information_from_rows
from lwrlab.excitation.solver import RejectedMotionError
from lwrlab.identification.identified import IdentifiedModel
from lwrlab.io.artifacts import save_identified_model
from lwrlab.io.logs import write_log
from lwrlab.model.friction_laws import law_mapping
from lwrlab.pipeline.build import build, shipped_config
from lwrlab.pipeline.excitation import run_excitation
from lwrlab.tracking.job_config.metric_sections import plain_metrics
from lwrlab.trajectory.core import Trajectory

QUICK = ["optimizer.max_iterations=30", "optimizer.show_progress=false", "trajectory.duration=2.0"]
TARGET = (
    "task.targets=[{q: [[0,0.5,0,-1,0,0.5,0],[0.3,0.7,0,-1.2,0,0.4,0]], "
    "dq: [[0.3,0,0,0,0,0,0],[0,0.3,0,0,0,0,0]]}]"
)
"""Two poses and speeds where the model will be used."""


def write_model(folder: Path, robot_option: str = "kuka_lwr4", slow: float = 0.01) -> Path:
    """An identified model of ``robot_option`` whose covariance is that of a slow random motion
    (``slow``: the share of the velocity and acceleration limits it reaches)."""
    settings = shipped_config("robot", robot_option)
    robot = instantiate(settings)
    base = compute_base_parameters(robot)
    q, dq, ddq = random_states(robot, 100, np.random.default_rng(0))
    density = np.full(robot.n_joints, 1e-5)
    covariance = np.linalg.inv(
        information_from_rows(base.base_regressor(regressor(robot, q, slow * dq, slow * ddq)), 50.0, density)
    )
    model = IdentifiedModel(
        base.names, base.base_values(robot.parameters), np.sqrt(np.diag(covariance)), robot.parameter_names,
        robot.parameters, base_covariance=covariance, noise_density=density,
    )  # fmt: skip
    description = {
        **OmegaConf.to_container(settings, resolve=True),
        "friction_terms": list(robot.friction_terms),
        "friction_law": law_mapping(robot.friction_law),
    }
    folder.mkdir(parents=True, exist_ok=True)
    return save_identified_model(model, description, folder / "identified_model.yaml")


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The LWR4 model of :func:`write_model` (read only: a test that changes it copies it)."""
    return write_model(tmp_path_factory.mktemp("model"))


@pytest.fixture(scope="module")
def excitation() -> DictConfig:
    """``task=excitation`` of a quick motion, composed once (the tests give what is known as arguments)."""
    return compose_config("task=excitation", *QUICK, "plant.show_progress=false")


def test_a_task_aware_motion_for_what_a_model_leaves_unknown_reports_before_and_after(
    tmp_path: Path, model: Path
) -> None:
    cfg = compose_config(
        "task=excitation", *QUICK, "criterion=target_variance", TARGET, f"task.known_model={model.parent}"
    )
    metrics = run_excitation(cfg, tmp_path / "run", **instantiate(cfg.task).keywords)
    assert metrics["accepted"] == 1.0
    assert metrics["poorly_known_after"] < metrics["poorly_known_before"] > 0
    assert metrics["target_torque_std_after"] < metrics["target_torque_std_before"]
    table = pd.read_csv(tmp_path / "run" / "parameter_uncertainty.csv", index_col="parameter")
    assert np.all(table["std_after"] <= table["std_before"] * (1 + 1e-9))
    assert (tmp_path / "run" / "parameter_uncertainty.png").stat().st_size > 0
    report = (tmp_path / "run" / "excitation_report.md").read_text()
    assert f"Known before this motion: model {model.parent}" in report
    assert "Torque noise density from the model" in report and "Along the target motions" in report
    provenance = (tmp_path / "run" / "exciting_motion.yaml").read_text()
    assert "known:" in provenance and "model" in provenance


@pytest.mark.slow
def test_a_conditioned_task_aware_motion_passes_the_same_check_and_is_rejected_when_it_fails(
    tmp_path: Path, model: Path
) -> None:
    """Optimised on a 10 Hz grid without margins, the motion breaks its limits between the samples: a
    conditioned, task-aware design is rejected like any other (tests/test_own_robot_motion.py, fast)."""
    cfg = compose_config(
        "task=excitation",
        *QUICK,
        "criterion=target_variance",
        TARGET,
        f"task.known_model={model}",
        "trajectory.rate_hz=10",
        "trajectory.window_s=0.1",
        "trajectory.constraints.limit_margin=0.0",
        "trajectory.constraints.distance_margin=0.0",
    )
    with pytest.raises(RejectedMotionError, match="not written as a motion to run"):
        run_excitation(cfg, tmp_path / "run", **instantiate(cfg.task).keywords)
    assert (tmp_path / "run" / "rejected_exciting_motion.yaml").is_file()
    assert not (tmp_path / "run" / "exciting_motion.yaml").exists()
    assert json.loads((tmp_path / "run" / "metrics.json").read_text())["accepted"] == 0.0


def test_known_logs_are_read_like_plant_log_and_their_noise_comes_from_their_residual(
    tmp_path: Path, excitation: DictConfig
) -> None:
    robot = instantiate(excitation.robot)
    plant = instantiate(excitation.plant)(robot=robot)
    t = np.arange(0.0, 2.0, 1e-3)
    q = 0.3 * np.sin(2 * np.pi * 0.5 * t)[:, None] * np.ones(7)  # one slow swing of every joint
    dq = np.gradient(q, t, axis=0)
    measurement = plant.measure(Trajectory(t, q, dq, np.gradient(dq, t, axis=0)))
    log = write_log(measurement, tmp_path / "swing.csv")
    # the known logs imply reading logs: without plant=log, its reader's defaults
    implied = run_excitation(excitation, tmp_path / "a", known_logs=[str(log)])
    cfg = compose_config(
        "task=excitation", *QUICK, f"task.known_logs=[{log}]", "plant=log", f"data.paths=[{log}]"
    )
    metrics = run_excitation(cfg, tmp_path / "b", **instantiate(cfg.task).keywords)
    report = (tmp_path / "b" / "excitation_report.md").read_text()
    assert "Known before this motion: logs swing" in report
    assert "the residual of a least-squares fit of the known logs" in report
    assert metrics["poorly_known_after"] < metrics["poorly_known_before"]
    assert "Known before this motion: logs swing" in (tmp_path / "a" / "excitation_report.md").read_text()
    assert implied["poorly_known_after"] < implied["poorly_known_before"]


def test_a_model_of_another_robot_is_refused(tmp_path: Path, excitation: DictConfig) -> None:
    model = write_model(tmp_path / "panda", "panda")
    with pytest.raises(ConfigError, match="kinematics differ"):
        run_excitation(excitation, tmp_path / "run", known_model=str(model))


def test_a_model_saved_without_covariance_is_refused_naming_the_fix(
    tmp_path: Path, model: Path, excitation: DictConfig
) -> None:
    path = tmp_path / "identified_model.yaml"
    text = model.read_text()
    path.write_text(text[: text.index("information:")])
    with pytest.raises(ConfigError, match=r"no covariance .* identify again, or give the logs"):
        run_excitation(excitation, tmp_path / "run", known_model=str(path))


@pytest.mark.slow
def test_a_sweep_over_criteria_and_what_is_known_runs_and_compares_from_mlflow(
    tmp_path: Path, model: Path
) -> None:
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    finished = run_app(
        None,
        "experiment_name=next_motion",
        f"hydra.sweep.dir={tmp_path / 'sweep'}",
        "task=excitation",
        *QUICK,
        "criterion=logdet,target_variance",
        TARGET,
        f"task.known_model=null,{model.parent}",
        store=tmp_path,
        multirun=True,
        timeout=600,
    )
    assert finished.returncode == 0, finished.stderr[-3000:]
    jobs, parents = jobs_and_parents(runs_of(uri, "next_motion"))
    assert len(parents) == 1 and len(jobs) == 4 and all(run.info.status == "FINISHED" for run in jobs)
    metrics = {
        (run.data.params["criterion"], run.data.params["task.known_model"] != "None"): plain_metrics(
            run.data.metrics
        )
        for run in jobs
    }
    assert len(metrics) == 4
    for known in (False, True):  # the task-aware design is better where the model will be used
        aimed, spread = metrics[("target_variance", known)], metrics[("logdet", known)]
        assert aimed["target_torque_std_after"] < spread["target_torque_std_after"]
    assert (
        metrics[("logdet", True)]["poorly_known_before"] < metrics[("logdet", False)]["poorly_known_before"]
    )
    compared = run_app(None, "compare", "--tracking-uri", uri, "--experiment", "next_motion", cwd=tmp_path)
    assert compared.returncode == 0, compared.stderr
    (folder,) = (tmp_path / "outputs" / "compare").iterdir()
    table = pd.read_csv(folder / "compare.csv")
    assert len(table) == 4 and {"poorly_known_after", "target_torque_std_after"} <= set(table.columns)


def test_the_identification_says_which_motion_would_help_next(lwr4) -> None:
    """A short motion at 10 % of the limits (cond ≈ 700): the note names the poorly known parameters and
    the command that designs a motion for them; the optimised motion leaves none."""
    from lwrlab.pipeline.identification import identify

    validation = build("trajectory", "multisine", duration=1.0)
    for fraction, expected in (
        (0.1, "NEXT MOTION: "),
        (0.8, "next motion: every base parameter is well known"),
    ):
        plant = build("plant", "simulated")(robot=lwr4, show_progress=False)
        motion = build("trajectory", "multisine", duration=3.0, limit_fraction=fraction)
        report = identify(lwr4, motion, validation, plant, build("estimator", "wls"))
        (note,) = [line for line in report.notes if line.lower().startswith("next motion")]
        assert note.startswith(expected) and "task=excitation task.known_model=" in note


def test_a_parameter_given_by_the_prior_is_not_called_well_known(lwr4) -> None:
    """A small σ from the prior is not knowledge from the data: the note names those parameters."""
    from lwrlab.dynamics.base_parameters import compute_base_parameters
    from lwrlab.pipeline.identification.next_motion import next_motion_note

    base = compute_base_parameters(lwr4)
    tiny = np.full(base.count, 1e-9)  # every σ far below what moves the torque
    assert next_motion_note(lwr4, base, tiny).startswith("next motion: every base parameter is well known")
    share = np.zeros(base.count)
    share[[0, 3]] = 0.9
    note = next_motion_note(lwr4, base, tiny, share)
    assert note.startswith(f"NEXT MOTION: 2 of {base.count} base parameters are not determined by the data")
    listed = note.split("the motion barely excites them): ", 1)[1].split("; a motion designed", 1)[0]
    assert set(listed.split(", ")) == {base.names[0], base.names[3]}
