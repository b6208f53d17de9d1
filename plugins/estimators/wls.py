"""Weighted least squares (config group ``estimator``): the paper's eq. (6) with Gautier's weighting.

Each joint's rows are weighted by ``1/σ_j²``, σ_j the standard deviation of that joint's residual
after an ordinary least-squares fit (Gautier 1997): joints with noisier torques count less, and the
%σ are then those of a best linear unbiased estimate under per-joint noise.
"""

from __future__ import annotations

from typing import Self

import numpy as np

from lwrlab.identification.context import IdentificationContext, resolve_joint_count
from lwrlab.identification.core import LearnedAttributes
from lwrlab.identification.hyperparameters import HyperParameters
from lwrlab.identification.least_squares import (
    joint_weighted_least_squares,
    set_learned_attributes_from_statistics,
)
from lwrlab.identification.rest_weights import checked_near_rest
from lwrlab.identification.row_statistics import RowStatistics
from lwrlab.numerics.threads import dense_algebra


class WeightedLeastSquares(HyperParameters, LearnedAttributes):
    """Base parameters minimising ``Σ_j ‖τ_j − W_j·φ‖² / σ_j²`` (eq. (6)), with covariance and %σ.

    Every setting is required: conf/estimator/wls.yaml gives their values.

    Parameters
    ----------
    n_joints : number of joints N_J (None: the ``context`` given to :meth:`fit`).
    min_relative_std : floor of σ_j relative to the largest one, so a noiseless joint does not get
        an infinite weight.
    reweight_steps : σ_j estimated from the OLS residual, then re-estimated from each weighted
        fit's residual this many times in all (the OLS residual of a quiet joint carries the
        parameter error caused by the noisy ones; a second pass removes most of it).
    near_rest : ``weighted``: the pipeline weights each joint's rows near rest by their own residual
        before this fit (:mod:`lwrlab.identification.rest_weights`); ``equal``: every row alike.

    Learned attributes: those of the protocol plus ``joint_std_`` (N_J,) σ_j (N·m) and ``weights_``
    (N_J,) the weights ``1/σ_j²``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> W = rng.normal(size=(400, 3))
    >>> from lwrlab.pipeline.build import build  # the shipped YAML's settings, n_joints changed
    >>> est = build("estimator", "wls", n_joints=2).fit(W, W @ np.array([1.0, 2.0, 3.0]))
    >>> np.allclose(est.phi_, [1.0, 2.0, 3.0])
    True
    """

    joint_std_: np.ndarray
    weights_: np.ndarray

    def __init__(
        self, *, n_joints: int | None, min_relative_std: float, reweight_steps: int, near_rest: str
    ) -> None:
        self.n_joints = n_joints
        self.min_relative_std = min_relative_std
        self.reweight_steps = reweight_steps
        self.near_rest = checked_near_rest(near_rest)

    @dense_algebra()
    def fit(self, W: np.ndarray, tau: np.ndarray, *, context: IdentificationContext | None = None) -> Self:
        """Fit to regressor rows ``W`` and torques ``tau``.

        ``context`` gives N_J when ``n_joints`` is None.
        """
        n_joints = resolve_joint_count(self.n_joints, context, "wls")
        return self.fit_statistics(RowStatistics.from_rows(W, tau, n_joints), context=context)

    @dense_algebra()
    def fit_statistics(
        self, statistics: RowStatistics, *, context: IdentificationContext | None = None
    ) -> Self:
        """Fit to rows given by their R factors per joint (:class:`RowStatistics`)."""
        n_joints = resolve_joint_count(self.n_joints, context, "wls")
        if statistics.n_joints != n_joints:
            raise ValueError(f"wls: statistics of {statistics.n_joints} joints, expected {n_joints}")
        phi, covariance, sigma = joint_weighted_least_squares(
            statistics, self.reweight_steps, self.min_relative_std
        )
        self.joint_std_ = sigma
        self.weights_ = 1.0 / sigma**2
        set_learned_attributes_from_statistics(self, phi, covariance, statistics)
        return self

    def predict(self, W: np.ndarray) -> np.ndarray:
        return W @ self.phi_
