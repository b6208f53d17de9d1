"""Sweeps through the real launchers into a real SQLite store: structure, resume, concurrency, tuning."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import mlflow
import pytest
import yaml
from tracking_apps import REPO_CONF, REPO_ROOT, TOY_APP, jobs_and_parents, run_app, runs_of

from lwrlab.tracking.job_config.metric_sections import plain_metrics
from lwrlab.tracking.runs.run_logging import ERROR_FILE, RESUMED_FILE

# A 2 s multisine motion instead of the (optimised) default one: seconds per job.
SHORT_JOB = [
    "task=identification",
    "trajectory=multisine",
    "trajectory.duration=2",
    "validation.duration=2",
    "plant.show_progress=false",
]


@pytest.mark.slow
def test_joblib_sweep_of_3_by_3_is_one_parent_with_nine_nested_runs(tmp_path: Path) -> None:
    finished = run_app(
        TOY_APP,
        "hydra/launcher=parallel",
        "experiment_name=grid",
        f"hydra.sweep.dir={tmp_path / 'sweep'}",
        "x=1,2,3",
        "seed=0,1,2",
        store=tmp_path,
        multirun=True,
    )
    assert finished.returncode == 0, finished.stderr
    jobs, parents = jobs_and_parents(runs_of(f"sqlite:///{tmp_path / 'mlflow.db'}", "grid"))
    assert len(parents) == 1 and len(jobs) == 9
    assert {run.data.tags["mlflow.parentRunId"] for run in jobs} == {parents[0].info.run_id}
    assert sorted((run.data.params["x"], run.data.tags["seed"]) for run in jobs) == [
        (x, s) for x in "123" for s in "012"
    ]
    assert len({run.data.tags["config_hash"] for run in jobs}) == 9
    assert all(run.info.status == "FINISHED" for run in jobs + parents)
    assert "database is locked" not in finished.stderr


def test_relaunched_sweep_skips_finished_jobs_and_reruns_the_failed_one(tmp_path: Path) -> None:
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    sweep = ["experiment_name=resume", "x=1,2,3"]
    first = run_app(
        TOY_APP,
        *sweep,
        f"hydra.sweep.dir={tmp_path / 'a'}",
        store=tmp_path,
        multirun=True,
        env={"TOY_TRANSIENT_FAILURE_X": "2"},
    )
    assert first.returncode != 0 and "transient failure" in first.stderr
    jobs, parents = jobs_and_parents(runs_of(uri, "resume"))
    assert sorted(run.info.status for run in jobs) == ["FAILED", "FINISHED", "FINISHED"]  # the sweep went on
    (failed,) = [run for run in jobs if run.info.status == "FAILED"]
    error = mlflow.artifacts.download_artifacts(
        run_id=failed.info.run_id, artifact_path=ERROR_FILE, tracking_uri=uri
    )
    assert "Traceback" in Path(error).read_text()
    assert parents[0].info.status == "FAILED"

    second = run_app(TOY_APP, *sweep, f"hydra.sweep.dir={tmp_path / 'b'}", store=tmp_path, multirun=True)
    assert second.returncode == 0, second.stderr
    jobs, parents = jobs_and_parents(runs_of(uri, "resume"))
    assert len(parents) == 1 and parents[0].info.status == "FINISHED"  # the same parent, reopened
    finished = [run for run in jobs if run.info.status == "FINISHED"]
    assert sorted(run.data.params["x"] for run in finished) == [
        "1",
        "2",
        "3",
    ]  # x=2 ran again, 1 and 3 did not
    retry = next(run for run in finished if run.data.params["x"] == "2")
    assert {run.info.run_id: run.data.tags.get("retried_by") for run in jobs}[
        failed.info.run_id
    ] == retry.info.run_id
    assert sorted(path.parent.name for path in (tmp_path / "b").rglob(RESUMED_FILE)) == ["0", "2"]

    third = run_app(TOY_APP, *sweep, f"hydra.sweep.dir={tmp_path / 'c'}", store=tmp_path, multirun=True)
    assert third.returncode == 0, third.stderr
    assert len(runs_of(uri, "resume")) == len(jobs) + len(parents)  # nothing logged twice


def test_a_sweep_reusing_finished_jobs_counts_and_compares_them_and_names_its_parent_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Another sweep over configs that already finished reuses their runs ("already finished"): its
    summary counts them, `lwrlab compare --parent` compares them, and its end names the parent run."""
    import pandas as pd

    from lwrlab.tracking.reports.compare import main as compare

    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    first = run_app(
        TOY_APP,
        "experiment_name=reuse",
        "x=1,2",
        f"hydra.sweep.dir={tmp_path / 'a'}",
        store=tmp_path,
        multirun=True,
    )
    assert first.returncode == 0, first.stderr
    second = run_app(
        TOY_APP,
        "experiment_name=reuse",
        "x=1,2,3",
        f"hydra.sweep.dir={tmp_path / 'b'}",
        store=tmp_path,
        multirun=True,
    )
    assert second.returncode == 0, second.stderr
    jobs, parents = jobs_and_parents(runs_of(uri, "reuse"))
    assert len(jobs) == 3 and len(parents) == 2  # x=1, 2 ran once
    newer = parents[-1]
    printed = second.stdout + second.stderr
    assert f"lwrlab compare --parent {newer.info.run_id}" in printed
    assert mlflow.MlflowClient(uri).get_run(newer.info.run_id).data.metrics["summary/jobs"] == 3.0

    monkeypatch.chdir(tmp_path)
    assert compare(["--tracking-uri", uri, "--parent", newer.info.run_id, "--no-log", "--output", "cmp"]) == 0
    assert sorted(pd.read_csv(tmp_path / "cmp" / "runs.csv")["params.x"]) == [1, 2, 3]


@pytest.mark.slow
def test_eight_parallel_processes_share_one_new_sqlite_store(tmp_path: Path) -> None:
    # Eight independent jobs started at once on a store that does not exist yet: schema creation,
    # experiment creation and writes all race.
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    processes = [
        subprocess.Popen(
            [
                sys.executable,
                str(TOY_APP),
                f"hydra.searchpath=[file://{REPO_CONF}]",
                f"tracking.uri={uri}",
                f"tracking.artifact_location={tmp_path / 'artifacts'}",
                "experiment_name=eight",
                f"x={x}",
                f"hydra.run.dir={tmp_path / f'run{x}'}",
            ],
            cwd=REPO_ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        for x in range(8)
    ]
    outputs = [process.communicate(timeout=300)[0] for process in processes]
    assert all(process.returncode == 0 for process in processes), outputs
    assert not any(
        "database is locked" in output or "MLflow tracking failed" in output for output in outputs
    ), outputs
    runs = runs_of(uri, "eight")
    assert sorted(int(run.data.params["x"]) for run in runs) == list(range(8))
    assert all(
        run.info.status == "FINISHED" and run.data.metrics["doubled"] == 2.0 * int(run.data.params["x"])
        for run in runs
    )


@pytest.mark.slow
def test_identification_sweep_3_by_3_with_joblib_and_its_table2_report(tmp_path: Path) -> None:
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    finished = run_app(
        None,
        "hydra/launcher=parallel",
        "experiment_name=noise_sweep",
        f"hydra.sweep.dir={tmp_path / 'sweep'}",
        "seed=0,1,2",
        "plant.torque_noise_std=0.05,0.1,0.2",
        *SHORT_JOB,
        store=tmp_path,
        multirun=True,
        timeout=600,
    )
    assert finished.returncode == 0, finished.stderr[-3000:]
    jobs, parents = jobs_and_parents(runs_of(uri, "noise_sweep"))
    assert len(parents) == 1 and len(jobs) == 9 and all(run.info.status == "FINISHED" for run in jobs)
    # More torque noise, larger cross-validation error, at every seed.
    by_seed: dict[str, dict[float, float]] = {}
    for run in jobs:
        by_seed.setdefault(run.data.tags["seed"], {})[float(run.data.params["plant.torque_noise_std"])] = (
            run.data.metrics["accuracy/rms_mean"]
        )
    for errors in by_seed.values():
        assert errors[0.05] < errors[0.1] < errors[0.2]
    # The parent's row says what the sweep found: its jobs and the best and mean headline error.
    summary = parents[0].data.metrics
    rms = [run.data.metrics["accuracy/rms_mean"] for run in jobs]
    assert (summary["summary/jobs"], summary["summary/finished"], summary["summary/failed"]) == (9, 9, 0)
    assert summary["summary/best_rms_mean"] == min(rms)
    assert summary["summary/mean_rms_mean"] == pytest.approx(sum(rms) / 9)

    # Table II pools seeds, not noise levels: refused for the whole sweep, built for one noise level.
    pooled = run_app(
        None,
        "report",
        "--tracking-uri",
        uri,
        "--experiment",
        "noise_sweep",
        "--output",
        str(tmp_path / "all"),
        cwd=tmp_path,
    )
    assert pooled.returncode == 0, pooled.stderr
    assert "differ in plant.torque_noise_std (0.05, 0.1, 0.2)" in (tmp_path / "all" / "report.md").read_text()
    assert not (tmp_path / "all" / "table2_base_parameters.csv").exists()
    report = run_app(
        None,
        "report",
        "--tracking-uri",
        uri,
        "--experiment",
        "noise_sweep",
        "--param",
        "plant.torque_noise_std=0.1",
        "--output",
        str(tmp_path / "report"),
        cwd=tmp_path,
    )
    assert report.returncode == 0, report.stderr
    table = (tmp_path / "report" / "table2_base_parameters.csv").read_text()
    assert "MSY2R" in table and "fig6 skipped" in (tmp_path / "report" / "report.md").read_text()

    compared = run_app(None, "compare", "--tracking-uri", uri, "--experiment", "noise_sweep", cwd=tmp_path)
    assert compared.returncode == 0, compared.stderr
    (folder,) = (tmp_path / "outputs" / "compare").iterdir()
    rows = (folder / "compare.csv").read_text().splitlines()[1:]
    assert [row.split(",")[0] for row in rows] == [
        f"plant.torque_noise_std={v}" for v in ("0.05", "0.1", "0.2")
    ]
    assert all(row.split(",")[2:4] == ["3", "3"] for row in rows)  # 3 runs, 3 seeds each


@pytest.mark.slow
def test_optuna_preset_tunes_cutoff_and_harmonics_on_cross_validation_rms(tmp_path: Path) -> None:
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    finished = run_app(
        None,
        "experiment=tune_processing",
        "hydra.sweeper.n_trials=3",
        f"hydra.sweep.dir={tmp_path / 'sweep'}",
        *SHORT_JOB,
        store=tmp_path,
        multirun=True,
        timeout=600,
    )
    assert finished.returncode == 0, finished.stderr[-3000:]
    jobs, parents = jobs_and_parents(runs_of(uri, "tune_processing"))
    assert len(parents) == 1 and len(jobs) == 3
    best = yaml.safe_load((tmp_path / "sweep" / "optimization_results.yaml").read_text())
    assert best["best_value"] == pytest.approx(
        min(run.data.metrics["accuracy/rms_mean"] for run in jobs), rel=1e-12
    )
    assert len({run.data.params["measurement.processing.cutoff_hz"] for run in jobs}) == 3


@pytest.mark.slow
def test_rerunning_the_logged_config_reproduces_the_metrics_exactly(tmp_path: Path) -> None:
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    first = run_app(
        None,
        "experiment_name=repro",
        f"hydra.run.dir={tmp_path / 'first'}",
        "seed=5",
        *SHORT_JOB,
        store=tmp_path,
    )
    assert first.returncode == 0, first.stderr[-3000:]
    (run,) = runs_of(uri, "repro")
    config_dir = Path(
        mlflow.artifacts.download_artifacts(
            run_id=run.info.run_id,
            artifact_path=".hydra",
            dst_path=str(tmp_path / "logged"),
            tracking_uri=uri,
        )
    )
    # --config-path makes the logged, fully composed config the primary one (--config-dir would only
    # add it to the search path, behind the repository's own config.yaml).
    again = run_app(
        None,
        "--config-path",
        str(config_dir),
        "--config-name",
        "config",
        f"hydra.run.dir={tmp_path / 'again'}",
        cwd=tmp_path,
    )
    assert again.returncode == 0, again.stderr[-3000:]
    metrics = json.loads((tmp_path / "again" / "metrics.json").read_text())
    logged = plain_metrics(run.data.metrics)  # MLflow's keys without their sections: metrics.json's names
    timings = {key for key in logged if key.endswith(("cpu_s", "wall_s", "time_s"))}  # clocks, not results
    results = {key: value for key, value in logged.items() if key not in timings}
    assert len(results) > 10 and {key: metrics[key] for key in results} == results  # bit for bit
    assert set(logged) <= set(metrics)  # every metric MLflow shows is in metrics.json, by the same name
