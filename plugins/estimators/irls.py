"""Iteratively reweighted least squares (config group ``estimator``): robust to outliers.

An M-estimator (Huber 1964): each row's weight ``w(u) = ψ(u)/u`` falls with its standardised
residual ``u = r / (c·s_j)``, where ``s_j`` is a robust scale (1.4826 × median absolute deviation)
of joint j's residuals and c the tuning constant; the weighted least-squares problem is re-solved
until the estimate stops moving. Huber's loss down-weights large residuals, Tukey's bisquare
rejects them. Torque spikes (sensor glitches, contacts) then barely move the estimate, where they
drag ordinary least squares.
"""

from __future__ import annotations

from typing import Self

import numpy as np

from lwrlab.identification.context import IdentificationContext, resolve_joint_count, row_joints
from lwrlab.identification.core import LearnedAttributes
from lwrlab.identification.hyperparameters import HyperParameters
from lwrlab.identification.least_squares import set_learned_attributes, weighted_least_squares
from lwrlab.numerics.threads import dense_algebra

LOSSES = {"huber": 1.345, "bisquare": 4.685}
"""Supported losses and their usual tuning constants (95 % efficiency under Gaussian noise)."""


def robust_weights(u: np.ndarray, loss: str) -> np.ndarray:
    """``ψ(u)/u`` for standardised residuals ``u`` already divided by the tuning constant."""
    a = np.abs(u)
    if loss == "huber":
        return np.where(a <= 1.0, 1.0, 1.0 / np.maximum(a, 1.0))
    return np.where(a < 1.0, (1.0 - u**2) ** 2, 0.0)


class IterativelyReweightedLeastSquares(HyperParameters, LearnedAttributes):
    """Robust base-parameter estimate by IRLS with per-joint robust scale.

    Every setting is required: conf/estimator/irls.yaml gives their values.

    Parameters
    ----------
    n_joints : number of joints N_J (None: the ``context`` given to :meth:`fit`).
    loss : ``"huber"`` or ``"bisquare"``.
    tuning : tuning constant (None = the loss's usual one, :data:`LOSSES`).
    max_iter : iteration limit.
    tol : stop when the estimate moves less than ``tol`` relative to its norm.

    Learned attributes: the protocol's, plus ``weights_`` (rows,) the final row weights,
    ``n_iter_`` and ``outlier_fraction_`` (share of rows with weight < 0.5).
    """

    weights_: np.ndarray
    n_iter_: int
    outlier_fraction_: float

    def __init__(
        self,
        *,
        n_joints: int | None,
        loss: str,
        tuning: float | None,
        max_iter: int,
        tol: float,
    ) -> None:
        self.n_joints = n_joints
        self.loss = loss
        self.tuning = tuning
        self.max_iter = max_iter
        self.tol = tol

    @dense_algebra()
    def fit(self, W: np.ndarray, tau: np.ndarray, *, context: IdentificationContext | None = None) -> Self:
        """Fit to regressor rows ``W`` and torques ``tau``.

        ``context`` gives N_J when ``n_joints`` is None.
        """
        if self.loss not in LOSSES:
            raise ValueError(f"unknown loss {self.loss!r}; valid: {sorted(LOSSES)}")
        tau = np.asarray(tau, dtype=float).ravel()
        n_joints = resolve_joint_count(self.n_joints, context, "irls")
        joints = row_joints(W.shape[0], n_joints)
        c = self.tuning if self.tuning is not None else LOSSES[self.loss]
        fit = weighted_least_squares(W, tau)  # start from OLS (Huber's loss is convex: any start)
        weights = np.ones(W.shape[0])
        iterations = 0
        for _ in range(self.max_iter):
            iterations += 1
            scale = np.array([1.4826 * np.median(np.abs(fit.residual[joints == j])) for j in range(n_joints)])
            tiny = np.finfo(float).eps * max(1.0, float(np.abs(tau).max()))
            if np.all(scale <= tiny):  # exact fit: nothing to reweight
                break
            weights = robust_weights(fit.residual / (c * np.maximum(scale, tiny)[joints]), self.loss)
            new = weighted_least_squares(W, tau, weights)
            moved = np.linalg.norm(new.phi - fit.phi) / max(np.linalg.norm(new.phi), tiny)
            fit = new
            if moved < self.tol:
                break
        self.n_iter_ = iterations
        self.weights_ = weights
        self.outlier_fraction_ = float(np.mean(weights < 0.5))
        set_learned_attributes(self, fit, W)
        return self

    def predict(self, W: np.ndarray) -> np.ndarray:
        return W @ self.phi_
