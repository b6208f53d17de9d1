"""Figures of the exciting-motion study.

The motion (Fig. 9), costs vs duration (Fig. 5), criteria (Fig. 6), and what a next motion brings: the
base parameters' expected uncertainty before and after it.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from lwrlab.figures.backend import set_margins, subplots
from lwrlab.figures.decimation import envelope


def motion_figure(
    t: np.ndarray, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, torque: np.ndarray, path: Path, title: str
) -> Path:
    """Joint positions, velocities, accelerations and CAD torques over time, one panel each (like Fig. 9)."""
    fig, axes = subplots(4, 1, figsize=(8, 9), sharex=True)
    for ax, values, label in zip(
        axes, (q, dq, ddq, torque), ("q [rad]", "q̇ [rad/s]", "q̈ [rad/s²]", "Γ (CAD) [N·m]"), strict=True
    ):
        for j in range(values.shape[1]):
            ax.plot(*envelope(t, values[:, j]), lw=0.9, label=f"joint {j + 1}")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, ncol=values.shape[1], fontsize=8, loc="lower center")
    fig.suptitle(title)
    axes[-1].set_xlabel("time [s]")
    # the margins tight_layout gives (it lays every tick label out once more: a fifth of the drawing)
    set_margins(fig, left=0.75, right=0.15, top=0.47, bottom=0.86, hspace=0.11)
    fig.savefig(path, dpi=120)
    return path


def duration_figure(
    costs: pd.DataFrame, knees: dict[str, float], recommended: float, fraction: float, path: Path
) -> Path:
    """(a) optimal cost vs T_F, (b) successive differences, per criterion (like Fig. 5).

    ``costs``: columns criterion, duration_s, cost, relative_cost, relative_step (see
    :func:`lwrlab.pipeline.studies.duration_study.knee_duration`). The criteria have unrelated scales, so (a)
    shows each one's cost rescaled to [0, 1] over the durations, and (b) each one's successive
    differences over its total decrease, with the knee threshold ``fraction``.
    """
    criteria = list(dict.fromkeys(costs["criterion"]))
    fig, (ax_cost, ax_diff) = subplots(1, 2, figsize=(11, 4))
    for i, criterion in enumerate(criteria):
        rows = costs[costs["criterion"] == criterion].sort_values("duration_s")
        color = f"C{i}"
        ax_cost.plot(rows["duration_s"], rows["relative_cost"], "o-", color=color, label=criterion)
        ax_diff.semilogy(rows["duration_s"], rows["relative_step"], "o-", color=color, label=criterion)
        if np.isfinite(knees.get(criterion, np.nan)):
            ax_diff.axvline(knees[criterion], color=color, ls=":", lw=1)
    ax_diff.axhline(fraction, color="0.4", lw=1, ls="--", label=f"knee threshold {fraction:g}")
    ax_diff.axvline(recommended, color="k", lw=1.2, label=f"recommended {recommended:g} s")
    ax_cost.set(
        xlabel="duration T_F [s]",
        ylabel="(J − J_min)/(J_max − J_min)",
        title="(a) optimal cost, rescaled per criterion",
    )
    ax_diff.set(
        xlabel="duration T_F [s]",
        ylabel="|J(T_F) − J(T_F − 1)| / (J_max − J_min)",
        title="(b) successive differences",
    )
    for ax in (ax_cost, ax_diff):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    return path


def criteria_figure(summary: pd.DataFrame, path: Path) -> Path:
    """Grouped bars of mean RMS and NRMS per joint for each criterion, ± one standard deviation (like Fig. 6).

    ``summary``: columns criterion, joint, rms_mean, rms_std, nrms_mean, nrms_std, and optionally
    model_rms_mean, model_rms_std (a third panel).
    """
    criteria = list(dict.fromkeys(summary["criterion"]))
    joints = np.sort(summary["joint"].unique())
    width = 0.8 / len(criteria)
    panels = [
        (m, u) for m, u in (("rms", "N·m"), ("nrms", "%"), ("model_rms", "N·m")) if f"{m}_mean" in summary
    ]
    fig, axes = subplots(1, len(panels), figsize=(6 * len(panels), 3.8))
    for ax, (metric, unit) in zip(np.atleast_1d(axes), panels, strict=True):
        for i, criterion in enumerate(criteria):
            rows = summary[summary["criterion"] == criterion].set_index("joint").loc[joints]
            ax.bar(
                joints + (i - (len(criteria) - 1) / 2) * width,
                rows[f"{metric}_mean"],
                width,
                yerr=rows[f"{metric}_std"],
                capsize=2,
                label=criterion,
                color=f"C{i}",
            )
        label = {"rms": "RMS measured − estimated", "nrms": "NRMS", "model_rms": "RMS true − estimated"}[
            metric
        ]
        ax.set(xlabel="joint", ylabel=f"{label} [{unit}]", xticks=joints)
        ax.grid(axis="y", alpha=0.3)
    np.atleast_1d(axes)[0].legend(fontsize=8)
    fig.suptitle("Cross-validation torque error per joint (mean ± std over seeds)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    return path


_SUPERSCRIPTS = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def power_of_ten(value: float, _position: int | None = None) -> str:
    """A log axis's label of a power of ten, ``10⁻²``, in plain text (empty between powers).

    Matplotlib's default writes ``10^{-2}`` as mathtext, whose parser costs a tenth of a second to
    build in a process that draws no other mathtext.

    Examples
    --------
    >>> power_of_ten(0.01), power_of_ten(1.0), power_of_ten(1e3), power_of_ten(2e3)
    ('10⁻²', '10⁰', '10³', '')
    """
    exponent = round(float(np.log10(value))) if value > 0 else 0
    if value <= 0 or not np.isclose(value, 10.0**exponent, rtol=1e-9):
        return ""
    return "10" + str(exponent).translate(_SUPERSCRIPTS)


def uncertainty_figure(
    names: Sequence[str], before: np.ndarray, after: np.ndarray, threshold: float, path: Path, title: str
) -> Path:
    """Each base parameter's torque effect (N·m) before and after a motion, the poorly-known line across.

    ``before``/``after``: the RMS torque a one-σ error of each parameter makes (inf: not determined,
    drawn at the top of the axis as a triangle).
    """
    before, after = np.asarray(before, dtype=float), np.asarray(after, dtype=float)
    finite = np.concatenate([before[np.isfinite(before)], after[np.isfinite(after)], [threshold]])
    top = 10 * finite.max()
    bottom = max(finite[finite > 0].min() / 3, top * 1e-9)
    x = np.arange(len(names))
    fig, ax = subplots(figsize=(max(8, 0.17 * len(names)), 4))
    undetermined = ~np.isfinite(before)
    ax.bar(x, np.where(undetermined, np.nan, before), 0.8, color="0.8", label="before (what is known)")
    ax.bar(x, np.minimum(after, top), 0.45, color="C0", label="after this motion")
    if undetermined.any():
        ax.plot(
            x[undetermined], np.full(undetermined.sum(), top), "v", color="0.5", label="not determined before"
        )
    ax.axhline(threshold, color="C3", lw=1, ls="--", label=f"poorly known above {threshold:.2g} N·m")
    ax.set_yscale("log")
    from matplotlib.ticker import FuncFormatter  # matplotlib is imported when a figure is drawn

    ax.yaxis.set_major_formatter(FuncFormatter(power_of_ten))
    ax.set_ylim(bottom, 1.5 * top)
    ax.set_xticks(x, names, rotation=90, fontsize=7)
    ax.set(xlim=(-0.7, len(names) - 0.3), ylabel="torque effect of a one-σ error [N·m]")
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    fig.suptitle(title)  # a figure title and fixed margins: placing them by the labels costs ~0.5 s
    fig.subplots_adjust(left=0.07, right=0.99, bottom=0.17, top=0.92)
    fig.savefig(path, dpi=120)
    return path
