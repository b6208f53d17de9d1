"""What a job's run receives, and the files that tie a job output folder to its run.

Shared by the tracking callback, ``lwrlab sync`` and the ending of interrupted runs:

* :func:`log_params` and :func:`log_metrics` log in batches of MLflow's maximum size (one store
  transaction per batch rather than one per value);
* :func:`log_output_folder` uploads the job output folder as the run's artifacts, secrets redacted;
* :func:`log_job_tags` sets the tags a stage asked for in ``tags.json``;
* :func:`write_error_file` keeps a failed job's traceback in ``error.txt``.

Files in a job output folder: ``mlflow_run_id.txt`` (the run it was logged as),
``resumed_from_run.txt`` (written instead of a run when a re-launched sweep skips a finished job),
``error.txt`` and ``tags.json``.
"""

from __future__ import annotations

import json
import logging
import time
import traceback
import urllib.parse
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import TypeVar

from mlflow.entities import Metric, Param
from mlflow.tracking import MlflowClient
from mlflow.utils import validation as mlflow_limits

from lwrlab.tracking.job_config.redaction import Redactor, redacted_folder
from lwrlab.tracking.runs.forwarded_error import ForwardedError
from lwrlab.tracking.store.sqlite import retry_locked

log = logging.getLogger(__name__)

PARAMS_PER_BATCH: int = getattr(mlflow_limits, "MAX_PARAMS_TAGS_PER_BATCH", 100)
METRICS_PER_BATCH: int = getattr(mlflow_limits, "MAX_METRICS_PER_BATCH", 1000)

RUN_ID_FILE = "mlflow_run_id.txt"
ERROR_FILE = "error.txt"
JOB_TAGS_FILE = "tags.json"
"""Tags a stage asks for (written into its output folder): set on the run before it ends."""
RESUMED_FILE = "resumed_from_run.txt"  # written instead of a new run when a sweep job already finished

Item = TypeVar("Item")


def _chunks(items: Sequence[Item], size: int) -> Iterator[Sequence[Item]]:
    for start in range(0, len(items), size):
        yield items[start : start + size]


def _local_path_of(uri: str) -> Path | None:
    if uri.startswith("file:"):
        return Path(urllib.parse.unquote(urllib.parse.urlparse(uri).path))
    if "://" not in uri:
        return Path(uri)
    return None


def log_params(client: MlflowClient, run_id: str, params: Mapping[str, str]) -> None:
    """Log params in batches of MLflow's maximum size."""
    entries = [Param(key, value) for key, value in params.items()]
    for chunk in _chunks(entries, PARAMS_PER_BATCH):
        retry_locked(client.log_batch, run_id, params=list(chunk))


def log_metrics(
    client: MlflowClient, run_id: str, metrics: Mapping[str, float], timestamp_ms: int | None = None
) -> None:
    """Log metrics in batches (one store transaction per batch rather than one per metric)."""
    timestamp_ms = int(time.time() * 1000) if timestamp_ms is None else timestamp_ms
    entries = [Metric(key, float(value), timestamp_ms, 0) for key, value in metrics.items()]
    for chunk in _chunks(entries, METRICS_PER_BATCH):
        retry_locked(client.log_batch, run_id, metrics=list(chunk))


def log_output_folder(
    client: MlflowClient, run_id: str, output_dir: Path, redactor: Redactor, exclude: Sequence[str] = ()
) -> None:
    """Upload a job output folder as the run's artifacts, secrets redacted."""
    if not output_dir.is_dir():
        return
    artifact_dir = _local_path_of(retry_locked(client.get_run, run_id).info.artifact_uri or "")
    if artifact_dir is not None and artifact_dir.resolve().is_relative_to(output_dir.resolve()):
        # Copying a folder into a folder inside it would never end.
        raise ValueError(f"artifact folder {artifact_dir} lies inside the job output folder {output_dir}")
    with redacted_folder(output_dir, redactor, exclude=exclude) as folder:
        client.log_artifacts(run_id, str(folder))


def log_job_tags(client: MlflowClient, run_id: str, output_dir: Path, redactor: Redactor) -> None:
    """Set the tags a stage wrote into ``tags.json`` (``identifiability=poor``: what a reader must know)."""
    path = output_dir / JOB_TAGS_FILE
    if not path.is_file():
        return
    try:
        tags = json.loads(path.read_text())
    except (OSError, ValueError) as error:
        log.warning("%s is not readable JSON (%s): its tags are not logged", path, error)
        return
    for key, value in dict(tags).items():
        retry_locked(client.set_tag, run_id, str(key), redactor.redact(str(value)))


def write_error_file(output_dir: Path, error: object) -> None:
    """Write a failed job's traceback (or the value it failed with) into ``error.txt``; never raises."""
    if isinstance(error, ForwardedError):  # from the job's process, through the companion
        text = error.traceback_text
    elif isinstance(error, BaseException):
        text = "".join(traceback.format_exception(error))
    else:
        text = f"{error!r}\n"
    try:
        output_dir.mkdir(parents=True, exist_ok=True)
        (output_dir / ERROR_FILE).write_text(text, encoding="utf-8")
    except OSError:
        log.warning("could not write %s into %s", ERROR_FILE, output_dir, exc_info=True)


__all__ = [
    "ERROR_FILE",
    "JOB_TAGS_FILE",
    "RESUMED_FILE",
    "RUN_ID_FILE",
    "log_job_tags",
    "log_metrics",
    "log_output_folder",
    "log_params",
    "write_error_file",
]
