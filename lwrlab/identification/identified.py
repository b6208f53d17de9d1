"""The identified model: what a user takes away from an identification."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lwrlab.dynamics.base_parameters import BaseParameters


@dataclass(frozen=True)
class IdentifiedModel:
    """Identified base parameters with their uncertainty, and a full standard set that reproduces them."""

    base_names: tuple[str, ...]
    """Names of the base parameters (``ZZ1R``, ``XX2R``, …, ``FC1``, …)."""
    base_values: np.ndarray
    """(N_B,) identified base parameters (SI units: kg, kg·m, kg·m², N·m, N·m·s/rad)."""
    base_std: np.ndarray
    """(N_B,) standard deviations of the base parameters (same units)."""
    standard_names: tuple[str, ...]
    """Names of the standard parameters."""
    standard_values: np.ndarray
    """(P,) a standard parameter vector whose base parameters equal ``base_values``: the prior
    (CAD) set moved by the least change that matches the identified combinations. It is not
    guaranteed physically consistent (the SDP estimator gives that)."""
    base_covariance: np.ndarray | None = None
    """(N_B, N_B) covariance of the base parameters (the estimator's), or None (a model saved without)."""
    noise_density: np.ndarray | None = None
    """(N_J,) torque noise density of each joint (N²·m²·s): the fit's residual variance per row times
    the seconds between rows, what a next motion's information is weighed with (None: not saved)."""
    friction_drift: float | None = None
    """ρ: the share of its friction torque by which friction differs from one log to the next, as the
    identification measured or stated it (:mod:`lwrlab.identification.friction_drift`; None: not saved)."""
    friction_drift_source: str | None = None
    """Where ρ comes from: ``logs`` (measured between several logs), ``prior`` (one log) or ``set``."""
    prior_share: np.ndarray | None = None
    """(N_B,) share of each base parameter's estimate that came from the prior, not the data
    (:func:`lwrlab.identification.prior_weight.prior_share`; None: fitted without a prior)."""

    @property
    def base_relative_std(self) -> np.ndarray:
        """%σ of each base parameter."""
        with np.errstate(divide="ignore"):
            return np.where(self.base_values != 0, 100 * self.base_std / np.abs(self.base_values), np.inf)


def standard_from_base(base: BaseParameters, base_values: np.ndarray, prior: np.ndarray) -> np.ndarray:
    """The standard vector closest to ``prior`` (Euclidean) with ``K·φ = base_values``."""
    correction, *_ = np.linalg.lstsq(base.regrouping, base_values - base.regrouping @ prior, rcond=None)
    return prior + correction
