"""Launcher configs compose against the installed Hydra plugins; Ray runs a real local sweep (slow).

The Ray launcher is an optional extra (`pip install -e '.[ray]'`); without it its tests are skipped
and say why.
"""

from __future__ import annotations

import importlib.util
import tempfile
from pathlib import Path

import pytest
from composing import compose_config
from tracking_apps import TOY_APP, jobs_and_parents, run_app, runs_of

RAY_MISSING = importlib.util.find_spec("hydra_plugins.hydra_ray_launcher") is None
SUBMITIT_MISSING = importlib.util.find_spec("hydra_plugins.hydra_submitit_launcher") is None


def _launcher(option: str) -> dict:
    config = compose_config(f"hydra/launcher={option}", hydra_node=True)
    return dict(config.hydra.launcher)


def test_parallel_launcher_is_joblib_with_two_workers() -> None:
    launcher = _launcher("parallel")
    assert launcher["_target_"].endswith("JoblibLauncher") and launcher["n_jobs"] == 2


@pytest.mark.skipif(SUBMITIT_MISSING, reason="optional extra [slurm] (hydra-submitit-launcher) not installed")
def test_slurm_launcher_config_composes() -> None:
    launcher = _launcher("slurm")
    assert launcher["_target_"].endswith("SlurmLauncher") and launcher["timeout_min"] == 60


def test_optuna_preset_composes_with_the_search_space() -> None:
    config = compose_config("experiment=tune_processing", hydra_node=True)
    assert config.hydra.sweeper._target_.endswith("OptunaSweeper")
    assert set(config.hydra.sweeper.params) == {
        "measurement.processing.cutoff_hz",
        "measurement.processing.order",
    }
    assert config.objective == "rms_mean" and config.experiment_name == "tune_processing"


@pytest.mark.slow
@pytest.mark.skipif(
    RAY_MISSING, reason="optional extra [ray] (hydra-ray-launcher) not installed: pip install -e '.[ray]'"
)
def test_ray_sweep_on_a_local_instance_is_one_parent_with_nested_runs(tmp_path: Path) -> None:
    finished = run_app(
        TOY_APP,
        "hydra/launcher=ray_local",
        "experiment_name=ray_grid",
        f"hydra.sweep.dir={tmp_path / 'sweep'}",
        "x=1,2,3",
        "seed=0,1,2",
        store=tmp_path,
        multirun=True,
        timeout=600,
        # Ray's socket paths must stay under 107 bytes: a short temporary folder, not tmp_path.
        env={"RAY_USAGE_STATS_ENABLED": "0", "RAY_TMPDIR": tempfile.mkdtemp(prefix="ray", dir="/tmp")},
    )
    assert finished.returncode == 0, finished.stderr[-4000:]
    jobs, parents = jobs_and_parents(runs_of(f"sqlite:///{tmp_path / 'mlflow.db'}", "ray_grid"))
    assert len(parents) == 1 and len(jobs) == 9
    assert {run.data.tags["mlflow.parentRunId"] for run in jobs} == {parents[0].info.run_id}
    assert all(run.info.status == "FINISHED" for run in jobs)
