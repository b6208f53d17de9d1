"""The Monte-Carlo estimator benchmark's figure: error and fit time per estimator and noise preset."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from lwrlab.figures.backend import subplots


def benchmark_figure(rows: pd.DataFrame, path: Path) -> Path:
    """Box plots of the relative base-parameter error and of the fit CPU time per estimator, one
    group per noise preset (log scales)."""
    presets = sorted(rows["preset"].unique())
    estimators = sorted(rows["estimator"].unique())
    fig, axes = subplots(1, 2, figsize=(11, 4.2))
    width = 0.8 / len(presets)
    for i, preset in enumerate(presets):
        subset = rows[rows["preset"] == preset]
        positions = np.arange(len(estimators)) + (i - (len(presets) - 1) / 2) * width
        for ax, metric in zip(axes, ("base_parameter_error", "fit_cpu_s"), strict=True):
            data = [subset.loc[subset["estimator"] == e, metric].to_numpy() for e in estimators]
            box = ax.boxplot(
                data, positions=positions, widths=width * 0.9, patch_artist=True, manage_ticks=False
            )
            for patch in box["boxes"]:
                patch.set_facecolor(f"C{i}")
            axes[0].plot(
                [], [], color=f"C{i}", lw=6, label=preset
            ) if metric == "base_parameter_error" else None
    for ax, label in zip(
        axes, ("relative base-parameter error ‖β̂−β‖/‖β‖", "CPU time of the fit (s)"), strict=True
    ):
        ax.set_xticks(np.arange(len(estimators)), estimators)
        ax.set_yscale("log")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(title="noise preset")
    fig.suptitle(f"Monte-Carlo estimator benchmark ({rows['seed'].nunique()} seeds per cell)")
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    return path
