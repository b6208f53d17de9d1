"""Pure position control (config group ``controller``, option ``position``): eq. (13) alone.

The tool-centre-point reference is the painting path shifted by a constant ``offset`` (e.g. a few
millimetres into the wall); the contact force is whatever the joint stiffness and the model's
gravity error make of it — the baseline the force loop improves on.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lwrlab.control.cartesian_offset import OffsetTrackingController, OffsetTrackingLaw


class PositionControl(OffsetTrackingController):
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

    def law(self) -> OffsetTrackingLaw:
        """Eq. (13) tracking the shifted path, no force loop."""
        return OffsetTrackingLaw.without_force_loop(kp=self.kp, kd=self.kd, offset=self.offset)
