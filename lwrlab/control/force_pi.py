"""Outer force loop, eq. (15): a PI on the force error moves the Cartesian position reference."""

from __future__ import annotations

import numpy as np


class ForcePI:
    """``ΔP_c = K_p^f (F_d − F) + K_i^f ∫ (F_d − F) dt`` (eq. 15), per Cartesian axis.

    Parameters
    ----------
    desired_force : (3,) F_d (N), base axes: the force the tool should exert on the environment;
        (R, 3) runs R loops in lockstep, every other setting then one per loop or one for all.
    kp : (3,) proportional gains (m/N); 0 on an axis leaves it position-controlled.
    ki : (3,) integral gains (m/(N·s)).
    period : sampling period (s).
    max_displacement : bound on |ΔP_c| per axis (m), scalar or (R, 1); the integral stops growing
        there (anti-windup).
    """

    def __init__(self, desired_force, kp, ki, period: float, max_displacement) -> None:
        self.desired_force = np.array(desired_force, dtype=float)
        if self.desired_force.shape[-1:] != (3,) or self.desired_force.ndim > 2:
            raise ValueError(f"desired force of shape (3,) or (R, 3), got {self.desired_force.shape}")
        shape = self.desired_force.shape
        self.kp = np.broadcast_to(np.asarray(kp, dtype=float), shape).copy()
        self.ki = np.broadcast_to(np.asarray(ki, dtype=float), shape).copy()
        if np.any(self.kp < 0) or np.any(self.ki < 0):
            raise ValueError(f"force gains must be non-negative, got kp={self.kp}, ki={self.ki}")
        self.period = period
        self.max_displacement = max_displacement
        self.integral = np.zeros(shape)
        self._integral_gain = self.ki * period
        self._proportional = bool(self.kp.any())
        bound = np.broadcast_to(np.asarray(max_displacement, dtype=float), shape)
        self._bounds = (-bound, bound.copy())

    def reset(self) -> None:
        """Forget the integral."""
        self.integral = np.zeros(self.desired_force.shape)

    def update(self, force: np.ndarray) -> np.ndarray:
        """ΔP_c (m) for the fed-back force ``force`` (N, base axes; first 3 columns; (R, ·) for R loops)."""
        error = self.desired_force - force[..., :3]
        low, high = self._bounds
        # anti-windup: integrate only while the integral term stays within the bound
        # (np.minimum/np.maximum: a fraction of np.clip's call overhead at 1 kHz)
        self.integral = np.minimum(np.maximum(self.integral + self._integral_gain * error, low), high)
        if not self._proportional:  # integral alone (the default): already within the bound
            return self.integral
        return np.minimum(np.maximum(self.kp * error + self.integral, low), high)
