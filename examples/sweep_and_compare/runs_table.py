"""The runs of an MLflow experiment as a pandas table: one row per job, its swept settings and metrics.

Usage::

    python runs_table.py TRACKING_URI EXPERIMENT [OUT_CSV]

``mlflow.search_runs`` returns a DataFrame with ``params.<key>``, ``metrics.<name>`` and ``tags.<key>``
columns. lwrlab logs the settings that tell runs apart as params (the swept ones, every plugin choice by
its short name: ``params.estimator``), and files each metric under a section (``accuracy/rms_mean``,
``diagnostics/cond_W_b``, ``timing/fit_cpu_s``); the sweep's parent run and ``lwrlab compare``'s own run
are left out here by keeping the runs that have a parent (the jobs). The table is then grouped by
estimator, mean ± std over seeds, as ``lwrlab compare`` does.
"""

from __future__ import annotations

import sys
from pathlib import Path

import mlflow
import pandas as pd

METRICS = {
    "accuracy/rms_mean": "RMS mean [N·m]",
    "accuracy/nrms_mean": "NRMS mean [%]",
    "accuracy/base_parameter_error": "‖β̂−β‖/‖β‖",
    "timing/fit_cpu_s": "fit CPU [s]",
}


def job_runs(tracking_uri: str, experiment: str) -> pd.DataFrame:
    """The FINISHED job runs (children of a sweep) of ``experiment``: estimator, seed and the metrics."""
    mlflow.set_tracking_uri(tracking_uri)
    runs = mlflow.search_runs(experiment_names=[experiment], filter_string="attributes.status = 'FINISHED'")
    jobs = runs[runs["tags.mlflow.parentRunId"].notna()] if "tags.mlflow.parentRunId" in runs else runs
    table = jobs[
        ["tags.mlflow.runName", "params.estimator", "params.seed", *(f"metrics.{m}" for m in METRICS)]
    ]
    return table.rename(
        columns={
            "tags.mlflow.runName": "run",
            "params.estimator": "estimator",
            "params.seed": "seed",
            **{f"metrics.{m}": label for m, label in METRICS.items()},
        }
    ).sort_values(["estimator", "seed"])


def main() -> None:
    if len(sys.argv) not in (3, 4):
        raise SystemExit(__doc__)
    table = job_runs(sys.argv[1], sys.argv[2])
    print(f"\n{len(table)} job runs of experiment {sys.argv[2]!r}\n")
    print(table.to_markdown(index=False, floatfmt=".4g"))
    groups = table.groupby("estimator")[list(METRICS.values())]
    means, spreads = groups.mean(), groups.std()
    summary = means.map(lambda v: f"{v:.4g}") + " ± " + spreads.map(lambda v: f"{v:.2g}")
    print("\nby estimator, mean ± std over seeds\n")
    print(summary.to_markdown())
    if len(sys.argv) == 4:
        Path(sys.argv[3]).parent.mkdir(parents=True, exist_ok=True)
        table.to_csv(sys.argv[3], index=False)


if __name__ == "__main__":
    main()
