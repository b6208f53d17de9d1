"""A sweep's parent run: opened (or reopened by a re-launch) before any job starts, closed after the last.

A Hydra multirun is one parent run with one nested run per job. The parent is named after what the
sweep varies (``sweep · wls · seed=1``) and tagged ``sweep_hash``, the sweep's identity (its primary
config, overrides and search space), so that a re-launched sweep nests its jobs under the same
parent instead of opening a new one. When the sweep ends, its ``multirun.yaml`` is logged and its
summary (jobs, failures, best and mean of the headline metrics:
:mod:`lwrlab.tracking.runs.sweep_summary`) becomes the parent run's metrics, and the link to the
experiment's runs in MLflow's UI is logged, opening on lwrlab's saved view of them (headline columns,
sorted best first, grouped by the swept keys: :mod:`lwrlab.tracking.runs.runs_view`).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from mlflow.tracking import MlflowClient
from omegaconf import DictConfig, OmegaConf

from lwrlab.tracking.job_config.config_params import (
    RUN_NAME_MAX_LENGTH,
    TAG_VALUE_MAX_LENGTH,
    original_cwd,
    resolved_job_config,
    sweep_identity,
    task_overrides,
    truncate,
)
from lwrlab.tracking.job_config.metric_sections import plain_name
from lwrlab.tracking.job_config.naming import NAME_SEPARATOR, job_run_name, swept_keys
from lwrlab.tracking.job_config.provenance import RUN_KIND_TAG, process_tags, provenance_tags
from lwrlab.tracking.job_config.redaction import Redactor, redacted_folder
from lwrlab.tracking.runs.finalise import KILLED_BY_TAG
from lwrlab.tracking.runs.run_queries import previous_sweep_run
from lwrlab.tracking.runs.runs_view import runs_view_link
from lwrlab.tracking.runs.sweep_summary import log_sweep_summary, sweep_jobs
from lwrlab.tracking.store.sqlite import retry_locked

log = logging.getLogger(__name__)

SWEEP_CONFIG_FILE = "multirun.yaml"


@dataclass(frozen=True)
class SweepDescription:
    """What a sweep varies and what names it, read from its primary config."""

    overrides: list[str]
    """The sweep's task overrides, as typed."""
    identity: str
    """See :func:`~lwrlab.tracking.job_config.config_params.sweep_identity`."""
    swept: list[str]
    """The keys it varies (run names show them first)."""


def describe_sweep(config: DictConfig) -> SweepDescription:
    """The overrides, identity and swept keys of the sweep whose primary config is ``config``."""
    overrides = task_overrides(config)
    sweeper_params = OmegaConf.select(config, "hydra.sweeper.params", default=None)
    search_space = (
        OmegaConf.to_container(sweeper_params) if OmegaConf.is_config(sweeper_params) else sweeper_params
    )
    searched = (
        {str(key): value for key, value in search_space.items()}
        if isinstance(search_space, Mapping)
        else None
    )
    return SweepDescription(
        overrides=overrides,
        identity=sweep_identity(resolved_job_config(config), overrides, search_space),
        swept=swept_keys(overrides, searched),
    )


def open_sweep_run(
    client: MlflowClient,
    experiment_id: str,
    config: DictConfig,
    sweep: SweepDescription,
    redactor: Redactor,
    resume: bool,
) -> str:
    """The sweep's parent run id: an earlier launch's (``resume``), set RUNNING again, or a new one."""
    parent = previous_sweep_run(client, experiment_id, sweep.identity) if resume else None
    if parent is not None:
        retry_locked(client.update_run, parent.info.run_id, status="RUNNING")
        if KILLED_BY_TAG in parent.data.tags:  # stopped before: its jobs may start again
            retry_locked(client.delete_tag, parent.info.run_id, KILLED_BY_TAG)
        log.info("re-launched sweep: jobs are nested under the existing parent run %s", parent.info.run_id)
        return parent.info.run_id
    tags = {
        RUN_KIND_TAG: "sweep",
        **process_tags(),
        "overrides": truncate(redactor.redact(" ".join(sweep.overrides)), TAG_VALUE_MAX_LENGTH),
        "sweep_hash": sweep.identity,
        "hydra_sweep_dir": str(OmegaConf.select(config, "hydra.sweep.dir", default="")),
        **provenance_tags(original_cwd(config)),
    }
    name = truncate(
        f"sweep{NAME_SEPARATOR}{redactor.redact(job_run_name(config, sweep.swept))}", RUN_NAME_MAX_LENGTH
    )
    run = retry_locked(client.create_run, experiment_id, run_name=name, tags=redactor.redact_mapping(tags))
    return run.info.run_id


def log_sweep_config(client: MlflowClient, run_id: str, config: DictConfig, redactor: Redactor) -> None:
    """Log the sweep folder's ``multirun.yaml`` (secrets redacted) on the parent run, if it exists."""
    sweep_dir = OmegaConf.select(config, "hydra.sweep.dir", default=None)
    sweep_config = Path(str(sweep_dir)) / SWEEP_CONFIG_FILE if sweep_dir else None
    if sweep_config is not None and sweep_config.is_file():
        with redacted_folder(sweep_config.parent, redactor) as folder:
            retry_locked(client.log_artifact, run_id, str(folder / SWEEP_CONFIG_FILE))


def sweep_view_link(client: MlflowClient, run_id: str, config: DictConfig) -> str | None:
    """Save lwrlab's view of the sweep's experiment (its swept keys, its jobs' metrics); return its link.

    See :func:`~lwrlab.tracking.runs.runs_view.runs_view_link`; ``None`` for a store without one.
    """
    parent = retry_locked(client.get_run, run_id)
    finished = [run for run in sweep_jobs(client, parent) if run.info.status == "FINISHED"]
    metrics = {plain_name(key) for run in finished for key in run.data.metrics}
    params = {key for run in finished for key in run.data.params}
    swept = [key for key in describe_sweep(config).swept if key in params]
    return runs_view_link(client, str(client.tracking_uri), parent.info.experiment_id, metrics, swept)


def close_sweep_run(client: MlflowClient, run_id: str, config: DictConfig, redactor: Redactor) -> None:
    """Log the sweep config and summary, end the parent run FINISHED unless a job already marked it FAILED,
    then log its id (what ``lwrlab compare --parent`` takes) and the link to its runs in MLflow's UI
    (:func:`sweep_view_link`)."""
    log_sweep_config(client, run_id, config, redactor)
    log_sweep_summary(client, run_id)
    if retry_locked(client.get_run, run_id).info.status == "RUNNING":
        retry_locked(client.set_terminated, run_id, status="FINISHED")
    log.info("the sweep's parent run is %s: `lwrlab compare --parent %s` compares its jobs", run_id, run_id)
    link = sweep_view_link(client, run_id, config)
    if link is not None:
        log.info("%s", redactor.redact(link))


def fail_sweep_run(client: MlflowClient, run_id: str, config: DictConfig, redactor: Redactor) -> None:
    """Log the sweep config and its summary so far, end the parent run FAILED (a job failed)."""
    log_sweep_config(client, run_id, config, redactor)
    log_sweep_summary(client, run_id)
    retry_locked(client.set_terminated, run_id, status="FAILED")


__all__ = [
    "SweepDescription",
    "close_sweep_run",
    "describe_sweep",
    "fail_sweep_run",
    "log_sweep_config",
    "open_sweep_run",
    "sweep_view_link",
]
