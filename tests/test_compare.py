"""`lwrlab compare` on synthetic run tables: groups, replication and statistics computed independently;
the view of the runs it saves on the experiment for MLflow's UI, read back without lwrlab's decoder."""

from __future__ import annotations

import base64
import json
import re
import warnings
import zlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from mlflow.exceptions import MlflowException
from mlflow.tracking import MlflowClient
from tracking_apps import new_store

from lwrlab.tracking.job_config.metric_sections import sectioned_name
from lwrlab.tracking.reports.compare import (
    compare_runs,
    comparison_metrics,
    group_key,
    main,
    runs_view_hint,
    to_markdown,
    write_comparison,
)
from lwrlab.tracking.reports.report import pooling_refusal, unseparated_parameters
from lwrlab.tracking.reports.run_groups import swept_parameters
from lwrlab.tracking.reports.run_selection import plain_metric_columns
from lwrlab.tracking.runs.runs_view import SHARED_VIEW_TAG_PREFIX, runs_view_link
from lwrlab.tracking.runs.view_state import runs_view_state

ESTIMATORS = ("ols", "sdp", "wls")
SEEDS = (0, 1, 2)


def _rms(estimator: str, seed: int, joint: int) -> float:
    return 0.1 * (1 + ESTIMATORS.index(estimator)) + 0.01 * joint + 0.003 * seed**2


@pytest.fixture
def runs() -> pd.DataFrame:
    rows = []
    for estimator in ESTIMATORS:
        for seed in SEEDS:
            per_joint = [_rms(estimator, seed, joint) for joint in (1, 2, 3)]
            rows.append(
                {
                    "run_id": f"{estimator}{seed}",
                    "params.estimator": estimator,
                    "params.estimator._target_": f"plugins.{estimator.upper()}",
                    "params.seed": str(seed),
                    "params.trajectory.seed": str(seed),
                    "params.tracking.uri": f"sqlite:///{seed}.db",
                    "params.plant.torque_noise_std": "0.1",
                    "metrics.rms_mean": float(np.mean(per_joint)),
                    "metrics.fit_cpu_s": 0.5 + seed,
                    "metrics.doubled": 3.0,
                    **{
                        f"metrics.rms_joint{joint}": value
                        for joint, value in zip((1, 2, 3), per_joint, strict=True)
                    },
                }
            )
    return pd.DataFrame(rows)


def test_swept_parameters_leave_out_seeds_their_copies_and_where_runs_are_logged(runs: pd.DataFrame) -> None:
    assert swept_parameters(runs) == ["estimator"]  # not estimator._target_, trajectory.seed, tracking.uri
    assert swept_parameters(runs[runs["params.estimator"] == "wls"]) == []


def test_one_row_per_estimator_with_seeds_pooled(runs: pd.DataFrame, tmp_path: Path) -> None:
    comparison = compare_runs(runs)
    assert comparison.groups == ["estimator"] and comparison.metrics == ["rms_mean", "fit_cpu_s"]
    table = comparison.table
    assert list(table.index) == [f"estimator={name}" for name in ESTIMATORS]
    for estimator in ESTIMATORS:
        per_seed = [np.mean([_rms(estimator, seed, joint) for joint in (1, 2, 3)]) for seed in SEEDS]
        row = table.loc[f"estimator={estimator}"]
        assert (row["runs"], row["seeds"]) == (3, 3)
        assert row["rms_mean"] == pytest.approx(np.mean(per_seed))
        assert row["rms_mean_std"] == pytest.approx(np.std(per_seed, ddof=1))
        assert row["fit_cpu_s"] == pytest.approx(1.5) and row["fit_cpu_s_std"] == pytest.approx(1.0)
    markdown = to_markdown(comparison)
    assert "rms_mean [N·m]" in markdown and "fit_cpu_s [s]" in markdown and " ± " in markdown
    written = write_comparison(comparison, tmp_path, "test")
    assert {path.name for path in written} == {
        "compare.md",
        "compare.csv",
        "runs.csv",
        "rms_per_joint.png",
        "compare.html",
    }


def test_the_comparison_run_carries_its_table_as_group_metrics_and_a_self_contained_page(
    runs: pd.DataFrame, tmp_path: Path
) -> None:
    comparison = compare_runs(runs)
    metrics = comparison_metrics(comparison)
    for estimator in ESTIMATORS:
        key = group_key(f"estimator={estimator}")
        assert key == f"estimator:{estimator}"  # a valid MLflow key ('=' is not)
        assert metrics[f"{key}/runs"] == 3.0
        assert metrics[f"{key}/rms_mean"] == pytest.approx(
            comparison.table.loc[f"estimator={estimator}", "rms_mean"]
        )
    page = (write_comparison(comparison, tmp_path, "sweep")[-1]).read_text()
    assert "data:image/png;base64," in page and "<script" in page  # the figure and the sorting inline
    assert 'src="http' not in page and 'href="http' not in page  # nothing fetched
    mean = float(comparison.table.loc["estimator=wls", "rms_mean"])
    assert f'data-value="{mean!r}"' in page  # sorted by the number, not by its text
    assert all(run_id in page for run_id in runs["run_id"])


def test_runs_logged_with_and_without_sections_are_compared_alike(runs: pd.DataFrame) -> None:
    sectioned = runs.rename(
        columns={
            c: "metrics." + sectioned_name(c[len("metrics.") :]) for c in runs if c.startswith("metrics.")
        }
    )
    assert "metrics.accuracy/rms_mean" in sectioned and "metrics.joints/rms_joint1" in sectioned
    mixed = pd.concat([sectioned.iloc[:4], runs.iloc[4:]], ignore_index=True)  # old and new runs together
    table = compare_runs(plain_metric_columns(mixed)).table
    pd.testing.assert_frame_equal(table, compare_runs(runs).table)


def test_the_printed_link_uses_the_port_given() -> None:
    hint = runs_view_hint("sqlite:////lab/mlflow.db", "7", ui_port=5123)
    assert hint is not None and "--port 5123" in hint and "http://127.0.0.1:5123/#/experiments/7/runs" in hint
    assert "--port" not in (runs_view_hint("sqlite:////lab/mlflow.db", "7") or "")


def test_a_single_run_has_no_spread_and_an_unknown_group_is_named(runs: pd.DataFrame) -> None:
    comparison = compare_runs(runs.iloc[:1], groups=[])
    assert comparison.table["runs"].tolist() == [1] and np.isnan(comparison.table["rms_mean_std"].iloc[0])
    with pytest.raises(ValueError, match="no_such_key"):
        compare_runs(runs, groups=["no_such_key"])


def test_tables_refuse_to_pool_what_their_columns_do_not_tell_apart(runs: pd.DataFrame) -> None:
    base_parameters = pd.DataFrame({"run_id": [], "parameter": [], "estimate": []})
    assert unseparated_parameters(["estimator"], base_parameters) == ["estimator"]
    assert (
        unseparated_parameters(["fixture_criterion"], pd.DataFrame({"criterion": ["cond"], "rms": [0.1]}))
        == []
    )
    assert unseparated_parameters(
        ["plant.torque_noise_std"], pd.DataFrame({"parameter": ["XX1"], "std": [0.1]})
    ) == ["plant.torque_noise_std"]
    message = pooling_refusal(runs, ["estimator"])
    assert "estimator (ols, sdp, wls)" in message and "--param estimator=" in message


def test_the_ui_view_puts_the_headline_columns_first_best_first_grouped_by_what_was_swept() -> None:
    metrics = ["fit_cpu_s", "base_parameter_error", "rms_mean", "nrms_mean", "fit_rel_error", "rms_joint1"]
    state = runs_view_state(metrics, ["estimator"], ["seed"])
    assert state["selectedColumns"] == [
        "params.`estimator`",
        "params.`seed`",
        "metrics.`accuracy/rms_mean`",  # the headline metrics present, in their order
        "metrics.`accuracy/nrms_mean`",
        "metrics.`accuracy/base_parameter_error`",
        "metrics.`summary/best_rms_mean`",  # the sweep's row
        "attributes.`Dataset`",
    ]
    assert state["columnOrder"] == state["selectedColumns"]
    assert (state["orderByKey"], state["orderByAsc"]) == ("metrics.`accuracy/rms_mean`", True)
    assert state["groupBy"] == {
        "aggregateFunction": "average",
        "groupByKeys": [{"mode": "param", "groupByData": "estimator"}],
    }
    assert state["groupsExpanded"] == {"param.estimator": True}  # the runs without an estimator: shown
    sections = [section["name"] for section in state["compareRunSections"]]
    assert sections == ["accuracy", "Model metrics", "System metrics"]
    assert [chart["metricKey"] for chart in state["compareRunCharts"]] == [
        "accuracy/rms_mean",
        "accuracy/nrms_mean",
        "accuracy/base_parameter_error",
        "accuracy/fit_rel_error",
    ]
    assert {chart["metricSectionId"] for chart in state["compareRunCharts"]} == {
        state["compareRunSections"][0]["uuid"]
    }
    # Nothing swept: grouped by the run kind, so that a sweep's jobs still show without a click.
    unswept = runs_view_state(["rms_mean"], [])
    assert unswept["groupBy"]["groupByKeys"] == [{"mode": "tag", "groupByData": "run_kind"}]
    painting = runs_view_state(["painted_fraction"], ["seed"])  # no headline metric: no sort, no charts
    assert "orderByKey" not in painting and "compareRunCharts" not in painting
    assert painting["selectedColumns"] == ["params.`seed`", "attributes.`Dataset`"]


def _stored_views(client: MlflowClient, experiment_id: str) -> dict[str, str]:
    tags = client.get_experiment(experiment_id).tags
    return {key: value for key, value in tags.items() if key.startswith(SHARED_VIEW_TAG_PREFIX)}


def _stored_state(value: str) -> dict:
    """A saved view's state as MLflow's UI reads it: a JSON envelope, its state deflated (``deflate;``)."""
    envelope = json.loads(value)
    assert set(envelope) == {"name", "createdAt", "updatedAt", "state"}
    assert isinstance(envelope["createdAt"], int) and envelope["updatedAt"] >= envelope["createdAt"]
    prefix, _, payload = envelope["state"].partition(";")
    assert prefix == "deflate"
    return json.loads(zlib.decompress(base64.b64decode(payload)).decode("utf-8"))


def test_compare_saves_its_view_on_the_experiment_once_and_prints_the_link_that_opens_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    uri = new_store(tmp_path / "mlflow.db")
    client = MlflowClient(tracking_uri=uri)
    experiment_id = client.create_experiment("shared_view", str(tmp_path / "artifacts"))
    for estimator, seed, rms in (("ols", 0, 0.2), ("ols", 1, 0.3), ("wls", 0, 0.1), ("wls", 1, 0.15)):
        run = client.create_run(experiment_id, tags={"run_kind": "job"})
        client.log_param(run.info.run_id, "estimator", estimator)
        client.log_param(run.info.run_id, "seed", str(seed))
        client.log_metric(run.info.run_id, "accuracy/rms_mean", rms)
        client.log_metric(run.info.run_id, "accuracy/base_parameter_error", rms / 10)
        client.set_terminated(run.info.run_id, "FINISHED")

    links, values = [], []
    for extra in (["--no-log"], [], []):  # the comparison run logged in between changes nothing
        assert main(["--tracking-uri", uri, "--experiment", "shared_view", "--output", "out", *extra]) == 0
        printed = capsys.readouterr().out
        links.append(next(line for line in printed.splitlines() if line.startswith("MLflow UI: ")))
        values.append(_stored_views(client, experiment_id))
    key = re.search(r"[?&]viewStateShareKey=([0-9a-f]{32})&workflowType=machine_learning$", links[0])
    assert key is not None, links[0]
    assert f"/#/experiments/{experiment_id}/runs?viewStateShareKey=" in links[0]
    assert links[1] == links[2] == links[0] and values[1] == values[2] == values[0]  # written once
    (tag,) = values[0]
    assert tag == SHARED_VIEW_TAG_PREFIX + key.group(1)
    state = _stored_state(values[0][tag])
    assert state["selectedColumns"] == [
        "params.`estimator`",
        "params.`seed`",
        "metrics.`accuracy/rms_mean`",
        "metrics.`accuracy/base_parameter_error`",
        "metrics.`summary/best_rms_mean`",
        "attributes.`Dataset`",
    ]
    assert (state["orderByKey"], state["orderByAsc"]) == ("metrics.`accuracy/rms_mean`", True)
    assert state["groupBy"]["groupByKeys"] == [{"mode": "param", "groupByData": "estimator"}]
    assert json.loads(values[0][tag])["name"] == "lwrlab · runs by estimator"


def test_a_store_that_refuses_the_view_still_gets_the_link_to_the_browsers_own_view(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    uri = new_store(tmp_path / "mlflow.db")
    client = MlflowClient(tracking_uri=uri)
    experiment_id = client.create_experiment("read_only")

    def refuse(*args: object, **kwargs: object) -> None:
        raise MlflowException("permission denied")

    monkeypatch.setattr(client, "set_experiment_tag", refuse)
    link = runs_view_link(client, uri, experiment_id, ["rms_mean"], ["estimator"])
    assert link is not None and link.endswith(
        f"/#/experiments/{experiment_id}/runs?workflowType=machine_learning"
    )
    assert runs_view_link(client, "postgresql://db/mlflow", experiment_id, ["rms_mean"], []) is None


def test_the_printed_ui_command_runs_after_the_readme_set_up(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The README's set-up puts nothing on PATH: the printed command names the mlflow executable
    beside the running Python (``.venv/bin/mlflow`` from the repository), which runs as printed."""
    import shlex
    import shutil
    import sys

    monkeypatch.setenv("PATH", "/usr/bin:/bin")
    for folder in (tmp_path, Path(sys.executable).parents[2]):  # elsewhere, and the repository
        monkeypatch.chdir(folder)
        hint = runs_view_hint("sqlite:////lab/mlflow.db", "7")
        assert hint is not None
        program = shlex.split(hint.removeprefix("MLflow UI: "))[0]
        assert shutil.which(program, path="/usr/bin:/bin") is not None, hint
        assert Path(program).resolve() == (Path(sys.executable).parent / "mlflow").resolve()
    assert program == ".venv/bin/mlflow" or not (Path.cwd() / ".venv").is_dir()


def _logged_runs(client: MlflowClient, experiment_id: str, rows: list[dict[str, str]]) -> None:
    for k, params in enumerate(rows):
        run = client.create_run(experiment_id, tags={"run_kind": "job"})
        for key, value in params.items():
            client.log_param(run.info.run_id, key, value)
        client.log_metric(run.info.run_id, "accuracy/rms_mean", 0.1 + 0.01 * k)
        client.set_terminated(run.info.run_id, "FINISHED")


def test_compare_on_an_experiment_of_simulated_runs_and_logs_of_several_robots_is_safe(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The identification experiment after the tutorials: simulated runs, real logs (long paths, a
    column map), another robot. The comparison keeps them apart (never one pooled row), its metric
    names stay within MLflow's 250 characters, one per group, and the full labels are in its table."""
    monkeypatch.chdir(tmp_path)
    uri = new_store(tmp_path / "mlflow.db")
    client = MlflowClient(tracking_uri=uri)
    experiment_id = client.create_experiment("identification", str(tmp_path / "artifacts"))
    logs = "/home/someone/robot_logs/2024_calibration_campaign/kuka_lwr4_hw/measurements"
    log_run = {
        "robot": "urdf",
        "robot.path": f"{logs}/kuka_lwr4.urdf",
        "plant": "log",
        "data.paths": f"{logs}_2.npz, {logs}_3.npz",
        "data.validation_paths": f"{logs}_1.npz",
        "data.column_map.t": "times",
        "data.column_map.q": "positions",
    }
    rows = [
        {"robot": "kuka_lwr4", "plant": "simulated", "estimator": "wls", "seed": "0"},
        {"robot": "kuka_lwr4", "plant": "simulated", "estimator": "wls", "seed": "1"},
        {"robot": "kuka_lwr4", "plant": "simulated", "estimator": "ols", "seed": "0"},
        {**log_run, "estimator": "sdp"},
        {**log_run, "data.paths": f"{logs}_3.npz", "estimator": "sdp"},
        {
            **log_run,
            "robot.path": "/opt/ur5/ur5_robot.urdf",
            "data.paths": "/opt/ur5/ur5_bag",
            "estimator": "sdp",
        },
    ]
    _logged_runs(client, experiment_id, rows)

    assert main(["--tracking-uri", uri, "--experiment", "identification", "--output", "all"]) == 0
    (compared,) = client.search_runs([experiment_id], "tags.run_kind = 'compare'")
    keys = [key for key in compared.data.metrics if key.endswith("/runs")]
    assert len(keys) == 5 and all(len(key) <= 250 for key in compared.data.metrics)
    table = pd.read_csv(tmp_path / "all" / "compare.csv")
    assert sorted(table["runs"]) == [1, 1, 1, 1, 2]
    assert f"{logs}_2.npz, {logs}_3.npz" in set(table["data.paths"])  # the full value
    assert "estimator=sdp, data.paths=measurements_3.npz" in set(table["group"])  # named by its file name
    assert {f"{key}/runs" for key in table["metric_key"]} == set(keys)

    assert main(["--tracking-uri", uri, "--experiment", "identification", "--by", "estimator"]) == 0
    printed = capsys.readouterr().out
    assert "runs differ in data.paths (what they are of)" in printed and "grouped by them too" in printed
    by_estimator = compare_runs(plain_metric_columns(_finished(uri)), ["estimator"])
    assert by_estimator.groups == ["estimator", "data.paths"]  # the robot follows from the data
    assert len(by_estimator.table) == 5  # sdp on three robots or data sets is three rows, not one


def _finished(uri: str) -> pd.DataFrame:
    from lwrlab.tracking.reports.run_selection import select_runs, selection_filter

    return select_runs(uri, ["identification"], selection_filter())


def test_runs_of_the_lessons_are_told_apart_by_few_choices_with_short_labels(tmp_path: Path) -> None:
    """The lessons one after the other in one store: simulated runs of two estimators, logs read with
    their own column maps and friction choice, a UR5 by its URDF. Their groups are named by the few
    choices that tell them apart (never how a log's columns are read), in short labels, and the
    figure is drawn without a layout warning."""
    simulated = {"plant": "simulated", "robot": "kuka_lwr4", "friction": "coulomb_viscous"}
    logs = {
        "plant": "log",
        "robot": "kuka_lwr4",
        "friction": "auto",
        "validation": "holdout",
        "robot.friction_terms": "coulomb, viscous, offset",
        "measurement.processing.state_cutoff_hz": "auto",
        "data.paths": "/home/you/lwrlab/outputs/example_logs/identification.csv",
        **{f"data.column_map.{c}": f"{c}_column" for c in ("t", "q1", "q5", "tau1", "tau5")},
    }
    ur5 = {
        **logs,
        "robot": "urdf",
        "robot.path": "/home/you/ur5_robot.urdf",
        "data.paths": "/home/you/ur5.csv",
    }
    ur5 |= {f"data.column_map.{c}": f"{c}_ur" for c in ("t", "q1", "q5", "tau1", "tau5")}
    settings = [*[simulated | {"estimator": e} for e in ("ols", "wls", "sdp")], logs | {"estimator": "sdp"}]
    settings.append(ur5 | {"estimator": "sdp"})
    rows = [
        {f"params.{k}": v for k, v in (setting | {"seed": str(seed)}).items()}
        | {"run_id": f"run{index}{seed}", "metrics.rms_mean": 0.1 + index, "metrics.rms_joint1": 0.1}
        | {"metrics.rms_joint2": 0.2}
        for index, setting in enumerate(settings)
        for seed in (0, 1)
    ]
    comparison = compare_runs(pd.DataFrame(rows))
    assert len(comparison.groups) == 3 and not any("." in group for group in comparison.groups)  # choices
    assert len(comparison.table) == len(settings)  # nothing pooled
    assert max(len(label) for label in comparison.table.index) <= 60
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # "Tight layout not applied" among them
        write_comparison(comparison, tmp_path, "identification: comparison")
    assert (tmp_path / "rms_per_joint.png").exists()
