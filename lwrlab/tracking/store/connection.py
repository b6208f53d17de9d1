"""Opening a tracking store for a job: a reachability probe, the store prepared once, its experiment ensured.

* :class:`StoreConnections` connects to a store once per process: a server is probed first (MLflow
  itself retries HTTP calls for minutes), a SQLite store gets its schema and WAL journal once, and a
  store that failed is not tried again by the same process (one warning, not one delay per job).
* :func:`ensure_experiment` finds or creates the experiment (one creator among parallel processes),
  restores it if deleted, and gives it the model-development kind and a description.
* :func:`global_tracking_uri` points MLflow's fluent API (which reads a global URI) at a store for
  a block of calls, and leaves the global URI and ``MLFLOW_TRACKING_URI`` as they were.

Examples
--------
>>> without_userinfo("http://user:secret@db.example.org:5000/mlflow")
'http://db.example.org:5000/mlflow'
"""

from __future__ import annotations

import http.client
import logging
import os
import re
import sqlite3
import urllib.parse
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager

import mlflow
from mlflow.exceptions import MlflowException
from mlflow.tracking import MlflowClient
from sqlalchemy.exc import SQLAlchemyError

from lwrlab.tracking.job_config.naming import (
    DESCRIPTION_TAG,
    EXPERIMENT_KIND,
    EXPERIMENT_KIND_TAG,
    experiment_description,
)
from lwrlab.tracking.job_config.redaction import Redactor
from lwrlab.tracking.store.settings import TrackingSettings
from lwrlab.tracking.store.sqlite import prepare_sqlite_store, retry_locked, store_lock

log = logging.getLogger(__name__)

TRACKING_URI_VARIABLE = "MLFLOW_TRACKING_URI"
"""The variable MLflow reads its store from, and writes whenever its global URI is set."""


@contextmanager
def global_tracking_uri(uri: str) -> Iterator[None]:
    """MLflow's global tracking URI set to ``uri`` inside the block, for the fluent calls that read
    it (``Model.log``, ``mlflow.search_runs``); afterwards the URI and :data:`TRACKING_URI_VARIABLE`
    are what they were (MLflow's own setter writes the variable, and unsets it when restoring none:
    a later look-up in this process would read another store)."""
    previous_uri = mlflow.get_tracking_uri()
    previous_variable = os.environ.get(TRACKING_URI_VARIABLE)
    mlflow.set_tracking_uri(uri)
    try:
        yield
    finally:
        mlflow.set_tracking_uri(previous_uri)
        if previous_variable is None:
            os.environ.pop(TRACKING_URI_VARIABLE, None)
        else:
            os.environ[TRACKING_URI_VARIABLE] = previous_variable


HEALTH_PROBE_TIMEOUT_S = 5


class TrackingUnavailable(RuntimeError):
    """The tracking store cannot be reached."""


STORE_ERRORS: tuple[type[BaseException], ...] = (
    TrackingUnavailable,
    MlflowException,
    SQLAlchemyError,
    sqlite3.Error,
    OSError,
)
"""What opening or preparing a store raises when the store is unusable (down, read-only, corrupt)."""


def without_userinfo(uri: str) -> str:
    """``uri`` without a user name and password (for a probe that must not send them, or a message)."""
    parts = urllib.parse.urlsplit(uri)
    host = parts.hostname or ""
    netloc = f"[{host}]" if ":" in host else host
    if parts.port is not None:
        netloc += f":{parts.port}"
    return urllib.parse.urlunsplit((parts.scheme, netloc, parts.path, parts.query, parts.fragment))


def probe_server(uri: str) -> None:
    """Raise :class:`TrackingUnavailable` unless an MLflow server answers ``/health`` at ``uri`` quickly."""
    address = without_userinfo(uri)
    try:
        with urllib.request.urlopen(address.rstrip("/") + "/health", timeout=HEALTH_PROBE_TIMEOUT_S):
            pass
    except (OSError, ValueError, http.client.HTTPException) as error:  # URLError and timeouts are OSErrors
        raise TrackingUnavailable(f"no MLflow server answers at {address}: {error}") from error


class StoreConnections:
    """The stores one process has prepared, or found unusable; picklable (it holds no client)."""

    def __init__(self) -> None:
        self.unreachable: set[str] = set()
        self.prepared: set[str] = set()

    def connect(self, uri: str, client: MlflowClient | None, redactor: Redactor) -> MlflowClient:
        """A client of the store at ``uri`` (``client`` itself if it is one), the store made ready.

        Also makes ``uri`` MLflow's global tracking URI, so that code inside the job sees the same store.

        Raises
        ------
        TrackingUnavailable, MlflowException, SQLAlchemyError, sqlite3.Error, OSError
            The store cannot be used; it is then not tried again by this process.
        """
        if uri in self.unreachable:
            raise TrackingUnavailable(f"{redactor.redact(uri)} was unreachable earlier in this process")
        reused = client if client is not None and client.tracking_uri == uri else None
        try:
            if uri.startswith(("http://", "https://")):
                probe_server(uri)
            if uri not in self.prepared:
                prepare_sqlite_store(uri)  # schema and WAL once per store, under a file lock
                reused = reused or MlflowClient(tracking_uri=uri)
                retry_locked(reused.search_experiments, max_results=1)  # fails here if the store is unusable
                self.prepared.add(uri)
        except STORE_ERRORS:
            self.unreachable.add(uri)
            raise
        mlflow.set_tracking_uri(uri)
        return reused or MlflowClient(tracking_uri=uri)


def experiment_tags(name: str) -> dict[str, str]:
    """Tags of a new experiment: the model-development kind and a description of its metrics."""
    return {EXPERIMENT_KIND_TAG: EXPERIMENT_KIND, DESCRIPTION_TAG: experiment_description(name)}


def ensure_experiment(client: MlflowClient, settings: TrackingSettings) -> str:
    """The id of ``settings.experiment``, created (once among parallel processes) or restored if needed.

    A new experiment gets :func:`experiment_tags`; an existing one without a kind gets them too.
    """
    name = settings.experiment
    experiment = retry_locked(client.get_experiment_by_name, name)
    if experiment is None:
        artifact_location = None
        if settings.artifact_location is not None:
            folder = re.sub(r"[^\w.\-]", "_", name)
            artifact_location = settings.artifact_location.rstrip("/") + "/" + folder
        with store_lock(settings.tracking_uri):  # one creator among parallel processes on SQLite
            experiment = retry_locked(client.get_experiment_by_name, name)
            if experiment is None:
                try:
                    return retry_locked(
                        client.create_experiment,
                        name,
                        artifact_location=artifact_location,
                        tags=experiment_tags(name),
                    )
                except MlflowException:
                    # Another process (another machine, for a server) created it first.
                    experiment = client.get_experiment_by_name(name)
                    if experiment is None:
                        raise
    if experiment.lifecycle_stage == "deleted":
        log.warning("MLflow experiment %r was deleted; restoring it to log this run", name)
        retry_locked(client.restore_experiment, experiment.experiment_id)
    if EXPERIMENT_KIND_TAG not in experiment.tags:  # made by an older lwrlab, or by hand
        for key, value in experiment_tags(name).items():
            if key not in experiment.tags:
                retry_locked(client.set_experiment_tag, experiment.experiment_id, key, value)
    return experiment.experiment_id


__all__ = [
    "STORE_ERRORS",
    "StoreConnections",
    "TrackingUnavailable",
    "ensure_experiment",
    "experiment_tags",
    "probe_server",
    "without_userinfo",
]
