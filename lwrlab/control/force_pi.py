"""Outer force loop, eq. (15): a PI on the force error moves the Cartesian position reference."""

from __future__ import annotations

import numpy as np


class ForcePI:
    """``ΔP_c = K_p^f (F_d − F) + K_i^f ∫ (F_d − F) dt`` (eq. 15), per Cartesian axis.

    Parameters
    ----------
    desired_force : (3,) F_d (N), base axes: the force the tool should exert on the environment.
    kp : (3,) proportional gains (m/N); 0 on an axis leaves it position-controlled.
    ki : (3,) integral gains (m/(N·s)).
    period : sampling period (s).
    max_displacement : bound on |ΔP_c| per axis (m); the integral stops growing there (anti-windup).
    """

    def __init__(self, desired_force, kp, ki, period: float, max_displacement: float = 0.05) -> None:
        self.desired_force = np.asarray(desired_force, dtype=float).reshape(3)
        self.kp = np.broadcast_to(np.asarray(kp, dtype=float), (3,)).copy()
        self.ki = np.broadcast_to(np.asarray(ki, dtype=float), (3,)).copy()
        if np.any(self.kp < 0) or np.any(self.ki < 0):
            raise ValueError(f"force gains must be non-negative, got kp={self.kp}, ki={self.ki}")
        self.period = period
        self.max_displacement = max_displacement
        self.integral = np.zeros(3)

    def reset(self) -> None:
        """Forget the integral."""
        self.integral = np.zeros(3)

    def update(self, force: np.ndarray) -> np.ndarray:
        """ΔP_c (m) for the fed-back force ``force`` (N, base axes)."""
        error = self.desired_force - np.asarray(force, dtype=float)[:3]
        candidate = self.integral + self.ki * error * self.period
        # anti-windup: integrate only while the integral term stays within the bound
        self.integral = np.clip(candidate, -self.max_displacement, self.max_displacement)
        return np.clip(self.kp * error + self.integral, -self.max_displacement, self.max_displacement)
