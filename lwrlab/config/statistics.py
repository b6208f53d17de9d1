"""Schema of the ``statistics`` group (``conf/statistics/``; :mod:`lwrlab.identification.bootstrap`)."""

from __future__ import annotations

from typing import Any

from lwrlab.config.schema import schema


@schema
class StatisticsSettings:
    """Parameter uncertainty: the estimator's covariance, plus block-bootstrap intervals when resampled."""

    resamples: int
    """Bootstrap fits (0: the covariance σ only)."""
    block_s: float
    """s per block of consecutive samples (longer than the correlation time of the torque errors)."""
    confidence: float
    """Level of the percentile intervals, in (0, 1)."""
    seed: int
    """Seed of the resampling."""
    friction_drift: Any
    """ρ: share of the friction torque by which the prediction intervals allow friction to differ on
    another motion (0: intervals from the fit's held-out error alone), or ``auto``: measured between
    the identification logs, :attr:`friction_drift_prior` for one log (a union OmegaConf cannot type)."""
    friction_drift_prior: float
    """ρ of ``auto`` when there is one identification log."""
