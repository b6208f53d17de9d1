"""Logged velocities: trust them only where the positions agree.

A robot's log often holds velocities beside the positions. They may be better than the derivative
of the positions (a motor encoder with a finer resolution, a velocity observer) or worse (a
recorder's causal filter delays them, another sensor's scale). The data can tell: the logged
velocity, low-passed like the positions, is compared with the derivative of the filtered positions
in the same band — their delay (by a local linearisation, sub-sample), their gain per joint, and what
disagrees after aligning both (the mismatch, relative to the velocity's RMS). A velocity is used,
shifted by its delay, only when the gains are within ``MAX_GAIN_ERROR`` and the aligned mismatch is
below ``MAX_MISMATCH``: it then carries the same motion as the positions. Otherwise the
derivative of the positions is used, and the reason is reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_GAIN_ERROR = 0.02
"""Largest relative gain error of a logged velocity against the derivative of the positions."""
MAX_MISMATCH = 0.005
"""Largest aligned mismatch ‖q̇_diff − q̇_log‖/‖q̇_diff‖ within the filter band."""
MAX_DELAY_SAMPLES = 20.0
"""Largest delay (working samples) a logged velocity may be shifted by."""


@dataclass(frozen=True)
class VelocityChoice:
    """Where the velocities of a processed measurement come from, and why."""

    logged: bool
    """True: the logged velocities (shifted by ``delay_samples``); False: the derivative of q."""
    reason: str
    """Why (one phrase)."""
    delay_samples: float = 0.0
    """Delay of the logged velocity behind the derivative of q (working samples; > 0: it lags)."""
    gain: np.ndarray | None = None
    """(N_J,) least-squares gain from the logged velocity to the derivative of q."""
    mismatch: float | None = None
    """‖q̇_diff − q̇_log,aligned‖/‖q̇_diff‖ after alignment."""

    @classmethod
    def differentiated(cls, reason: str) -> VelocityChoice:
        """The derivative of the filtered positions, for ``reason``."""
        return cls(logged=False, reason=reason)

    def apply(self, logged: np.ndarray) -> np.ndarray:
        """The logged velocity aligned with the positions (shifted earlier by its delay)."""
        return _shift(logged, self.delay_samples)

    def describe(self) -> str:
        """One phrase: the source, and the check's figures when there was one."""
        source = "logged" if self.logged else "derivative of q"
        if self.mismatch is None:
            return f"{source} ({self.reason})"
        gains = f"gain {np.min(self.gain):.4f}…{np.max(self.gain):.4f}" if self.gain is not None else ""
        return (
            f"{source} ({self.reason}; logged vs derivative: delay {self.delay_samples:.2f} samples, "
            f"{gains}, mismatch {100 * self.mismatch:.2f} %)"
        )


def _shift(x: np.ndarray, delay: float) -> np.ndarray:
    """``x`` advanced by ``delay`` samples (linear interpolation, ends held)."""
    if delay == 0.0:
        return x
    samples = np.arange(x.shape[0], dtype=float)
    return np.column_stack([np.interp(samples + delay, samples, x[:, j]) for j in range(x.shape[1])])


def estimate_delay(reference: np.ndarray, delayed: np.ndarray, iterations: int = 8) -> float:
    """Delay (samples) of ``delayed`` behind ``reference``.

    Gauss–Newton on ``delayed(k + d) ≈ reference(k)``.
    """
    delay = 0.0
    interior = slice(min(25, reference.shape[0] // 10), -min(25, reference.shape[0] // 10) or None)
    for _ in range(iterations):
        shifted = _shift(delayed, delay)
        slope = np.gradient(shifted, axis=0)[interior]
        curvature = float(np.sum(slope * slope))
        if curvature == 0.0:
            return 0.0
        step = float(np.sum((reference - shifted)[interior] * slope)) / curvature
        delay = float(np.clip(delay + step, -MAX_DELAY_SAMPLES, MAX_DELAY_SAMPLES))
        if abs(step) < 1e-3:
            break
    return delay


def choose_velocity(logged: np.ndarray, differentiated: np.ndarray, forced: bool = False) -> VelocityChoice:
    """Check filtered logged velocities against the derivative of the filtered positions.

    Parameters
    ----------
    logged : (N, N_J) logged velocities (rad/s), low-passed like the positions.
    differentiated : (N, N_J) derivative of the filtered positions (rad/s), same samples.
    forced : use the logged velocities whatever the check says (``velocity=logged``); the figures
        are still reported.
    """
    delay = estimate_delay(differentiated, logged)
    aligned = _shift(logged, delay)
    interior = slice(int(abs(delay)) + 2, -(int(abs(delay)) + 2))
    a, b = differentiated[interior], aligned[interior]
    power = np.sum(b * b, axis=0)
    gain = np.where(power > 0, np.sum(a * b, axis=0) / np.where(power > 0, power, 1.0), 1.0)
    norm = float(np.linalg.norm(a))
    mismatch = float(np.linalg.norm(a - b) / norm) if norm > 0 else np.inf
    moving = np.sum(a * a, axis=0) > 1e-6 * np.max(np.sum(a * a, axis=0), initial=0.0)

    def choice(logged: bool, reason: str) -> VelocityChoice:
        return VelocityChoice(logged, reason, delay_samples=delay, gain=gain, mismatch=mismatch)

    if forced:
        return choice(True, "requested")
    if not np.isfinite(mismatch):
        return choice(False, "the positions do not move")
    if np.any(np.abs(gain[moving] - 1.0) > MAX_GAIN_ERROR):
        return choice(False, f"logged velocities are off in scale by more than {100 * MAX_GAIN_ERROR:g} %")
    if mismatch > MAX_MISMATCH:
        return choice(False, f"logged velocities disagree with the positions (> {100 * MAX_MISMATCH:g} %)")
    return choice(True, "consistent with the positions")
