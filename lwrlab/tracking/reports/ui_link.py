"""Where to see an experiment's runs in MLflow's UI: a server's URL, or the ``mlflow ui`` command for a
local store, opening on lwrlab's saved view of them.

The link and the view live in :mod:`lwrlab.tracking.runs.runs_view`, below both the reports and the
end of a sweep, which prints the link too; this module keeps the names importable from here.
"""

from __future__ import annotations

from lwrlab.tracking.runs.runs_view import (
    MLFLOW_UI_ADDRESS,
    MLFLOW_UI_HOST,
    MLFLOW_UI_PORT,
    runs_view_hint,
    runs_view_link,
    runs_view_path,
    share_runs_view,
)

__all__ = [
    "MLFLOW_UI_ADDRESS",
    "MLFLOW_UI_HOST",
    "MLFLOW_UI_PORT",
    "runs_view_hint",
    "runs_view_link",
    "runs_view_path",
    "share_runs_view",
]
