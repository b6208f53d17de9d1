"""The painting stage: scoring one run (fast), and the whole stage through Hydra on a shrunken config."""

from __future__ import annotations

import inspect
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from composing import CONF, compose_config
from hydra.utils import instantiate
from omegaconf import OmegaConf

from lwrlab.control.contact_loop import ContactRun
from lwrlab.kinematics.swivel_ik import Branch
from lwrlab.pipeline.painting import run_painting
from lwrlab.pipeline.painting.report import format_table4
from lwrlab.pipeline.painting.runs import RollerPlan, force_errors, score_run
from lwrlab.pipeline.tools.library import load_tool
from lwrlab.planning.painting_path import PaintingPathParameters
from lwrlab.planning.path_optimisation import PathSolution
from lwrlab.plants.mujoco_contact import Wall

# one roller, 4 s identification motions, one SLSQP start, 2 s approach + 1.5 s of painting, two cases
SHORT = [
    "experiment=paper_table4_force",
    "trajectory=multisine",
    "trajectory.duration=4",
    "task.tool_motion.duration=4",
    "task.tools=[large_roller]",
    "task.path.starting_swivels=[-1.6]",
    "task.models=[identified]",
    "task.feedbacks=[estimate]",
    "task.contact.max_duration=3.5",
]

TASK = OmegaConf.load(CONF / "task" / "painting.yaml")


def test_force_errors_are_rms_and_rms_over_the_mean_of_the_second_signal():
    rms, rms_over_mean_pct = force_errors(np.full(10, -27.0), np.full(10, -30.0))
    assert rms == pytest.approx(3.0) and rms_over_mean_pct == pytest.approx(10.0)  # 3 N of 30 N


def _plan_and_run(estimated_n: float) -> tuple[RollerPlan, ContactRun]:
    """A vertical stroke at y = 0.3 m, z = 0.2 … 0.5 m, pressing −30 N, the estimate at ``estimated_n``."""
    tool = load_tool("large_roller")
    parameters = PaintingPathParameters(
        duration=1.5, swivel=-1.6, z_upper=0.5, z_lower=0.2, y_start=0.3, y_step=0.1, n_steps=0
    )
    path = PathSolution(parameters, Branch(1, -1, -1), {}, {}, 0.06, 1, 1)
    plan = RollerPlan(tool, tool, tool.parameters, path, 0.0)
    n, approach = 2000, 500
    t = np.arange(n) * 1e-3
    painting = np.arange(n) >= approach
    actual = np.zeros((n, 3))
    actual[:, 0], actual[:, 1] = -0.8, 0.3
    actual[:, 2] = np.where(painting, 0.2 + 0.3 * (np.arange(n) - approach) / (n - approach - 1), 0.2)
    force = np.zeros((n, 3))
    force[:, 0] = -30.0
    wrench = np.zeros((n, 6))
    wrench[:, 0] = estimated_n
    joints = np.zeros((n, 7))
    run = ContactRun(t, actual, actual, actual, wrench, force, joints, joints, joints, painting)
    return plan, run


def test_score_run_compares_with_the_desired_force_only_when_the_controller_has_one():
    plan, run = _plan_and_run(estimated_n=-27.0)
    with_target = score_run("large_roller", "identified", "estimate", plan, run, -30.0, 20.0, 1.0)
    errors = {row["comparison"]: row for row in with_target.force_errors}
    assert list(errors) == ["estimated/measured", "estimated/desired", "measured/desired"]
    assert errors["estimated/measured"]["rms"] == pytest.approx(3.0, rel=1e-6)  # sensor low-pass settled
    assert errors["estimated/desired"]["rms_over_mean_pct"] == pytest.approx(10.0)
    assert errors["measured/desired"]["rms"] == pytest.approx(0.0, abs=1e-6)
    assert with_target.summary["coverage"] > 0.95 and with_target.summary["tracking_rms_m"] == 0.0
    assert with_target.key == "large_roller_identified_estimate"
    without = score_run("large_roller", "identified", "none", plan, run, None, 20.0, 1.0)
    assert [row["comparison"] for row in without.force_errors] == ["estimated/measured"]
    assert "desired" not in without.forces


def test_table4_markdown_names_the_ratio_apart_from_identifications_nrms():
    plan, run = _plan_and_run(estimated_n=-27.0)
    table = pd.DataFrame(score_run("large_roller", "cad", "sensor", plan, run, -30.0, 20.0, 1.0).force_errors)
    header = format_table4(table).splitlines()[0]
    assert "large_roller rms " in header and "large_roller rms_over_mean_pct" in header
    assert "nrms" not in header


def test_the_task_yaml_gives_every_setting_of_the_stage():
    """conf/task/painting.yaml is the one place of the painting settings: the stage has no defaults."""
    parameters = inspect.signature(run_painting).parameters
    runtime = {"cfg", "output_dir", "identification"}  # what the caller passes, not settings
    assert all(p.default is inspect.Parameter.empty for name, p in parameters.items() if name not in runtime)
    settings = {str(key) for key in TASK if not str(key).startswith("_") and key != "defaults"}
    assert settings | {"comparison_controller"} == set(parameters) - runtime  # comparison: a defaults entry


def test_wall_is_built_from_the_task_yaml_and_has_no_face_defaults():
    wall = Wall(**{key: float(value) for key, value in TASK.wall.items()})
    assert (
        wall.x == -0.8
        and wall.y_bounds == pytest.approx((0.0, 0.6))
        and wall.z_bounds == pytest.approx((0.0, 0.8))
    )
    with pytest.raises(TypeError):
        Wall()  # the face comes from the task YAML only


@pytest.mark.slow
def test_painting_preset_writes_table4_and_presses_with_30_newtons(tmp_path: Path) -> None:
    cfg = compose_config(*SHORT)
    metrics = instantiate(cfg.task)(cfg, tmp_path)
    table = pd.read_csv(tmp_path / "table4_force.csv")
    assert list(table.columns) == ["roller", "model", "feedback", "comparison", "rms", "rms_over_mean_pct"]
    assert set(table.model) == {"identified", "position"}
    row = table[(table.model == "identified") & (table.comparison == "estimated/measured")].iloc[0]
    assert row.rms < 1.0  # the estimate follows the wall sensor
    runs = pd.read_csv(tmp_path / "painting_runs.csv").set_index("model")
    assert runs.loc["identified", "mean_measured_N"] == pytest.approx(-30.0, abs=2.0)
    paths = pd.read_csv(tmp_path / "painting_paths.csv")
    assert paths.recognised[0] == "large_roller" and paths.dY[0] <= paths.roller_width_m[0] + 1e-9
    assert np.isfinite(metrics["duration_s_large_roller"])
    for name in ("fig12_large_roller.png", "fig13_large_roller.png", "summary.md"):
        assert (tmp_path / name).is_file(), name


@pytest.mark.slow
def test_position_controller_is_scored_without_a_desired_force(tmp_path: Path) -> None:
    """controller=position declares no force loop and no target: one run per model, no */desired rows."""
    overrides = [*SHORT, "controller=position", "task.comparison_controller=null"]
    cfg = compose_config(*overrides)
    metrics = instantiate(cfg.task)(cfg, tmp_path)
    table = pd.read_csv(tmp_path / "table4_force.csv")
    assert set(zip(table.model, table.feedback, table.comparison, strict=True)) == {
        ("identified", "none", "estimated/measured")
    }
    assert "rms_large_roller_identified_none_estimated_vs_measured" in metrics
    assert (tmp_path / "fig13_large_roller.png").is_file()
