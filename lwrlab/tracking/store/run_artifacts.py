"""Files of an earlier MLflow run, fetched by run id (what a plugin is handed instead of MLflow itself)."""

from __future__ import annotations

from pathlib import Path


def download_run_artifact(run_id: str, artifact_path: str, tracking_uri: str | None = None) -> Path:
    """Download the artifact ``artifact_path`` of MLflow run ``run_id`` and return its local path.

    Parameters
    ----------
    run_id : the MLflow run id.
    artifact_path : the artifact's path inside the run, e.g. ``identified_model.yaml``.
    tracking_uri : the store to look the run up in (``None``: ``MLFLOW_TRACKING_URI`` or MLflow's default).

    Raises
    ------
    FileNotFoundError
        When the store has no such run or the run no such artifact; the message names both and the store.
    """
    import mlflow.artifacts  # only when a run id is looked up: keeps file-based use light
    from mlflow.exceptions import MlflowException

    try:
        local = mlflow.artifacts.download_artifacts(
            run_id=run_id, artifact_path=artifact_path, tracking_uri=tracking_uri
        )
    except (MlflowException, OSError) as error:
        store = tracking_uri or "(default)"
        raise FileNotFoundError(
            f"no {artifact_path} for MLflow run {run_id!r} in store {store}: {error}"
        ) from error
    return Path(local)
