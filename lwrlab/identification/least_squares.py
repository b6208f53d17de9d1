"""Weighted least squares and its statistics: the one solver of base-parameter and payload identification.

:func:`weighted_least_squares` solves eq. (6) for given row weights; :func:`grouped_least_squares`
is Gautier's weighting on top of it (rows in groups, one joint of one motion each, weighted by
``1/σ_g²`` from the residual of the previous fit). The least-squares estimators
(``plugins/estimators``) and the payload identification of eq. (7)
(:mod:`lwrlab.identification.payload`) all solve through these two functions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lwrlab.identification.compression import compress
from lwrlab.identification.core import LearnedAttributes, column_scaled_condition_number, relative_std
from lwrlab.identification.row_statistics import RowStatistics
from lwrlab.numerics.threads import dense_algebra


@dataclass(frozen=True)
class LeastSquaresFit:
    """Solution of ``min Σ_i w_i (τ_i − W_i·φ)²`` with its covariance."""

    phi: np.ndarray
    """(N_B,) estimate."""
    covariance: np.ndarray
    """(N_B, N_B) covariance: ``s²·(WᵀPW)⁻¹`` with s² the weighted residual variance, or
    ``(WᵀPW)⁻¹`` when the weights are taken as known inverse variances (:func:`grouped_least_squares`)."""
    residual: np.ndarray
    """(rows,) unweighted residual τ − W·φ (N·m)."""
    weights: np.ndarray | None = None
    """(rows,) the row weights ``P`` of the solve (None: unit weights)."""
    group_std: np.ndarray | None = None
    """(groups,) σ_g of each row group behind the weights (:func:`grouped_least_squares`), N·m."""

    @property
    def std(self) -> np.ndarray:
        """Standard deviations σ of the estimate."""
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))

    def weighted_system(self, W: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(√P·W, √P·τ)``: the rows as the solver saw them.

        For a constrained or total least-squares re-solve.
        """
        if self.weights is None:
            return W, np.asarray(tau, dtype=float).ravel()
        root = np.sqrt(self.weights)
        return W * root[:, None], np.asarray(tau, dtype=float).ravel() * root


def _check_shapes(W: np.ndarray, tau: np.ndarray) -> None:
    rows, columns = W.shape
    if rows != tau.shape[0]:
        raise ValueError(f"W has {rows} rows but tau has {tau.shape[0]}")
    if rows <= columns:
        raise ValueError(f"{rows} rows cannot estimate {columns} parameters with a residual variance")


@dense_algebra()
def weighted_least_squares(
    W: np.ndarray,
    tau: np.ndarray,
    weights: np.ndarray | None = None,
    rcond: float | None = None,
    known_variance: bool = False,
) -> LeastSquaresFit:
    """Eq. (6) of the paper: ``φ = (WᵀPW)⁻¹WᵀPτ`` with ``P = diag(weights)``.

    The weighted rows are QR-compressed (:func:`lwrlab.identification.compression.compress`) and
    the small triangular system solved by ``lstsq``: the minimum-norm solution of the full system
    (same singular values, same ``rcond``), without squaring the condition number as a Gram matrix
    would. Measured (``benchmarks/least_squares.py``, one BLAS thread): 2.4× faster than ``lstsq``
    on the tall rows at 67 200 × 57, 1.5× slower (7 ms) at 3 500 × 57.

    The covariance is ``s²·(WᵀPW)⁻¹`` with ``s² = Σ w r² / (rows − columns)``: with unit weights it
    is Gautier's OLS covariance ``σ²·(WᵀW)⁻¹``. With ``known_variance`` the weights are inverse
    variances and the covariance is ``(WᵀPW)⁻¹``.
    """
    tau = np.asarray(tau, dtype=float).ravel()
    _check_shapes(W, tau)
    root = None if weights is None else np.sqrt(np.asarray(weights, dtype=float))
    weighted_w, weighted_tau = (W, tau) if root is None else (W * root[:, None], tau * root)
    compressed = compress(weighted_w, weighted_tau)
    phi, *_ = np.linalg.lstsq(compressed.R, compressed.y, rcond=rcond)
    residual = tau - W @ phi
    r_inverse = np.linalg.pinv(compressed.R)
    covariance = r_inverse @ r_inverse.T  # (WᵀPW)⁻¹ = R⁻¹R⁻ᵀ, without squaring cond(W)
    if not known_variance:
        weighted_residual = residual if root is None else root * residual
        covariance = covariance * float(weighted_residual @ weighted_residual) / (W.shape[0] - W.shape[1])
    return LeastSquaresFit(
        phi=phi,
        covariance=covariance,
        residual=residual,
        weights=None if weights is None else np.asarray(weights, dtype=float),
    )


def group_residual_std(residual: np.ndarray, groups: np.ndarray, n_parameters: int) -> np.ndarray:
    """σ_g of the residual of each row group (indexed by group label), the parameters' degrees of
    freedom shared between groups by row share.

    Gautier's weighting (the paper's eq. (6)) uses ``σ_g² = ‖r_g‖² / (r_g − c_g)``; here ``c_g`` is
    the share ``N_B · r_g / r`` of the degrees of freedom used by the group's rows.
    """
    groups = np.asarray(groups, dtype=int)
    count = np.bincount(groups).astype(float)
    squares = np.bincount(groups, weights=residual**2)
    dof = count * (1.0 - n_parameters / residual.size)
    return np.sqrt(squares / np.maximum(dof, 1.0))


def weighting_std(sigma: np.ndarray, min_relative_std: float = 0.0) -> np.ndarray:
    """The σ_g that weight the rows: at least ``min_relative_std`` × the largest, a noiseless group
    (σ_g = 0 with no floor) as the largest, and all ones when every σ_g is 0 (exact data: equal weights)."""
    largest = float(sigma.max())
    if largest <= 0.0:
        return np.ones_like(sigma)
    sigma = np.maximum(sigma, min_relative_std * largest)
    return np.where(sigma > 0.0, sigma, largest)


@dense_algebra()
def grouped_least_squares(
    W: np.ndarray,
    tau: np.ndarray,
    groups: np.ndarray | None,
    steps: int = 1,
    min_relative_std: float = 0.0,
    known_variance: bool = False,
) -> LeastSquaresFit:
    """Gautier's weighted least squares over row groups (eq. (6) with ``P`` per group).

    An ordinary least-squares fit gives the residual σ_g of each group (:func:`group_residual_std`);
    the rows are weighted by ``1/σ_g²`` and solved again, ``steps`` times in all, each σ_g from the
    previous weighted fit's residual.

    Parameters
    ----------
    W, tau : stacked regressor (rows, N) and right-hand side (rows,).
    groups : (rows,) group label of each row (0, 1, …: a joint of a motion), or None for one group.
    steps : weighted solves after the ordinary one (at least 1).
    min_relative_std : floor of σ_g relative to the largest (:func:`weighting_std`).
    known_variance : covariance ``(Wᵀ·Σ⁻¹·W)⁻¹`` with the σ_g as the noise (payload identification),
        instead of scaling it by the weighted residual variance s² (the base-parameter WLS).

    Returns the last weighted fit, with its ``weights`` and ``group_std`` (the σ_g behind them).
    """
    tau = np.asarray(tau, dtype=float).ravel()
    groups = np.zeros(tau.shape[0], dtype=int) if groups is None else np.asarray(groups, dtype=int)
    fit = weighted_least_squares(W, tau)
    for _ in range(max(1, int(steps))):
        residual_std = group_residual_std(fit.residual, groups, W.shape[1])
        sigma = weighting_std(residual_std, min_relative_std)
        fit = weighted_least_squares(W, tau, 1.0 / sigma[groups] ** 2, known_variance=known_variance)
    covariance = fit.covariance
    if known_variance and not residual_std.any():  # every σ_g is 0: exact data, no spread
        covariance = np.zeros_like(covariance)
    return LeastSquaresFit(fit.phi, covariance, fit.residual, fit.weights, group_std=sigma)


@dense_algebra()
def fit_with_covariance(
    W: np.ndarray, tau: np.ndarray, phi: np.ndarray, information: np.ndarray
) -> LeastSquaresFit:
    """An estimate ``phi`` with the covariance ``σ²·information⁻¹``, σ² = ‖τ − Wφ‖² / (rows − columns).

    ``information`` is ``WᵀW`` for least squares, ``ŴᵀŴ`` for instrumental variables.
    """
    residual = tau - W @ phi
    rows, columns = W.shape
    sigma2 = float(residual @ residual) / (rows - columns)
    return LeastSquaresFit(phi=phi, covariance=sigma2 * np.linalg.pinv(information), residual=residual)


@dense_algebra()
def set_learned_attributes(estimator: LearnedAttributes, fit: LeastSquaresFit, W: np.ndarray) -> None:
    """Store the protocol's learned attributes (phi_, covariance_, std_, …) of a least-squares fit."""
    estimator.phi_ = fit.phi
    estimator.covariance_ = fit.covariance
    estimator.std_ = fit.std
    estimator.relative_std_ = relative_std(fit.phi, fit.std)
    rows, columns = W.shape
    estimator.residual_std_ = float(np.sqrt(fit.residual @ fit.residual / (rows - columns)))
    estimator.cond_ = column_scaled_condition_number(W)


@dense_algebra()
def least_squares_from_statistics(
    statistics: RowStatistics, rcond: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`weighted_least_squares` (unit weights) from the rows' R factor: ``(φ, σ²·(WᵀW)⁻¹)``."""
    compressed = statistics.compressed()
    phi, *_ = np.linalg.lstsq(compressed.R, compressed.y, rcond=rcond)
    r_inverse = np.linalg.pinv(compressed.R)
    squares = float(statistics.residual_squares(phi).sum())
    covariance = r_inverse @ r_inverse.T * squares / (statistics.rows - statistics.n_columns)
    return phi, covariance


@dense_algebra()
def joint_weighted_least_squares(
    statistics: RowStatistics, steps: int = 1, min_relative_std: float = 0.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`grouped_least_squares` with one group per joint, from the rows' R factors.

    Returns ``(φ, covariance, σ_j)``: the last weighted fit and the per-joint σ_j behind its weights.
    """
    n_joints, columns, rows = statistics.n_joints, statistics.n_columns, statistics.rows
    joint_rows = rows / n_joints

    def joint_std(phi: np.ndarray) -> np.ndarray:
        squares = statistics.residual_squares(phi).sum(axis=0)
        dof = joint_rows * (1.0 - columns / rows)
        return np.sqrt(squares / max(dof, 1.0))

    phi, _ = least_squares_from_statistics(statistics)
    for _ in range(max(1, int(steps))):
        sigma = weighting_std(joint_std(phi), min_relative_std)
        weighted = statistics.weighted(1.0 / sigma**2)
        phi, covariance = least_squares_from_statistics(weighted)
    return phi, covariance, sigma


@dense_algebra()
def set_learned_attributes_from_statistics(
    estimator: LearnedAttributes, phi: np.ndarray, covariance: np.ndarray, statistics: RowStatistics
) -> None:
    """:func:`set_learned_attributes` of an estimate ``phi`` fitted to the rows behind ``statistics``."""
    std = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    estimator.phi_ = phi
    estimator.covariance_ = covariance
    estimator.std_ = std
    estimator.relative_std_ = relative_std(phi, std)
    squares = float(statistics.residual_squares(phi).sum())
    estimator.residual_std_ = float(np.sqrt(squares / (statistics.rows - statistics.n_columns)))
    estimator.cond_ = column_scaled_condition_number(statistics.compressed().R)
