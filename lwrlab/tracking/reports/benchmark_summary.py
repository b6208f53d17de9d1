"""Hydra callback closing an ``experiment=estimator_benchmark`` sweep: the summary table and figure.

At the end of the multirun it aggregates the jobs' ``estimator_benchmark.csv`` files
(:func:`lwrlab.tracking.reports.benchmark_tables.write_summary`) into the sweep folder, and, when a
tracking URI is set, logs them as one extra MLflow run (tag ``run_kind=summary``) in the
benchmark's experiment beside the per-job runs, with the summary's mean metrics.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from hydra.experimental.callback import Callback
from omegaconf import DictConfig

from lwrlab.tracking.reports.benchmark_tables import collect, summarize, write_summary

log = logging.getLogger(__name__)


class EstimatorBenchmarkSummary(Callback):
    """Summarise the sweep (``on_multirun_end``) and log the summary to ``tracking_uri``/``experiment``."""

    def __init__(self, tracking_uri: str | None = None, experiment: str = "estimator_benchmark") -> None:
        self.tracking_uri = tracking_uri
        self.experiment = experiment

    def on_multirun_end(self, config: DictConfig, **kwargs: Any) -> None:
        sweep_dir = Path(str(config.hydra.sweep.dir))
        try:
            files = write_summary(sweep_dir)
        except FileNotFoundError as error:
            log.warning("estimator benchmark summary: %s", error)
            return
        log.info("estimator benchmark summary written to %s", sweep_dir)
        if not self.tracking_uri:
            return
        try:
            import mlflow

            from lwrlab.tracking.store.sqlite import absolute_tracking_uri

            client = mlflow.MlflowClient(absolute_tracking_uri(self.tracking_uri, Path.cwd()))
            experiment = client.get_experiment_by_name(self.experiment)
            experiment_id = (
                experiment.experiment_id if experiment else client.create_experiment(self.experiment)
            )
            run = client.create_run(
                experiment_id, run_name="summary", tags={"run_kind": "summary", "sweep_dir": str(sweep_dir)}
            )
            table = summarize(collect(sweep_dir)[0])
            cells = zip(table.index.tolist(), table.to_dict("records"), strict=True)
            for (preset, estimator), row in cells:
                for metric in (
                    "base_parameter_error_mean",
                    "rms_mean_mean",
                    "fit_cpu_s_mean",
                    "consistent_share",
                ):
                    client.log_metric(run.info.run_id, f"{estimator}.{preset}.{metric}", float(row[metric]))
            for path in files.values():
                client.log_artifact(run.info.run_id, str(path))
            client.set_terminated(run.info.run_id)
        except Exception as error:  # tracking never hides the result: the files are in the sweep folder
            log.warning("estimator benchmark summary not logged to MLflow: %s", error)
