"""Monte-Carlo benchmark of the estimators, in the style of BIRDy (Leboutet et al. 2021).

One job = one (estimator, noise preset, seed): the simulated robot (truth drawn from the seed)
executes the exciting motion with the preset's encoder and torque noise, the estimator identifies
the base parameters, and the job scores them. ``experiment=estimator_benchmark`` sweeps
estimator × preset × seed as a Hydra multirun, so each job is one MLflow run (logged by the
tracking callback like any job, params and status included), and
:class:`lwrlab.tracking.reports.benchmark_summary.EstimatorBenchmarkSummary` aggregates the sweep at its
end. Why a sweep and not one job looping over everything: every (estimator, preset, seed) gets its
own run, status and artifacts, a failed estimator does not hide the others, and the sweep runs in
parallel with ``hydra/launcher=parallel`` (or on a cluster) unchanged; the price is that each job
simulates its measurement again (a few seconds).

Files of a job (``estimator_benchmark.csv``, one row), columns:

- ``estimator``, ``preset``, ``seed``: the cell of the benchmark;
- ``base_parameter_error``: ‖β̂ − β‖/‖β‖, relative base-parameter error against the truth;
- ``rms_mean`` (N·m), ``nrms_mean`` (%): cross-validation torque error on the 20 s motion;
- ``min_pseudo_inertia_eigenvalue`` (kg·m²): smallest eigenvalue of the reported standard set's
  pseudo-inertias (the SDP's own set, else the set closest to CAD with the same base parameters);
- ``consistency_margin`` (kg·m²): the largest ε such that *some* standard set with these base
  parameters has every pseudo-inertia ⪰ ε and Coulomb/viscous friction ≥ ε: < 0 proves that no
  rigid bodies reproduce the estimate;
- ``fit_cpu_s`` (s): CPU time of the estimator's fit;
- ``residual_std`` (N·m): torque residual σ.

and ``parameter_errors.csv``: per base parameter its truth, estimate, error and relative error.
The summary (sweep folder, :mod:`lwrlab.tracking.reports.benchmark_tables`) has ``estimator_benchmark.csv``
(all rows), ``estimator_benchmark_summary.csv`` and ``.md`` (mean and spread per estimator and
preset), ``estimator_benchmark_parameters.csv`` (per parameter: mean and spread of the relative
error) and ``estimator_benchmark.png``.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from lwrlab.identification.consistency import consistency_margin
from lwrlab.identification.context import IdentificationContext
from lwrlab.pipeline.config_nodes import processing_settings
from lwrlab.pipeline.identification import identify
from lwrlab.tracking.reports.benchmark_tables import JOB_TABLE, METRICS, PARAMETER_TABLE, write_summary

log = logging.getLogger(__name__)


def _estimator_name(cfg: Any) -> str:
    try:
        from hydra.core.hydra_config import HydraConfig

        return str(HydraConfig.get().runtime.choices["estimator"])
    except Exception:  # outside a Hydra app (tests): the class name
        return str(cfg.estimator._target_).rsplit(".", 1)[-1]


def run_estimator_benchmark(
    cfg: Any, output_dir: Path, noise: str, noise_presets: Mapping[str, Mapping[str, float]]
) -> dict[str, float]:
    """Task ``estimator_benchmark``: one (estimator, noise preset, seed) cell; see the module doc."""
    from hydra.utils import instantiate

    if noise not in noise_presets:
        raise ValueError(f"unknown noise preset {noise!r}; valid: {sorted(noise_presets)}")
    preset = noise_presets[noise]
    robot = instantiate(cfg.robot)
    plant = instantiate(
        cfg.plant,
        encoder_noise_std=float(np.radians(preset["encoder_noise_deg"])),
        torque_noise_std=float(preset["torque_noise_std"]),
    )(robot=robot)
    report = identify(
        robot=robot,
        motion_source=instantiate(cfg.trajectory),
        validation_source=instantiate(cfg.validation),
        plant=plant,
        estimator=instantiate(cfg.estimator),
        rate_hz=cfg.measurement.rate_hz,
        processing=processing_settings(cfg),
    )
    context = IdentificationContext.from_robot(robot, report.base)
    dissipative = np.concatenate([context.friction_indices("coulomb"), context.friction_indices("viscous")])
    metrics = dict(report.metrics)
    metrics["consistency_margin"] = consistency_margin(
        report.base.regrouping, report.identified.base_values, robot.n_links, dissipative
    )
    row = {
        "estimator": _estimator_name(cfg),
        "preset": noise,
        "seed": int(cfg.seed),
        **{m: metrics[m] for m in METRICS},
    }
    output_dir.mkdir(parents=True, exist_ok=True)
    pd.DataFrame([row]).to_csv(output_dir / JOB_TABLE, index=False)
    parameters = report.parameters[["truth", "estimate"]].copy()
    parameters["error"] = parameters["estimate"] - parameters["truth"]
    parameters["relative_error"] = parameters["error"] / parameters["truth"].abs()
    parameters.to_csv(output_dir / PARAMETER_TABLE)
    print(pd.DataFrame([row]).to_markdown(index=False, floatfmt=".4g"))
    return {m: float(metrics[m]) for m in METRICS}


if (
    __name__ == "__main__"
):  # re-aggregate an earlier sweep (also python -m lwrlab.tracking.reports.benchmark_tables <sweep_dir>)
    import sys

    write_summary(Path(sys.argv[1]))
