"""The identification's note on the next motion: what an exciting motion designed for this model
would still teach (the identification's result read with the excitation's measure of what is known)."""

from __future__ import annotations

import numpy as np

from lwrlab.dynamics.base_parameters import BaseParameters
from lwrlab.excitation.problem import column_scales
from lwrlab.excitation.uncertainty import POORLY_KNOWN_SHARE, poorly_known, workspace_torque_rms
from lwrlab.model.robot import RobotModel


def next_motion_note(robot: RobotModel, base: BaseParameters, std: np.ndarray) -> str:
    """Which motion would help next: the base parameters still poorly known (their std moves the torque
    by more than :data:`POORLY_KNOWN_SHARE` of its RMS over the workspace), and the command that
    designs a motion for them from this model."""
    scales = column_scales(robot, base)
    torque_rms = workspace_torque_rms(robot)
    effect = np.asarray(std, dtype=float) / scales
    poor = poorly_known(std, scales, torque_rms)
    command = (
        "`lwrlab task=excitation task.known_model=<model>` (<model>: this run's folder, or "
        "runs:/<run id>/model; add criterion=target_variance and task.targets to aim it at where the "
        "model will be used)"
    )
    if not poor.any():
        return (
            f"next motion: every base parameter is well known (largest torque effect of a one-σ error "
            f"{effect.max():.2g} N·m, {100 * effect.max() / torque_rms:.2g} % of the torque RMS over the "
            f"workspace); a motion designed for what is left, {command}, would add little"
        )
    named = [f"{base.names[g]} ({effect[g]:.2g} N·m)" for g in np.argsort(-effect) if poor[g]]
    return (
        f"NEXT MOTION: {len(named)} of {base.count} base parameters stay poorly known (a one-σ error moves "
        f"the torque by more than {100 * POORLY_KNOWN_SHARE:g} % of its RMS over the workspace, "
        f"{POORLY_KNOWN_SHARE * torque_rms:.2g} N·m): {', '.join(named[:10])}"
        + (" …" if len(named) > 10 else "")
        + f"; a motion designed for them: {command}"
    )
