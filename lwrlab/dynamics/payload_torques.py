"""Joint torques a payload adds at given states: τ_L = W_L(q, q̇, q̈)·Φ_L.

The columns ``W_L`` are those of the segment that carries the flange (its joint frame), as the
payload identification uses them (:func:`lwrlab.identification.payload.tool_columns` of the full
regressor, :mod:`lwrlab.dynamics.regressor`); ``Φ_L`` is the payload's 10 standard parameters
moved from the flange frame into that joint frame (``Φ_L = T·φ_flange``,
:func:`lwrlab.model.payload.frame_change_matrix`). The columns are inertial only, so the torques
are the rigid-body difference between the robot with and without the payload: no friction, no
drive term, whatever the robot's friction law. They depend on the robot's kinematics and gravity,
not on its own inertial parameters.

Examples
--------
A payload's torques are the inverse dynamics of the robot carrying it minus those of the robot:

>>> from lwrlab.model.description import load_robot_yaml
>>> from lwrlab.model.inertia import standard_parameters
>>> from lwrlab.model.payload import attach_payload
>>> from lwrlab.resources import config_group
>>> robot = load_robot_yaml(config_group("robot")["kuka_lwr4"])
>>> payload = standard_parameters(0.5, np.array([0.0, 0.02, 0.05]), np.diag([1e-3, 1e-3, 5e-4]))
>>> model = PayloadTorques.of(robot, payload)
>>> q, dq, ddq = np.full((3, 7), 0.3), np.full((3, 7), 0.5), np.ones((3, 7))
>>> loaded = attach_payload(robot, payload).inverse_dynamics(q, dq, ddq, with_friction=False)
>>> bool(np.allclose(model.predict(q, dq, ddq), loaded - robot.inverse_dynamics(q, dq, ddq, False)))
True
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from lwrlab.dynamics.regressor import regressor
from lwrlab.model.payload import flange_placement, frame_change_matrix
from lwrlab.model.robot import RobotModel


@dataclass(frozen=True)
class PayloadTorques:
    """A payload at a robot's flange as a function of the joint states: τ_L = W_L(q, q̇, q̈)·Φ_L."""

    robot: RobotModel
    """The robot carrying the payload (its kinematics, gravity and flange frame; no friction columns)."""
    joint: int
    """The joint whose segment carries the flange (1-based)."""
    phi_flange: np.ndarray
    """(10,) the payload's standard parameters in the flange frame (kg, kg·m, kg·m²)."""
    phi_joint: np.ndarray
    """(10,) the same in the joint frame of :attr:`joint`: the coefficients of the columns ``W_L``."""

    @classmethod
    def of(cls, robot: RobotModel, phi_flange: np.ndarray) -> PayloadTorques:
        """The payload ``phi_flange`` (10,), flange frame, at the flange of ``robot``.

        Raises a ``ValueError`` when ``phi_flange`` is not 10 values, and
        :class:`~lwrlab.errors.ConfigError` when the robot has no ``flange`` frame.
        """
        phi_flange = np.asarray(phi_flange, dtype=float)
        if phi_flange.shape != (10,):
            raise ValueError(f"a payload has 10 inertial parameters, got shape {phi_flange.shape}")
        joint, placement = flange_placement(robot)
        phi_joint = frame_change_matrix(placement.rotation, placement.translation) @ phi_flange
        return cls(replace(robot, friction_terms=()), joint, phi_flange, phi_joint)

    def columns(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        """(N, N_J, 10) the columns ``W_L`` at positions ``q`` (rad), velocities ``dq`` (rad/s) and
        accelerations ``ddq`` (rad/s²), each (N, N_J)."""
        full = regressor(self.robot, q, dq, ddq, stacked=False)
        return full[:, :, 10 * (self.joint - 1) : 10 * self.joint]

    def predict(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        """(N, N_J) torques (N·m) the payload adds at the joints, at states (N, N_J) as :meth:`columns`."""
        return self.columns(q, dq, ddq) @ self.phi_joint


__all__ = ["PayloadTorques"]
