"""The estimator benchmark's sweep summarised: job rows collected, mean and spread per estimator and preset.

Pure pandas over the files the jobs wrote (:mod:`lwrlab.pipeline.studies.estimator_benchmark` names and
documents them): :class:`lwrlab.tracking.reports.benchmark_summary.EstimatorBenchmarkSummary` calls
:func:`write_summary` at the end of the sweep;
``python -m lwrlab.tracking.reports.benchmark_tables <sweep_dir>`` re-aggregates an earlier one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from lwrlab.figures.estimator_benchmark import benchmark_figure

JOB_TABLE = "estimator_benchmark.csv"
"""A job's one-row table (in its output folder)."""
PARAMETER_TABLE = "parameter_errors.csv"
"""A job's per-base-parameter errors (in its output folder)."""
METRICS = (
    "base_parameter_error",
    "rms_mean",
    "nrms_mean",
    "min_pseudo_inertia_eigenvalue",
    "consistency_margin",
    "fit_cpu_s",
    "residual_std",
)
"""The metrics of a job's row, summarised over seeds."""


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
    levels = table.columns.get_level_values(0), table.columns.get_level_values(1)
    table.columns = [f"{metric}_{stat}" for metric, stat in zip(*levels, strict=True)]
    table["consistent_share"] = grouped["consistency_margin"].apply(lambda m: float(np.mean(m >= -1e-9)))
    table["seeds"] = grouped.size()
    return table


def summary_markdown(table: pd.DataFrame) -> str:
    """The summary as a compact Markdown table (mean ± std)."""

    def pm(metric: str, fmt: str) -> pd.Series:
        return table.apply(lambda r: f"{r[f'{metric}_mean']:{fmt}} ± {r[f'{metric}_std']:{fmt}}", axis=1)

    view = pd.DataFrame(
        {
            "preset": table.index.get_level_values("preset"),
            "estimator": table.index.get_level_values("estimator"),
            "‖β̂−β‖/‖β‖": pm("base_parameter_error", ".3g"),
            "CV RMS (N·m)": pm("rms_mean", ".4g"),
            "min eig J (kg·m²)": table["min_pseudo_inertia_eigenvalue_mean"].map(lambda v: f"{v:.2g}"),
            "consistent": table["consistent_share"].map(lambda v: f"{100 * v:.0f} %"),
            "CPU fit (s)": pm("fit_cpu_s", ".3g"),
            "seeds": table["seeds"],
        },
        index=table.index,
    )
    return view.to_markdown(index=False)


def parameter_summary(parameters: pd.DataFrame) -> pd.DataFrame:
    """Per (preset, estimator, parameter): mean and spread (std) of the relative error over seeds."""
    grouped = parameters.groupby(["preset", "estimator", "parameter"], sort=False)["relative_error"]
    return grouped.agg(relative_error_mean="mean", relative_error_std="std").reset_index()


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


if (
    __name__ == "__main__"
):  # re-aggregate an earlier sweep: python -m lwrlab.tracking.reports.benchmark_tables <sweep_dir>
    import sys

    write_summary(Path(sys.argv[1]))
