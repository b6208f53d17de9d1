"""Exciting-motion stages end to end: the excitation task, and the Fig. 5 and Fig. 6 presets (shrunken)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from composing import compose_config
from hydra.utils import instantiate
from omegaconf import DictConfig
from test_end_to_end import only_run, run_lwrlab

from lwrlab.pipeline.studies.criteria_comparison import run_criteria_comparison
from lwrlab.pipeline.studies.duration_study import run_duration_study

SMALL = ["optimizer.max_iterations=40", "optimizer.show_progress=false", "plant.show_progress=false"]


def composed(*overrides: str) -> DictConfig:
    """The config with ``overrides``, its optimiser shortened and quiet (``SMALL``)."""
    return compose_config(*SMALL, *overrides)


def test_duration_study_writes_fig5_table_and_knee(tmp_path: Path) -> None:
    cfg = composed(
        "experiment=paper_fig5_duration",
        "task.durations=[1,2]",
        "~task.criteria.cond",
        "~task.criteria.hadamard",
        "optimizer.max_iterations=40",
    )
    stage = instantiate(cfg.task)
    assert set(stage.keywords["criteria"]) == {"logdet"}
    metrics = stage(cfg, tmp_path)
    table = pd.read_csv(tmp_path / "fig5_duration.csv")
    assert list(table.columns[:3]) == ["criterion", "duration_s", "cost"]
    assert table["duration_s"].tolist() == [1.0, 2.0]
    costs = table["cost"].to_numpy()
    assert costs[1] < costs[0] or not np.isfinite(costs[0])  # a longer motion excites more
    assert metrics["recommended_duration_s"] in (1.0, 2.0)
    assert (tmp_path / "fig5_duration.png").stat().st_size > 10_000
    assert "Knee rule" in (tmp_path / "fig5_duration.md").read_text()


@pytest.mark.slow
def test_criteria_comparison_writes_fig6_table(tmp_path: Path) -> None:
    cfg = composed(
        "experiment=paper_fig6_criteria",
        "trajectory.duration=2.0",
        "validation.duration=4.0",
        "task.seeds=[0,1]",
        "~task.criteria.cond",
        "~task.criteria.hadamard",
    )
    metrics = run_criteria_comparison(
        cfg, tmp_path, criteria={"logdet": instantiate(cfg.criterion)}, seeds=[0, 1]
    )
    table = pd.read_csv(tmp_path / "fig6_criteria.csv")
    assert list(table.columns) == ["criterion", "seed", "joint", "rms", "nrms", "model_rms"]
    assert np.all(table["model_rms"] < table["rms"])  # the simulated sensor noise is left out
    assert len(table) == 2 * 7 and set(table["seed"]) == {0, 1}
    assert np.all(table["rms"] > 0) and metrics["rms_mean_logdet"] == pytest.approx(table["rms"].mean())
    assert "±" in (tmp_path / "fig6_criteria.md").read_text()
    assert (tmp_path / "fig6_criteria.png").is_file()


def test_duration_study_needs_the_optimal_trajectory(tmp_path: Path) -> None:
    cfg = composed("task=duration_study", "trajectory=multisine")
    with pytest.raises(ValueError, match="needs trajectory=optimal"):
        run_duration_study(cfg, tmp_path, criteria={"logdet": instantiate(cfg.criterion)}, durations=[1])
    with pytest.raises(ValueError, match="no criteria"):
        run_duration_study(composed("task=duration_study"), tmp_path, criteria={}, durations=[1])


@pytest.mark.slow
def test_excitation_task_writes_a_motion_the_identification_plays(tmp_path: Path) -> None:
    completed = run_lwrlab(tmp_path / "optimise", "task=excitation", "trajectory.duration=2.0", *SMALL)
    assert completed.returncode == 0, completed.stderr[-3000:]
    folder = tmp_path / "optimise" / "run"
    for name in (
        "exciting_motion.yaml",
        "exciting_motion.csv",
        "excitation_report.md",
        "exciting_motion.png",
    ):
        assert (folder / name).is_file(), name
    metrics = json.loads((folder / "metrics.json").read_text())
    assert metrics["violated_families"] == 0.0
    motion_csv = pd.read_csv(folder / "exciting_motion.csv")
    assert len(motion_csv) == 2001  # 1 kHz
    identified = run_lwrlab(
        tmp_path / "identify",
        "task=identification",
        "experiment_name=identification",
        f"trajectory.from_file={folder / 'exciting_motion.yaml'}",
        "trajectory.duration=2.0",
        *SMALL,
    )
    assert identified.returncode == 0, identified.stderr[-3000:]
    assert "optimising instead" not in identified.stderr
    assert only_run(tmp_path / "identify", "identification").info.status == "FINISHED"


@pytest.mark.slow
@pytest.mark.parametrize(
    ("preset", "overrides", "table"),
    [
        ("paper_fig5_duration", ["task.durations=[2,3]", "~task.criteria.cond"], "fig5_duration.csv"),
        (
            "paper_fig6_criteria",
            ["trajectory.duration=2.0", "validation.duration=5.0", "task.seeds=[0,1]", "~task.criteria.cond"],
            "fig6_criteria.csv",
        ),
    ],
)
def test_presets_log_their_tables_and_figures_to_mlflow(
    tmp_path: Path, preset: str, overrides: list[str], table: str
) -> None:
    completed = run_lwrlab(tmp_path, f"experiment={preset}", *overrides, *SMALL)
    assert completed.returncode == 0, completed.stderr[-3000:]
    run = only_run(tmp_path, preset)
    assert run.info.status == "FINISHED"
    from mlflow.tracking import MlflowClient

    client = MlflowClient(tracking_uri=f"sqlite:///{tmp_path / 'mlflow.db'}")
    logged = {entry.path for entry in client.list_artifacts(run.info.run_id)}
    assert table in logged and table.replace(".csv", ".png") in logged
