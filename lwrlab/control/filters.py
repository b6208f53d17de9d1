"""Causal filters and differences for a controller running sample by sample (no look-ahead).

Each filter keeps its state and does O(1) work per sample; :meth:`FirstOrderLowPass.apply` runs the
same recursion over a whole recorded signal at once (for analysis after a run).
"""

from __future__ import annotations

import numpy as np


def low_pass_gain(cutoff_hz: float, period: float) -> float:
    """``a = 1 − exp(−2π·f_c·Δt)`` of the RC filter ``y_k = y_{k−1} + a·(x_k − y_{k−1})``; 1 for f_c = ∞."""
    if cutoff_hz <= 0 or period <= 0:
        raise ValueError(f"cutoff ({cutoff_hz} Hz) and period ({period} s) must be positive")
    return 1.0 if np.isinf(cutoff_hz) else float(1.0 - np.exp(-2 * np.pi * cutoff_hz * period))


class FirstOrderLowPass:
    """``y_k = y_{k−1} + a·(x_k − y_{k−1})`` with ``a = 1 − exp(−2π·f_c·Δt)``: a causal RC filter.

    Parameters
    ----------
    cutoff_hz : −3 dB frequency f_c (Hz); ``inf`` passes the signal through.
    period : sampling period Δt (s).
    """

    def __init__(self, cutoff_hz: float, period: float) -> None:
        self.gain = low_pass_gain(cutoff_hz, period)
        self.state: np.ndarray | None = None
        self._gains = np.asarray(self.gain)

    def reset(self, value: np.ndarray) -> None:
        """Start from ``value`` (a filter at rest)."""
        self._start(value)

    def _start(self, value: np.ndarray) -> np.ndarray:
        self.state = np.array(value, dtype=float)
        self._gains = np.full(self.state.shape, self.gain)  # the gain at the value's shape: no broadcast
        return self.state

    def __call__(self, value: np.ndarray) -> np.ndarray:
        """The filtered sample; a new array each call (the caller may keep it)."""
        state = self.state
        self.state = self._start(value) if state is None else state + self._gains * (value - state)
        return self.state

    def apply(self, signal: np.ndarray, initial: np.ndarray | float = 0.0) -> np.ndarray:
        """The recursion over a whole signal (N, ...) at once, from rest at ``initial``.

        Equals calling the filter sample by sample after ``reset(initial)``; leaves ``state`` alone.
        """
        from scipy.signal import lfilter  # scipy.signal is slow to import; only analysis needs it

        signal = np.asarray(signal, dtype=float)
        initial = np.broadcast_to(np.asarray(initial, dtype=float), signal.shape[1:])
        a = self.gain
        # y_k = (1 − a)·y_{k−1} + a·x_k, with the filter state (1 − a)·y_{−1} = (1 − a)·initial
        out, _ = lfilter([a], [1.0, a - 1.0], signal, axis=0, zi=((1.0 - a) * initial)[None])
        return out


class BackwardDifference:
    """First-order backward difference ``(x_k − x_{k−1})/Δt`` then a low-pass (eq. (13): q̇ from q).

    Parameters
    ----------
    period : sampling period Δt (s).
    cutoff_hz : the low-pass (Hz; ``inf``: none).
    """

    def __init__(self, period: float, cutoff_hz: float) -> None:
        self.period = period
        self.inverse_period = 1.0 / period
        self.low_pass = FirstOrderLowPass(cutoff_hz, period)
        self.previous: np.ndarray | None = None

    def reset(self, value: np.ndarray, rate: np.ndarray | None = None) -> None:
        """Start at ``value`` with derivative ``rate`` (default zero)."""
        self.previous = np.array(value, dtype=float)
        self.low_pass.reset(np.zeros_like(self.previous) if rate is None else rate)

    def __call__(self, value: np.ndarray) -> np.ndarray:
        if self.previous is None:
            self.reset(value)
        rate = (value - self.previous) * self.inverse_period
        self.previous = np.array(value, dtype=float)
        if self.low_pass.gain == 1.0:  # no filtering: the difference itself
            self.low_pass.state = rate
            return rate
        return self.low_pass(rate)


class FilteredDifferences:
    """Velocity and acceleration of sampled positions: low-passed backward differences, cascaded.

    ``v_k = LP_v((x_k − x_{k−1})/Δt)``, ``a_k = LP_a((v_k − v_{k−1})/Δt)`` — the two
    :class:`BackwardDifference` filters of eq. (13)–(14) in a row — written as one linear state update
    ``[x, v, a]_k = M·[x_{k−1}, v_{k−1}, a_{k−1}, x_k]``: one small matrix product per sample.

    Parameters
    ----------
    period : sampling period Δt (s).
    velocity_cutoff_hz, acceleration_cutoff_hz : the two low-passes (Hz; ``inf``: none).
    """

    def __init__(self, period: float, velocity_cutoff_hz: float, acceleration_cutoff_hz: float) -> None:
        av, aa = low_pass_gain(velocity_cutoff_hz, period), low_pass_gain(acceleration_cutoff_hz, period)
        r = 1.0 / period
        # rows: new x, new v, new a; columns: old x, old v, old a, input x
        velocity = np.array([-av * r, 1.0 - av, 0.0, av * r])
        old_velocity = np.array([0.0, 1.0, 0.0, 0.0])
        acceleration = aa * r * (velocity - old_velocity) + (1.0 - aa) * np.array([0.0, 0.0, 1.0, 0.0])
        self.update_matrix = np.array([[0.0, 0.0, 0.0, 1.0], velocity, acceleration])
        self.stacked = np.zeros((4, 0))
        """(4, ...) x_{k−1}, v_{k−1}, a_{k−1} and the newest input, each of the value's shape."""
        self._columns = self.stacked
        self._state_shape: tuple[int, ...] = (3, 0)
        self._started = False

    def reset(self, value: np.ndarray, rate: np.ndarray | None = None) -> None:
        """Start at ``value`` (any shape, e.g. (N_J,) or (R, N_J)) with velocity ``rate`` (default zero)
        and zero acceleration."""
        value = np.asarray(value, dtype=float)
        self.stacked = np.zeros((4, *value.shape))
        self.stacked[0] = value
        if rate is not None:
            self.stacked[1] = rate
        self._columns = self.stacked.reshape(4, -1)  # a view: the state as one (4, n) matrix
        self._state_shape = (3, *value.shape)
        self._started = True

    def __call__(self, value: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(velocity, acceleration) after the sample ``value`` (shaped as at the reset); new arrays."""
        if not self._started:
            self.reset(value)
        stacked = self.stacked
        stacked[3] = value
        state = (self.update_matrix @ self._columns).reshape(self._state_shape)
        stacked[:3] = state
        return state[1], state[2]
