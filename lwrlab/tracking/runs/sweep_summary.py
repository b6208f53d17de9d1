"""A sweep's summary on its parent run: what the runs table shows on the sweep's row.

The parent run of a sweep computes nothing itself; without metrics its row is empty. When the sweep
ends (or a job fails it), :func:`log_sweep_summary` reads its nested job runs and logs, under the
``summary`` section:

* ``summary/jobs`` (the sweep's jobs: a failed attempt retried by a later one counts once),
  ``summary/finished``, ``summary/failed`` and ``summary/killed``;
* for each headline metric the finished jobs have (``rms_mean``, ``validation_rel_error``, …):
  ``summary/best_<metric>`` (the smallest: every headline metric is an error) and
  ``summary/mean_<metric>``.

Examples
--------
>>> statuses = ["FINISHED", "FINISHED", "FAILED"]
>>> summary = summary_metrics(statuses, [{"accuracy/rms_mean": 0.25}, {"rms_mean": 0.75}, {}])
>>> [summary[f"summary/{key}"] for key in ("jobs", "failed", "best_rms_mean", "mean_rms_mean")]
[3.0, 1.0, 0.25, 0.5]
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from mlflow.entities import Run
from mlflow.tracking import MlflowClient

from lwrlab.tracking.job_config.metric_sections import SUMMARY, plain_metrics
from lwrlab.tracking.job_config.naming import HEADLINE_METRICS
from lwrlab.tracking.job_config.provenance import PARENT_RUN_TAG, RUN_KIND_TAG
from lwrlab.tracking.runs.run_logging import log_metrics
from lwrlab.tracking.runs.run_queries import RETRIED_BY_TAG, reused_run_ids, run_id_filter
from lwrlab.tracking.store.sqlite import retry_locked


def summary_metrics(statuses: Sequence[str], metrics: Sequence[Mapping[str, float]]) -> dict[str, float]:
    """The summary of a sweep's jobs, given each job's status and its metrics (MLflow keys)."""
    summary = {
        f"{SUMMARY}/jobs": float(len(statuses)),
        f"{SUMMARY}/finished": float(statuses.count("FINISHED")),
        f"{SUMMARY}/failed": float(statuses.count("FAILED")),
        f"{SUMMARY}/killed": float(statuses.count("KILLED")),
    }
    finished = [
        plain_metrics(values)
        for status, values in zip(statuses, metrics, strict=True)
        if status == "FINISHED"
    ]
    for metric in HEADLINE_METRICS:
        values = np.array([run[metric] for run in finished if metric in run], dtype=float)
        values = values[np.isfinite(values)]
        if values.size:
            summary[f"{SUMMARY}/best_{metric}"] = float(values.min())
            summary[f"{SUMMARY}/mean_{metric}"] = float(values.mean())
    return summary


def sweep_jobs(client: MlflowClient, parent: Run) -> list[Run]:
    """The job runs of the sweep whose parent run is ``parent``, a retried attempt counted once, with
    the runs it reused (jobs whose config had already finished elsewhere)."""
    jobs = retry_locked(
        client.search_runs,
        [parent.info.experiment_id],
        f"tags.`{PARENT_RUN_TAG}` = '{parent.info.run_id}' and tags.{RUN_KIND_TAG} = 'job'",
        max_results=10_000,
    )
    reused = reused_run_ids(parent)
    for start in range(0, len(reused), 100):
        chunk = run_id_filter(reused[start : start + 100])
        jobs += retry_locked(client.search_runs, [parent.info.experiment_id], chunk, max_results=10_000)
    return [run for run in jobs if RETRIED_BY_TAG not in run.data.tags]


def log_sweep_summary(client: MlflowClient, parent_run_id: str) -> dict[str, float]:
    """Compute the summary of the sweep whose parent run is ``parent_run_id`` and log it on that run."""
    current = sweep_jobs(client, retry_locked(client.get_run, parent_run_id))
    summary = summary_metrics([run.info.status for run in current], [run.data.metrics for run in current])
    log_metrics(client, parent_run_id, summary)
    return summary


__all__ = ["log_sweep_summary", "summary_metrics", "sweep_jobs"]
