"""Estimator protocol (scikit-learn shaped) and the statistics shared by estimators."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol, Self

import numpy as np

if TYPE_CHECKING:  # the context module builds on the model; the protocol only names it
    from lwrlab.identification.context import IdentificationContext


class LearnedAttributes(Protocol):
    """The learned attributes of the :class:`Estimator` protocol, declared for the type checker.

    Estimators derive from it (a class that names a protocol among its bases is a regular class
    that declares its members); it sets nothing, so an unfitted estimator has no ``*_`` attribute
    (scikit-learn's convention) until ``fit`` stores them
    (:func:`lwrlab.identification.least_squares.set_learned_attributes`).
    """

    phi_: np.ndarray
    """(N_B,) estimated base parameters."""
    covariance_: np.ndarray
    """(N_B, N_B) their covariance."""
    std_: np.ndarray
    """(N_B,) standard deviations σ."""
    relative_std_: np.ndarray
    """(N_B,) %σ = 100·σ/|φ|."""
    residual_std_: float
    """Standard deviation of the torque residual (N·m)."""
    cond_: float
    """Condition number of the column-scaled regressor."""


class Estimator(LearnedAttributes, Protocol):
    """An estimator plugin (config group ``estimator``), scikit-learn's protocol.

    Hyper-parameters are keyword arguments of ``__init__`` stored untouched, read and set by
    ``get_params`` / ``set_params`` (:class:`lwrlab.identification.hyperparameters.HyperParameters`
    implements both), so ``sklearn.base.clone`` copies an estimator. What comes from the data
    (the joint of each row, the regrouping matrix, the prior, the instruments) arrives in
    ``fit(W, tau, context=...)`` (:class:`lwrlab.identification.context.IdentificationContext`).
    ``fit`` learns the attributes ending in ``_``:

    - ``phi_``: (N_B,) estimated base parameters;
    - ``covariance_``: (N_B, N_B) their covariance (where defined);
    - ``std_``: (N_B,) standard deviations σ;
    - ``relative_std_``: (N_B,) %σ = 100·σ/|φ| (the paper's Table II columns);
    - ``residual_std_``: (float) standard deviation of the torque residual (N·m);
    - ``cond_``: condition number of the (scaled) regressor.

    Estimators declare them by deriving from :class:`LearnedAttributes`.
    """

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """The hyper-parameters, by ``__init__`` keyword."""
        ...

    def set_params(self, **params: Any) -> Self:
        """Set hyper-parameters by ``__init__`` keyword; returns the estimator."""
        ...

    def fit(self, W: np.ndarray, tau: np.ndarray, *, context: IdentificationContext | None = None) -> Self:
        """Fit base parameters to stacked regressor ``W`` (rows) and torques ``tau`` (same rows)."""
        ...

    def predict(self, W: np.ndarray) -> np.ndarray:
        """Torques predicted for regressor rows ``W``."""
        ...


def relative_std(phi: np.ndarray, std: np.ndarray) -> np.ndarray:
    """%σ = 100·σ/|φ|: the relative standard deviation of each parameter (inf where φ = 0)."""
    with np.errstate(divide="ignore"):
        return np.where(phi != 0.0, 100.0 * std / np.abs(phi), np.inf)


def column_scaled_condition_number(W: np.ndarray) -> float:
    """Condition number of ``W`` after scaling its columns to unit norm (unit-independent)."""
    norms = np.linalg.norm(W, axis=0)
    return float(np.linalg.cond(W / np.where(norms > 0, norms, 1.0)))


def torque_errors(measured: np.ndarray, predicted: np.ndarray) -> dict[str, np.ndarray]:
    """RMS (N·m) and NRMS (%, RMS over the range of the measured torque) per joint."""
    rms = np.sqrt(np.mean((measured - predicted) ** 2, axis=0))
    span = measured.max(axis=0) - measured.min(axis=0)
    return {"rms": rms, "nrms": 100.0 * rms / np.where(span > 0, span, np.nan)}
