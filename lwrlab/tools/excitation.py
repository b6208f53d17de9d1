"""Exciting the tool: a criterion on the tool's 10 regressor columns, and the choice of a motion by it.

Once the robot is identified, the tool's parameters come from ``Γˡ − W_bˡ·Φ_b = W_Lˡ·Φ_L``: their
covariance is ``σ²·(W_LᵀW_L)⁻¹``, so a motion that excites the tool well makes ``W_LᵀW_L`` large in
every direction. :class:`ToolLogDet` is D-optimality on those columns (each scaled to unit RMS over
random states, so the criterion is unit-free), with the gradient of the excitation criteria's
protocol (``value_and_gradient(W) -> (J, ∂J/∂W)``); :func:`select_tool_motion` keeps the best of a
few candidate motions by it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lwrlab.dynamics.base_parameters import random_states
from lwrlab.dynamics.regressor import regressor
from lwrlab.model.payload import flange_placement
from lwrlab.model.robot import RobotModel
from lwrlab.trajectory.core import Trajectory


class ToolLogDet:
    """``J = −log det(W_LᵀW_L / rows)`` on the (column-scaled) tool columns; the lower, the better."""

    name = "tool_logdet"

    def value_and_gradient(self, w: np.ndarray) -> tuple[float, np.ndarray]:
        """J and ∂J/∂W for a (rows, 10) column-scaled tool regressor."""
        rows = w.shape[0]
        information = w.T @ w / rows
        sign, logdet = np.linalg.slogdet(information)
        if sign <= 0:
            raise np.linalg.LinAlgError(
                "the motion does not excite every tool parameter (W_LᵀW_L is singular)"
            )
        return -float(logdet), -2.0 * w @ np.linalg.inv(information) / rows


def tool_regressor(robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
    """The 10 regressor columns of the flange-carrying segment (its joint frame), stacked rows."""
    joint, _ = flange_placement(robot)
    return regressor(robot, q, dq, ddq)[:, 10 * (joint - 1) : 10 * joint]


def tool_column_scales(robot: RobotModel, n_samples: int = 400, seed: int = 0) -> np.ndarray:
    """(10,) inverse RMS of each tool column over random states within the limits."""
    w = tool_regressor(robot, *random_states(robot, n_samples, np.random.default_rng(seed)))
    rms = np.sqrt(np.mean(w**2, axis=0))
    return 1.0 / np.where(rms > 0, rms, 1.0)


def tool_excitation(robot: RobotModel, motion: Trajectory, scales: np.ndarray, stride: int = 10) -> float:
    """:class:`ToolLogDet` of a motion (every ``stride``-th sample: the criterion is a mean)."""
    w = tool_regressor(robot, motion.q[::stride], motion.dq[::stride], motion.ddq[::stride]) * scales
    return ToolLogDet().value_and_gradient(w)[0]


def select_tool_motion(robot: RobotModel, candidates: Sequence[Trajectory]) -> tuple[int, np.ndarray]:
    """Index of the candidate motion that excites the tool best, and every candidate's criterion."""
    if not candidates:
        raise ValueError("no candidate motion to choose from")
    scales = tool_column_scales(robot)
    values = np.array([tool_excitation(robot, motion, scales) for motion in candidates])
    return int(np.argmin(values)), values
