"""`lwrlab report` on a real SQLite store filled through the real tracking callback.

The CSVs of Fig. 5, Fig. 6, Table III and Table IV come from a TEST FIXTURE app
(tests/apps/table_fixtures_app.py) writing synthetic values with the stages' column contracts, so
the expected report is computed here independently. Table II from real identification runs is
covered by tests/test_sweeps.py (slow).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from apps.table_fixtures_app import CRITERIA, JOINTS, fixture_rms
from mlflow.tracking import MlflowClient
from tracking_apps import TABLE_FIXTURES_APP, run_app

from lwrlab.reference import paper_results
from lwrlab.tracking.reports.compare import main as compare_main
from lwrlab.tracking.reports.report import build_report, main
from lwrlab.tracking.reports.run_selection import REPORT_EXPERIMENT, selection_filter

SEEDS = (0, 1, 2)

pytestmark = pytest.mark.slow  # nine Hydra jobs in a subprocess build the store


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> str:
    folder = tmp_path_factory.mktemp("report_store")
    finished = run_app(
        TABLE_FIXTURES_APP,
        f"hydra.sweep.dir={folder / 'sweep'}",
        f"fixture_criterion={','.join(CRITERIA)}",
        f"seed={','.join(map(str, SEEDS))}",
        store=folder,
        multirun=True,
    )
    assert finished.returncode == 0, finished.stderr
    return f"sqlite:///{folder / 'mlflow.db'}"


def test_report_rebuilds_fig5_fig6_and_refuses_to_pool_tables_across_criteria(
    store: str, tmp_path: Path
) -> None:
    report = build_report(store, tmp_path, ["report_fixture"], selection_filter())
    assert len(report.runs) == len(CRITERIA) * len(SEEDS)  # job runs only, not the sweep's parent
    assert set(report.parts) == {"fig5", "fig6"}  # their CSVs tell the criteria apart
    assert "base_parameters.csv" in report.skipped["table2"]
    for kind in ("table3", "table4"):  # one table would pool three criteria: refused, saying which
        assert "fixture_criterion (cond, hadamard, logdet)" in report.skipped[kind]
        assert "--param fixture_criterion=" in report.skipped[kind]

    summary = report.parts["fig6"].tables["fig6_summary"]
    paper = paper_results()["fig6_crossvalidation_mean_rms_Nm"]
    for criterion in CRITERIA:
        per_seed = [np.mean([fixture_rms(criterion, seed, joint) for joint in JOINTS]) for seed in SEEDS]
        assert summary.loc[criterion, "mean_rms"] == pytest.approx(np.mean(per_seed))
        assert summary.loc[criterion, "mean_rms_std"] == pytest.approx(np.std(per_seed, ddof=1))
        assert summary.loc[criterion, "seeds"] == len(SEEDS)
        assert summary.loc[criterion, "paper_mean_rms"] == paper[criterion]

    fig5 = report.parts["fig5"].tables["fig5_duration"].set_index(["criterion", "duration_s"])
    assert fig5.loc[("cond", 10.0), "mean"] == pytest.approx(np.mean([70 / 10 + seed for seed in SEEDS]))
    for name in ("report.md", "fig5_duration.png", "fig6_criteria.png", "fig6_summary.csv", "runs.csv"):
        assert (tmp_path / name).is_file(), name
    assert (tmp_path / "fig6_criteria.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    markdown = (tmp_path / "report.md").read_text()
    assert (
        "## Fig. 6" in markdown and "table2 skipped" in markdown and "differ in fixture_criterion" in markdown
    )


def test_report_of_one_criterion_pools_its_seeds_into_table3_and_table4(store: str, tmp_path: Path) -> None:
    report = build_report(
        store, tmp_path, ["report_fixture"], selection_filter(params={"fixture_criterion": "cond"})
    )
    table4 = report.parts["table4"].tables["table4_force"].set_index("comparison")
    assert table4.loc["estimated/measured", "rms"] == pytest.approx(np.mean([2.5 + seed for seed in SEEDS]))
    # the painting's names (large_roller, estimated/measured) find the paper's row (large, …_vs_…)
    assert table4.loc["estimated/measured", "paper_rms"] == 2.9
    assert table4.loc["measured/desired", "paper_rms_over_mean_pct"] == 10.5
    table3 = report.parts["table3"].tables["table3_tools"].set_index("parameter")
    assert table3.loc["M", "paper_phi"] == pytest.approx(0.237)


def test_report_filters_runs_by_param(store: str, tmp_path: Path) -> None:
    report = build_report(
        store,
        tmp_path,
        ["report_fixture"],
        selection_filter(params={"fixture_criterion": "cond"}),
        kinds=["fig6"],
    )
    assert list(report.parts["fig6"].tables["fig6_summary"].index) == ["cond"]
    assert len(report.runs) == len(SEEDS)


def test_report_command_logs_the_report_once_in_its_source_experiment(
    store: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)  # nothing may land in ./mlruns of the current folder
    client = MlflowClient(tracking_uri=store)
    experiments_before = {experiment.name for experiment in client.search_experiments()}
    for _ in range(2):
        assert (
            main(
                [
                    "--tracking-uri",
                    store,
                    "--experiment",
                    "report_fixture",
                    "--tag",
                    "seed=1",
                    "--output",
                    str(tmp_path / "r"),
                ]
            )
            == 0
        )
    printed = capsys.readouterr().out
    assert "## Fig. 6" in printed and "report logged as run" in printed and "already logged as run" in printed
    assert {
        experiment.name for experiment in client.search_experiments()
    } == experiments_before  # no `reports`
    assert REPORT_EXPERIMENT not in experiments_before and not (tmp_path / "mlruns").exists()
    experiment = client.get_experiment_by_name("report_fixture")
    (run,) = client.search_runs([experiment.experiment_id], filter_string="tags.run_kind = 'report'")
    assert run.info.status == "FINISHED" and run.data.tags["source_runs"] == str(len(CRITERIA))
    assert {"report.md", "fig6_criteria.png", "fig5_duration.png"} <= {
        item.path for item in client.list_artifacts(run.info.run_id)
    }
    assert run.info.artifact_uri.startswith(
        str(Path(store[len("sqlite:///") :]).parent)
    )  # beside the store, under its artifact root


def test_compare_groups_by_the_swept_parameter_with_seeds_as_replication(
    store: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    assert compare_main(["--tracking-uri", store, "--experiment", "report_fixture"]) == 0
    (folder,) = (tmp_path / "outputs" / "compare").iterdir()
    table = pd.read_csv(folder / "compare.csv", index_col="group")
    assert list(table.index) == [f"fixture_criterion={name}" for name in sorted(CRITERIA)]
    for criterion in CRITERIA:
        per_run = [np.mean([fixture_rms(criterion, seed, joint) for joint in JOINTS]) for seed in SEEDS]
        row = table.loc[f"fixture_criterion={criterion}"]
        assert row["runs"] == row["seeds"] == len(SEEDS)
        assert row["rms_mean"] == pytest.approx(np.mean(per_run)) and row["rms_mean_std"] == pytest.approx(
            np.std(per_run, ddof=1)
        )
    assert (folder / "rms_per_joint.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    printed = capsys.readouterr().out
    assert "rms_mean [N·m]" in printed and "comparison logged as run" in printed

    assert (
        compare_main(
            [
                "--tracking-uri",
                store,
                "--experiment",
                "report_fixture",
                "--param",
                "fixture_criterion=cond",
                "--no-log",
            ]
        )
        == 0
    )
    assert "| fixture_criterion=cond" not in capsys.readouterr().out  # one criterion left: nothing differs
    client = MlflowClient(tracking_uri=store)
    experiment = client.get_experiment_by_name("report_fixture")
    assert len(client.search_runs([experiment.experiment_id], filter_string="tags.run_kind = 'compare'")) == 1
    assert not (tmp_path / "mlruns").exists()


def test_report_names_unknown_experiments_and_kinds(store: str, tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="report_fixture"):  # the message lists the experiments there are
        build_report(store, tmp_path, ["no_such_experiment"], selection_filter())
    with pytest.raises(ValueError, match="table2"):
        build_report(store, tmp_path, ["report_fixture"], selection_filter(), kinds=["table9"])
