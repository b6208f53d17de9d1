"""Joint PD + gravity compensation tracking a Cartesian reference moved by an offset (eq. 13, 15).

Both painting controllers of the paper are this law: the tool-centre-point reference of the path,
moved by ``ΔP = offset + PI(F_d − F)`` — the force PI of eq. (15) on the estimated (eq. 14) or the
sensed force, or no force loop and a constant offset (pure position control) — tracked through the
IK by the joint PD with gravity compensation of eq. (13).

:class:`OffsetTrackingBatch` runs R such controllers in lockstep (the runs of a painting task that
share a path), on stacked (R, ·) arrays: one force-loop update, one stacked IK lookup
(:class:`~lwrlab.kinematics.displaced_path.DisplacedPathBatch`) and one PD update for all of them,
with one Pinocchio gravity call per run. A controller plugin whose law this is derives from
:class:`OffsetTrackingController`; run alone it is a batch of one.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from lwrlab.control.filters import low_pass_gain
from lwrlab.control.force_estimation import StateEstimate
from lwrlab.control.force_pi import ForcePI
from lwrlab.control.joint_pd import ControlOutput, ControlSetup, JointPDGravity
from lwrlab.kinematics.displaced_path import DisplacedPathBatch

FEEDBACKS = ("estimate", "sensor", "none")
"""Force a law feeds back: eq. (14)'s estimate, the wall's sensor, or none (no force loop)."""


@dataclass(frozen=True, kw_only=True)
class OffsetTrackingLaw:
    """The settings of one controller: ``ΔP = offset + PI(F_d − F)`` tracked by joint PD + gravity.

    Every field is given by the controller plugin building the law from its YAML (conf/controller/);
    a law without a force loop takes the constants of :meth:`without_force_loop`.
    """

    kp: ArrayLike
    """Joint proportional gains (N·m/rad), one per joint or one for all."""
    kd: ArrayLike
    """Joint derivative gains (N·m·s/rad)."""
    offset: ArrayLike
    """(3,) constant shift of the reference, base axes (m)."""
    feedback: str
    """``estimate`` (eq. 14), ``sensor`` (the wall's sensor, low-passed) or ``none`` (no force loop)."""
    desired_force: ArrayLike
    """(3,) F_d (N), force on the environment, base axes."""
    force_kp: ArrayLike
    """(3,) proportional force gains (m/N)."""
    force_ki: ArrayLike
    """(3,) integral force gains (m/(N·s))."""
    max_displacement: float
    """Bound on each component of the force loop's ΔP (m)."""
    sensor_cutoff_hz: float
    """Low-pass on the sensed force before feedback (Hz)."""

    def __post_init__(self) -> None:
        if self.feedback not in FEEDBACKS:
            raise ValueError(f"unknown force feedback {self.feedback!r}; valid: {list(FEEDBACKS)}")

    @classmethod
    def without_force_loop(cls, *, kp: ArrayLike, kd: ArrayLike, offset: ArrayLike) -> OffsetTrackingLaw:
        """Pure position control: the reference shifted by ``offset``, no force loop.

        The force-loop fields are constants of such a law, not settings: nothing fed back, no target,
        zero gains and bound (the loop stays at rest), no sensor filter.
        """
        return cls(
            kp=kp,
            kd=kd,
            offset=offset,
            feedback="none",
            desired_force=(0.0, 0.0, 0.0),
            force_kp=(0.0, 0.0, 0.0),
            force_ki=(0.0, 0.0, 0.0),
            max_displacement=0.0,
            sensor_cutoff_hz=np.inf,
        )


class OffsetTrackingBatch:
    """R controllers of :class:`OffsetTrackingLaw` stepped together on (R, ·) arrays."""

    def __init__(self, laws: Sequence[OffsetTrackingLaw]) -> None:
        if not laws:
            raise ValueError("a controller batch needs at least one law")
        self.laws = list(laws)
        offset = np.array([np.asarray(law.offset, dtype=float).reshape(3) for law in laws])
        self._offset = offset if offset.any() else None
        self._desired = np.array([np.asarray(law.desired_force, dtype=float).reshape(3) for law in laws])
        # per-run constants at the full (R, 3) shape: a broadcast costs more than the operation itself
        feedbacks = np.array([[law.feedback] * 3 for law in laws])
        self._sensed = feedbacks == "sensor" if (feedbacks == "sensor").any() else None
        self._unforced = feedbacks == "none" if (feedbacks == "none").any() else None

    def reset(self, setups: Sequence[ControlSetup], q0: np.ndarray, reference: np.ndarray) -> None:
        """Prepare R runs (one setup each) starting at rest at ``q0`` (R, N_J) along the tool poses
        ``reference`` (N, 4, 4), which they share."""
        laws, period = self.laws, setups[0].period
        if any(setup.period != period for setup in setups) or len(setups) != len(laws):
            raise ValueError(f"{len(laws)} controllers need as many setups with one period")
        self._positions = np.repeat(reference[:, None, :3, 3], len(laws), axis=1)  # (N, R, 3)
        self.path_ik = DisplacedPathBatch([setup.path_ik(reference) for setup in setups])
        n_joints = setups[0].robot.n_joints
        self.joint = JointPDGravity(
            [setup.robot for setup in setups],
            [np.broadcast_to(np.asarray(law.kp, dtype=float), (n_joints,)) for law in laws],
            [np.broadcast_to(np.asarray(law.kd, dtype=float), (n_joints,)) for law in laws],
            period,
        )
        self.joint.reset(q0)
        self.force_loop = ForcePI(
            self._desired,
            [law.force_kp for law in laws],
            [law.force_ki for law in laws],
            period,
            [[law.max_displacement] * 3 for law in laws],
        )
        self._sensor_gain = np.array(
            [
                [low_pass_gain(law.sensor_cutoff_hz, period) if law.feedback == "sensor" else 1.0] * 3
                for law in laws
            ]
        )
        self._sensor_state = np.zeros((len(laws), 3))

    def command(self, k: int, state: StateEstimate, measured_force: np.ndarray) -> ControlOutput:
        """Torques of every run for period ``k`` from its estimated state (R, ·) and sensed force (R, 3) N."""
        force = state.wrench  # the force loop reads its first 3 columns
        if self._sensed is not None:
            self._sensor_state = self._sensor_state + self._sensor_gain * (
                measured_force - self._sensor_state
            )
            force = np.where(self._sensed, self._sensor_state, force[:, :3])
        if self._unforced is not None:  # no error, no displacement: the PI stays at rest
            force = np.where(self._unforced, self._desired, force[:, :3])
        displacement = self.force_loop.update(force)  # eq. (15)
        if self._offset is not None:
            displacement = displacement + self._offset
        q_desired = self.path_ik(k, displacement)
        return ControlOutput(
            self.joint.torque(q_desired, state.q, state.dq), self._positions[k] + displacement, q_desired
        )


class OffsetTrackingController:
    """Base of a controller plugin whose law is an :class:`OffsetTrackingLaw` (``law()``).

    The contact loop steps all such controllers of a batch of runs together; ``reset``/``command``
    run one alone (the :class:`~lwrlab.control.contact_loop.PaintingController` protocol).
    """

    def law(self) -> OffsetTrackingLaw:
        """The controller's settings as the law it runs."""
        raise NotImplementedError

    def reset(self, setup: ControlSetup, q0: np.ndarray, reference: np.ndarray) -> None:
        self._single = OffsetTrackingBatch([self.law()])
        self._single.reset([setup], np.asarray(q0, dtype=float)[None], reference)

    def command(self, k: int, state: StateEstimate, measured_force: np.ndarray) -> ControlOutput:
        stacked = StateEstimate(*(np.asarray(value)[None] for value in state))
        output = self._single.command(k, stacked, np.asarray(measured_force, dtype=float)[None])
        return ControlOutput(*(value[0] for value in output))
