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

from typing import NamedTuple

import numpy as np
import pinocchio as pin
from scipy.linalg.lapack import dgels

from lwrlab.control.filters import FilteredDifferences, FirstOrderLowPass
from lwrlab.model.robot import RobotModel

_BASE_AXES = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


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


class StateEstimate(NamedTuple):
    """What the estimator derived from one sensor sample (a tuple: cheap to make at 1 kHz)."""

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
        self.differences = FilteredDifferences(period, velocity_cutoff_hz, acceleration_cutoff_hz)
        self.wrench_filter = FirstOrderLowPass(wrench_cutoff_hz, period)
        # friction coefficients once: zero for a term the model leaves out
        friction, terms, n = robot.friction, robot.friction_terms, robot.n_joints
        self._coulomb = np.asarray(friction.coulomb, dtype=float) if "coulomb" in terms else np.zeros(n)
        self._viscous = np.asarray(friction.viscous, dtype=float) if "viscous" in terms else np.zeros(n)
        self._offset = np.asarray(friction.offset, dtype=float) if "offset" in terms else np.zeros(n)

    def friction_torque(self, dq: np.ndarray) -> np.ndarray:
        """Γ_f (N·m) with smoothed Coulomb friction."""
        return self._coulomb * np.tanh(dq / self.coulomb_smoothing) + self._viscous * dq + self._offset

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """(6, N_J) Jacobian of the tool centre point, base-frame axes ([linear; angular])."""
        return pin.computeFrameJacobian(self.model, self.data, q, self.frame_id, _BASE_AXES)

    def reset(self, q: np.ndarray) -> None:
        """Start at rest at ``q`` (rad), with no force."""
        self.differences.reset(q)
        self.wrench_filter.reset(np.zeros(6))

    def update(self, q: np.ndarray, tau: np.ndarray) -> StateEstimate:
        """One sample: measured positions ``q`` (rad) and link-side torques ``tau`` (N·m)."""
        model, data = self.model, self.data
        dq, ddq = self.differences(q)
        external = tau - pin.rnea(model, data, q, dq, ddq) - self.friction_torque(dq)
        jacobian = pin.computeFrameJacobian(model, data, q, self.frame_id, _BASE_AXES)
        # eq. (14): (Jᵀ)⁺·Γ_ext = (J·Jᵀ)⁻¹·J·Γ_ext, the least-squares solution of Jᵀ·w = Γ_ext; one LAPACK
        # QR solve (dgels) on Jᵀ, full rank away from singularities; lstsq (SVD) where it is not
        _, solution, info = dgels(jacobian.T, external)
        wrench = solution[:6] if info == 0 else np.linalg.lstsq(jacobian.T, external, rcond=None)[0]
        return StateEstimate(q, dq, ddq, external, self.wrench_filter(wrench))
