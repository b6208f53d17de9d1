"""Tracking at the edge of the pipeline: MLflow logging as a Hydra callback, run comparison.

``MlflowTracking`` and ``runs_table`` are loaded on first access (PEP 562) so that importing a
light module of the package (``lwrlab.tracking.benchmark_tables``) does not pay for importing mlflow.
Figures live in :mod:`lwrlab.figures`.

Examples
--------
>>> from lwrlab.tracking import runs_table  # doctest: +SKIP
>>> runs_table("sqlite:///outputs/mlflow.db", "identification")  # doctest: +SKIP
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from lwrlab.tracking.callback import MlflowTracking
    from lwrlab.tracking.run_queries import runs_table

_MODULE_OF = {
    "MlflowTracking": "lwrlab.tracking.callback",
    "runs_table": "lwrlab.tracking.run_queries",
}
__all__ = ["MlflowTracking", "runs_table"]


def __getattr__(name: str) -> Any:
    if name in _MODULE_OF:
        return getattr(importlib.import_module(_MODULE_OF[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
