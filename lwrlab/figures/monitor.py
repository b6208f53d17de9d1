"""External joint torques of a monitored log with their thresholds and the detected contacts."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from lwrlab.figures.backend import set_margins, subplots
from lwrlab.figures.decimation import envelope


def external_torques(
    t: np.ndarray,
    observer: np.ndarray,
    residual: np.ndarray,
    thresholds: np.ndarray,
    detections: Sequence[tuple[float, float]],
    path: Path,
    title: str,
    true_contacts: Sequence[tuple[float, float]] = (),
) -> Path:
    """One panel per joint: observer and direct residual (N·m), ± the observer's thresholds ((N_J,)
    constant, or (N, N_J) following the state), detections shaded (and true contacts marked below
    the axis when known)."""
    n_joints = observer.shape[1]
    thresholds = np.asarray(thresholds, dtype=float)
    fig, axes = subplots(n_joints, 1, figsize=(11, 1.35 * n_joints + 1.0), sharex=True, squeeze=False)
    elapsed = t - t[0]
    for j, ax in enumerate(axes[:, 0]):
        ax.plot(*envelope(elapsed, residual[:, j]), lw=0.5, color="0.6", label="direct residual τ − τ̂")
        ax.plot(*envelope(elapsed, observer[:, j]), lw=0.7, color="C0", label="momentum observer")
        for sign in (-1, 1):
            if thresholds.ndim == 1:
                ax.axhline(sign * thresholds[j], color="C3", lw=0.7, ls="--")
            else:
                ax.plot(*envelope(elapsed, sign * thresholds[:, j]), color="C3", lw=0.7, ls="--")
        lowest = float(np.min(thresholds[..., j]))
        for start, end in detections:
            ax.axvspan(start - t[0], end - t[0], color="C1", alpha=0.25, lw=0)
        for start, end in true_contacts:
            ax.plot([start - t[0], end - t[0]], [-1.1 * lowest] * 2, color="k", lw=2)
        ax.set_ylabel(f"τ_ext{j + 1} [N·m]", fontsize=8)
        ax.grid(alpha=0.3)
    axes[0, 0].set_title(title, fontsize=10)
    axes[0, 0].legend(loc="upper right", ncol=2, fontsize=7)
    axes[-1, 0].set_xlabel("time from the log's start [s] (dashed: thresholds; shaded: detected contacts)")
    set_margins(fig, left=0.8, right=0.15, top=0.35, bottom=0.5, hspace=0.15)
    fig.savefig(path, dpi=110)
    return path
