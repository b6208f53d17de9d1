"""Weighted least squares and its statistics, shared by the least-squares family of estimators."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lwrlab.identification.core import column_scaled_condition_number, relative_std
from lwrlab.numerics.threads import dense_algebra


@dataclass(frozen=True)
class LeastSquaresFit:
    """Solution of ``min Σ_i w_i (τ_i − W_i·φ)²`` with its covariance."""

    phi: np.ndarray
    """(N_B,) estimate."""
    covariance: np.ndarray
    """(N_B, N_B) covariance ``s²·(WᵀPW)⁻¹`` with s² the weighted residual variance."""
    residual: np.ndarray
    """(rows,) unweighted residual τ − W·φ (N·m)."""

    @property
    def std(self) -> np.ndarray:
        """Standard deviations σ of the estimate."""
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))


@dense_algebra()
def weighted_least_squares(W: np.ndarray, tau: np.ndarray, weights: np.ndarray | None = None, rcond: float | None = None) -> LeastSquaresFit:  # noqa: N803
    """Eq. (6) of the paper: ``φ = (WᵀPW)⁻¹WᵀPτ`` with ``P = diag(weights)``.

    The covariance is ``s²·(WᵀPW)⁻¹`` with ``s² = Σ w r² / (rows − columns)``: with weights
    ``1/σ_j²`` and a well-chosen σ_j, ``s² ≈ 1``; with unit weights it is Gautier's OLS covariance.
    """
    tau = np.asarray(tau, dtype=float).ravel()
    rows, columns = W.shape
    if rows != tau.shape[0]:
        raise ValueError(f"W has {rows} rows but tau has {tau.shape[0]}")
    if rows <= columns:
        raise ValueError(f"{rows} rows cannot estimate {columns} parameters with a residual variance")
    root = np.ones(rows) if weights is None else np.sqrt(np.asarray(weights, dtype=float))
    scaled = W * root[:, None]
    phi, *_ = np.linalg.lstsq(scaled, tau * root, rcond=rcond)
    residual = tau - W @ phi
    s2 = float(np.sum((root * residual) ** 2)) / (rows - columns)
    return LeastSquaresFit(phi=phi, covariance=s2 * np.linalg.pinv(scaled.T @ scaled), residual=residual)


@dense_algebra()
def fit_with_covariance(W: np.ndarray, tau: np.ndarray, phi: np.ndarray, information: np.ndarray) -> LeastSquaresFit:  # noqa: N803
    """An estimate ``phi`` with the covariance ``σ²·information⁻¹``, σ² = ‖τ − Wφ‖² / (rows − columns).

    ``information`` is ``WᵀW`` for least squares, ``ŴᵀŴ`` for instrumental variables.
    """
    residual = tau - W @ phi
    rows, columns = W.shape
    sigma2 = float(residual @ residual) / (rows - columns)
    return LeastSquaresFit(phi=phi, covariance=sigma2 * np.linalg.pinv(information), residual=residual)


@dense_algebra()
def set_learned_attributes(estimator: object, fit: LeastSquaresFit, W: np.ndarray) -> None:  # noqa: N803
    """Store the protocol's learned attributes (phi_, covariance_, std_, …) of a least-squares fit."""
    estimator.phi_ = fit.phi  # type: ignore[attr-defined]
    estimator.covariance_ = fit.covariance  # type: ignore[attr-defined]
    estimator.std_ = fit.std  # type: ignore[attr-defined]
    estimator.relative_std_ = relative_std(fit.phi, fit.std)  # type: ignore[attr-defined]
    rows, columns = W.shape
    estimator.residual_std_ = float(np.sqrt(fit.residual @ fit.residual / (rows - columns)))  # type: ignore[attr-defined]
    estimator.cond_ = column_scaled_condition_number(W)  # type: ignore[attr-defined]


def per_joint_residual_std(residual: np.ndarray, joints: np.ndarray, n_joints: int, n_parameters: int) -> np.ndarray:
    """σ_j of each joint's residual, with the parameter count shared between joints by row share.

    Gautier's weighting (the paper's eq. (6)) uses ``σ_j² = ‖r_j‖² / (r_j − c_j)``; here ``c_j`` is
    the share ``N_B · r_j / r`` of the degrees of freedom used by the joint's rows.
    """
    sigma = np.empty(n_joints)
    for j in range(n_joints):
        r_j = residual[joints == j]
        dof = r_j.size - n_parameters * r_j.size / residual.size
        sigma[j] = np.sqrt(r_j @ r_j / max(dof, 1.0))
    return sigma
