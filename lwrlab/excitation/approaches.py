"""Closest approaches of a motion: where a body comes nearest to another body or to the world.

A value object shared by the exact collision check (:mod:`lwrlab.excitation.collision_check`), the
reports and the preview figure (:mod:`lwrlab.figures.motion_preview`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np


@dataclass(frozen=True)
class ClosestApproach:
    """The smallest distance between two bodies (or a body and the world) over a motion."""

    kind: Literal["self", "world"]
    """``self``: two bodies of the robot; ``world``: a body of the robot and a world object."""
    body_a: str
    """The robot's body (its URDF link, or a collision sphere's name)."""
    body_b: str
    """The other body, or the world object (``mounting surface``, ``table``, …)."""
    distance: float
    """Smallest distance (m) over the motion; negative: penetration depth."""
    t: float
    """Time (s) of the smallest distance."""
    point_a: np.ndarray
    """(3,) closest point on ``body_a`` at ``t``, base frame (m)."""
    point_b: np.ndarray
    """(3,) closest point on ``body_b`` at ``t``, base frame (m)."""
    clearance: float = 0.0
    """Distance (m) the motion must keep; ``distance < clearance`` is a violation."""

    @property
    def violated(self) -> bool:
        return self.distance < self.clearance

    @property
    def label(self) -> str:
        """e.g. ``link2–link5 12.0 mm at t = 3.41 s``."""
        return f"{self.body_a}–{self.body_b} {1000 * self.distance:.1f} mm at t = {self.t:.2f} s"
