"""Safe concurrent use of one SQLite MLflow store by many processes.

Known MLflow problems with SQLite under parallel jobs: several processes creating the schema of a
new database at once (migration races), two processes creating the same experiment, and
``database is locked`` errors when writers collide. The remedies here:

* :func:`store_lock` — an exclusive file lock (``<db>.lock``) held while a process creates the
  schema or an experiment, so that only one does it;
* :func:`prepare_sqlite_store` — creates the schema once (a new store copies an empty migrated
  database, see :mod:`lwrlab.tracking.store.schema_template`) and switches the database to WAL
  journaling (readers no longer block the writer; the setting persists in the file);
* :func:`retry_locked` — retries a store call that failed with ``database is locked``, with
  jittered exponential back-off.

:func:`absolute_tracking_uri` and :func:`absolute_artifact_location` pin a relative store or artifact
folder to the folder a command was started in, so that every process of a sweep finds the same store.
"""

from __future__ import annotations

import argparse
import logging
import os
import random
import sqlite3
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TypeVar

from lwrlab.tracking.store.schema_template import copy_schema_template

try:  # POSIX only; elsewhere the lock is a no-op and retries carry the load
    import fcntl
except ImportError:  # pragma: no cover
    fcntl = None  # type: ignore[assignment]

log = logging.getLogger(__name__)

DEFAULT_TRACKING_URI = "sqlite:///outputs/mlflow.db"
"""The store the subcommands read when neither ``--tracking-uri`` nor ``$MLFLOW_TRACKING_URI`` says
(the one ``conf/tracking/sqlite.yaml`` writes jobs into)."""


def add_tracking_uri_option(parser: argparse.ArgumentParser, what: str = "MLflow store") -> None:
    """``--tracking-uri`` of the ``lwrlab`` subcommands: ``$MLFLOW_TRACKING_URI``, else the default store."""
    parser.add_argument(
        "--tracking-uri",
        default=os.environ.get("MLFLOW_TRACKING_URI", DEFAULT_TRACKING_URI),
        help=f"{what} (default: $MLFLOW_TRACKING_URI, else {DEFAULT_TRACKING_URI})",
    )


Result = TypeVar("Result")

LOCKED_MESSAGES = ("database is locked", "database table is locked")
RETRY_ATTEMPTS = 12
RETRY_FIRST_DELAY_S = 0.05
RETRY_MAX_DELAY_S = 2.0

# Tracking URIs without "://" that are not file paths.
_BARE_URI_SCHEMES = frozenset({"databricks", "databricks-uc", "uc"})


def absolute_tracking_uri(tracking_uri: str, base_dir: Path) -> str:
    """Make a relative SQLite path (``sqlite:///outputs/mlflow.db``) or plain folder absolute.

    Relative paths are taken from ``base_dir`` (the directory Hydra was started from), so the store
    does not move when ``hydra.job.chdir=true`` changes the working directory.

    Examples
    --------
    >>> absolute_tracking_uri("sqlite:///outputs/mlflow.db", Path("/home/me/lab"))
    'sqlite:////home/me/lab/outputs/mlflow.db'
    >>> absolute_tracking_uri("http://127.0.0.1:5000", Path("/home/me/lab"))
    'http://127.0.0.1:5000'
    """
    if tracking_uri.startswith("sqlite:///"):
        path = tracking_uri[len("sqlite:///") :]
        if path and path != ":memory:" and not os.path.isabs(path):
            return "sqlite:///" + str((base_dir / path).resolve())
        return tracking_uri
    if "://" not in tracking_uri and ":" not in tracking_uri and tracking_uri not in _BARE_URI_SCHEMES:
        return str((base_dir / tracking_uri).resolve())
    return tracking_uri


def absolute_artifact_location(artifact_location: str | None, base_dir: Path) -> str | None:
    """Make a relative artifact folder absolute (URIs such as ``s3://`` are kept as they are)."""
    if artifact_location is None or "://" in artifact_location:
        return artifact_location
    return str((base_dir / artifact_location).resolve())


def sqlite_database_path(tracking_uri: str) -> Path | None:
    """The database file of a ``sqlite:///`` URI, ``None`` for other stores."""
    if not tracking_uri.startswith("sqlite:///"):
        return None
    path = tracking_uri[len("sqlite:///") :]
    return Path(path) if path and path != ":memory:" else None


@contextmanager
def store_lock(tracking_uri: str) -> Iterator[None]:
    """Hold an exclusive lock on a SQLite store (other stores: no lock, they serialise themselves)."""
    database = sqlite_database_path(tracking_uri)
    if database is None or fcntl is None:
        yield
        return
    database.parent.mkdir(parents=True, exist_ok=True)
    with open(database.with_name(database.name + ".lock"), "a+") as handle:
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle.fileno(), fcntl.LOCK_UN)


def _use_wal_journal(database: Path) -> None:
    connection = sqlite3.connect(database, timeout=30)
    try:
        connection.execute("PRAGMA journal_mode=WAL")
    finally:
        connection.close()


def prepare_sqlite_store(tracking_uri: str) -> None:
    """Create the schema of a SQLite store once and turn on WAL journaling; no-op for other stores.

    Call it in the launching process before workers start; workers calling it later find the
    store ready and return at once.
    """
    database = sqlite_database_path(tracking_uri)
    if database is None:
        return
    from mlflow.tracking import MlflowClient

    with store_lock(tracking_uri):
        copy_schema_template(database)  # a new store: MLflow's schema copied, not migrated again
        MlflowClient(tracking_uri=tracking_uri).search_experiments(
            max_results=1
        )  # creates or migrates the schema
        _use_wal_journal(database)


def is_locked_error(error: BaseException) -> bool:
    """Whether ``error`` (or its cause) is SQLite's ``database is locked``."""
    for _ in range(10):  # a chain of causes, never a cycle
        if error is None:
            return False
        if any(message in str(error) for message in LOCKED_MESSAGES):
            return True
        error = error.__cause__ or error.__context__  # type: ignore[assignment]
    return False


def retry_locked(function: Callable[..., Result], *args: object, **kwargs: object) -> Result:
    """Call ``function``; on ``database is locked``, wait (jittered, doubling) and try again."""
    delay = RETRY_FIRST_DELAY_S
    for attempt in range(RETRY_ATTEMPTS):
        try:
            return function(*args, **kwargs)
        except Exception as error:  # a filter, not a catch: anything but a lock error is raised again
            if attempt == RETRY_ATTEMPTS - 1 or not is_locked_error(error):
                raise
            log.debug("store locked, retry %d in %.2f s", attempt + 1, delay)
            time.sleep(delay * (0.5 + random.random()))
            delay = min(2 * delay, RETRY_MAX_DELAY_S)
    raise AssertionError("unreachable")  # pragma: no cover


__all__ = [
    "absolute_artifact_location",
    "absolute_tracking_uri",
    "is_locked_error",
    "prepare_sqlite_store",
    "retry_locked",
    "sqlite_database_path",
    "store_lock",
]
