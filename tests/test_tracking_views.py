"""What a person sees of a run in MLflow's UI: few scalar params, metrics in sections, datasets, summaries."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hydra import compose, initialize_config_module

from lwrlab.tracking.job_config.config_params import plugin_choices, resolved_job_config, runtime_choices
from lwrlab.tracking.job_config.datasets import (
    IDENTIFICATION,
    VALIDATION,
    content_digest,
    job_datasets,
)
from lwrlab.tracking.job_config.metric_sections import (
    ACCURACY,
    SECTIONS,
    metric_section,
    plain_name,
    sectioned_filter,
    sectioned_name,
)
from lwrlab.tracking.job_config.run_params import KNOBS, MAX_PARAMS, job_params
from lwrlab.tracking.runs.run_datasets import dataset_input
from lwrlab.tracking.runs.sweep_summary import summary_metrics

# The metrics of a log identification (its metrics.json) and of metrics being added elsewhere.
IDENTIFICATION_METRICS = [
    "cond_W_b", "residual_std", "rms_mean", "nrms_mean", "fit_rel_error", "validation_rel_error",
    "validation_interval_coverage", "fit_interval_coverage", "validation_rel_error_measurements_1",
    "n_base_parameters", "n_rows", "fit_cpu_s", "min_pseudo_inertia_eigenvalue", "identifiability_rank",
    "identifiability_rank_deficiency", "cond_W_b_scaled", "smallest_relative_singular_value",
    "still_joints", "rms_joint1", "rms_joint7", "nrms_joint3", "base_parameter_error", "prior_weight",
    "prior_dominated_parameters", "cv_rel_error", "stage_identification_s",
]  # fmt: skip


def test_every_identification_metric_has_a_section_and_the_headline_one_sorts_first() -> None:
    sections = {name: metric_section(name) for name in IDENTIFICATION_METRICS}
    assert None not in sections.values(), sections
    headline = {"rms_mean", "nrms_mean", "validation_rel_error", "base_parameter_error", "fit_rel_error"}
    assert {name for name, section in sections.items() if section == ACCURACY} >= headline | {"cv_rel_error"}
    assert sections["rms_joint7"] == "joints" and sections["fit_cpu_s"] == "timing"
    assert {sections[n] for n in ("validation_interval_coverage", "prior_weight", "cond_W_b")} == {
        "diagnostics"
    }
    assert sorted(set(sections.values()))[0] == ACCURACY  # MLflow's chart view lists sections by name
    for name in [*IDENTIFICATION_METRICS, "painted_fraction", "detections"]:
        assert plain_name(sectioned_name(name)) == name  # the name in metrics.json, read back
    assert metric_section("painted_fraction") is None  # a task's own result: MLflow's default section
    assert not SECTIONS & {name.split("/")[0] for name in ("painted_fraction", "estimator:ols/rms_mean")}


def test_plain_metric_names_in_filters_become_the_logged_keys() -> None:
    assert sectioned_filter("metrics.rms_mean < 0.5") == "metrics.`accuracy/rms_mean` < 0.5"
    assert sectioned_filter("params.`estimator` = 'ols'") == "params.`estimator` = 'ols'"
    assert sectioned_filter("metrics.`painted_fraction` > 1") == "metrics.`painted_fraction` > 1"


@pytest.mark.parametrize(
    "overrides",
    [
        ["task=identification", "estimator=ols", "seed=1"],
        [
            "task=identification",
            "plant=log",
            "data.paths=[a.csv,b.csv]",
            "data.column_map={t: times, q: pos}",
        ],
        ["plant.torque_noise_std=0.2", "robot=panda", "trajectory@validation=multisine"],
    ],
)
def test_params_are_the_few_scalars_that_tell_a_run_apart(overrides: list[str]) -> None:
    with initialize_config_module("lwrlab.conf", version_base="1.3"):
        config = compose("config", overrides=overrides, return_hydra_config=True)
    config.hydra.overrides.task = overrides  # as Hydra records them for a launched job
    job_config = resolved_job_config(config)
    params = job_params(config, job_config)
    assert 0 < len(params) <= MAX_PARAMS
    assert all("\n" not in value and not value.startswith(("[", "{")) for value in params.values())
    assert not any(
        key.startswith(("classifier.", "controller.", "optimizer.", "robot.links")) for key in params
    )
    choices = plugin_choices(runtime_choices(config))
    assert {key: params[key] for key in choices} == {key: str(value) for key, value in choices.items()}
    for override in overrides:
        key = override.split("=")[0]
        if key not in choices and "@" not in key:
            assert any(param == key or param.startswith(key + ".") for param in params), key
    assert {knob for knob in KNOBS if knob in params} >= {"seed"}


def test_datasets_are_the_logs_used_or_the_simulated_motions_with_content_digests(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    (logs / "run1.csv").write_text("t,q1\n0,0\n")
    (logs / "run2.csv").write_text("t,q1\n0,1\n")
    (tmp_path / "copy.csv").write_text("t,q1\n0,0\n")
    config = {"data": {"paths": ["logs/run1.csv"], "validation_paths": ["logs/run2.csv"]}}
    uses = job_datasets(config, {"plant": "log"}, tmp_path, tmp_path / "out")
    assert [(use.name, use.role) for use in uses] == [("run1", IDENTIFICATION), ("run2", VALIDATION)]
    assert content_digest(logs / "run1.csv") == content_digest(tmp_path / "copy.csv")  # by content
    assert content_digest(logs / "run1.csv") != content_digest(logs / "run2.csv")
    assert content_digest(logs) != content_digest(tmp_path / "copy.csv")  # a folder (a ROS 2 bag) too

    output = tmp_path / "out"
    output.mkdir()
    (output / "exciting_motion.parquet").write_bytes(b"1")
    choices = {"plant": "simulated", "trajectory": "optimal", "validation": "multisine_validation"}
    assert job_datasets({}, choices, tmp_path, output) == []  # an exciting motion alone is a result
    (output / "validation_motion.parquet").write_bytes(b"2")
    uses = job_datasets({}, choices, tmp_path, output)
    assert [(use.name, use.role) for use in uses] == [
        ("optimal_motion", IDENTIFICATION),
        ("multisine_validation_motion", VALIDATION),
    ]

    inputs = [dataset_input(use) for use in uses]  # the store round trip: the slow test in the UI
    shown = {(i.dataset.name, i.dataset.digest, i.tags[0].key, i.tags[0].value) for i in inputs}
    assert shown == {(use.name, content_digest(use.path), "mlflow.data.context", use.role) for use in uses}
    assert json.loads(inputs[0].dataset.source)["uri"].startswith("file://")


def test_a_sweep_summary_counts_jobs_and_takes_best_and_mean_of_finished_ones() -> None:
    statuses = ["FINISHED", "FAILED", "FINISHED", "KILLED"]
    metrics = [{"accuracy/rms_mean": 0.3}, {"accuracy/rms_mean": 0.1}, {"accuracy/rms_mean": 0.5}, {}]
    summary = summary_metrics(statuses, metrics)
    assert summary["summary/jobs"] == 4 and summary["summary/finished"] == 2
    assert summary["summary/failed"] == 1 and summary["summary/killed"] == 1
    assert summary["summary/best_rms_mean"] == 0.3  # the failed job's value is not a result
    assert summary["summary/mean_rms_mean"] == pytest.approx(0.4)
    assert "summary/best_base_parameter_error" not in summary
