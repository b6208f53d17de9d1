"""Joint PD with gravity compensation, eq. (13), and the Cartesian → joint reference through the IK."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from lwrlab.control.filters import BackwardDifference
from lwrlab.kinematics.swivel_ik import Branch, SwivelIK
from lwrlab.model.robot import RobotModel


@dataclass(frozen=True)
class ControlSetup:
    """What every painting controller is given: the model it believes in and how to reach a pose."""

    robot: RobotModel
    """The controller's model (identified or CAD) with the tool's inertia on the flange segment."""
    ik: SwivelIK
    """Analytic inverse geometric model of that robot."""
    tcp_in_flange: np.ndarray
    """(4, 4) tool centre point in the flange frame."""
    swivel: float
    """Swivel angle φ of the painting path (rad)."""
    branch: Branch
    """IK branch of the painting path."""
    period: float = 1e-3
    """Control period (s)."""

    def joint_reference(self, tcp_pose: np.ndarray) -> np.ndarray:
        """(N_J,) joint positions (rad) putting the tool centre point at ``tcp_pose`` (4×4)."""
        flange = tcp_pose @ np.linalg.inv(self.tcp_in_flange)
        return self.ik.solve_branch(flange[None], self.swivel, self.branch).q[0]


class JointPDGravity:
    """``Γ_d = K_p (q_d − q) + K_d (q̇_d − q̇) + Ĝ(q)`` (eq. 13), q̇_d by backward difference of q_d.

    Parameters
    ----------
    robot : the model whose gravity torques Ĝ compensate (with the tool).
    kp : (N_J,) proportional gains (N·m/rad).
    kd : (N_J,) derivative gains (N·m·s/rad).
    period : control period (s).
    """

    def __init__(self, robot: RobotModel, kp, kd, period: float) -> None:
        n = robot.n_joints
        self.kp = np.broadcast_to(np.asarray(kp, dtype=float), (n,)).copy()
        self.kd = np.broadcast_to(np.asarray(kd, dtype=float), (n,)).copy()
        self.model, self.data = robot.model, robot.model.createData()
        self.reference_rate = BackwardDifference(period)

    def gravity(self, q: np.ndarray) -> np.ndarray:
        """Ĝ(q) (N·m)."""
        return pin.computeGeneralizedGravity(self.model, self.data, q).copy()

    def reset(self, q_desired: np.ndarray) -> None:
        """Start with the reference at rest at ``q_desired``."""
        self.reference_rate.reset(q_desired)

    def torque(self, q_desired: np.ndarray, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """Commanded joint torques (N·m)."""
        dq_desired = self.reference_rate(q_desired)
        return self.kp * (q_desired - q) + self.kd * (dq_desired - dq) + self.gravity(q)
