"""The run of one Hydra job in this process: started (or skipped, or kept offline), logged and ended.

The tracking callback makes one :class:`JobRun` per job and calls it from its hooks:

* :meth:`JobRun.start`: the experiment ensured, runs a dead process of this host left RUNNING ended,
  a job whose config already FINISHED skipped (a re-launched sweep), then the run created;
  :meth:`JobRun.log_start` writes ``mlflow_run_id.txt``, the params and the resolved config;
* :meth:`JobRun.keep_offline`: the store could not be reached; the run is kept in
  ``mlflow_offline_run.json`` for ``lwrlab sync``;
* :meth:`JobRun.end`: metrics (each under its section: ``accuracy/rms_mean``), the datasets it used,
  the tags the job asked for, the models it read, the error, the output folder, the model it
  identified (an MLflow Model of a robot or a payload, registered when ``tracking.register_model``
  names a model), the status;
* :meth:`JobRun.end_killed` (a stop signal) and :meth:`JobRun.end_at_exit` (the process exits
  without ``on_job_end``): the run ends KILLED.

Each store step of :meth:`JobRun.end` runs through the callback's guard: a failure is warned about
once and the next steps still run.
"""

from __future__ import annotations

import atexit
import logging
import signal
import socket
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from hydra.core.utils import JobReturn, JobStatus
from mlflow.entities import DatasetInput, Run
from mlflow.tracking import MlflowClient
from omegaconf import DictConfig, OmegaConf

from lwrlab.tracking.job_config.config_params import (
    is_sweep_job,
    numeric_metrics,
    original_cwd,
    plugin_choices,
    resolved_job_config,
    runtime_choices,
    task_overrides,
    truncate,
)
from lwrlab.tracking.job_config.datasets import job_datasets
from lwrlab.tracking.job_config.metric_sections import plain_metrics, sectioned_metrics
from lwrlab.tracking.job_config.provenance import PARENT_RUN_TAG
from lwrlab.tracking.job_config.redaction import Redactor
from lwrlab.tracking.job_config.run_params import RESOLVED_CONFIG_ARTIFACT
from lwrlab.tracking.lifecycle import job_state
from lwrlab.tracking.lifecycle.sweep_run import fail_sweep_run
from lwrlab.tracking.lifecycle.sweep_stop import Guard, end_earlier_attempts
from lwrlab.tracking.models.model_logging import log_model_inputs
from lwrlab.tracking.models.registry import log_and_register
from lwrlab.tracking.runs import offline
from lwrlab.tracking.runs.finalise import end_killed, finalise_stale_runs
from lwrlab.tracking.runs.forwarded_error import ForwardedError
from lwrlab.tracking.runs.processes import JobInterrupted
from lwrlab.tracking.runs.run_datasets import log_datasets
from lwrlab.tracking.runs.run_logging import (
    RESUMED_FILE,
    RUN_ID_FILE,
    log_job_tags,
    log_metrics,
    log_output_folder,
    log_params,
    write_error_file,
)
from lwrlab.tracking.runs.run_queries import (
    RETRIED_BY_TAG,
    REUSED_RUN_TAG_PREFIX,
    resume_lookup,
    sweep_is_stopping,
)
from lwrlab.tracking.store.connection import ensure_experiment
from lwrlab.tracking.store.settings import TrackingSettings
from lwrlab.tracking.store.sqlite import retry_locked

log = logging.getLogger(__name__)

ERROR_TAG_MAX_LENGTH = 1000  # a readable summary; the full traceback goes to error.txt
_STATUS_OF_JOB = {JobStatus.COMPLETED: "FINISHED", JobStatus.FAILED: "FAILED", JobStatus.UNKNOWN: "KILLED"}

Warn = Callable[[str, BaseException], None]
"""``warn(action, error)``: report a tracking failure (the callback's warn-once)."""


class JobRun:
    """The run of one job; ``run_id`` is set while the run is open in the store.

    Parameters
    ----------
    output_dir
        The job output folder.
    redactor
        The job's secrets, kept out of everything logged.
    warn, guard
        The callback's failure reporting (see :data:`Warn` and
        :data:`~lwrlab.tracking.lifecycle.sweep_stop.Guard`).
    """

    def __init__(self, output_dir: Path, redactor: Redactor, warn: Warn, guard: Guard) -> None:
        self.output_dir = output_dir
        self.redactor = redactor
        self.warn = warn
        self.guard = guard
        self.start_ms = int(time.time() * 1000)
        self.settings: TrackingSettings | None = None
        self.client: MlflowClient | None = None
        self.run_id: str | None = None
        self.run_name = ""
        self.datasets: list[DatasetInput] = []  # what the job used, once recorded at its end
        self.offline_record: dict[str, Any] | None = None
        self.skipped = False
        self.failed_attempts: list[str] = []

    def start(
        self,
        client: MlflowClient,
        config: DictConfig,
        tags: Mapping[str, str],
        run_name: str,
        parent_run_id: str | None,
        resume: bool,
    ) -> None:
        """Create the job's run in the store, or skip the job if its config already FINISHED.

        Raises the store's errors (the caller then keeps the run offline), and :class:`JobInterrupted`
        when the sweep is stopping: the job must not start.
        """
        assert self.settings is not None
        settings = self.settings
        experiment_id = ensure_experiment(client, settings)
        if not is_sweep_job(config):  # a sweep's launching process did this for its jobs
            finalise_stale_runs(client, [experiment_id], socket.gethostname(), settings.log_artifacts)
        if parent_run_id is not None and sweep_is_stopping(client, parent_run_id):
            raise JobInterrupted(signal.SIGTERM)  # dispatched while the sweep stops: do not start
        if resume and is_sweep_job(config):
            found = resume_lookup(client, experiment_id, tags["config_hash"])
            if found.finished is not None:
                self._skip(found.finished.info.run_id, found.finished.data.metrics)
                if (
                    parent_run_id is not None
                    and found.finished.data.tags.get(PARENT_RUN_TAG) != parent_run_id
                ):
                    key = f"{REUSED_RUN_TAG_PREFIX}{found.finished.info.run_id}"
                    retry_locked(client.set_tag, parent_run_id, key, tags.get("hydra_job_num", ""))
                return
            self.failed_attempts = found.failed_attempts
        if parent_run_id is not None:
            self.failed_attempts += end_earlier_attempts(
                client, experiment_id, parent_run_id, tags, settings.log_artifacts
            )
        run = retry_locked(
            client.create_run, experiment_id, run_name=run_name, tags=dict(tags), start_time=self.start_ms
        )
        self.client, self.run_id, self.run_name = client, run.info.run_id, run_name
        # Marks the run KILLED if the process exits without on_job_end (Ctrl-C: Hydra only
        # catches Exception, so a KeyboardInterrupt skips the callback).
        atexit.register(self.end_at_exit)

    def log_start(self, params: Mapping[str, str], config_text: str | None = None) -> None:
        """Write the run id into the output folder, log the params and the config (after :meth:`start`).

        ``config_text``: the job's whole resolved config (redacted), logged as
        :data:`~lwrlab.tracking.job_config.run_params.RESOLVED_CONFIG_ARTIFACT` when artifacts are logged.
        """
        if self.run_id is None or self.client is None or self.settings is None:
            return
        (self.output_dir / RUN_ID_FILE).write_text(self.run_id + "\n", encoding="utf-8")
        log_params(self.client, self.run_id, params)
        if config_text is not None and self.settings.log_artifacts:
            retry_locked(self.client.log_text, self.run_id, config_text, RESOLVED_CONFIG_ARTIFACT)
        uri = self.redactor.redact(self.settings.tracking_uri)
        log.info("MLflow run %s in experiment %r at %s", self.run_id, self.settings.experiment, uri)

    def _skip(self, finished_run_id: str, metrics: Mapping[str, float]) -> None:
        """Resume: the config already FINISHED as ``finished_run_id``; the job returns its metrics instead."""
        job_state.set_completed_metrics(plain_metrics(metrics))
        (self.output_dir / RESUMED_FILE).write_text(finished_run_id + "\n", encoding="utf-8")
        log.info("skipping the job: its config already finished as run %s", finished_run_id)
        self.skipped = True

    @staticmethod
    def _record_reuse(
        client: MlflowClient, parent_run_id: str | None, finished: Run, tags: Mapping[str, str]
    ) -> None:
        """Tag the sweep's parent run with a reused run that is not already one of its jobs
        (:data:`~lwrlab.tracking.runs.run_queries.REUSED_RUN_TAG_PREFIX`)."""
        if parent_run_id is None or finished.data.tags.get(PARENT_RUN_TAG) == parent_run_id:
            return
        key = REUSED_RUN_TAG_PREFIX + finished.info.run_id
        retry_locked(client.set_tag, parent_run_id, key, tags.get("hydra_job_num", ""))

    def end(self, job_return: JobReturn, config: DictConfig, parent_run_id: str | None) -> None:
        """Log metrics and artifacts, then end the run (or the offline record) with the job's status."""
        failed = job_return.status == JobStatus.FAILED
        # job_return.return_value re-raises a failed job's exception; the private field holds it.
        error = job_return._return_value if failed else None
        if failed:
            write_error_file(self.output_dir, error)
        recorded = job_state.take_recorded_metrics()
        metrics: dict[str, float] = {}
        if job_return.status == JobStatus.COMPLETED:
            metrics = sectioned_metrics(
                numeric_metrics(recorded if recorded is not None else job_return.return_value)
            )
        status = _STATUS_OF_JOB.get(job_return.status, "KILLED")
        error_type = error.type_name if isinstance(error, ForwardedError) else type(error).__name__
        summary = self.redactor.redact(truncate(f"{error_type}: {error}", ERROR_TAG_MAX_LENGTH))
        if self.skipped:
            job_state.reset()
            return
        if self.offline_record is not None:
            self.finish_offline(metrics, status, summary if failed else None)
            return
        run_id, client, settings = self.run_id, self.client, self.settings
        if run_id is None or client is None or settings is None:
            return  # tracking was unavailable at job start (already warned)
        try:
            guard = self.guard
            guard("logging metrics", log_metrics, client, run_id, metrics)
            guard("recording the datasets", self._log_datasets, client, run_id, config)
            guard(
                "tagging what the job reported", log_job_tags, client, run_id, self.output_dir, self.redactor
            )
            guard("recording the models the job read", log_model_inputs, client, run_id, self.output_dir)
            if failed:
                guard("tagging the error", retry_locked, client.set_tag, run_id, "error", summary)
            if settings.log_artifacts:
                guard("logging artifacts", log_output_folder, client, run_id, self.output_dir, self.redactor)
            if status == "FINISHED":
                guard("logging the identified model", self._log_model, client, run_id, config, metrics)
            guard("ending the run", retry_locked, client.set_terminated, run_id, status=status)
            if status == "FINISHED":
                for attempt in self.failed_attempts:
                    link = "linking the failed attempt"
                    guard(link, retry_locked, client.set_tag, attempt, RETRIED_BY_TAG, run_id)
            if failed and parent_run_id is not None:
                # The basic sweeper raises after a failed batch and skips on_multirun_end: mark now.
                guard(
                    "marking the sweep FAILED", fail_sweep_run, client, parent_run_id, config, self.redactor
                )
        finally:
            self.run_id = None
            atexit.unregister(self.end_at_exit)

    def _log_datasets(self, client: MlflowClient, run_id: str, config: DictConfig) -> None:
        """Record the logs or simulated motions the job used as the run's dataset inputs."""
        choices = plugin_choices(runtime_choices(config))
        uses = job_datasets(resolved_job_config(config), choices, original_cwd(config), self.output_dir)
        self.datasets = log_datasets(client, run_id, uses)

    def _log_model(
        self, client: MlflowClient, run_id: str, config: DictConfig, metrics: Mapping[str, float]
    ) -> None:
        """Log the model the job identified (a robot or a payload, if any); register it where
        ``tracking.register_model`` says."""
        assert self.settings is not None
        setting = OmegaConf.select(config, "tracking.register_model", default=None)
        log_and_register(
            client,
            run_id,
            self.output_dir,
            self.settings.tracking_uri,
            setting,
            self.run_name,
            metrics,
            self.datasets,
        )

    def end_killed(self, reason: str) -> None:
        """A stop signal: end the run (or the offline record) KILLED, saying where its outputs are."""
        if self.offline_record is not None:
            self.finish_offline({}, "KILLED", f"stopped by {reason}")
            return
        run_id, client, settings = self.run_id, self.client, self.settings
        if run_id is None or client is None or settings is None:
            return
        self.run_id = None
        atexit.unregister(self.end_at_exit)
        where = end_killed(client, run_id, reason, self.output_dir, self.redactor, settings.log_artifacts)
        log.warning("%s: MLflow run %s ended KILLED; %s", reason, run_id, where)

    def end_at_exit(self) -> None:
        """The process exits without on_job_end (Ctrl-C: Hydra only catches Exception): end the run KILLED."""
        if self.run_id is None or self.client is None:
            return
        try:
            self.client.set_terminated(self.run_id, status="KILLED")
        except Exception as error:  # broad: the interpreter is exiting; nothing more useful to do
            log.debug("run %s not ended at exit (%s: %s)", self.run_id, type(error).__name__, error)
        self.run_id = None

    def keep_offline(
        self, config: DictConfig, run_name: str, tags: Mapping[str, str], params: Mapping[str, str]
    ) -> None:
        """Keep the run in the output folder for ``lwrlab sync`` (the store could not be reached)."""
        assert self.settings is not None
        sweep_dir = (
            OmegaConf.select(config, "hydra.sweep.dir", default=None) if is_sweep_job(config) else None
        )
        sweep_overrides = "" if sweep_dir is None else self.redactor.redact(" ".join(task_overrides(config)))
        self.offline_record = offline.new_record(
            self.settings.experiment,
            run_name,
            {key: value for key, value in tags.items() if key != PARENT_RUN_TAG},
            params,
            self.start_ms,
            sweep_dir=None if sweep_dir is None else str(Path(str(sweep_dir)).resolve()),
            sweep_overrides=sweep_overrides,
        )
        self._write_offline()

    def finish_offline(self, metrics: Mapping[str, float], status: str, error: str | None) -> None:
        """End the offline record with ``status`` and write it (the job ended or was stopped)."""
        assert self.offline_record is not None
        offline.finish_record(self.offline_record, metrics, status, error)
        if self._write_offline():
            log.info("run kept in %s for `lwrlab sync`", self.output_dir / offline.OFFLINE_RECORD)
        self.offline_record = None

    def _write_offline(self) -> bool:
        assert self.offline_record is not None
        try:
            offline.write_record(self.output_dir, self.offline_record)
        except OSError as error:
            self.warn("keeping the run in the output folder", error)
            return False
        return True


__all__ = ["ERROR_TAG_MAX_LENGTH", "JobRun", "Warn"]
