"""Tracking at the edge of the pipeline: MLflow logging as a Hydra callback, run comparison.

Its parts, each a sub-package importing only those listed after it:

* :mod:`~lwrlab.tracking.companion`: the callback the configs name (``MlflowTracking``) and the
  companion process that logs a single run;
* :mod:`~lwrlab.tracking.lifecycle`: the Hydra hooks, one job's run and a sweep's parent run, and the
  upload of runs kept offline (``lwrlab sync``);
* :mod:`~lwrlab.tracking.models`: identified models as MLflow Models (logged at a job's end,
  registered, ``lwrlab model``) and any model setting, a path or an MLflow URI, resolved;
* :mod:`~lwrlab.tracking.reports`: ``lwrlab compare``, ``lwrlab report``, the benchmark summary
  (next to the lifecycle, not above it: it imports only the three below);
* :mod:`~lwrlab.tracking.runs`: runs in the store logged, searched, ended and kept offline (their
  later upload with their models, ``lwrlab sync``, is the lifecycle's);
* :mod:`~lwrlab.tracking.store`: which store, its connection and its safe use by many processes;
* :mod:`~lwrlab.tracking.job_config`: params, names, provenance tags and secrets read from a config.

``MlflowTracking`` and ``runs_table`` are loaded on first access (PEP 562) so that importing a
light module of the package (``lwrlab.tracking.reports.benchmark_tables``) does not pay for
importing mlflow. Figures live in :mod:`lwrlab.figures`.

Examples
--------
>>> from lwrlab.tracking import runs_table  # doctest: +SKIP
>>> runs_table("sqlite:///outputs/mlflow.db", "identification")  # doctest: +SKIP
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from lwrlab.tracking.companion.callback import MlflowTracking
    from lwrlab.tracking.runs.run_queries import runs_table

_MODULE_OF = {
    "MlflowTracking": "lwrlab.tracking.companion.callback",
    "runs_table": "lwrlab.tracking.runs.run_queries",
}
__all__ = ["MlflowTracking", "runs_table"]


def __getattr__(name: str) -> Any:
    if name in _MODULE_OF:
        return getattr(importlib.import_module(_MODULE_OF[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
