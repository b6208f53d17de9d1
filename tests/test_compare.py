"""`lwrlab compare` on synthetic run tables: groups, replication and statistics computed independently."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from lwrlab.tracking.job_config.metric_sections import sectioned_name
from lwrlab.tracking.reports.compare import (
    compare_runs,
    comparison_metrics,
    group_key,
    runs_view_hint,
    to_markdown,
    write_comparison,
)
from lwrlab.tracking.reports.report import pooling_refusal, unseparated_parameters
from lwrlab.tracking.reports.run_groups import swept_parameters
from lwrlab.tracking.reports.run_selection import plain_metric_columns

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
