"""Estimator protocol (scikit-learn shaped) and the statistics shared by estimators."""

from __future__ import annotations

from typing import Protocol, Self

import numpy as np


class Estimator(Protocol):
    """An estimator plugin (config group ``estimator``).

    Hyperparameters are keyword arguments of ``__init__`` stored untouched; ``fit`` learns the
    attributes ending in ``_``:

    - ``phi_``: (N_B,) estimated base parameters;
    - ``covariance_``: (N_B, N_B) their covariance (where defined);
    - ``std_``: (N_B,) standard deviations σ;
    - ``relative_std_``: (N_B,) %σ = 100·σ/|φ| (the paper's Table II columns);
    - ``residual_std_``: (float) standard deviation of the torque residual (N·m);
    - ``cond_``: condition number of the (scaled) regressor.
    """

    def fit(self, W: np.ndarray, tau: np.ndarray) -> Self:  # noqa: N803 - the paper's symbol
        """Fit base parameters to stacked regressor ``W`` (rows) and torques ``tau`` (same rows)."""
        ...

    def predict(self, W: np.ndarray) -> np.ndarray:  # noqa: N803
        """Torques predicted for regressor rows ``W``."""
        ...


def parameter_covariance(W: np.ndarray, residual: np.ndarray) -> tuple[np.ndarray, float]:  # noqa: N803
    """Covariance ``σ²·(WᵀW)⁻¹`` of least-squares estimates, with σ² = ‖r‖²/(rows − columns).

    Returns the covariance and σ (N·m). Gautier's classical hypothesis: the residual is zero-mean
    white noise of equal variance on every row.
    """
    rows, columns = W.shape
    if rows <= columns:
        raise ValueError(f"{rows} rows cannot estimate {columns} parameters with a residual variance")
    sigma2 = float(residual @ residual) / (rows - columns)
    return sigma2 * np.linalg.inv(W.T @ W), float(np.sqrt(sigma2))


def relative_std(phi: np.ndarray, std: np.ndarray) -> np.ndarray:
    """%σ = 100·σ/|φ|: the relative standard deviation of each parameter (inf where φ = 0)."""
    with np.errstate(divide="ignore"):
        return np.where(phi != 0.0, 100.0 * std / np.abs(phi), np.inf)


def column_scaled_condition_number(W: np.ndarray) -> float:  # noqa: N803
    """Condition number of ``W`` after scaling its columns to unit norm (unit-independent)."""
    norms = np.linalg.norm(W, axis=0)
    return float(np.linalg.cond(W / np.where(norms > 0, norms, 1.0)))


def torque_errors(measured: np.ndarray, predicted: np.ndarray) -> dict[str, np.ndarray]:
    """RMS (N·m) and NRMS (%, RMS over the range of the measured torque) per joint."""
    rms = np.sqrt(np.mean((measured - predicted) ** 2, axis=0))
    span = measured.max(axis=0) - measured.min(axis=0)
    return {"rms": rms, "nrms": 100.0 * rms / np.where(span > 0, span, np.nan)}
