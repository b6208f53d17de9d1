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

from collections.abc import Sequence
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
    """(6,) estimated wrench [f (N); m (N·m)] the robot exerts at the tool centre point, base axes,
    low-passed."""


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

    The filters and ε are the painting task's ``estimator`` settings (conf/task/painting.yaml), the
    one place of their values.

    The estimator holds the model and the settings; the per-sample work is that of
    :class:`ForceEstimatorBatch`, which runs several estimators in lockstep (alone: a batch of one).
    """

    def __init__(
        self,
        robot: RobotModel,
        tcp_in_flange: np.ndarray,
        period: float,
        *,
        velocity_cutoff_hz: float,
        acceleration_cutoff_hz: float,
        wrench_cutoff_hz: float,
        coulomb_smoothing: float,
    ) -> None:
        self.robot = robot
        self.model, self.frame_id = add_tool_frame(robot, tcp_in_flange)
        self.data = self.model.createData()
        self.period = period
        self.cutoffs_hz = (float(velocity_cutoff_hz), float(acceleration_cutoff_hz), float(wrench_cutoff_hz))
        """Low-passes of the velocity, the acceleration and the wrench (Hz)."""
        self.coulomb_smoothing = coulomb_smoothing
        # friction coefficients once: zero for a term the model leaves out
        friction, terms, n = robot.friction, robot.friction_terms, robot.n_joints
        self.friction_coefficients = {
            term: np.asarray(getattr(friction, term), dtype=float) if term in terms else np.zeros(n)
            for term in ("coulomb", "viscous", "offset")
        }
        """FC, FV, FO (N·m, N·m·s/rad, N·m) per joint; zero for a term the model leaves out."""
        self._single: ForceEstimatorBatch | None = None

    def friction_torque(self, dq: np.ndarray) -> np.ndarray:
        """Γ_f (N·m) with smoothed Coulomb friction."""
        c = self.friction_coefficients
        return c["coulomb"] * np.tanh(dq / self.coulomb_smoothing) + c["viscous"] * dq + c["offset"]

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """(6, N_J) Jacobian of the tool centre point, base-frame axes ([linear; angular])."""
        return pin.computeFrameJacobian(self.model, self.data, q, self.frame_id, _BASE_AXES)

    def reset(self, q: np.ndarray) -> None:
        """Start at rest at ``q`` (rad), with no force."""
        self._start(q)

    def _start(self, q: np.ndarray) -> ForceEstimatorBatch:
        self._single = ForceEstimatorBatch([self])
        self._single.reset(np.asarray(q, dtype=float)[None])
        return self._single

    def update(self, q: np.ndarray, tau: np.ndarray) -> StateEstimate:
        """One sample: measured positions ``q`` (rad) and link-side torques ``tau`` (N·m); before any
        reset, the estimator starts at rest at ``q``."""
        single = self._single if self._single is not None else self._start(q)
        state = single.update(np.asarray(q, dtype=float)[None], np.asarray(tau, dtype=float)[None])
        return StateEstimate(*(value[0] for value in state))


class ForceEstimatorBatch:
    """R estimators of eq. (14) with the same period and filters, updated in lockstep.

    Each keeps its own model (identified or CAD) for Γ_dyn and J, one Pinocchio call each per sample;
    the differences, the friction and the filters run once on the stacked (R, ·) arrays.
    """

    def __init__(self, estimators: Sequence[ExternalForceEstimator]) -> None:
        if not estimators:
            raise ValueError("an estimator batch needs at least one estimator")
        first = estimators[0]
        for estimator in estimators[1:]:
            if (estimator.period, estimator.cutoffs_hz) != (first.period, first.cutoffs_hz):
                raise ValueError(
                    "estimators updated together need one period and the same filters, got "
                    f"{(first.period, first.cutoffs_hz)} and {(estimator.period, estimator.cutoffs_hz)}"
                )
        velocity_hz, acceleration_hz, wrench_hz = first.cutoffs_hz
        self.differences = FilteredDifferences(first.period, velocity_hz, acceleration_hz)
        self.wrench_filter = FirstOrderLowPass(wrench_hz, first.period)
        self._coulomb, self._viscous, self._offset = (
            np.stack([estimator.friction_coefficients[term] for estimator in estimators])
            for term in ("coulomb", "viscous", "offset")
        )
        n_joints = first.robot.n_joints  # per-run constants at the full shape: a broadcast costs more
        self._smoothing = np.array([[estimator.coulomb_smoothing] * n_joints for estimator in estimators])
        self._models = [(estimator.model, estimator.data, estimator.frame_id) for estimator in estimators]
        self._dynamics, self._raw_wrench = (
            np.zeros((len(estimators), n_joints)),
            np.zeros((len(estimators), 6)),
        )

    def reset(self, q: np.ndarray) -> None:
        """Start at rest at ``q`` (R, N_J) rad, with no force."""
        self.differences.reset(q)
        self.wrench_filter.reset(np.zeros((q.shape[0], 6)))

    def update(self, q: np.ndarray, tau: np.ndarray) -> StateEstimate:
        """One sample of every run: measured positions ``q`` (R, N_J) rad and link-side torques ``tau`` (N·m).

        The fields of the returned estimate are (R, ·) arrays, new each call.
        """
        dq, ddq = self.differences(q)
        dynamics, wrench = self._dynamics, self._raw_wrench  # scratch: fully rewritten each sample
        for r, (model, data, _) in enumerate(self._models):
            dynamics[r] = pin.rnea(model, data, q[r], dq[r], ddq[r])
        friction = self._coulomb * np.tanh(dq / self._smoothing) + self._viscous * dq + self._offset
        external = tau - dynamics - friction
        for r, (model, data, frame_id) in enumerate(self._models):
            jacobian = pin.computeFrameJacobian(model, data, q[r], frame_id, _BASE_AXES)
            # eq. (14): (Jᵀ)⁺·Γ_ext = (J·Jᵀ)⁻¹·J·Γ_ext, the least-squares solution of Jᵀ·w = Γ_ext; one
            # LAPACK QR solve (dgels) on Jᵀ, full rank away from singularities; lstsq (SVD) where it is not
            # (the Jacobian is this call's own array: LAPACK may factor it in place, no copy)
            _, solution, info = dgels(jacobian.T, external[r], overwrite_a=1)
            if info == 0:
                wrench[r] = solution[:6]
            else:
                jacobian = pin.computeFrameJacobian(model, data, q[r], frame_id, _BASE_AXES)
                wrench[r] = np.linalg.lstsq(jacobian.T, external[r], rcond=None)[0]
        return StateEstimate(q, dq, ddq, external, self.wrench_filter(wrench))
