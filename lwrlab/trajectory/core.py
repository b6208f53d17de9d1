"""The ``Trajectory`` value object, the ``MotionSource`` protocol, and limit checks."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from lwrlab.model.robot import RobotModel


@dataclass(frozen=True)
class Trajectory:
    """A joint motion sampled on a uniform time grid."""

    t: np.ndarray
    """(N,) sample times (s), uniform, starting at 0."""
    q: np.ndarray
    """(N, N_J) joint positions (rad)."""
    dq: np.ndarray
    """(N, N_J) joint velocities (rad/s)."""
    ddq: np.ndarray
    """(N, N_J) joint accelerations (rad/s²)."""
    metadata: dict[str, Any] = field(default_factory=dict)
    """Where the motion comes from (plugin, parameters), free-form."""

    def __post_init__(self) -> None:
        n = self.t.shape[0]
        for name in ("q", "dq", "ddq"):
            array = getattr(self, name)
            if array.ndim != 2 or array.shape[0] != n:
                raise ValueError(f"Trajectory.{name} must have shape ({n}, N_J), got {array.shape}")

    @property
    def duration(self) -> float:
        """Duration (s)."""
        return float(self.t[-1] - self.t[0])

    @property
    def rate_hz(self) -> float:
        """Sampling rate (Hz)."""
        return float((self.t.shape[0] - 1) / self.duration)


class MotionSource(Protocol):
    """A trajectory plugin: anything that can sample a motion for a robot at a given rate."""

    def sample(self, robot: RobotModel, rate_hz: float) -> Trajectory:
        """The motion sampled at ``rate_hz`` (Hz), within the robot's limits."""
        ...


class LimitViolation(ValueError):
    """A motion leaves the robot's joint limits; the message names each violated limit."""


def limit_violations(
    trajectory: Trajectory, robot: RobotModel, torque: np.ndarray | None = None
) -> list[str]:
    """Human-readable descriptions of every violated joint limit (empty if none).

    ``torque`` (N, N_J) — e.g. the CAD model's inverse dynamics — is checked against the torque limits
    when given.
    """
    lim = robot.limits
    problems = []
    checks = [
        ("position", trajectory.q, lim.position_lower, lim.position_upper, "rad"),
        ("velocity", trajectory.dq, -lim.velocity, lim.velocity, "rad/s"),
        ("acceleration", trajectory.ddq, -lim.acceleration, lim.acceleration, "rad/s²"),
    ]
    if torque is not None:
        checks.append(("torque", torque, -lim.torque, lim.torque, "N·m"))
    for quantity, values, lower, upper, unit in checks:
        for j in range(robot.n_joints):
            worst_low, worst_high = values[:, j].min(), values[:, j].max()
            if worst_low < lower[j] or worst_high > upper[j]:
                k = int(np.argmax(np.maximum(lower[j] - values[:, j], values[:, j] - upper[j])))
                problems.append(
                    f"joint {j + 1} {quantity} {values[k, j]:.4g} {unit} at t = {trajectory.t[k]:.3f} s "
                    f"outside [{lower[j]:.4g}, {upper[j]:.4g}]"
                )
    return problems


def require_motion_limits(robot: RobotModel, purpose: str) -> None:
    """A clear error when ``robot`` has no acceleration limits (a URDF has none) and ``purpose`` needs
    them."""
    unknown = [j + 1 for j in range(robot.n_joints) if not np.isfinite(robot.limits.acceleration[j])]
    if unknown:
        raise ValueError(
            f"{robot.name}: no acceleration limits for joints {unknown} (a URDF holds none): "
            f"give robot.acceleration_limits (rad/s², one per joint or a scalar) to {purpose}; "
            "identifying from recorded logs (plant=log) does not need them"
        )


def check_limits(
    trajectory: Trajectory, robot: RobotModel, torque: np.ndarray | None = None, what: str = "motion"
) -> None:
    """Raise :class:`LimitViolation` naming every violated limit of ``trajectory`` on ``robot``."""
    require_motion_limits(robot, f"check the {what}")
    problems = limit_violations(trajectory, robot, torque)
    if problems:
        raise LimitViolation(f"{what} violates the limits of {robot.name}:\n  " + "\n  ".join(problems))
