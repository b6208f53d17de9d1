"""Periodic multi-sine joint motion, scaled into the robot's limits (config group ``trajectory``).

Each joint follows a finite Fourier series whose period is the motion's duration T (Swevers et al.
1997)::

    q_j(t) = c_j + Σ_k a_jk·sin(ω_k t) + b_jk·(cos(ω_k t) − 1),    ω_k = 2πk/T, k = 1…K

Seeded random coefficients (decaying as 1/k) are projected onto the linear constraints
``Σ_k a_jk·ω_k = 0`` and ``Σ_k b_jk·ω_k² = 0``, so the motion starts and ends at rest (q̇ = q̈ = 0)
at the posture ``c``; being periodic and band-limited it has no corner for the filters and finite
differences to smear. Each joint's coefficients are then scaled so its position, velocity and
acceleration use at most ``limit_fraction`` of the robot's limits.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lwrlab.model.position_ranges import range_center
from lwrlab.model.robot import RobotModel
from lwrlab.trajectory.core import Trajectory


def _remove_component(coefficients: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Project each row of ``coefficients`` onto the hyperplane orthogonal to ``direction``."""
    return coefficients - np.outer(coefficients @ direction, direction) / (direction @ direction)


class MultisineMotion:
    """Seeded periodic multi-sine motion within a fraction of the joint limits.

    Every setting is required: conf/trajectory/multisine.yaml gives their values.

    Parameters
    ----------
    duration : motion duration T (s), also its period.
    harmonics : number K of harmonics per joint (frequencies k/T Hz; K ≥ 2).
    seed : seed of the coefficients.
    limit_fraction : fraction (0, 1] of the position room around ``center``, of the velocity and of
        the acceleration limits the motion may reach.
    center : start/end posture (rad per joint); None: the middle of each position range (0 for a
        continuous joint, whose motion only its velocity and acceleration limits bound).
    """

    def __init__(
        self,
        *,
        duration: float,
        harmonics: int,
        seed: int,
        limit_fraction: float,
        center: Sequence[float] | None,
    ) -> None:
        self.duration = duration
        self.harmonics = harmonics
        self.seed = seed
        self.limit_fraction = limit_fraction
        self.center = center
        if not 0.0 < limit_fraction <= 1.0:
            raise ValueError(f"limit_fraction must be in (0, 1], got {limit_fraction}")
        if harmonics < 2:
            raise ValueError(f"at least 2 harmonics are needed to start and stop at rest, got {harmonics}")
        if duration <= 0:
            raise ValueError(f"duration must be positive, got {duration}")

    def sample(self, robot: RobotModel, rate_hz: float) -> Trajectory:
        """The motion at ``rate_hz`` (Hz), scaled into ``robot``'s limits."""
        n = robot.n_joints
        rng = np.random.default_rng(self.seed)
        k = np.arange(1, self.harmonics + 1)
        omega = 2 * np.pi * k / self.duration
        a = _remove_component(rng.normal(size=(n, self.harmonics)) / k, omega)  # q̇(0) = 0
        b = _remove_component(rng.normal(size=(n, self.harmonics)) / k, omega**2)  # q̈(0) = 0

        t = np.arange(round(self.duration * rate_hz) + 1) / rate_hz
        sin, cos = np.sin(np.outer(t, omega)), np.cos(np.outer(t, omega))  # (N, K)
        x = sin @ a.T + (cos - 1.0) @ b.T
        dx = cos @ (a * omega).T - sin @ (b * omega).T
        ddx = -sin @ (a * omega**2).T - cos @ (b * omega**2).T

        lim = robot.limits
        center = (
            np.asarray(self.center, dtype=float)
            if self.center is not None
            else range_center(lim.position_lower, lim.position_upper)
        )
        room = np.minimum(center - lim.position_lower, lim.position_upper - center)  # inf: continuous
        if np.any(room <= 0):
            raise ValueError(f"center {center} is outside the position limits of {robot.name}")
        scale = self.limit_fraction * np.min(
            [
                room / np.abs(x).max(0),
                lim.velocity / np.abs(dx).max(0),
                lim.acceleration / np.abs(ddx).max(0),
            ],
            axis=0,
        )
        return Trajectory(
            t=t,
            q=center + scale * x,
            dq=scale * dx,
            ddq=scale * ddx,
            metadata={
                "source": "multisine",
                "seed": self.seed,
                "duration": self.duration,
                "harmonics": self.harmonics,
            },
        )
