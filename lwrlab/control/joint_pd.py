"""Joint PD with gravity compensation, eq. (13), the Cartesian → joint reference through the IK, and
what every painting controller is given (:class:`ControlSetup`) and returns (:class:`ControlOutput`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from lwrlab.kinematics.displaced_path import DisplacedPathIK
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
    period: float
    """Control period (s)."""
    ik_chunk: int = 2048
    """Most path samples solved per batched IK call (:class:`DisplacedPathIK`): long chunks cost least
    in all, short ones bound the longest single period (a controller commanding a robot live)."""

    @cached_property
    def flange_in_tcp(self) -> np.ndarray:
        """(4, 4) inverse of ``tcp_in_flange``, computed once."""
        return np.linalg.inv(self.tcp_in_flange)

    def joint_reference(self, tcp_pose: np.ndarray) -> np.ndarray:
        """(N_J,) joint positions (rad) putting the tool centre point at ``tcp_pose`` (4×4)."""
        flange = tcp_pose @ self.flange_in_tcp
        return self.ik.solve_branch(flange[None], self.swivel, self.branch).q[0]

    def path_ik(self, reference: np.ndarray) -> DisplacedPathIK:
        """Joint positions along the tool poses ``reference`` (N, 4, 4) moved by an offset, per sample."""
        return DisplacedPathIK(
            self.ik, reference, self.tcp_in_flange, self.swivel, self.branch, chunk=self.ik_chunk
        )


class ControlOutput(NamedTuple):
    """A controller's decision for one period (a tuple: cheap to make at 1 kHz); (R, ·) for R runs."""

    tau: np.ndarray
    """(N_J,) commanded joint torques (N·m)."""
    commanded_position: np.ndarray
    """(3,) tool-centre-point position it aimed at, reference + ΔP_c (m)."""
    q_desired: np.ndarray
    """(N_J,) joint reference (rad)."""


class JointPDGravity:
    """``Γ_d = K_p (q_d − q) + K_d (q̇_d − q̇) + Ĝ(q)`` (eq. 13), q̇_d by backward difference of q_d.

    Parameters
    ----------
    robot : the model whose gravity torques Ĝ compensate (with the tool); a sequence of R models
        runs R controllers in lockstep on (R, N_J) arrays, each with its own Ĝ.
    kp : (N_J,) proportional gains (N·m/rad); (R, N_J) for R models.
    kd : (N_J,) derivative gains (N·m·s/rad); (R, N_J) for R models.
    period : control period (s).
    """

    def __init__(self, robot: RobotModel | Sequence[RobotModel], kp, kd, period: float) -> None:
        self._batched = not isinstance(robot, RobotModel)
        robots = list(robot) if not isinstance(robot, RobotModel) else [robot]
        shape = (len(robots), robots[0].n_joints) if self._batched else (robots[0].n_joints,)
        self.kp = np.broadcast_to(np.asarray(kp, dtype=float), shape).copy()
        self.kd = np.broadcast_to(np.asarray(kd, dtype=float), shape).copy()
        self._models = [(r.model, r.model.createData()) for r in robots]
        self.model, self.data = self._models[0]
        self._gravity = np.zeros(shape)  # scratch of the batched Ĝ, summed before it is rewritten
        self.inverse_period = 1.0 / period
        self._inverse_period = np.full(shape, self.inverse_period)  # at the gains' shape: no broadcast
        self.previous_desired: np.ndarray | None = None

    def gravity(self, q: np.ndarray) -> np.ndarray:
        """Ĝ(q) (N·m), a new array; ``q`` (N_J,), or (R, N_J) for R models."""
        if not self._batched:
            return pin.computeGeneralizedGravity(self.model, self.data, q).copy()
        gravity = np.empty_like(q)
        for r, (model, data) in enumerate(self._models):
            gravity[r] = pin.computeGeneralizedGravity(model, data, q[r])
        return gravity

    def reset(self, q_desired: np.ndarray) -> None:
        """Start with the reference at rest at ``q_desired``."""
        self.previous_desired = np.array(q_desired, dtype=float)

    def torque(self, q_desired: np.ndarray, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """Commanded joint torques (N·m); ``q_desired`` is kept (the caller must not change it)."""
        if self.previous_desired is None:
            self.reset(q_desired)
        dq_desired = (q_desired - self.previous_desired) * self._inverse_period
        self.previous_desired = q_desired
        if self._batched:
            gravity = self._gravity
            for r, (model, data) in enumerate(self._models):
                gravity[r] = pin.computeGeneralizedGravity(model, data, q[r])
        else:  # Pinocchio's own Ĝ array, summed before the next call overwrites it
            gravity = pin.computeGeneralizedGravity(self.model, self.data, q)
        return self.kp * (q_desired - q) + self.kd * (dq_desired - dq) + gravity
