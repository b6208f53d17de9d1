"""Monte-Carlo benchmark of the estimators, in the style of BIRDy (Leboutet et al. 2021).

One job = one (estimator, noise preset, seed): the simulated robot (truth drawn from the seed)
executes the exciting motion with the preset's encoder and torque noise, the estimator identifies
the base parameters, and the job scores them. ``experiment=estimator_benchmark`` sweeps
estimator × preset × seed as a Hydra multirun, so each job is one MLflow run (logged by the
tracking callback like any job, params and status included), and
:class:`lwrlab.tracking.benchmark_summary.EstimatorBenchmarkSummary` aggregates the sweep at its
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
The summary (sweep folder) has ``estimator_benchmark.csv`` (all rows), ``estimator_benchmark_summary.csv``
and ``.md`` (mean and spread per estimator and preset), ``estimator_benchmark_parameters.csv`` (per
parameter: mean and spread of the relative error) and ``estimator_benchmark.png``.
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
from lwrlab.pipeline.identification import identify

log = logging.getLogger(__name__)

JOB_TABLE = "estimator_benchmark.csv"
PARAMETER_TABLE = "parameter_errors.csv"
METRICS = ("base_parameter_error", "rms_mean", "nrms_mean", "min_pseudo_inertia_eigenvalue", "consistency_margin", "fit_cpu_s", "residual_std")


def _estimator_name(cfg: Any) -> str:
    try:
        from hydra.core.hydra_config import HydraConfig

        return str(HydraConfig.get().runtime.choices["estimator"])
    except Exception:  # outside a Hydra app (tests): the class name
        return str(cfg.estimator._target_).rsplit(".", 1)[-1]


def run_estimator_benchmark(cfg: Any, output_dir: Path, noise: str, noise_presets: Mapping[str, Mapping[str, float]]) -> dict[str, float]:
    """Task ``estimator_benchmark``: one (estimator, noise preset, seed) cell; see the module doc."""
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    if noise not in noise_presets:
        raise ValueError(f"unknown noise preset {noise!r}; valid: {sorted(noise_presets)}")
    preset = noise_presets[noise]
    robot = instantiate(cfg.robot)
    plant = instantiate(cfg.plant, encoder_noise_std=float(np.radians(preset["encoder_noise_deg"])), torque_noise_std=float(preset["torque_noise_std"]))(robot=robot)
    report = identify(
        robot=robot,
        motion_source=instantiate(cfg.trajectory),
        validation_source=instantiate(cfg.validation),
        plant=plant,
        estimator=instantiate(cfg.estimator),
        rate_hz=cfg.measurement.rate_hz,
        processing=OmegaConf.to_container(cfg.measurement.processing, resolve=True),
    )
    context = IdentificationContext.from_robot(robot, report.base)
    dissipative = np.concatenate([context.friction_indices("coulomb"), context.friction_indices("viscous")])
    metrics = dict(report.metrics)
    metrics["consistency_margin"] = consistency_margin(report.base.regrouping, report.identified.base_values, robot.n_links, dissipative)
    row = {"estimator": _estimator_name(cfg), "preset": noise, "seed": int(cfg.seed), **{m: metrics[m] for m in METRICS}}
    output_dir.mkdir(parents=True, exist_ok=True)
    pd.DataFrame([row]).to_csv(output_dir / JOB_TABLE, index=False)
    parameters = report.parameters[["truth", "estimate"]].copy()
    parameters["error"] = parameters["estimate"] - parameters["truth"]
    parameters["relative_error"] = parameters["error"] / parameters["truth"].abs()
    parameters.to_csv(output_dir / PARAMETER_TABLE)
    print(pd.DataFrame([row]).to_markdown(index=False, floatfmt=".4g"))
    return {m: float(metrics[m]) for m in METRICS}


def collect(sweep_dir: Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """All job rows of a sweep, and all per-parameter errors (with estimator, preset, seed)."""
    rows, parameters = [], []
    for table in sorted(Path(sweep_dir).glob(f"*/{JOB_TABLE}")):
        row = pd.read_csv(table)
        rows.append(row)
        errors = pd.read_csv(table.parent / PARAMETER_TABLE)
        parameters.append(errors.assign(**{k: row[k].iloc[0] for k in ("estimator", "preset", "seed")}))
    if not rows:
        raise FileNotFoundError(f"no {JOB_TABLE} under {sweep_dir}/*/: did the benchmark jobs run?")
    return pd.concat(rows, ignore_index=True), pd.concat(parameters, ignore_index=True)


def summarize(rows: pd.DataFrame) -> pd.DataFrame:
    """Mean and standard deviation over seeds of every metric, per estimator and preset, plus the
    share of seeds whose estimate is physically consistent (consistency margin ≥ −1e-9)."""
    grouped = rows.groupby(["preset", "estimator"], sort=True)
    table = grouped[list(METRICS)].agg(["mean", "std"])
    table.columns = [f"{metric}_{stat}" for metric, stat in table.columns]
    table["consistent_share"] = grouped["consistency_margin"].apply(lambda m: float(np.mean(m >= -1e-9)))
    table["seeds"] = grouped.size()
    return table


def summary_markdown(table: pd.DataFrame) -> str:
    """The summary as a compact Markdown table (mean ± std)."""
    def pm(metric: str, fmt: str) -> pd.Series:
        return table.apply(lambda r: f"{r[f'{metric}_mean']:{fmt}} ± {r[f'{metric}_std']:{fmt}}", axis=1)

    view = pd.DataFrame({
        "preset": table.index.get_level_values("preset"),
        "estimator": table.index.get_level_values("estimator"),
        "‖β̂−β‖/‖β‖": pm("base_parameter_error", ".3g"),
        "CV RMS (N·m)": pm("rms_mean", ".4g"),
        "min eig J (kg·m²)": table["min_pseudo_inertia_eigenvalue_mean"].map(lambda v: f"{v:.2g}"),
        "consistent": table["consistent_share"].map(lambda v: f"{100 * v:.0f} %"),
        "CPU fit (s)": pm("fit_cpu_s", ".3g"),
        "seeds": table["seeds"],
    }, index=table.index)
    return view.to_markdown(index=False)


def parameter_summary(parameters: pd.DataFrame) -> pd.DataFrame:
    """Per (preset, estimator, parameter): mean and spread (std) of the relative error over seeds."""
    grouped = parameters.groupby(["preset", "estimator", "parameter"], sort=False)["relative_error"]
    return grouped.agg(relative_error_mean="mean", relative_error_std="std").reset_index()


def benchmark_figure(rows: pd.DataFrame, path: Path) -> Path:
    """Box plots of the relative base-parameter error and of the fit CPU time per estimator, one
    group per noise preset (log scales)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    presets = sorted(rows["preset"].unique())
    estimators = sorted(rows["estimator"].unique())
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    width = 0.8 / len(presets)
    for i, preset in enumerate(presets):
        subset = rows[rows["preset"] == preset]
        positions = np.arange(len(estimators)) + (i - (len(presets) - 1) / 2) * width
        for ax, metric in zip(axes, ("base_parameter_error", "fit_cpu_s"), strict=True):
            data = [subset.loc[subset["estimator"] == e, metric].to_numpy() for e in estimators]
            box = ax.boxplot(data, positions=positions, widths=width * 0.9, patch_artist=True, manage_ticks=False)
            for patch in box["boxes"]:
                patch.set_facecolor(f"C{i}")
            axes[0].plot([], [], color=f"C{i}", lw=6, label=preset) if metric == "base_parameter_error" else None
    for ax, label in zip(axes, ("relative base-parameter error ‖β̂−β‖/‖β‖", "CPU time of the fit (s)"), strict=True):
        ax.set_xticks(np.arange(len(estimators)), estimators)
        ax.set_yscale("log")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(title="noise preset")
    fig.suptitle(f"Monte-Carlo estimator benchmark ({rows['seed'].nunique()} seeds per cell)")
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)
    return path


def write_summary(sweep_dir: Path) -> dict[str, Path]:
    """Aggregate a finished sweep into its folder; returns the files written."""
    sweep_dir = Path(sweep_dir)
    rows, parameters = collect(sweep_dir)
    table = summarize(rows)
    files = {
        "rows": sweep_dir / "estimator_benchmark.csv",
        "summary_csv": sweep_dir / "estimator_benchmark_summary.csv",
        "summary_md": sweep_dir / "estimator_benchmark_summary.md",
        "parameters": sweep_dir / "estimator_benchmark_parameters.csv",
    }
    rows.sort_values(["preset", "estimator", "seed"]).to_csv(files["rows"], index=False)
    table.to_csv(files["summary_csv"])
    files["summary_md"].write_text(summary_markdown(table) + "\n")
    parameter_summary(parameters).to_csv(files["parameters"], index=False)
    files["figure"] = benchmark_figure(rows, sweep_dir / "estimator_benchmark.png")
    print(summary_markdown(table))
    return files


if __name__ == "__main__":  # re-aggregate an earlier sweep: python -m lwrlab.pipeline.estimator_benchmark <sweep_dir>
    import sys

    write_summary(Path(sys.argv[1]))
