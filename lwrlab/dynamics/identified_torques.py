"""Joint torques an identified model predicts at given states: τ̂ = W(q, q̇, q̈)·φ_B.

The product an identification scores every log with (``predicted_torque.parquet``), for states a
caller gives instead of a log the pipeline filters: the robot's full regressor (inertial, drive and
friction columns of the law it was identified with) block by block, through
:class:`~lwrlab.dynamics.regressor.LogRegressor`, times the identified base parameters scattered
into their columns (:meth:`~lwrlab.dynamics.base_parameters.BaseParameters.torques`).

Friction with memory (a law that holds still, ``friction=holding``): the rows are taken as one
motion's consecutive samples, ``1 / rate_hz`` seconds apart, and the law's columns are computed
over all of them first, as for a whole log; the first row starts from rest, as a log does. A
memoryless law predicts every row on its own.

Examples
--------
The CAD model's own base parameters predict its inverse dynamics:

>>> from lwrlab.model.description import load_robot_yaml
>>> from lwrlab.resources import config_group
>>> robot = load_robot_yaml(config_group("robot")["kuka_lwr4"])
>>> base = compute_base_parameters(robot)
>>> model = IdentifiedTorques.of(robot, base.names, base.base_values(robot.parameters), 1000.0)
>>> q, dq, ddq = np.full((3, 7), 0.3), np.full((3, 7), 0.5), np.ones((3, 7))
>>> bool(np.allclose(model.predict(q, dq, ddq), robot.inverse_dynamics(q, dq, ddq)))
True
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from lwrlab.dynamics.base_parameters import BaseParameters, compute_base_parameters
from lwrlab.dynamics.regressor import LogRegressor
from lwrlab.model.friction_laws import has_memory
from lwrlab.model.robot import RobotModel
from lwrlab.numerics.threads import dense_algebra

BLOCK_SAMPLES = 8192
"""Samples whose full regressor is built at a time (8192 × 7 joints × 91 columns: 42 MB)."""


@dataclass(frozen=True)
class IdentifiedTorques:
    """An identified model as a function of the joint states: τ̂ = W(q, q̇, q̈)·φ_B."""

    robot: RobotModel
    """The identified robot (its kinematics, drive train, friction law and terms give ``W``)."""
    base: BaseParameters
    """The base parameters that were identified (their columns of ``W``)."""
    base_values: np.ndarray
    """(N_B,) identified base parameters (SI units)."""
    rate_hz: float
    """Sampling rate (Hz) of consecutive rows when none is given: a law with memory integrates at it."""

    @classmethod
    def of(
        cls, robot: RobotModel, base_names: Sequence[str], base_values: np.ndarray, rate_hz: float
    ) -> IdentifiedTorques:
        """The model with ``base_values`` of the base parameters ``base_names`` of ``robot``.

        ``base_names`` are those an identification reports: the robot's base parameters, less
        drive columns no fitted joint loads. Raises ``ValueError`` naming the first one the robot
        does not have (another robot, other friction terms).
        """
        base = compute_base_parameters(robot)
        wanted = set(base_names)
        keep = np.array([name in wanted for name in base.names], dtype=bool)
        kept = tuple(name for name, chosen in zip(base.names, keep, strict=True) if chosen)
        if kept != tuple(base_names):
            missing = [name for name in base_names if name not in set(base.names)]
            raise ValueError(
                f"base parameters {missing or list(base_names)} are not those of {robot.name} "
                f"with friction terms {list(robot.friction_terms)} ({list(base.names)})"
            )
        base = replace(base, columns=base.columns[keep], regrouping=base.regrouping[keep], names=kept)
        return cls(robot, base, np.asarray(base_values, dtype=float), float(rate_hz))

    @property
    def has_memory(self) -> bool:
        """Whether the friction law reads the motion before each sample (rows are then consecutive)."""
        return has_memory(self.robot.friction_law)

    def predict(
        self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, rate_hz: float | None = None
    ) -> np.ndarray:
        """(N, N_J) torques (N·m) at positions ``q`` (rad), velocities ``dq`` (rad/s) and
        accelerations ``ddq`` (rad/s²), each (N, N_J); ``rate_hz``: of consecutive rows (None:
        :attr:`rate_hz`), read by a law with memory only."""
        q, dq, ddq = (np.ascontiguousarray(a, dtype=float) for a in (q, dq, ddq))
        if not q.shape == dq.shape == ddq.shape or q.ndim != 2 or q.shape[1] != self.robot.n_joints:
            raise ValueError(
                f"q, dq and ddq must be (N, {self.robot.n_joints}) arrays, got {q.shape}, {dq.shape}, "
                f"{ddq.shape}"
            )
        log_regressor = LogRegressor.of(self.robot, lambda: dq, rate_hz or self.rate_hz)
        torques = np.empty(q.shape)
        with dense_algebra():
            for first in range(0, len(q), BLOCK_SAMPLES):
                part = slice(first, first + BLOCK_SAMPLES)
                full = log_regressor(q[part], dq[part], ddq[part], first, stacked=False)
                torques[part] = self.base.torques(full, self.base_values)
        return torques


__all__ = ["BLOCK_SAMPLES", "IdentifiedTorques"]
