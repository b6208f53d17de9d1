"""Causal filters and differences for a controller running sample by sample (no look-ahead)."""

from __future__ import annotations

import numpy as np


class FirstOrderLowPass:
    """``y_k = y_{k−1} + a·(x_k − y_{k−1})`` with ``a = 1 − exp(−2π·f_c·Δt)``: a causal RC filter.

    Parameters
    ----------
    cutoff_hz : −3 dB frequency f_c (Hz); ``inf`` passes the signal through.
    period : sampling period Δt (s).
    """

    def __init__(self, cutoff_hz: float, period: float) -> None:
        if cutoff_hz <= 0 or period <= 0:
            raise ValueError(f"cutoff ({cutoff_hz} Hz) and period ({period} s) must be positive")
        self.gain = 1.0 if np.isinf(cutoff_hz) else float(1.0 - np.exp(-2 * np.pi * cutoff_hz * period))
        self.state: np.ndarray | None = None

    def reset(self, value: np.ndarray) -> None:
        """Start from ``value`` (a filter at rest)."""
        self.state = np.array(value, dtype=float)

    def __call__(self, value: np.ndarray) -> np.ndarray:
        if self.state is None:
            self.reset(value)
        else:
            self.state = self.state + self.gain * (np.asarray(value, dtype=float) - self.state)
        return self.state.copy()


class BackwardDifference:
    """First-order backward difference ``(x_k − x_{k−1})/Δt`` then a low-pass (eq. (13): q̇ from q)."""

    def __init__(self, period: float, cutoff_hz: float = np.inf) -> None:
        self.period = period
        self.low_pass = FirstOrderLowPass(cutoff_hz, period)
        self.previous: np.ndarray | None = None

    def reset(self, value: np.ndarray, rate: np.ndarray | None = None) -> None:
        """Start at ``value`` with derivative ``rate`` (default zero)."""
        self.previous = np.array(value, dtype=float)
        self.low_pass.reset(np.zeros_like(self.previous) if rate is None else rate)

    def __call__(self, value: np.ndarray) -> np.ndarray:
        value = np.asarray(value, dtype=float)
        if self.previous is None:
            self.reset(value)
        rate = (value - self.previous) / self.period
        self.previous = value.copy()
        return self.low_pass(rate)
