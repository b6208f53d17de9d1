"""Filters and differences along time, and the automatic cut-off they run at.

A zero-phase Butterworth low-pass (:func:`lowpass`, or only a span of it: :func:`lowpass_span`,
which filters a window reaching :func:`lwrlab.signal.zero_phase.settling_samples` beyond the span),
centred differences (:func:`central_difference`), and the cut-off chosen from the motion
(:func:`motion_frequency`, :func:`auto_cutoff`). Used by :mod:`lwrlab.signal.processing`.
"""

from __future__ import annotations

import numpy as np

from lwrlab.signal.zero_phase import butterworth_sos, settling_samples, sosfiltfilt_window

CUTOFF_PER_MOTION_FREQUENCY = 15.0
"""Auto cut-off = this × the motion's frequency (Gautier: a filter at least ten times faster than the
dynamics; 15 chosen by the processing study, benchmarks/processing_study.py)."""
MIN_AUTO_CUTOFF_HZ = 0.5
"""Lowest automatic cut-off (Hz)."""


def _window(n: int, start: int, stop: int, overlap: int, padlen: int) -> tuple[int, int, int, int]:
    """``(lo, hi, pad_before, pad_after)``: the window of a signal of ``n`` samples that filters
    ``[start, stop)`` like the whole signal (``overlap`` samples beyond it, the odd extension of
    ``padlen`` samples only at the signal's own ends, which the window then must exceed)."""
    lo, hi = max(0, start - overlap), min(n, stop + overlap)
    if lo == 0:
        hi = max(hi, min(n, padlen + 1))
    if hi == n:
        lo = min(lo, max(0, n - padlen - 1))
    return lo, hi, padlen if lo == 0 else 0, padlen if hi == n else 0


def _padlen(n: int, rate_hz: float, cutoff_hz: float) -> int:
    # Odd extension over ~3 filter time constants (scipy's default is a few samples): the edge
    # transient of a smooth signal then stays below the noise instead of bending its derivatives.
    return min(n - 1, int(3 * rate_hz / cutoff_hz))


def lowpass_span(
    x: np.ndarray, start: int, stop: int, rate_hz: float, cutoff_hz: float, order: int
) -> np.ndarray:
    """Samples ``[start, stop)`` of :func:`lowpass` ``(x, ...)``, filtering only a window around them."""
    sos = butterworth_sos(order, cutoff_hz, rate_hz)  # checks the cut-off against Nyquist
    lo, hi, before, after = _window(
        x.shape[0], start, stop, settling_samples(sos), _padlen(x.shape[0], rate_hz, cutoff_hz)
    )
    return sosfiltfilt_window(sos, x[lo:hi], before, after)[start - lo : stop - lo]


def lowpass(x: np.ndarray, rate_hz: float, cutoff_hz: float, order: int) -> np.ndarray:
    """Zero-phase Butterworth low-pass along axis 0 (second-order sections, forward-backward)."""
    sos = butterworth_sos(order, cutoff_hz, rate_hz)  # checks the cut-off against Nyquist
    padlen = _padlen(x.shape[0], rate_hz, cutoff_hz)
    return sosfiltfilt_window(sos, x, padlen, padlen)


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


def motion_frequency(q: np.ndarray, rate_hz: float, block_samples: int = 1 << 16) -> float:
    """Frequency of a motion's accelerations (Hz): ‖q̈‖/(2π‖q̇‖) over all joints (exact for a sinusoid).

    It weighs the fast parts of a motion more than the RMS frequency of the positions does, and so
    tells a slow sinusoid from an exciting motion with sharp accelerations. Derivatives of positions
    smoothed at min(20 Hz, rate/5), so encoder noise does not count as motion; the first and last
    half second (smoothing transients) are left out. Computed in blocks of ``block_samples``.
    """
    dt = 1.0 / rate_hz
    n = q.shape[0]
    edge = min(int(0.5 * rate_hz), n // 4)
    speed2 = acceleration2 = 0.0
    halo = 2  # two centred differences
    for start in range(edge, n - edge, block_samples):
        stop = min(n - edge, start + block_samples)
        lo, hi = max(0, start - halo), min(n, stop + halo)
        smooth = lowpass_span(q, lo, hi, rate_hz, min(20.0, rate_hz / 5.0), 2) if n > 12 else q[lo:hi]
        velocity = central_difference(smooth, dt)
        acceleration = central_difference(velocity, dt)
        speed2 += float(np.sum(velocity[start - lo : stop - lo] ** 2))
        acceleration2 += float(np.sum(acceleration[start - lo : stop - lo] ** 2))
    if speed2 == 0.0:
        return 0.0
    return float(np.sqrt(acceleration2) / (2.0 * np.pi * np.sqrt(speed2)))


def auto_cutoff(q: np.ndarray, rate_hz: float) -> float:
    """The automatic cut-off (Hz): 15 × the motion's frequency, within [0.5 Hz, rate/5]."""
    return float(
        np.clip(CUTOFF_PER_MOTION_FREQUENCY * motion_frequency(q, rate_hz), MIN_AUTO_CUTOFF_HZ, rate_hz / 5.0)
    )
