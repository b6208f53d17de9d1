"""What the tracking callback and the task function of one Hydra job tell each other.

Both run in the same process (the launching one, or a joblib/Ray/Slurm worker), one job after the
other, so a module-level slot is enough. It carries two things:

* from the callback to the task: the metrics of an identical job that already FINISHED in the store
  (a re-launched sweep skips it and returns those metrics instead of computing them again);
* from the task to the callback: the full metrics dict, when the task function returns a single
  number to a sweeper (``objective=rms_mean``) but every metric should still be logged.

This module imports nothing heavy: the entry point uses it without loading mlflow.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

_completed_metrics: dict[str, float] | None = None
_recorded_metrics: Mapping[str, Any] | None = None


def set_completed_metrics(metrics: Mapping[str, float] | None) -> None:
    """Called by the callback: this job's config already has a FINISHED run with these metrics."""
    global _completed_metrics
    _completed_metrics = None if metrics is None else dict(metrics)


def completed_metrics() -> dict[str, float] | None:
    """The metrics of an identical finished run, or ``None`` when the job must run."""
    return None if _completed_metrics is None else dict(_completed_metrics)


def record_metrics(metrics: Mapping[str, Any]) -> None:
    """Called by the entry point with everything the task returned."""
    global _recorded_metrics
    _recorded_metrics = metrics


def take_recorded_metrics() -> Mapping[str, Any] | None:
    """The metrics recorded by this job's task (and forget them, ready for the next job)."""
    global _recorded_metrics
    metrics, _recorded_metrics = _recorded_metrics, None
    return metrics


def reset() -> None:
    """Forget everything (start of a job)."""
    global _completed_metrics, _recorded_metrics
    _completed_metrics = None
    _recorded_metrics = None
