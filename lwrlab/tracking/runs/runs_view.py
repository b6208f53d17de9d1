"""Where to see an experiment's runs in MLflow's UI, opened on lwrlab's view of them in any browser.

:func:`share_runs_view` saves the view of :mod:`lwrlab.tracking.runs.view_state` (headline columns,
sorted best first, grouped by what was swept) on the experiment, as the tag
``mlflow.sharedViewState.<key>`` that MLflow's *Save view* writes; :func:`runs_view_hint` says how
to open it: a server's URL, or the ``mlflow ui`` command and the URL for a local store, on MLflow's
model-training view (MLflow 3.17 opens a new browser on its GenAI view whatever the experiment's
kind) with ``viewStateShareKey=<key>``. A colleague's fresh browser opens the same table: nothing
is kept in local storage first. :func:`runs_view_link` does both for ``lwrlab compare`` and the end
of a sweep.

The key is a hash of the view's name, which says what the view groups by (``lwrlab · runs by
estimator``): comparing again, or another sweep of the same keys, writes the same key, so a link
printed before keeps working; a view whose state has not changed is not written again. The view
appears in the UI's list of saved views under its name.

Examples
--------
>>> view_name(["estimator"]), share_key(view_name(["estimator"]))
('lwrlab · runs by estimator', '13ebe67a34e49cd7064ba24bea277451')
"""

from __future__ import annotations

import hashlib
import logging
import os
import shlex
import sys
import time
from collections.abc import Iterable, Sequence
from pathlib import Path

from mlflow.exceptions import MlflowException
from mlflow.tracking import MlflowClient

from lwrlab.tracking.job_config.provenance import RUN_KIND_TAG
from lwrlab.tracking.job_config.redaction import Redactor
from lwrlab.tracking.runs.view_state import (
    SavedView,
    decode_view,
    encode_view,
    is_replication,
    runs_view_state,
)
from lwrlab.tracking.store.connection import without_userinfo
from lwrlab.tracking.store.sqlite import retry_locked, sqlite_database_path

log = logging.getLogger(__name__)

MLFLOW_UI_HOST = "127.0.0.1"
MLFLOW_UI_PORT = 5000
MLFLOW_UI_ADDRESS = f"http://{MLFLOW_UI_HOST}:{MLFLOW_UI_PORT}"
"""Where ``mlflow ui`` serves by default."""
SHARED_VIEW_TAG_PREFIX = "mlflow.sharedViewState."
"""The experiment tags holding saved views (MLflow's ``EXPERIMENT_PAGE_VIEW_STATE_SHARE_TAG_PREFIX``)."""
SHARE_KEY_PARAMETER = "viewStateShareKey"
"""The URL parameter naming the saved view the runs page opens on."""


def view_name(grouped_by: Sequence[str]) -> str:
    """The name of lwrlab's view of runs grouped by ``grouped_by`` (by ``run_kind`` without any)."""
    return "lwrlab · runs by " + (", ".join(grouped_by) or RUN_KIND_TAG)


def share_key(name: str) -> str:
    """The key of the view named ``name``: 32 hex digits of its SHA-256, the same on every run."""
    return hashlib.sha256(f"lwrlab runs view: {name}".encode()).hexdigest()[:32]


def _has_logged_models(client: MlflowClient, experiment_id: str) -> bool:
    try:
        return len(retry_locked(client.search_logged_models, [experiment_id], max_results=1)) > 0
    except (MlflowException, NotImplementedError):  # a store without logged models
        return False


def share_runs_view(
    client: MlflowClient,
    experiment_id: str,
    metrics: Iterable[str],
    grouped_by: Sequence[str],
    shown_params: Sequence[str] = (),
) -> str:
    """Save lwrlab's view of the experiment's runs on it; return the view's key.

    Parameters are those of :func:`~lwrlab.tracking.runs.view_state.runs_view_state` (whether to
    show Models is read from the store); a seed among ``grouped_by`` is shown, not grouped by. The
    tag is written only if it is missing or holds another state; its creation time is kept.
    """
    grouped = [key for key in grouped_by if not is_replication(key)]
    shown = [*(key for key in grouped_by if is_replication(key)), *shown_params]
    name = view_name(grouped)
    key = share_key(name)
    state = runs_view_state(metrics, grouped, shown, _has_logged_models(client, experiment_id))
    tag = SHARED_VIEW_TAG_PREFIX + key
    now_ms = int(time.time() * 1000)
    created_ms = now_ms
    stored = retry_locked(client.get_experiment, experiment_id).tags.get(tag)
    if stored is not None:
        try:
            previous = decode_view(stored)
        except ValueError:  # not readable: replaced
            previous = None
        if previous is not None and previous.state == state and previous.name == name:
            return key
        created_ms = previous.created_ms if previous is not None and previous.created_ms else now_ms
    value = encode_view(SavedView(name, state, created_ms, now_ms))
    retry_locked(client.set_experiment_tag, experiment_id, tag, value)
    return key


def runs_view_path(experiment_id: str, key: str | None = None) -> str:
    """The UI path of an experiment's runs in MLflow's model-training view, on the saved view ``key``.

    Examples
    --------
    >>> runs_view_path("3")
    '/#/experiments/3/runs?workflowType=machine_learning'
    >>> runs_view_path("3", "13eb")
    '/#/experiments/3/runs?viewStateShareKey=13eb&workflowType=machine_learning'
    """
    shared = f"{SHARE_KEY_PARAMETER}={key}&" if key else ""
    return f"/#/experiments/{experiment_id}/runs?{shared}workflowType=machine_learning"


def mlflow_executable() -> str:
    """The ``mlflow`` command installed beside the running Python (the MLflow lwrlab uses), as a reader
    types it: relative to the working directory inside it (``.venv/bin/mlflow`` after the README's
    set-up, which puts nothing on ``PATH``), else its absolute path; ``mlflow`` where there is none."""
    beside = Path(sys.executable).parent / ("mlflow.exe" if os.name == "nt" else "mlflow")
    if not beside.is_file():
        return "mlflow"
    try:
        return str(beside.relative_to(Path.cwd()))
    except ValueError:
        return str(beside)


def runs_view_hint(
    tracking_uri: str,
    experiment_id: str,
    ui_port: int = MLFLOW_UI_PORT,
    key: str | None = None,
    mlflow: str | None = None,
) -> str | None:
    """How to open an experiment's runs in MLflow's UI: a server's URL, or ``mlflow ui`` for a local store.

    Parameters
    ----------
    tracking_uri
        The store, absolute (see :func:`~lwrlab.tracking.store.sqlite.absolute_tracking_uri`).
    experiment_id
        The experiment.
    ui_port
        The port ``mlflow ui`` serves a local store on (``mlflow ui --port``).
    key
        The saved view the link opens (:func:`share_runs_view`); ``None``: the browser's own.
    mlflow
        The ``mlflow`` command printed; ``None``: :func:`mlflow_executable`.

    Returns
    -------
    str | None
        One line; ``None`` for a store that is neither a server nor local (a database server, Databricks).

    Examples
    --------
    >>> runs_view_hint("http://user:secret@mlflow.lab:5000/", "3")
    'MLflow UI: http://mlflow.lab:5000/#/experiments/3/runs?workflowType=machine_learning'
    >>> runs_view_hint(
    ...     "sqlite:////lab/outputs/mlflow.db", "3", key="13eb", mlflow=".venv/bin/mlflow"
    ... )  # doctest: +NORMALIZE_WHITESPACE
    'MLflow UI: .venv/bin/mlflow ui --backend-store-uri sqlite:////lab/outputs/mlflow.db, then open
    http://127.0.0.1:5000/#/experiments/3/runs?viewStateShareKey=13eb&workflowType=machine_learning'
    >>> runs_view_hint(
    ...     "sqlite:////lab/mlflow.db", "3", ui_port=5001, mlflow="mlflow"
    ... )  # doctest: +NORMALIZE_WHITESPACE
    'MLflow UI: mlflow ui --backend-store-uri sqlite:////lab/mlflow.db --port 5001, then open
    http://127.0.0.1:5001/#/experiments/3/runs?workflowType=machine_learning'
    """
    path = runs_view_path(experiment_id, key)
    if tracking_uri.startswith(("http://", "https://")):
        server = Redactor().redact(without_userinfo(tracking_uri)).rstrip("/")
        return f"MLflow UI: {server}{path}"
    is_folder = "://" not in tracking_uri and ":" not in tracking_uri  # a plain path: a file store
    if sqlite_database_path(tracking_uri) is None and not tracking_uri.startswith("file:") and not is_folder:
        return None
    executable = shlex.quote(mlflow or mlflow_executable())
    command = f"{executable} ui --backend-store-uri {shlex.quote(tracking_uri)}"
    if ui_port != MLFLOW_UI_PORT:
        command += f" --port {ui_port}"
    return f"MLflow UI: {command}, then open http://{MLFLOW_UI_HOST}:{ui_port}{path}"


def runs_view_link(
    client: MlflowClient,
    tracking_uri: str,
    experiment_id: str,
    metrics: Iterable[str],
    grouped_by: Sequence[str],
    shown_params: Sequence[str] = (),
    ui_port: int = MLFLOW_UI_PORT,
) -> str | None:
    """Save lwrlab's view of the runs (:func:`share_runs_view`) and return the line that opens it.

    ``None`` where :func:`runs_view_hint` has no link (nothing is saved then). A store that refuses
    the tag (read-only, no permission) gets a warning and the link to the browser's own view.
    """
    if runs_view_hint(tracking_uri, experiment_id, ui_port) is None:
        return None
    try:
        key: str | None = share_runs_view(client, experiment_id, metrics, grouped_by, shown_params)
    except (MlflowException, OSError) as error:
        log.warning(
            "could not save the runs view on the experiment (%s): the link opens the browser's own view",
            Redactor().redact(f"{type(error).__name__}: {error}"),
        )
        key = None
    return runs_view_hint(tracking_uri, experiment_id, ui_port, key)


__all__ = [
    "MLFLOW_UI_ADDRESS",
    "MLFLOW_UI_HOST",
    "MLFLOW_UI_PORT",
    "SHARED_VIEW_TAG_PREFIX",
    "SHARE_KEY_PARAMETER",
    "mlflow_executable",
    "runs_view_hint",
    "runs_view_link",
    "runs_view_path",
    "share_key",
    "share_runs_view",
    "view_name",
]
