"""``lwrlab sync``: upload the runs that jobs kept on disk while the tracking store was unreachable.

Each ``mlflow_offline_run.json`` under the given folders (default ``outputs/``) becomes a run with
its params, tags, metrics, status, times and the job output folder as artifacts (secrets redacted),
and the model a finished job identified becomes the run's MLflow Model (registered where the job's
``tracking.register_model`` says), as if the store had been there.
Jobs of one sweep are nested under one parent run. A synced record is renamed
``mlflow_synced_run.json``; its id is also a run tag, so running sync twice never logs a run twice.

Examples
--------
::

    lwrlab sync                                            # outputs/ into the default SQLite store
    lwrlab sync outputs/multiruns/2026-11-23 --tracking-uri http://127.0.0.1:5000
"""

from __future__ import annotations

import argparse
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import mlflow
import yaml
from mlflow.tracking import MlflowClient

from lwrlab.tracking.job_config.provenance import PARENT_RUN_TAG, RUN_KIND_TAG
from lwrlab.tracking.job_config.redaction import Redactor
from lwrlab.tracking.models.model_logging import log_model_inputs
from lwrlab.tracking.models.registry import log_and_register
from lwrlab.tracking.runs import offline
from lwrlab.tracking.runs.run_logging import RUN_ID_FILE, log_metrics, log_output_folder, log_params
from lwrlab.tracking.runs.run_queries import run_with_tag, sweep_run_of_folder
from lwrlab.tracking.store.connection import ensure_experiment
from lwrlab.tracking.store.settings import TrackingSettings
from lwrlab.tracking.store.sqlite import (
    absolute_artifact_location,
    absolute_tracking_uri,
    add_tracking_uri_option,
    prepare_sqlite_store,
    retry_locked,
)

log = logging.getLogger(__name__)

DEFAULT_ARTIFACT_LOCATION = "outputs/mlartifacts"
RECORD_TAG = "offline_record_id"


class Syncer:
    """Uploads offline records into one store, creating experiments and sweep parents as needed."""

    def __init__(self, tracking_uri: str, artifact_location: str | None, log_artifacts: bool = True) -> None:
        self.tracking_uri = tracking_uri
        self.artifact_location = artifact_location
        self.log_artifacts = log_artifacts
        prepare_sqlite_store(tracking_uri)
        self.client = MlflowClient(tracking_uri=tracking_uri)
        mlflow.set_tracking_uri(tracking_uri)  # registering resolves a logged model through the global URI
        self._parents: dict[tuple[str, str], str] = {}
        self._failed_parents: set[str] = set()

    def _experiment(self, name: str) -> str:
        return ensure_experiment(
            self.client, TrackingSettings(self.tracking_uri, name, self.artifact_location, self.log_artifacts)
        )

    def _parent(self, experiment_id: str, record: dict[str, Any]) -> str | None:
        sweep_dir = record.get("sweep_dir")
        if not sweep_dir:
            return None
        key = (experiment_id, sweep_dir)
        if key not in self._parents:
            existing = sweep_run_of_folder(self.client, experiment_id, sweep_dir)
            if existing is not None:
                self._parents[key] = existing.info.run_id
            else:
                overrides = record.get("sweep_overrides", "")
                run = retry_locked(
                    self.client.create_run,
                    experiment_id,
                    run_name=f"sweep (synced): {overrides}".strip(),
                    start_time=record.get("start_time_ms"),
                    tags={
                        RUN_KIND_TAG: "sweep",
                        "overrides": overrides,
                        "hydra_sweep_dir": sweep_dir,
                        "synced": "true",
                    },
                )
                self._parents[key] = run.info.run_id
        return self._parents[key]

    def _already_synced(self, experiment_id: str, record_id: str) -> str | None:
        run = run_with_tag(self.client, experiment_id, RECORD_TAG, record_id)
        return run.info.run_id if run is not None else None

    def sync(self, path: Path) -> str:
        """Upload one record; returns the run id (an existing one if it was uploaded before)."""
        record = offline.read_record(path)
        output_dir = path.parent
        experiment_id = self._experiment(record["experiment"])
        run_id = self._already_synced(experiment_id, record["record_id"])
        if run_id is None:
            tags = {**record["tags"], RECORD_TAG: record["record_id"], "synced": "true"}
            parent = self._parent(experiment_id, record)
            if parent is not None:
                tags[PARENT_RUN_TAG] = parent
            run = retry_locked(
                self.client.create_run,
                experiment_id,
                run_name=record["run_name"],
                start_time=record.get("start_time_ms"),
                tags=tags,
            )
            run_id = run.info.run_id
            log_params(self.client, run_id, record["params"])
            log_metrics(self.client, run_id, record["metrics"], record.get("end_time_ms"))
            if self.log_artifacts:
                redactor = Redactor.for_output_folder(output_dir)
                log_output_folder(self.client, run_id, output_dir, redactor, exclude=[offline.OFFLINE_RECORD])
            status = record["status"] if record["status"] != "RUNNING" else "KILLED"  # the job never ended
            self._guarded(run_id, output_dir, "recording the models it read", log_model_inputs, self.client)
            if status == "FINISHED":
                self._guarded(
                    run_id, output_dir, "logging its model as an MLflow Model", self._log_model, record
                )
            retry_locked(
                self.client.set_terminated, run_id, status=status, end_time=record.get("end_time_ms")
            )
            if status != "FINISHED" and parent is not None:
                self._failed_parents.add(parent)
        (output_dir / RUN_ID_FILE).write_text(run_id + "\n", encoding="utf-8")
        offline.mark_synced(path, run_id)
        return run_id

    @staticmethod
    def _guarded(run_id: str, output_dir: Path, what: str, step: Any, *args: Any) -> None:
        """``step(*args, run_id, output_dir)``; a failure is warned about, the upload goes on."""
        try:
            step(*args, run_id, output_dir)
        except Exception as error:  # broad: the run is uploaded; only this part of it is missing
            log.warning(
                "run %s (%s): %s failed (%s: %s); the job's files are among the run's artifacts",
                run_id,
                output_dir,
                what,
                type(error).__name__,
                error,
            )

    def _log_model(self, record: dict[str, Any], run_id: str, output_dir: Path) -> None:
        """Log the model the job identified (a robot or a payload) as the run's MLflow Model, and
        register it where the job's ``tracking.register_model`` says, as the job would have."""
        config_file = output_dir / ".hydra" / "config.yaml"
        config = yaml.safe_load(config_file.read_text()) if config_file.is_file() else None
        setting = ((config or {}).get("tracking") or {}).get("register_model")
        run_name, metrics = record["run_name"], record["metrics"]
        log_and_register(self.client, run_id, output_dir, self.tracking_uri, setting, run_name, metrics, [])

    def close_parents(self) -> None:
        """End the parent runs created or reused by this sync: FAILED if one of their jobs failed."""
        for parent in self._parents.values():
            if retry_locked(self.client.get_run, parent).info.status == "RUNNING":
                status = "FAILED" if parent in self._failed_parents else "FINISHED"
                retry_locked(self.client.set_terminated, parent, status=status)


def sync_offline_runs(
    roots: Sequence[Path], tracking_uri: str, artifact_location: str | None = None, log_artifacts: bool = True
) -> dict[Path, str]:
    """Upload every offline run record under ``roots``.

    Parameters
    ----------
    roots
        Folders (searched recursively) or record files.
    tracking_uri
        The store to upload into.
    artifact_location
        Artifact root of experiments created by the sync (``None``: the store's default).
    log_artifacts
        Upload each job output folder as the run's artifacts.

    Returns
    -------
    dict[Path, str]
        Record path → run id.
    """
    records = offline.find_records(roots)
    if not records:
        return {}
    syncer = Syncer(tracking_uri, artifact_location, log_artifacts)
    synced = {}
    try:
        for path in records:
            synced[path] = syncer.sync(path)
    finally:
        syncer.close_parents()
    return synced


def build_parser() -> argparse.ArgumentParser:
    """The command line of ``lwrlab sync`` (the README's commands are parsed with it in the tests)."""
    parser = argparse.ArgumentParser(prog="lwrlab sync", description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "folders", nargs="*", type=Path, default=[Path("outputs")], help="where to look (default: outputs)"
    )
    add_tracking_uri_option(parser, "store to upload into")
    parser.add_argument(
        "--artifact-location",
        default=None,
        help="artifact root of experiments it creates "
        f"(default: {DEFAULT_ARTIFACT_LOCATION} for SQLite stores)",
    )
    parser.add_argument("--no-artifacts", action="store_true", help="upload params, tags and metrics only")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """``lwrlab sync [FOLDER ...] [--tracking-uri URI]``; returns the process exit status."""
    parser = build_parser()
    arguments = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    uri = absolute_tracking_uri(arguments.tracking_uri, Path.cwd())
    artifact_location = arguments.artifact_location
    if artifact_location is None and uri.startswith("sqlite:"):
        artifact_location = DEFAULT_ARTIFACT_LOCATION
    artifact_location = absolute_artifact_location(artifact_location, Path.cwd())
    synced = sync_offline_runs(arguments.folders, uri, artifact_location, not arguments.no_artifacts)
    for path, run_id in synced.items():
        print(f"{path.parent}: run {run_id}")
    print(f"synced {len(synced)} run(s) into {Redactor().redact(uri)}")
    return 0


__all__ = ["Syncer", "main", "sync_offline_runs"]
