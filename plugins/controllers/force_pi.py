"""Position/force control of Fig. 8 (config group ``controller``, option ``force_pi``).

The outer PI (eq. 15) turns the force error into a displacement ΔP_c of the tool-centre-point
reference; the inner joint PD + gravity compensation (eq. 13) tracks the IK of the displaced pose.
The force fed back is the estimate of eq. (14) (``feedback: estimate``, the paper's Fig. 13a, no
force sensor needed) or the wall sensor (``feedback: sensor``, Fig. 13b).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lwrlab.control.contact_loop import ControlOutput
from lwrlab.control.filters import FirstOrderLowPass
from lwrlab.control.force_estimation import StateEstimate
from lwrlab.control.force_pi import ForcePI
from lwrlab.control.joint_pd import ControlSetup, JointPDGravity

FEEDBACKS = ("estimate", "sensor")


class ForcePIControl:
    """Force PI on the Cartesian reference around a joint PD + gravity compensation.

    Every setting is required: conf/controller/force_pi.yaml is the one place of their values.

    Parameters
    ----------
    kp, kd : joint gains (N·m/rad, N·m·s/rad).
    desired_force : (3,) F_d (N), force on the environment, base axes.
    force_kp : (3,) proportional force gains (m/N).
    force_ki : (3,) integral force gains (m/(N·s)).
    feedback : ``estimate`` (eq. 14) or ``sensor`` (the wall's force sensor).
    max_displacement : bound on each component of ΔP_c (m).
    sensor_cutoff_hz : low-pass on the wall sensor's force before feedback (Hz), the same
        bandwidth as the estimate's (a raw stiff-contact reading would make the loop chatter).
    """

    name = "force_pi"
    uses_force_feedback = True
    """A force loop closes on ``feedback``: the painting stage runs it once per force source."""

    def __init__(
        self,
        *,
        kp: Sequence[float] | float,
        kd: Sequence[float] | float,
        desired_force: Sequence[float],
        force_kp: Sequence[float],
        force_ki: Sequence[float],
        feedback: str,
        max_displacement: float,
        sensor_cutoff_hz: float,
    ) -> None:
        if feedback not in FEEDBACKS:
            raise ValueError(f"unknown force feedback {feedback!r}; valid: {list(FEEDBACKS)}")
        self.kp, self.kd = kp, kd
        self.desired_force = np.asarray(desired_force, dtype=float).reshape(3)
        self.force_kp, self.force_ki = force_kp, force_ki
        self.feedback = feedback
        self.max_displacement = max_displacement
        self.sensor_cutoff_hz = sensor_cutoff_hz

    def reset(self, setup: ControlSetup, q0: np.ndarray, reference: np.ndarray) -> None:
        self.positions = reference[:, :3, 3]
        self.path_ik = setup.path_ik(reference)
        self.joint = JointPDGravity(setup.robot, self.kp, self.kd, setup.period)
        self.joint.reset(q0)
        self.sensor_filter = FirstOrderLowPass(self.sensor_cutoff_hz, setup.period)
        self.sensor_filter.reset(np.zeros(3))
        self.force_loop = ForcePI(
            self.desired_force, self.force_kp, self.force_ki, setup.period, self.max_displacement
        )

    def command(self, k: int, state: StateEstimate, measured_force: np.ndarray) -> ControlOutput:
        if self.feedback == "estimate":
            displacement = self.force_loop.update(state.wrench[:3])  # eq. (15)
        else:
            displacement = self.force_loop.update(self.sensor_filter(measured_force))
        q_desired = self.path_ik(k, displacement)
        return ControlOutput(
            self.joint.torque(q_desired, state.q, state.dq), self.positions[k] + displacement, q_desired
        )
