"""Pure position control (config group ``controller``, option ``position``): eq. (13) alone.

The tool-centre-point reference is the painting path shifted by a constant ``offset`` (e.g. a few
millimetres into the wall); the contact force is whatever the joint stiffness and the model's
gravity error make of it — the baseline the force loop improves on.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lwrlab.control.contact_loop import ControlOutput
from lwrlab.control.force_estimation import StateEstimate
from lwrlab.control.joint_pd import ControlSetup, JointPDGravity


class PositionControl:
    """Joint PD + gravity compensation tracking the IK of the (offset) painting path.

    Every setting is required: conf/controller/position.yaml (or the painting task's
    ``comparison_controller``) gives their values.

    Parameters
    ----------
    kp, kd : joint gains (N·m/rad, N·m·s/rad), one per joint or one for all.
    offset : (3,) constant shift of the reference, base axes (m).
    """

    name = "position"
    uses_force_feedback = False
    """No force loop: the contact force is left to the joint stiffness."""
    desired_force: np.ndarray | None = None
    """No force target."""

    def __init__(
        self,
        *,
        kp: Sequence[float] | float,
        kd: Sequence[float] | float,
        offset: Sequence[float],
    ) -> None:
        self.kp, self.kd = kp, kd
        self.offset = np.asarray(offset, dtype=float).reshape(3)

    def reset(self, setup: ControlSetup, q0: np.ndarray, reference: np.ndarray) -> None:
        self.positions = reference[:, :3, 3] + self.offset
        self.path_ik = setup.path_ik(reference)
        self.joint = JointPDGravity(setup.robot, self.kp, self.kd, setup.period)
        self.joint.reset(q0)

    def command(self, k: int, state: StateEstimate, measured_force: np.ndarray) -> ControlOutput:
        q_desired = self.path_ik(k, self.offset)
        return ControlOutput(self.joint.torque(q_desired, state.q, state.dq), self.positions[k], q_desired)
