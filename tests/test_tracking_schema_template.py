"""New SQLite stores copied from an empty migrated database hold what MLflow's own migration builds."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest
from mlflow.tracking import MlflowClient

from lwrlab.tracking.store import schema_template
from lwrlab.tracking.store.sqlite import prepare_sqlite_store


def _statements(database: Path) -> list[str]:
    """The database as SQL, sorted (MLflow's migrations emit indexes and constraints in varying order),
    without the Default experiment's creation time."""
    connection = sqlite3.connect(database)
    try:
        lines = [line for statement in connection.iterdump() for line in statement.splitlines()]
    finally:
        connection.close()
    return sorted(line for line in lines if "'Default'" not in line)


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv(schema_template.CACHE_ENVIRONMENT_VARIABLE, str(folder))
    return folder


@pytest.mark.slow
def test_a_copied_store_equals_one_mlflow_migrated(tmp_path: Path, cache: Path) -> None:
    migrated = tmp_path / "migrated" / "mlflow.db"
    migrated.parent.mkdir()
    MlflowClient(tracking_uri=f"sqlite:///{migrated}").search_experiments()  # MLflow alone
    first, second = tmp_path / "first" / "mlflow.db", tmp_path / "second" / "mlflow.db"
    prepare_sqlite_store(f"sqlite:///{first}")  # builds the template
    assert schema_template.template_path().is_file() and schema_template.template_path().parent == cache
    built_at = schema_template.template_path().stat().st_mtime_ns
    prepare_sqlite_store(f"sqlite:///{second}")  # copies it
    assert schema_template.template_path().stat().st_mtime_ns == built_at
    expected = _statements(migrated)
    assert _statements(first) == expected and _statements(second) == expected
    client = MlflowClient(tracking_uri=f"sqlite:///{second}")
    (default,) = client.search_experiments()
    assert default.name == "Default" and default.artifact_location.endswith("0")
    run = client.create_run(client.create_experiment("e"))
    client.log_metric(run.info.run_id, "rms", 0.5)
    assert client.get_run(run.info.run_id).data.metrics == {"rms": 0.5}


def test_a_template_mlflow_refuses_is_not_copied_and_is_discarded(tmp_path: Path, cache: Path) -> None:
    template = schema_template.template_path()
    template.parent.mkdir(parents=True)
    connection = sqlite3.connect(template)
    connection.execute("create table alembic_version (version_num varchar(32) not null)")
    connection.execute("insert into alembic_version values ('not_a_revision')")
    connection.commit()
    connection.close()
    database = tmp_path / "store" / "mlflow.db"
    assert not schema_template.copy_schema_template(database)
    assert not database.exists() and not template.exists()
    assert not list(database.parent.glob("*.copying"))


def test_an_existing_store_is_left_alone(tmp_path: Path, cache: Path) -> None:
    database = tmp_path / "mlflow.db"
    database.write_bytes(b"")
    assert not schema_template.copy_schema_template(database)
    assert database.read_bytes() == b"" and not cache.exists()
