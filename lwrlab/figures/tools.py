"""Figures of the tool experiments: Table III's %σ per parameter, and recognition confusion matrices."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from lwrlab.figures.backend import subplots


def relative_std_bars(
    parameters: Sequence[str], series: Mapping[str, np.ndarray], path: Path, title: str
) -> Path:
    """%σ of each tool parameter (log scale), one group of bars per parameter, one colour per series."""
    fig, ax = subplots(figsize=(8, 3.5))
    width = 0.8 / max(1, len(series))
    x = np.arange(len(parameters))
    for i, (label, values) in enumerate(series.items()):
        ax.bar(x + (i - (len(series) - 1) / 2) * width, np.clip(values, 1e-3, None), width, label=label)
    ax.set_yscale("log")
    ax.set_xticks(x, parameters)
    ax.set_ylabel("%σ")
    ax.set_title(title)
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    return path


def confusion_matrices(
    names: Sequence[str], matrices: Mapping[str, np.ndarray], accuracies: Mapping[str, float], path: Path
) -> Path:
    """One confusion matrix per classifier (rows: true tool, columns: recognised tool, share of trials)."""
    n = len(matrices)
    fig, axes = subplots(1, n, figsize=(4.2 * n + 0.8, 4.6), squeeze=False)
    for ax, (label, matrix) in zip(axes[0], matrices.items(), strict=True):
        shares = matrix / np.maximum(matrix.sum(axis=1, keepdims=True), 1)
        image = ax.imshow(shares, cmap="Blues", vmin=0, vmax=1)
        ax.set_xticks(range(len(names)), names, rotation=90, fontsize=7)
        ax.set_yticks(range(len(names)), names, fontsize=7)
        ax.set_xlabel("recognised")
        ax.set_title(f"{label}: {100 * accuracies[label]:.1f} %", fontsize=10)
        for i, j in zip(*np.nonzero(matrix), strict=True):
            ax.text(
                j,
                i,
                str(int(matrix[i, j])),
                ha="center",
                va="center",
                fontsize=6,
                color="white" if shares[i, j] > 0.5 else "black",
            )
    axes[0][0].set_ylabel("true tool")
    fig.colorbar(image, ax=axes[0].tolist(), shrink=0.7, label="share of trials")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    return path
