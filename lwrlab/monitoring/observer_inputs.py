"""What the momentum observer reads from a log: q, q̇ and τ at one instant, through one causal filter.

A robot's loop has its velocity from its positions: backward differences (each the velocity half a
sample back) through a causal low-pass (:func:`causal_velocity`), which delays it — a 2nd-order
Butterworth at f_c by ≈ √2/(2π·f_c) at low frequencies, 7.5 ms at 30 Hz. The observer balances the
momentum's change against the torques that cause it (:mod:`lwrlab.monitoring.observer`): fed the
delayed velocity beside the present torque, it reads the delay as an external torque — ``M·q⃛``
times the delay, and the friction flipping a delay late at a reversal. That error grows with the
motion's jerk, as the cube of its speed for a motion played faster: thresholds calibrated on
slower motions do not hold it (on the zoo's simulated arms it is 90 % of the observer's error on a
faster motion, the model's own error the rest).

:func:`observer_inputs` gives the observer positions and torques through the same filter at the
same instants as the velocity (each interval's mean, then the causal low-pass,
:func:`filtered_like_velocity`): every term of the balance is delayed alike and the delay leaves it,
the way the direct residual's zero-phase filter treats both of its sides (parallel filtering). The
price is the filter's delay on the estimate: a contact is seen that much later. Causal throughout: a
real-time loop filters its samples the same way, one at a time.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.signal import butter, sosfilt, sosfilt_zi

VELOCITY_FILTER_ORDER = 2
"""Order of the causal Butterworth on the backward differences (and on what goes with them)."""


class ObserverInputs(NamedTuple):
    """A log's positions, velocities and torques as the observer reads them: one instant, one filter."""

    q: np.ndarray
    """(N, N_J) positions (rad)."""
    dq: np.ndarray
    """(N, N_J) velocities (rad/s)."""
    tau: np.ndarray
    """(N, N_J) torques (N·m)."""


def causal_lowpass(
    t: np.ndarray, x: np.ndarray, cutoff_hz: float, order: int = VELOCITY_FILTER_ORDER
) -> np.ndarray:
    """``x`` (N, N_J) through a causal Butterworth low-pass at ``cutoff_hz``, started in its steady
    state for ``x[0]`` (no start-up transient at rest)."""
    x = np.asarray(x, dtype=float)
    sos = butter(order, cutoff_hz, fs=1.0 / float(np.mean(np.diff(np.asarray(t, dtype=float)))), output="sos")
    initial = sosfilt_zi(sos)[:, :, None] * x[0][None, None, :]
    return sosfilt(sos, x, axis=0, zi=initial)[0]


def causal_velocity(
    t: np.ndarray, q: np.ndarray, cutoff_hz: float, order: int = VELOCITY_FILTER_ORDER
) -> np.ndarray:
    """q̇ (rad/s) as a real-time loop has it: backward differences, then a causal Butterworth low-pass.

    The filter starts in its steady state for the first difference (no start-up transient at rest).
    Its lag (≈ order/(2π·f_c) at low frequencies) is what a robot's own velocity estimate has too.
    """
    t = np.asarray(t, dtype=float)
    q = np.asarray(q, dtype=float)
    difference = np.vstack([np.zeros((1, q.shape[1])), np.diff(q, axis=0) / np.diff(t)[:, None]])
    difference[0] = difference[1] if len(difference) > 1 else 0.0
    return causal_lowpass(t, difference, cutoff_hz, order)


def filtered_like_velocity(
    t: np.ndarray, x: np.ndarray, cutoff_hz: float, order: int = VELOCITY_FILTER_ORDER
) -> np.ndarray:
    """``x`` (N, N_J) at the instants of :func:`causal_velocity`'s samples and through its filter: each
    interval's mean ``(x_{k−1} + x_k)/2`` (the backward difference's instant; the first sample as
    it is), then the same causal low-pass.

    Examples
    --------
    A ramp's positions filtered so keep the pace of its filtered velocity: their difference is the
    velocity the filter gives.

    >>> t = np.arange(2000) * 1e-3
    >>> q = np.column_stack([np.sin(3 * t)])
    >>> lagged = filtered_like_velocity(t, q, 30.0)
    >>> velocity = causal_velocity(t, q, 30.0)
    >>> bool(np.abs(np.gradient(lagged[:, 0], t) - velocity[:, 0])[100:-1].max() < 1e-3)
    True
    """
    x = np.asarray(x, dtype=float)
    means = np.vstack([x[:1], 0.5 * (x[1:] + x[:-1])])
    return causal_lowpass(t, means, cutoff_hz, order)


def observer_inputs(t: np.ndarray, q: np.ndarray, tau: np.ndarray, cutoff_hz: float) -> ObserverInputs:
    """Positions, velocities and torques (N, N_J) of a log for the observer, each through the causal
    filter at the same instants (see the module): the velocity's delay leaves the observer's balance."""
    return ObserverInputs(
        filtered_like_velocity(t, q, cutoff_hz),
        causal_velocity(t, q, cutoff_hz),
        filtered_like_velocity(t, tau, cutoff_hz),
    )


__all__ = [
    "VELOCITY_FILTER_ORDER",
    "ObserverInputs",
    "causal_lowpass",
    "causal_velocity",
    "filtered_like_velocity",
    "observer_inputs",
]
