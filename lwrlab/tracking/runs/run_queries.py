"""Searching the store: runs as a table for comparing them, and the look-ups of a resumed sweep.

* :func:`runs_table` and :func:`search_runs_table`: runs of an experiment as pandas, oldest first;
* :func:`previous_sweep_run`: the parent run of an earlier launch of the same sweep (same identity);
* :func:`sweep_run_of_folder`: the parent run of the sweep launched into a folder (``lwrlab sync``);
* :func:`run_with_tag`: the run holding a unique tag (a synced offline record, a derived run's key);
* :func:`resume_lookup`: a job's FINISHED run of the same config (skip the job), or its failed ones
  (linked to the new run as ``retried_by``);
* :func:`earlier_attempts`: RUNNING runs of this very job, left by a worker the launcher lost;
* :func:`sweep_is_stopping`: whether a sweep's launching process has begun to stop.

Examples
--------
>>> from lwrlab.tracking.runs.run_queries import runs_table
>>> runs_table("sqlite:///outputs/mlflow.db", "identification", "tags.run_kind = 'job'")  # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mlflow
import pandas as pd
from mlflow.entities import Run
from mlflow.tracking import MlflowClient

from lwrlab.tracking.job_config.provenance import PARENT_RUN_TAG, RUN_KIND_TAG
from lwrlab.tracking.runs.finalise import KILLED_BY_TAG, running_runs
from lwrlab.tracking.store.connection import global_tracking_uri
from lwrlab.tracking.store.sqlite import absolute_tracking_uri, retry_locked

RESUME_SEARCH_LIMIT = 200
"""Runs of one config read when a job is resumed (newest first)."""
RETRIED_BY_TAG = "retried_by"
"""Set on a FAILED or KILLED run when a later run of the same config finished."""
REUSED_RUN_TAG_PREFIX = "reused_run."
"""``reused_run.<run id>`` on a sweep's parent run: one of its jobs had already FINISHED as that run
(nested under another sweep, or alone) and was not run again; the value is the job's number."""


def reused_run_ids(parent: Run) -> list[str]:
    """The runs a sweep reused as its jobs (:data:`REUSED_RUN_TAG_PREFIX` tags of its parent run)."""
    tags = parent.data.tags
    return sorted(key[len(REUSED_RUN_TAG_PREFIX) :] for key in tags if key.startswith(REUSED_RUN_TAG_PREFIX))


def run_id_filter(run_ids: Sequence[str]) -> str:
    """An MLflow filter clause selecting these runs (``attributes.run_id IN (…)``)."""
    return "attributes.run_id IN (" + ", ".join(f"'{run_id}'" for run_id in run_ids) + ")"


def runs_table(tracking_uri: str, experiment: str, filter_string: str = "") -> pd.DataFrame:
    """All runs of an experiment as a table, oldest first, for comparing runs.

    Parameters
    ----------
    tracking_uri
        The store (a relative ``sqlite:///`` path is taken from the current directory).
    experiment
        Experiment name.
    filter_string
        MLflow search filter, e.g. ``"metrics.rms_mean < 0.5 and params.estimator._target_ LIKE '%OLS%'"``
        or ``"tags.run_kind = 'job'"`` to leave out the parent runs of sweeps.

    Returns
    -------
    pandas.DataFrame
        One row per run: ``run_id``, ``status``, ``start_time``, … and ``metrics.*``, ``params.*``,
        ``tags.*`` columns (the layout of ``mlflow.search_runs``); empty if the experiment does not
        exist.

    Examples
    --------
    >>> table = runs_table("sqlite:///outputs/mlflow.db", "identification")  # doctest: +SKIP
    >>> table[["tags.overrides", "metrics.rms_mean"]].sort_values("metrics.rms_mean")  # doctest: +SKIP
    """
    uri = absolute_tracking_uri(tracking_uri, Path.cwd())
    found = MlflowClient(tracking_uri=uri).get_experiment_by_name(experiment)
    if found is None:
        return pd.DataFrame()
    return search_runs_table(uri, [found.experiment_id], filter_string)


def search_runs_table(
    tracking_uri: str, experiment_ids: Sequence[str], filter_string: str = ""
) -> pd.DataFrame:
    """``mlflow.search_runs`` on a given store (not the global one), oldest run first, as pandas."""
    with global_tracking_uri(tracking_uri):  # mlflow.search_runs reads the global URI
        table = mlflow.search_runs(
            experiment_ids=list(experiment_ids),
            filter_string=filter_string,
            order_by=["attributes.start_time ASC"],
            output_format="pandas",
        )
    assert isinstance(table, pd.DataFrame)
    return table


def experiment_ids(client: MlflowClient) -> list[str]:
    """The ids of every active experiment of the store."""
    return [experiment.experiment_id for experiment in retry_locked(client.search_experiments)]


def runs_tagged(
    client: MlflowClient, experiment_id: str, tag: str, value: str, kind: str, limit: int
) -> list[Run]:
    """Runs of one kind (``job``/``sweep``) with ``tags.<tag> = value``, newest first."""
    return list(
        retry_locked(
            client.search_runs,
            [experiment_id],
            filter_string=f"tags.{tag} = '{value}' and tags.{RUN_KIND_TAG} = '{kind}'",
            order_by=["attributes.start_time DESC"],
            max_results=limit,
        )
    )


def previous_sweep_run(client: MlflowClient, experiment_id: str, identity: str) -> Run | None:
    """The newest parent run of a sweep with this identity (``sweep_hash`` tag), if any."""
    runs = runs_tagged(client, experiment_id, "sweep_hash", identity, "sweep", 1)
    return runs[0] if runs else None


def sweep_run_of_folder(client: MlflowClient, experiment_id: str, sweep_dir: str) -> Run | None:
    """The newest parent run of a sweep launched into ``sweep_dir`` (``hydra_sweep_dir`` tag), if any."""
    runs = runs_tagged(client, experiment_id, "hydra_sweep_dir", sweep_dir, "sweep", 1)
    return runs[0] if runs else None


def run_with_tag(client: MlflowClient, experiment_id: str, tag: str, value: str) -> Run | None:
    """The newest run of any kind with ``tags.<tag> = value``, if any: the run an identity tag names."""
    runs = retry_locked(
        client.search_runs,
        [experiment_id],
        filter_string=f"tags.{tag} = '{value}'",
        order_by=["attributes.start_time DESC"],
        max_results=1,
    )
    return runs[0] if runs else None


@dataclass
class ResumeLookup:
    """What the store knows of a job's config."""

    finished: Run | None
    """The newest FINISHED run of the config: the job need not run again."""
    failed_attempts: list[str] = field(default_factory=list)
    """FAILED or KILLED runs of the config not yet linked to a retry."""


def resume_lookup(client: MlflowClient, experiment_id: str, config_hash: str) -> ResumeLookup:
    """The job runs of ``config_hash``: the newest FINISHED one, or else the failed attempts to link."""
    runs = runs_tagged(client, experiment_id, "config_hash", config_hash, "job", RESUME_SEARCH_LIMIT)
    finished = [run for run in runs if run.info.status == "FINISHED"]
    if finished:
        return ResumeLookup(finished[0])
    failed = [
        run.info.run_id
        for run in runs
        if run.info.status in ("FAILED", "KILLED") and RETRIED_BY_TAG not in run.data.tags
    ]
    return ResumeLookup(None, failed)


def earlier_attempts(
    client: MlflowClient, experiment_id: str, parent_run_id: str, tags: Mapping[str, str]
) -> list[Run]:
    """RUNNING runs of this very job (same sweep, job number and config): attempts whose worker died."""
    same_job = (
        f"tags.`{PARENT_RUN_TAG}` = '{parent_run_id}' "
        f"and tags.hydra_job_num = '{tags.get('hydra_job_num', '')}' "
        f"and tags.config_hash = '{tags['config_hash']}'"
    )
    return running_runs(client, [experiment_id], same_job)


def sweep_is_stopping(client: MlflowClient, parent_run_id: str) -> bool:
    """Whether the sweep's launching process has begun to stop (it tags the parent run first)."""
    return KILLED_BY_TAG in retry_locked(client.get_run, parent_run_id).data.tags


__all__ = [
    "RETRIED_BY_TAG",
    "REUSED_RUN_TAG_PREFIX",
    "ResumeLookup",
    "earlier_attempts",
    "experiment_ids",
    "previous_sweep_run",
    "resume_lookup",
    "reused_run_ids",
    "run_id_filter",
    "run_with_tag",
    "runs_table",
    "runs_tagged",
    "search_runs_table",
    "sweep_is_stopping",
    "sweep_run_of_folder",
]
