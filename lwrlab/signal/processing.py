"""From raw samples (t, q, τ) to the states and torques that the regressor consumes.

The paper's processing (§III.E): zero-phase 5th-order Butterworth low-pass at 10 Hz on positions
and torques, velocities and accelerations by centred finite differences of the filtered positions.
Zero phase (forward-backward filtering) keeps q, q̇, q̈ and τ aligned in time; the first and last
``trim_s`` seconds, where the filter's edge transients live, are dropped; optional decimation
(after the low-pass, so no aliasing) reduces the row count of the regressor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal


@dataclass(frozen=True)
class ProcessedData:
    """Filtered states and torques on a uniform grid, ready for the regressor."""

    t: np.ndarray
    """(N,) times (s)."""
    q: np.ndarray
    """(N, N_J) filtered positions (rad)."""
    dq: np.ndarray
    """(N, N_J) velocities (rad/s)."""
    ddq: np.ndarray
    """(N, N_J) accelerations (rad/s²)."""
    tau: np.ndarray
    """(N, N_J) filtered torques (N·m)."""
    index: np.ndarray
    """(N,) indices of these samples in the raw measurement (to compare with raw torques)."""


def lowpass(x: np.ndarray, rate_hz: float, cutoff_hz: float, order: int) -> np.ndarray:
    """Zero-phase Butterworth low-pass along axis 0 (second-order sections, forward-backward)."""
    if not 0.0 < cutoff_hz < rate_hz / 2:
        raise ValueError(f"cut-off {cutoff_hz} Hz must lie in (0, {rate_hz / 2}) Hz (Nyquist)")
    sos = scipy.signal.butter(order, cutoff_hz, fs=rate_hz, output="sos")
    # Odd extension over ~3 filter time constants (scipy's default is a few samples): the edge
    # transient of a smooth signal then stays below the noise instead of bending its derivatives.
    padlen = min(x.shape[0] - 1, int(3 * rate_hz / cutoff_hz))
    return scipy.signal.sosfiltfilt(sos, x, axis=0, padtype="odd", padlen=padlen)


def central_difference(x: np.ndarray, dt: float, accuracy: int = 2) -> np.ndarray:
    """First derivative along axis 0 by centred differences.

    ``accuracy=2`` is the paper's ``(x[k+1] − x[k−1]) / 2dt``; ``accuracy=4`` uses the five-point
    stencil ``(−x[k+2] + 8x[k+1] − 8x[k−1] + x[k−2]) / 12dt``, whose error (∝ dt⁴) is negligible for
    noiseless data. Ends use second-order one-sided differences.
    """
    derivative = np.gradient(x, dt, axis=0, edge_order=2)
    if accuracy == 4 and x.shape[0] >= 5:
        derivative[2:-2] = (-x[4:] + 8 * x[3:-1] - 8 * x[1:-3] + x[:-4]) / (12 * dt)
    elif accuracy != 2:
        raise ValueError(f"difference accuracy must be 2 or 4, got {accuracy}")
    return derivative


def process(
    t: np.ndarray,
    q: np.ndarray,
    tau: np.ndarray,
    cutoff_hz: float | None = 10.0,
    order: int = 5,
    difference_accuracy: int = 2,
    trim_s: float = 0.2,
    decimation: int = 1,
    filter_torque: bool = True,
) -> ProcessedData:
    """Filter, differentiate, trim and decimate one measurement.

    Parameters
    ----------
    t, q, tau : raw times (s), positions (rad) and torques (N·m) on a uniform grid.
    cutoff_hz, order : Butterworth cut-off (Hz) and order (paper: 10 Hz, 5); ``None`` disables the
        filter (noiseless simulations).
    difference_accuracy : order of the centred differences, 2 (paper) or 4.
    trim_s : seconds dropped at each end (filter edge transients).
    decimation : keep one sample in ``decimation`` after filtering.
    filter_torque : low-pass the torques too (the paper filters all data).
    """
    dt = float(np.mean(np.diff(t)))
    rate = 1.0 / dt
    filtered = cutoff_hz is not None
    q_filtered = lowpass(q, rate, cutoff_hz, order) if filtered else q
    dq = central_difference(q_filtered, dt, difference_accuracy)
    ddq = central_difference(dq, dt, difference_accuracy)
    tau_used = lowpass(tau, rate, cutoff_hz, order) if filtered and filter_torque else tau
    trim = int(round(trim_s * rate))
    if 2 * trim >= len(t):
        raise ValueError(f"trimming {trim_s} s at each end leaves nothing of a {t[-1] - t[0]:.3f} s measurement")
    index = np.arange(trim, len(t) - trim, max(1, int(decimation)))
    return ProcessedData(t=t[index], q=q_filtered[index], dq=dq[index], ddq=ddq[index], tau=tau_used[index], index=index)
