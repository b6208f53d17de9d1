"""External force from joint torques and a dynamic model, eq. (14): no force sensor.

With the measured link-side torques Γ, the model's rigid-body torques Γ_dyn = M̂(q)q̈ + Ĉ(q, q̇) + Ĝ(q)
and friction Γ_f (the identified — or CAD — robot *with its tool*),

    Γ_ext = Γ − Γ_dyn − Γ_f,        F_est = (Jᵀ)⁺ Γ_ext                                  (eq. 14)

where J (6 × N_J) is the Jacobian of the tool centre point in base-frame axes. F_est = [f; m] is the
wrench the robot exerts on its environment at the tool centre point (N, N·m): with the wall at
−x, pressing on it gives f_x < 0, the paper's F_d = (−30, 0, 0) N.

q̇ and q̈ come from backward differences of the encoder positions, each low-passed (causal, a
real-time controller has no future samples); Coulomb friction uses ``tanh(q̇/ε)`` instead of
``sign(q̇)`` so that the noise of the velocity estimate around a stop does not flip ±FC.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from lwrlab.control.filters import BackwardDifference, FirstOrderLowPass
from lwrlab.model.robot import RobotModel


def add_tool_frame(robot: RobotModel, tcp_in_flange: np.ndarray, name: str = "tcp") -> tuple[pin.Model, int]:
    """A copy of the robot's Pinocchio model with an operational frame at the tool centre point.

    ``tcp_in_flange`` (4×4): pose of the tool centre point in the flange frame (m).
    """
    model = robot.model.copy()
    if not model.existFrame("flange"):
        raise ValueError(f"robot {robot.name!r} has no flange frame to place a tool centre point on")
    flange = model.frames[model.getFrameId("flange")]
    placement = flange.placement * pin.SE3(np.asarray(tcp_in_flange, dtype=float))
    frame_id = model.addFrame(pin.Frame(name, flange.parentJoint, placement, pin.FrameType.OP_FRAME))
    return model, frame_id


@dataclass(frozen=True)
class StateEstimate:
    """What the estimator derived from one sensor sample."""

    q: np.ndarray
    """(N_J,) measured positions (rad)."""
    dq: np.ndarray
    """(N_J,) filtered velocity (rad/s)."""
    ddq: np.ndarray
    """(N_J,) filtered acceleration (rad/s²)."""
    external_torque: np.ndarray
    """(N_J,) Γ_ext = Γ − Γ_dyn − Γ_f (N·m)."""
    wrench: np.ndarray
    """(6,) estimated wrench [f (N); m (N·m)] the robot exerts at the tool centre point, base axes, low-passed."""


class ExternalForceEstimator:
    """Sample-by-sample external wrench estimate of eq. (14).

    Parameters
    ----------
    robot : the model the estimate relies on (identified or CAD), *including the tool's inertia*.
    tcp_in_flange : (4, 4) tool centre point in the flange frame.
    period : sampling period (s).
    velocity_cutoff_hz : low-pass on the backward-difference velocity (Hz).
    acceleration_cutoff_hz : low-pass on the difference of the filtered velocity (Hz).
    wrench_cutoff_hz : low-pass on the estimated wrench (Hz).
    coulomb_smoothing : ε (rad/s) of ``FC·tanh(q̇/ε)``.
    """

    def __init__(
        self,
        robot: RobotModel,
        tcp_in_flange: np.ndarray,
        period: float = 1e-3,
        velocity_cutoff_hz: float = 50.0,
        acceleration_cutoff_hz: float = 10.0,
        wrench_cutoff_hz: float = 20.0,
        coulomb_smoothing: float = 0.01,
    ) -> None:
        self.robot = robot
        self.model, self.frame_id = add_tool_frame(robot, tcp_in_flange)
        self.data = self.model.createData()
        self.period = period
        self.coulomb_smoothing = coulomb_smoothing
        self.velocity = BackwardDifference(period, velocity_cutoff_hz)
        self.acceleration = BackwardDifference(period, acceleration_cutoff_hz)
        self.wrench_filter = FirstOrderLowPass(wrench_cutoff_hz, period)

    def friction_torque(self, dq: np.ndarray) -> np.ndarray:
        """Γ_f (N·m) with smoothed Coulomb friction."""
        friction, terms = self.robot.friction, self.robot.friction_terms
        tau = np.zeros_like(dq)
        if "coulomb" in terms:
            tau += friction.coulomb * np.tanh(dq / self.coulomb_smoothing)
        if "viscous" in terms:
            tau += friction.viscous * dq
        if "offset" in terms:
            tau += friction.offset
        return tau

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """(6, N_J) Jacobian of the tool centre point, base-frame axes ([linear; angular])."""
        return pin.computeFrameJacobian(self.model, self.data, q, self.frame_id, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)

    def reset(self, q: np.ndarray) -> None:
        """Start at rest at ``q`` (rad), with no force."""
        self.velocity.reset(q)
        self.acceleration.reset(np.zeros_like(q))
        self.wrench_filter.reset(np.zeros(6))

    def update(self, q: np.ndarray, tau: np.ndarray) -> StateEstimate:
        """One sample: measured positions ``q`` (rad) and link-side torques ``tau`` (N·m)."""
        dq = self.velocity(q)
        ddq = self.acceleration(dq)
        tau_dyn = pin.rnea(self.model, self.data, q, dq, ddq)
        external = tau - tau_dyn - self.friction_torque(dq)
        jacobian = self.jacobian(q)
        # eq. (14): (Jᵀ)⁺ = (J·Jᵀ)⁻¹·J for a full-rank 6 × N_J Jacobian (away from singularities)
        wrench = np.linalg.solve(jacobian @ jacobian.T, jacobian @ external)
        return StateEstimate(q=q, dq=dq, ddq=ddq, external_torque=external, wrench=self.wrench_filter(wrench))
