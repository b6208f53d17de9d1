"""Monte-Carlo estimator benchmark: one job through the real config tree, and the sweep summary."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from composing import compose_config

from lwrlab.pipeline.studies.estimator_benchmark import run_estimator_benchmark
from lwrlab.tracking.reports.benchmark_tables import METRICS, collect, write_summary


def _job(tmp_path: Path, estimator: str, noise: str, seed: int) -> dict[str, float]:
    overrides = [
        f"estimator={estimator}",
        "task=estimator_benchmark",
        f"task.noise={noise}",
        f"seed={seed}",
        "trajectory.duration=3",
        "validation.duration=2",
        "measurement.rate_hz=200",
        "plant.show_progress=false",
    ]
    cfg = compose_config(*overrides)
    return run_estimator_benchmark(
        cfg, tmp_path / f"{estimator}-{noise}-{seed}", cfg.task.noise, cfg.task.noise_presets
    )


def test_benchmark_jobs_and_summary(tmp_path: Path) -> None:
    for estimator in ("ols", "sdp"):
        metrics = _job(tmp_path, estimator, "high_torque", 0)
        assert set(metrics) == set(METRICS)
    rows, _ = collect(tmp_path)
    assert list(rows["estimator"]) == ["OrdinaryLeastSquares", "PhysicallyConsistentSDP"]
    sdp = rows.iloc[1]
    assert sdp["consistency_margin"] > -1e-9 and sdp["min_pseudo_inertia_eigenvalue"] >= -1e-12
    assert np.all(rows["base_parameter_error"] < 0.2)
    files = write_summary(tmp_path)
    assert files["figure"].stat().st_size > 10_000
    summary = pd.read_csv(files["summary_csv"])
    assert {"base_parameter_error_mean", "consistent_share", "fit_cpu_s_mean"} <= set(summary.columns)
    per_parameter = pd.read_csv(files["parameters"])
    assert {"relative_error_mean", "relative_error_std"} <= set(per_parameter.columns)


def test_unknown_noise_preset_lists_the_valid_ones(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="valid: \\['high_position', 'high_torque', 'standard'\\]"):
        _job(tmp_path, "ols", "loud", 0)


def test_summary_of_an_empty_sweep_says_so(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="did the benchmark jobs run"):
        collect(tmp_path)
