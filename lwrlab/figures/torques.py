"""Figures in the style of the paper: torque overlays (Fig. 10) and RMS/NRMS per joint (Fig. 6)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from lwrlab.figures.backend import set_margins, subplots
from lwrlab.figures.decimation import envelope


def torque_overlay(
    t: np.ndarray, measured: np.ndarray, estimated: np.ndarray, path: Path, title: str
) -> Path:
    """Measured vs estimated torque of every joint over time, one panel per joint."""
    n = measured.shape[1]
    fig, axes = subplots(n, 1, figsize=(8, 1.5 * n + 1), sharex=True)
    for j, ax in enumerate(np.atleast_1d(axes)):
        ax.plot(*envelope(t, measured[:, j]), color="0.6", lw=0.8, label="measured")
        ax.plot(*envelope(t, estimated[:, j]), color="C3", lw=1.0, label="estimated")
        ax.set_ylabel(f"Γ{j + 1} [N·m]")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", ncol=2, fontsize=8)
    axes[0].set_title(title)
    axes[-1].set_xlabel("time [s]")
    set_margins(fig, left=0.9, right=0.15, top=0.35, bottom=0.5, hspace=0.18)
    fig.savefig(path, dpi=120)
    return path


def error_per_joint(
    rms: np.ndarray, nrms: np.ndarray, path: Path, title: str, noise_std: np.ndarray | None = None
) -> Path:
    """Bar charts of RMS (N·m) and NRMS (%) per joint, with the torque-noise floor if known."""
    joints = np.arange(1, rms.shape[0] + 1)
    fig, (ax_rms, ax_nrms) = subplots(1, 2, figsize=(9, 3.2))
    ax_rms.bar(joints, rms, color="C0")
    if noise_std is not None:
        ax_rms.step(
            np.r_[joints - 0.5, joints[-1] + 0.5],
            np.r_[noise_std, noise_std[-1]],
            where="post",
            color="k",
            lw=1,
            label="noise σ_τ",
        )
        ax_rms.legend(fontsize=8)
    ax_rms.set(xlabel="joint", ylabel="RMS [N·m]", xticks=joints)
    ax_nrms.bar(joints, nrms, color="C1")
    ax_nrms.set(xlabel="joint", ylabel="NRMS [%]", xticks=joints)
    for ax in (ax_rms, ax_nrms):
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle(title)
    set_margins(fig, left=0.75, right=0.15, top=0.45, bottom=0.5, wspace=0.3)
    fig.savefig(path, dpi=120)
    return path


def rms_per_joint_by_group(
    mean: np.ndarray, spread: np.ndarray, labels: list[str], path: Path, title: str
) -> Path:
    """Grouped bars of the cross-validation RMS per joint (N·m), one colour per group, ± the spread over runs.

    Parameters
    ----------
    mean, spread
        ``(groups, joints)`` arrays: mean and standard deviation over each group's runs (seeds).
    labels
        One label per group (``estimator=wls``).
    """
    groups, joints = mean.shape
    positions = np.arange(1, joints + 1)
    width = 0.8 / max(groups, 1)
    fig, ax = subplots(figsize=(max(6.0, 1.1 * joints + 0.3 * groups), 3.6))
    for index in range(groups):
        offset = (index - (groups - 1) / 2) * width
        ax.bar(
            positions + offset,
            mean[index],
            width,
            yerr=np.nan_to_num(spread[index]),
            capsize=2,
            label=labels[index],
            color=f"C{index % 10}",
        )
    ax.set(xlabel="joint", ylabel="cross-validation RMS [N·m]", xticks=positions, title=title)
    ax.grid(axis="y", alpha=0.3)
    longest = max((len(label) for label in labels), default=1)
    # below the bars, as many columns as the labels' length lets fit: never over the bars, never clipped
    ax.legend(
        fontsize=8,
        ncol=max(1, min(groups, 4, 120 // longest)),
        loc="upper center",
        bbox_to_anchor=(0.5, -0.16),
    )
    fig.savefig(path, dpi=120, bbox_inches="tight")
    return path
