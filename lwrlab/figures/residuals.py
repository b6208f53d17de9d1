"""Torque residuals of an identified model on each log it predicted (fit and validation logs)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from lwrlab.figures.backend import set_margins, subplots
from lwrlab.figures.decimation import envelope


def residuals_per_log(
    names: Sequence[str],
    roles: Sequence[str],
    times: Sequence[np.ndarray],
    residuals: Sequence[np.ndarray],
    path: Path,
) -> Path:
    """One row of panels per log: the residual τ − τ̂ of every joint over time (N·m), and its RMS per joint."""
    count = len(names)
    fig, axes = subplots(
        count, 2, figsize=(10, 2.4 * count + 0.6), squeeze=False, gridspec_kw={"width_ratios": [3, 1]}
    )
    for row, (name, role, t, residual) in enumerate(zip(names, roles, times, residuals, strict=True)):
        over_time, per_joint = axes[row]
        for j in range(residual.shape[1]):
            over_time.plot(*envelope(t - t[0], residual[:, j]), lw=0.6, label=f"joint {j + 1}")
        over_time.set(ylabel="τ − τ̂ [N·m]", title=f"{name} ({role})")
        over_time.grid(alpha=0.3)
        joints = np.arange(1, residual.shape[1] + 1)
        per_joint.bar(joints, np.sqrt(np.mean(residual**2, axis=0)), color="C0")
        per_joint.set(ylabel="RMS [N·m]", xticks=joints)
        per_joint.grid(alpha=0.3, axis="y")
    axes[0, 0].legend(loc="upper right", ncol=min(7, residuals[0].shape[1]), fontsize=7)
    axes[-1, 0].set_xlabel("time from the log's start [s]")
    axes[-1, 1].set_xlabel("joint")
    set_margins(fig, left=0.85, right=0.15, top=0.3, bottom=0.5, hspace=0.4, wspace=0.22)
    fig.savefig(path, dpi=110)
    return path
