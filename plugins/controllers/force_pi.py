"""Position/force control of Fig. 8 (config group ``controller``, option ``force_pi``).

The outer PI (eq. 15) turns the force error into a displacement ΔP_c of the tool-centre-point
reference; the inner joint PD + gravity compensation (eq. 13) tracks the IK of the displaced pose.
The force fed back is the estimate of eq. (14) (``feedback: estimate``, the paper's Fig. 13a, no
force sensor needed) or the wall sensor (``feedback: sensor``, Fig. 13b).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lwrlab.control.cartesian_offset import OffsetTrackingController, OffsetTrackingLaw

FEEDBACKS = ("estimate", "sensor")


class ForcePIControl(OffsetTrackingController):
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

    def law(self) -> OffsetTrackingLaw:
        """Eq. (15) on the chosen force around eq. (13); the contact loop steps it with the other runs."""
        return OffsetTrackingLaw(
            kp=self.kp,
            kd=self.kd,
            offset=(0.0, 0.0, 0.0),  # a constant of the method: the force loop alone moves the reference
            feedback=self.feedback,
            desired_force=self.desired_force,
            force_kp=self.force_kp,
            force_ki=self.force_ki,
            max_displacement=self.max_displacement,
            sensor_cutoff_hz=self.sensor_cutoff_hz,
        )
