"""MLflow opens on the answer: experiment kind and description, runs named by what differs, plugin params."""

from __future__ import annotations

from pathlib import Path

import pytest
from composing import compose_config
from mlflow.tracking import MlflowClient
from omegaconf import OmegaConf
from tracking_apps import TOY_APP, jobs_and_parents, run_app, runs_of

from lwrlab.tracking.companion.callback import MlflowTracking
from lwrlab.tracking.job_config.config_params import plugin_choices
from lwrlab.tracking.job_config.naming import (
    DESCRIPTION_TAG,
    EXPERIMENT_KIND,
    EXPERIMENT_KIND_TAG,
    log_file_stem,
    run_name,
    swept_keys,
)
from lwrlab.tracking.lifecycle.mlflow_callback import InProcessTracking


def test_swept_overrides_come_first_and_plugin_choices_read_as_their_names() -> None:
    overrides = [
        "task=identification",
        "estimator=sdp",
        "seed=1",
        "tracking.uri=sqlite:///x.db",
        "experiment_name=e",
    ]
    groups = {"task", "estimator", "plant"}
    assert (
        run_name(overrides, swept=swept_keys(["estimator=ols,wls,sdp", "seed=0,1"]), groups=groups)
        == "sdp · seed=1 · identification"
    )
    assert run_name([], fallback="paper_chain") == "paper_chain"
    assert swept_keys(
        ["x=range(3)", "+y=choice(a,b)", "z=1"], {"measurement.cutoff_hz": "interval(1, 5)"}
    ) == ["x", "y", "measurement.cutoff_hz"]


def test_a_log_run_names_its_log_file() -> None:
    assert log_file_stem(OmegaConf.create({"data": {"path": "/logs/lwr_2019-03-01.csv"}})) == "lwr_2019-03-01"
    assert (
        log_file_stem(OmegaConf.create({"data": {"paths": ["a/first.parquet", "b/second.csv"]}})) == "first"
    )
    assert log_file_stem(OmegaConf.create({"data": {"path": "???"}})) is None
    assert log_file_stem(OmegaConf.create({})) is None
    name = run_name(
        ["plant=log", "data.path=/logs/run7.csv", "seed=2"], swept={"seed"}, groups={"plant"}, log_stem="run7"
    )
    assert name == "seed=2 · log · run7"
    assert run_name(["seed=2"], swept={"seed"}, log_stem="run7") == "seed=2 · run7"


def test_plugin_choices_are_params_under_their_group_names() -> None:
    choices = {
        "robot": "kuka_lwr4",
        "criterion": "logdet",
        "trajectory@validation": "multisine_validation",
        "tool": None,
        "hydra/launcher": "joblib",
    }
    assert plugin_choices(choices) == {
        "robot": "kuka_lwr4",
        "criterion": "logdet",
        "validation": "multisine_validation",
        "tool": "none",
    }


@pytest.mark.parametrize(
    ("overrides", "experiment"),
    [
        (["task=identification"], "identification"),
        ([], "paper_chain"),
        (["experiment=paper_table2"], "paper_table2"),
        (["task=identification", "experiment_name=mine"], "mine"),
    ],
)
def test_one_experiment_per_task_or_preset_unless_named(overrides: list[str], experiment: str) -> None:
    config = compose_config(*overrides, hydra_node=True)
    callback = InProcessTracking(
        "sqlite:///x.db", "${experiment_name}", None, True, True, configured_as=MlflowTracking
    )
    assert callback.settings_for(config).experiment == experiment


def test_a_sweep_opens_on_runs_named_by_what_differs_with_plugin_names_as_params(tmp_path: Path) -> None:
    finished = run_app(
        TOY_APP,
        "experiment_name=naming",
        f"hydra.sweep.dir={tmp_path / 'sweep'}",
        "+estimator=ols,wls",
        "seed=0,1",
        "x=5",
        store=tmp_path,
        multirun=True,
    )
    assert finished.returncode == 0, finished.stderr[-3000:]
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    experiment = MlflowClient(uri).get_experiment_by_name("naming")
    assert experiment.tags[EXPERIMENT_KIND_TAG] == EXPERIMENT_KIND
    assert (
        "rms_mean` [N·m]" in experiment.tags[DESCRIPTION_TAG]
        and "nrms_mean` [%]" in experiment.tags[DESCRIPTION_TAG]
    )
    jobs, parents = jobs_and_parents(runs_of(uri, "naming"))
    assert sorted(run.info.run_name for run in jobs) == [
        "ols · seed=0 · x=5",
        "ols · seed=1 · x=5",
        "wls · seed=0 · x=5",
        "wls · seed=1 · x=5",
    ]
    assert parents[0].info.run_name == "sweep · estimator=ols,wls · seed=0,1 · x=5"
    assert {run.data.params["estimator"] for run in jobs} == {"ols", "wls"}
    assert all(run.data.params["tracking"] == "sqlite" for run in jobs)
