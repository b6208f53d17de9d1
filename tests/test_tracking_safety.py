"""Secrets never reach the store; an unreachable store costs one warning and `lwrlab sync` catches up.

Real Hydra apps, real SQLite stores, the real `lwrlab sync` command; the PostgreSQL store is
unreachable on purpose (no such server, no driver needed to prove the job goes on).
"""

from __future__ import annotations

import json
import socket
import sqlite3
import sys
from pathlib import Path

import pytest
from tracking_apps import TOY_APP, all_logged_text, jobs_and_parents, run_app, runs_of

from lwrlab.tracking.job_config.redaction import REDACTED, Redactor, redact_uri_passwords
from lwrlab.tracking.runs.offline import OFFLINE_RECORD, SYNCED_RECORD
from lwrlab.tracking.store.sqlite import is_locked_error, retry_locked

SECRET_URI = "postgresql://user:secret@host/db"


def test_uri_passwords_are_redacted() -> None:
    assert redact_uri_passwords(SECRET_URI) == f"postgresql://user:{REDACTED}@host/db"
    assert (
        redact_uri_passwords("http://me:p%40ss@127.0.0.1:5000/x") == f"http://me:{REDACTED}@127.0.0.1:5000/x"
    )
    assert redact_uri_passwords("https://h/api?token=abc123&x=1") == f"https://h/api?token={REDACTED}&x=1"
    assert (
        redact_uri_passwords("sqlite:////tmp/a:b/mlflow.db") == "sqlite:////tmp/a:b/mlflow.db"
    )  # no user info


def test_redactor_removes_secrets_found_in_texts_and_environment() -> None:
    redactor = Redactor.from_texts(
        [SECRET_URI], environ={"MLFLOW_TRACKING_PASSWORD": "hunter22", "HOME": "/root"}
    )
    text = "connected with secret, password hunter22, home /root"
    assert redactor.redact(text) == f"connected with {REDACTED}, password {REDACTED}, home /root"
    assert redactor.needs_redaction(b"... hunter22 ...") and not redactor.needs_redaction(b"nothing here")


def test_secret_in_config_reaches_no_param_tag_or_artifact(tmp_path: Path) -> None:
    job_dir = tmp_path / "run"
    finished = run_app(
        TOY_APP,
        "experiment_name=secret_config",
        f"hydra.run.dir={job_dir}",
        f"+database_uri={SECRET_URI}",
        store=tmp_path,
    )
    assert finished.returncode == 0, finished.stderr
    (run,) = runs_of(f"sqlite:///{tmp_path / 'mlflow.db'}", "secret_config")
    assert run.data.params["database_uri"] == f"postgresql://user:{REDACTED}@host/db"
    logged = all_logged_text(f"sqlite:///{tmp_path / 'mlflow.db'}", run, tmp_path / "download")
    assert "overrides.yaml" in logged or ".hydra" in str(list((tmp_path / "download").rglob("*")))
    assert "secret" not in logged
    assert "secret" in (job_dir / ".hydra" / "overrides.yaml").read_text()  # the user's own disk keeps it


def _closed_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.mark.slow
def test_unreachable_postgresql_store_keeps_the_run_offline_then_sync_uploads_it_once(tmp_path: Path) -> None:
    job_dir = tmp_path / "run"
    finished = run_app(
        TOY_APP,
        "experiment_name=offline_single",
        f"hydra.run.dir={job_dir}",
        f"tracking.uri=postgresql://user:secret@127.0.0.1:{_closed_port()}/db",
        "x=4",
    )
    assert finished.returncode == 0, finished.stderr  # the job completes without its store
    output = finished.stdout + finished.stderr
    assert output.count("MLflow tracking failed") == 1, output  # warned once
    assert "secret" not in finished.stderr + finished.stdout
    record_text = (job_dir / OFFLINE_RECORD).read_text()
    assert "secret" not in record_text
    record = json.loads(record_text)
    assert record["status"] == "FINISHED" and record["metrics"]["doubled"] == 8.0

    store = f"sqlite:///{tmp_path / 'store' / 'mlflow.db'}"
    for _ in range(2):  # a second sync finds nothing left to upload
        synced = run_app(None, "sync", str(job_dir), "--tracking-uri", store, cwd=tmp_path)
        assert synced.returncode == 0, synced.stderr
    (run,) = runs_of(store, "offline_single")
    assert run.info.status == "FINISHED"
    assert run.data.metrics["doubled"] == 8.0 and run.data.params["x"] == "4"
    assert run.data.params["tracking.uri"].startswith(f"postgresql://user:{REDACTED}@")
    logged = all_logged_text(store, run, tmp_path / "download")
    assert "table.csv" in str(list((tmp_path / "download").rglob("*"))) and "secret" not in logged
    assert not (job_dir / OFFLINE_RECORD).exists() and (job_dir / SYNCED_RECORD).is_file()


@pytest.mark.slow
def test_offline_sweep_is_synced_as_one_parent_with_nested_runs(tmp_path: Path) -> None:
    sweep_dir = tmp_path / "sweep"
    finished = run_app(
        TOY_APP,
        "experiment_name=offline_sweep",
        f"hydra.sweep.dir={sweep_dir}",
        f"tracking.uri=http://user:secret@127.0.0.1:{_closed_port()}",
        "x=1,2",
        multirun=True,
    )
    assert finished.returncode == 0, finished.stderr
    assert (finished.stdout + finished.stderr).count("MLflow tracking failed") == 1, finished.stdout
    store = f"sqlite:///{tmp_path / 'store' / 'mlflow.db'}"
    synced = run_app(None, "sync", str(sweep_dir), "--tracking-uri", store, cwd=tmp_path)
    assert synced.returncode == 0, synced.stderr
    jobs, parents = jobs_and_parents(runs_of(store, "offline_sweep"))
    assert len(parents) == 1 and len(jobs) == 2
    assert {run.data.tags["mlflow.parentRunId"] for run in jobs} == {parents[0].info.run_id}
    assert sorted(run.data.metrics["doubled"] for run in jobs) == [2.0, 4.0]
    assert parents[0].info.status == "FINISHED"


def test_read_only_store_warns_once_and_keeps_the_run(tmp_path: Path) -> None:
    store = tmp_path / "ro"
    store.mkdir()
    sqlite3.connect(store / "mlflow.db").close()  # an empty file the job may not write to
    store.chmod(0o500)
    (store / "mlflow.db").chmod(0o400)
    try:
        if sys.platform != "win32" and (store / "probe").parent.stat().st_mode & 0o200:
            pytest.skip("the directory stayed writable")
        job_dir = tmp_path / "run"
        finished = run_app(TOY_APP, "experiment_name=ro", f"hydra.run.dir={job_dir}", store=store)
        if (store / "mlflow.db").stat().st_size > 0:
            pytest.skip("running as a user who may write read-only files (root)")
        assert finished.returncode == 0, finished.stderr
        assert (job_dir / OFFLINE_RECORD).is_file()
    finally:
        store.chmod(0o700)
        (store / "mlflow.db").chmod(0o600)


def test_retry_locked_retries_only_lock_errors() -> None:
    calls = []

    def flaky() -> str:
        calls.append(1)
        if len(calls) < 3:
            raise sqlite3.OperationalError("database is locked")
        return "done"

    assert retry_locked(flaky) == "done" and len(calls) == 3
    assert (
        is_locked_error(
            RuntimeError(
                "wrapped",
            )
        )
        is False
    )
    with pytest.raises(ValueError):
        retry_locked(lambda: (_ for _ in ()).throw(ValueError("other")))
