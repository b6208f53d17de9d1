"""Where to see an experiment's runs in MLflow's UI: a server's URL, or the ``mlflow ui`` command for a
local store, on MLflow's model-training view (not its GenAI view).
"""

from __future__ import annotations

import logging
import shlex

from lwrlab.tracking.job_config.redaction import Redactor
from lwrlab.tracking.store.connection import without_userinfo
from lwrlab.tracking.store.sqlite import (
    sqlite_database_path,
)

log = logging.getLogger(__name__)


MLFLOW_UI_HOST = "127.0.0.1"
MLFLOW_UI_PORT = 5000
MLFLOW_UI_ADDRESS = f"http://{MLFLOW_UI_HOST}:{MLFLOW_UI_PORT}"
"""Where ``mlflow ui`` serves by default."""


def runs_view_path(experiment_id: str) -> str:
    """The UI path of an experiment's runs in MLflow's model-training view (not its GenAI view).

    Examples
    --------
    >>> runs_view_path("3")
    '/#/experiments/3/runs?workflowType=machine_learning'
    """
    return f"/#/experiments/{experiment_id}/runs?workflowType=machine_learning"


def runs_view_hint(tracking_uri: str, experiment_id: str, ui_port: int = MLFLOW_UI_PORT) -> str | None:
    """How to open an experiment's runs in MLflow's UI: a server's URL, or ``mlflow ui`` for a local store.

    Parameters
    ----------
    tracking_uri
        The store, absolute (see :func:`~lwrlab.tracking.store.sqlite.absolute_tracking_uri`).
    experiment_id
        The experiment.
    ui_port
        The port ``mlflow ui`` serves a local store on (``mlflow ui --port``).

    Returns
    -------
    str | None
        One line; ``None`` for a store that is neither a server nor local (a database server, Databricks).

    Examples
    --------
    >>> runs_view_hint("http://user:secret@mlflow.lab:5000/", "3")
    'MLflow UI: http://mlflow.lab:5000/#/experiments/3/runs?workflowType=machine_learning'
    >>> runs_view_hint("sqlite:////lab/outputs/mlflow.db", "3")  # doctest: +NORMALIZE_WHITESPACE
    'MLflow UI: mlflow ui --backend-store-uri sqlite:////lab/outputs/mlflow.db, then open
    http://127.0.0.1:5000/#/experiments/3/runs?workflowType=machine_learning'
    >>> runs_view_hint("sqlite:////lab/mlflow.db", "3", ui_port=5001)  # doctest: +NORMALIZE_WHITESPACE
    'MLflow UI: mlflow ui --backend-store-uri sqlite:////lab/mlflow.db --port 5001, then open
    http://127.0.0.1:5001/#/experiments/3/runs?workflowType=machine_learning'
    """
    path = runs_view_path(experiment_id)
    if tracking_uri.startswith(("http://", "https://")):
        server = Redactor().redact(without_userinfo(tracking_uri)).rstrip("/")
        return f"MLflow UI: {server}{path}"
    is_folder = "://" not in tracking_uri and ":" not in tracking_uri  # a plain path: a file store
    if sqlite_database_path(tracking_uri) is None and not tracking_uri.startswith("file:") and not is_folder:
        return None
    command = f"mlflow ui --backend-store-uri {shlex.quote(tracking_uri)}"
    if ui_port != MLFLOW_UI_PORT:
        command += f" --port {ui_port}"
    return f"MLflow UI: {command}, then open http://{MLFLOW_UI_HOST}:{ui_port}{path}"
