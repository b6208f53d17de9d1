"""Ordinary least squares (config group ``estimator``): eq. (6) of the paper with P = I."""

from __future__ import annotations

from typing import Self

import numpy as np

from lwrlab.identification.context import IdentificationContext
from lwrlab.identification.core import LearnedAttributes
from lwrlab.identification.hyperparameters import HyperParameters
from lwrlab.identification.least_squares import (
    least_squares_from_statistics,
    set_learned_attributes_from_statistics,
)
from lwrlab.identification.row_statistics import RowStatistics
from lwrlab.numerics.threads import dense_algebra


class OrdinaryLeastSquares(HyperParameters, LearnedAttributes):
    """Base parameters minimising ‖τ − W·φ‖², with their covariance σ²·(WᵀW)⁻¹ and %σ.

    Every setting is required: conf/estimator/ols.yaml gives their values.

    Parameters
    ----------
    rcond : cut-off of small singular values of ``W`` (``numpy.linalg.lstsq``; None: its default,
        machine precision × the largest dimension).

    Examples
    --------
    >>> W = np.random.default_rng(0).normal(size=(100, 3))
    >>> est = OrdinaryLeastSquares(rcond=None).fit(W, W @ np.array([1.0, -2.0, 0.5]))
    >>> np.allclose(est.phi_, [1.0, -2.0, 0.5])
    True
    """

    def __init__(self, *, rcond: float | None) -> None:
        self.rcond = rcond

    @dense_algebra()
    def fit(self, W: np.ndarray, tau: np.ndarray, *, context: IdentificationContext | None = None) -> Self:
        """Fit to regressor rows ``W`` and torques ``tau``.

        ``context`` is not needed (accepted for the protocol).
        """
        return self.fit_statistics(RowStatistics.from_rows(W, tau), context=context)

    @dense_algebra()
    def fit_statistics(
        self, statistics: RowStatistics, *, context: IdentificationContext | None = None
    ) -> Self:
        """Fit to rows given by their R factors (:class:`RowStatistics`, accumulated block by block)."""
        phi, covariance = least_squares_from_statistics(statistics, rcond=self.rcond)
        set_learned_attributes_from_statistics(self, phi, covariance, statistics)
        return self

    def predict(self, W: np.ndarray) -> np.ndarray:
        return W @ self.phi_
