"""Figures of the painting task: the path on the wall (Fig. 12) and the normal force (Fig. 13)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from lwrlab.figures.backend import subplots


def path_on_wall(
    desired: np.ndarray, actual: np.ndarray, wall: tuple[float, float, float, float], path: Path, title: str
) -> Path:
    """Desired vs actual tool-centre-point path in the wall plane (y, z), like Fig. 12.

    ``desired``, ``actual``: (N, 3) positions (m); ``wall``: (y_min, y_max, z_min, z_max) (m).
    """
    from matplotlib.patches import Rectangle

    fig, ax = subplots(figsize=(4.5, 5.0))
    y_min, y_max, z_min, z_max = wall
    ax.add_patch(
        Rectangle(
            (y_min, z_min),
            y_max - y_min,
            z_max - z_min,
            fill=False,
            color="0.6",
            lw=1.0,
            ls="--",
            label="wall",
        )
    )
    ax.plot(desired[:, 1], desired[:, 2], color="k", lw=1.5, label="desired")
    ax.plot(actual[:, 1], actual[:, 2], color="tab:red", lw=0.8, label="actual")
    ax.set_xlabel("y (m)")
    ax.set_ylabel("z (m)")
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    return path


def normal_force(
    t: np.ndarray,
    panels: Mapping[str, Mapping[str, np.ndarray]],
    desired: float | None,
    path: Path,
    title: str,
) -> Path:
    """Desired, estimated and measured normal force over time, one panel per case, like Fig. 13.

    ``panels``: panel title → {"estimated": (N,), "measured": (N,)} (N); ``desired`` (N), None for a
    controller without a force target (no line drawn).
    """
    fig, axes = subplots(len(panels), 1, figsize=(7.0, 2.4 * len(panels)), sharex=True, squeeze=False)
    for ax, (name, series) in zip(axes[:, 0], panels.items(), strict=True):
        ax.plot(t, series["measured"], color="tab:blue", lw=0.8, label="measured (wall sensor)")
        ax.plot(t, series["estimated"], color="tab:red", lw=0.8, label="estimated (eq. 14)")
        if desired is not None:
            ax.axhline(desired, color="k", lw=1.2, ls="--", label="desired")
        ax.set_ylabel("F_x (N)")
        ax.set_title(name, fontsize=9)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8, loc="lower right")
    axes[-1, 0].set_xlabel("time (s)")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    return path
