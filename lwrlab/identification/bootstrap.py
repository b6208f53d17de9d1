"""Bootstrap confidence intervals of identified parameters, by resampling blocks of the trajectory.

The covariance ``σ²(WᵀW)⁻¹`` assumes white torque errors of equal variance; filtered data and
model errors are neither (neighbouring samples are correlated). The moving-block bootstrap
(Künsch 1989) keeps that correlation: the measurement is cut into blocks of consecutive samples
(all joints of a sample stay together), blocks are drawn with replacement until the original
length is reached, the estimator is refitted, and the spread of the refitted parameters gives
percentile confidence intervals and a bootstrap standard deviation.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from lwrlab.identification.context import IdentificationContext
from lwrlab.identification.hyperparameters import clone_estimator


@dataclass(frozen=True)
class BootstrapResult:
    """Percentile confidence intervals and spread of bootstrap estimates."""

    lower: np.ndarray
    """(N_B,) lower bound of the confidence interval."""
    upper: np.ndarray
    """(N_B,) upper bound."""
    std: np.ndarray
    """(N_B,) standard deviation of the bootstrap estimates."""
    estimates: np.ndarray
    """(resamples, N_B) every refitted estimate."""
    confidence: float
    """Confidence level of the intervals (e.g. 0.95)."""


def block_bootstrap(
    estimator: Any,
    W: np.ndarray,
    tau: np.ndarray,
    n_joints: int,
    block_samples: int,
    resamples: int = 200,
    confidence: float = 0.95,
    seed: int = 0,
    show_progress: bool = True,
    context: IdentificationContext | None = None,
) -> BootstrapResult:
    """Moving-block bootstrap of ``estimator`` on sample-major rows ``W``, ``tau``.

    Parameters
    ----------
    estimator : a fitted or unfitted estimator; clones of it (same hyper-parameters,
        :func:`lwrlab.identification.hyperparameters.clone_estimator`) are fitted, it is left untouched.
    W, tau : stacked regressor and torques, rows ``k·N_J + j``.
    n_joints : N_J.
    block_samples : samples per block (choose it longer than the correlation time of the errors).
    resamples : number of bootstrap fits.
    confidence : level of the percentile intervals.
    seed : seed of the block draws.
    show_progress : show a progress bar.
    context : the identification context of the rows, passed to every refit with its
        row-aligned data (the reference regressor) resampled like the rows.
    """
    from tqdm.auto import tqdm  # here: an identification without the bootstrap does not load it

    tau = np.asarray(tau, dtype=float).ravel()
    n_samples = W.shape[0] // n_joints
    block_samples = int(min(max(1, block_samples), n_samples))
    n_blocks = -(-n_samples // block_samples)
    rng = np.random.default_rng(seed)
    rows_of_block = (np.arange(block_samples)[:, None] * n_joints + np.arange(n_joints)).ravel()
    estimates = []
    for _ in tqdm(
        range(resamples), desc="block bootstrap", unit="fit", disable=not show_progress, leave=False
    ):
        starts = rng.integers(0, n_samples - block_samples + 1, size=n_blocks)
        rows = (starts[:, None] * n_joints + rows_of_block).ravel()[: n_samples * n_joints]
        resampled_context = None if context is None else context.take_rows(rows)
        estimates.append(clone_estimator(estimator).fit(W[rows], tau[rows], context=resampled_context).phi_)
    estimates_array = np.array(estimates)
    alpha = (1.0 - confidence) / 2
    lower, upper = np.quantile(estimates_array, [alpha, 1.0 - alpha], axis=0)
    return BootstrapResult(
        lower=lower,
        upper=upper,
        std=estimates_array.std(axis=0, ddof=1),
        estimates=estimates_array,
        confidence=confidence,
    )
