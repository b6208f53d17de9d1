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

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from lwrlab.tracking.mlflow_callback import MlflowTracking, runs_table

__all__ = ["MlflowTracking", "runs_table"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from lwrlab.tracking import mlflow_callback

        return getattr(mlflow_callback, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
