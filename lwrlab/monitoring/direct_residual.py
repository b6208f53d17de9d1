"""The direct residual τ − τ̂(q, q̇, q̈) and the joint motion it needs, from a log.

The model's torque needs the acceleration: the positions are low-passed by a zero-phase Butterworth
(:func:`lwrlab.signal.filters.lowpass`) and differentiated twice by centred differences, and the
measured torque goes through the same filter so that both sides of the residual see the same band
(Gautier's parallel filtering). Zero-phase filtering looks ahead: the direct residual is an offline
comparison. The observer (:mod:`lwrlab.monitoring.observer`) needs no acceleration, and its velocity
is what a robot's loop has (:mod:`lwrlab.monitoring.observer_inputs`): it sees nothing before it
happens.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin

from lwrlab.signal.filters import central_difference, lowpass

FILTER_ORDER = 4
"""Order of the zero-phase Butterworth on positions and torques."""


class JointMotion(NamedTuple):
    """Positions and their derivatives on a uniform grid."""

    q: np.ndarray
    """(N, N_J) low-passed positions (rad)."""
    dq: np.ndarray
    """(N, N_J) velocities (rad/s)."""
    ddq: np.ndarray
    """(N, N_J) accelerations (rad/s²)."""


def uniform_period(t: np.ndarray) -> float:
    """The sampling period (s) of uniform stamps; a ValueError if they are not uniform (1 % jitter)."""
    steps = np.diff(np.asarray(t, dtype=float))
    period = float(np.mean(steps))
    if steps.size == 0 or np.max(np.abs(steps - period)) > 0.01 * period:
        raise ValueError("the joint motion needs uniform stamps (the log readers resample irregular ones)")
    return period


def smooth(x: np.ndarray, period: float, cutoff_hz: float | None) -> np.ndarray:
    """``x`` (N, ·) low-passed at ``cutoff_hz`` (zero phase); unchanged for None."""
    if cutoff_hz is None:
        return np.asarray(x, dtype=float)
    return lowpass(np.asarray(x, dtype=float), 1.0 / period, cutoff_hz, FILTER_ORDER)


def joint_motion(t: np.ndarray, q: np.ndarray, cutoff_hz: float | None) -> JointMotion:
    """q, q̇, q̈ from sampled positions: low-passed at ``cutoff_hz`` (None: unfiltered), centred differences."""
    period = uniform_period(t)
    filtered = smooth(q, period, cutoff_hz)
    dq = central_difference(filtered, period)
    return JointMotion(filtered, dq, central_difference(dq, period))


def model_torque(
    robot_model: pin.Model, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, friction: np.ndarray
) -> np.ndarray:
    """τ̂ = RNEA(q, q̇, q̈) + friction (N·m, (N, N_J)); ``friction`` the model's τ_f at each sample."""
    data = robot_model.createData()
    tau = np.empty_like(q)
    for k in range(q.shape[0]):
        tau[k] = pin.rnea(robot_model, data, q[k], dq[k], ddq[k])
    return tau + friction
