"""Ordinary least squares (config group ``estimator``): eq. (6) of the paper with P = I."""

from __future__ import annotations

from typing import Self

import numpy as np

from lwrlab.identification.core import column_scaled_condition_number, parameter_covariance, relative_std
from lwrlab.numerics.threads import dense_algebra


class OrdinaryLeastSquares:
    """Base parameters minimising ‖τ − W·φ‖², with their covariance and %σ.

    Examples
    --------
    >>> W = np.random.default_rng(0).normal(size=(100, 3))
    >>> est = OrdinaryLeastSquares().fit(W, W @ np.array([1.0, -2.0, 0.5]))
    >>> np.allclose(est.phi_, [1.0, -2.0, 0.5])
    True
    """

    def __init__(self, rcond: float | None = None) -> None:
        self.rcond = rcond

    @dense_algebra()
    def fit(self, W: np.ndarray, tau: np.ndarray) -> Self:  # noqa: N803 - the paper's symbol
        tau = np.asarray(tau, dtype=float).ravel()
        if W.shape[0] != tau.shape[0]:
            raise ValueError(f"W has {W.shape[0]} rows but tau has {tau.shape[0]}")
        self.phi_, *_ = np.linalg.lstsq(W, tau, rcond=self.rcond)
        self.covariance_, self.residual_std_ = parameter_covariance(W, tau - W @ self.phi_)
        self.std_ = np.sqrt(np.diag(self.covariance_))
        self.relative_std_ = relative_std(self.phi_, self.std_)
        self.cond_ = column_scaled_condition_number(W)
        return self

    def predict(self, W: np.ndarray) -> np.ndarray:  # noqa: N803
        return W @ self.phi_
