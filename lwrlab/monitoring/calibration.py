"""Detection thresholds per joint from contact-free data, for a stated false-alarm rate.

A threshold must hold two things a contact-free residual does: its noise, whose rare peaks set the
false alarms, and the model's error, which follows the motion. For a rate of ``A`` false alarms per
hour over N_J joints at sampling period Δt, each joint may exceed its threshold on a share
``p = A·Δt / (3600·N_J)`` of the samples (an exceedance counted per sample: an upper bound on the
alarms, which span several samples). A calibration log holds too few samples to see so rare an
event, so the threshold is the largest of

- the Gaussian level ``z(p)·rms`` (z the two-sided normal quantile, rms about zero: bias included),
- the empirical ``1 − p`` quantile of |r| where the data hold at least :data:`MIN_TAIL_SAMPLES`
  samples beyond it, otherwise the largest |r| seen,

times ``margin`` (≥ 1), which covers motions the calibration did not contain. The calibration data
themselves then raise no alarm.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtri

MIN_TAIL_SAMPLES = 10
"""Samples beyond an empirical quantile for it to be trusted; fewer: the largest |r| is used."""


@dataclass(frozen=True)
class Calibration:
    """Thresholds per joint and what they came from."""

    thresholds: np.ndarray
    """(N_J,) |τ_ext| above which a joint is in contact (N·m)."""
    rms: np.ndarray
    """(N_J,) RMS of the contact-free residual (N·m)."""
    peak: np.ndarray
    """(N_J,) largest contact-free |residual| (N·m)."""
    exceedance_probability: float
    """p: share of samples each joint may exceed its threshold."""
    false_alarm_rate: float
    """The stated rate (alarms per hour)."""
    margin: float
    """Safety factor on the levels."""
    samples: int
    """Contact-free samples calibrated on."""
    duration_s: float
    """Contact-free time calibrated on (s)."""


def calibrate_thresholds(
    residuals: Sequence[np.ndarray],
    periods: Sequence[float],
    false_alarm_rate: float,
    margin: float = 1.0,
) -> Calibration:
    """Thresholds per joint from contact-free residuals (one (N, N_J) array per log).

    Parameters
    ----------
    residuals : external torque estimates of contact-free logs (N·m).
    periods : each log's sampling period (s).
    false_alarm_rate : the stated rate, alarms per hour (> 0).
    margin : factor ≥ 1 on the levels.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> calibration = calibrate_thresholds([rng.normal(size=(10_000, 2))], [1e-3], 1.0)
    >>> bool(np.all(calibration.thresholds > 4))
    True
    """
    if false_alarm_rate <= 0:
        raise ValueError(f"false_alarm_rate must be positive (alarms per hour), got {false_alarm_rate}")
    if margin < 1:
        raise ValueError(f"margin must be at least 1, got {margin}")
    if not residuals:
        raise ValueError("no contact-free data to calibrate on")
    stacked = np.abs(np.vstack([np.asarray(r, dtype=float) for r in residuals]))
    n_samples, n_joints = stacked.shape
    duration = float(sum(len(r) * period for r, period in zip(residuals, periods, strict=True)))
    mean_period = duration / n_samples
    probability = min(0.5, false_alarm_rate * mean_period / (3600.0 * n_joints))
    rms = np.sqrt(np.mean(stacked**2, axis=0))
    peak = stacked.max(axis=0)
    gaussian = -ndtri(probability / 2) * rms
    if probability * n_samples >= MIN_TAIL_SAMPLES:
        empirical = np.quantile(stacked, 1.0 - probability, axis=0)
    else:
        empirical = peak
    thresholds = margin * np.maximum(gaussian, empirical)
    return Calibration(
        thresholds=thresholds,
        rms=rms,
        peak=peak,
        exceedance_probability=float(probability),
        false_alarm_rate=float(false_alarm_rate),
        margin=float(margin),
        samples=int(n_samples),
        duration_s=duration,
    )
