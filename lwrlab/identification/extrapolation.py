"""Whether a model can be trusted on motions other than its fit's: what the data say about each parameter.

The identifiability report (:mod:`lwrlab.identification.identifiability`) looks at the regressor with
its columns scaled to unit norm: a slow motion excites every column a little, so the scaled
regressor can be well conditioned while the inertial parameters are buried in the noise. This
module asks the question that matters to whoever uses the model: how uncertain are its torque
predictions on motions the robot can make? It draws states across the joint limits (positions
over the whole range, velocities and accelerations up to half the limits), propagates the
parameters' covariance to the predicted torques, ``σ_pred = √(wᵀ·Σ·w)``, and compares the median
over states and joints with the fit's residual σ. A ratio well above 1 means the fit leaves
parameters that matter on other motions undetermined: their estimates carry noise, not physics.

Measured (median σ_pred / σ_res; the validation error on a motion not in the fit in brackets):
least squares on the real LWR4+ runs 2+3 → 0.7 (2.6 %), 3 → 1.1 (4.7 %), 2 → 4.2 (12.2 %); on a
slow 300 s multisine of the simulated LWR4 62 (17 %); the physically consistent default with its
data-chosen prior 0.6–1.1 on all of them (0.9–4.2 %, 2.1 % on a 600 s one). :data:`DEFAULT_MAX_SPREAD`
= 3 separates them.

Nothing here prints: callers print :meth:`ExtrapolationReport.warning_text` and count it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

DEFAULT_MAX_SPREAD = 3.0
"""Median σ_pred / σ_res above which the predictions on other motions are not to be trusted."""

DEFAULT_MAX_VALIDATION_RATIO = 3.0
"""Validation error over fit error above which the model is said not to carry over."""


@dataclass(frozen=True)
class ExtrapolationReport:
    """The spread of the torque predictions over the joint limits, against the fit's residual."""

    prediction_std: np.ndarray
    """(N_J,) median over the drawn states of each joint's predicted-torque σ from the parameters (N·m)."""
    residual_std: float
    """σ of the fit's residual (N·m)."""
    spread: float
    """Median over joints of ``prediction_std / residual_std``."""
    culprits: tuple[tuple[str, float], ...]
    """The base parameters contributing most to the predictions' variance, with their share."""
    causes: tuple[str, ...]
    """Likely reasons read from the data (too slow, too short, joints barely moving)."""
    max_spread: float = DEFAULT_MAX_SPREAD

    @property
    def ok(self) -> bool:
        """Whether the predictions on other motions are as certain as the fit."""
        return bool(self.spread <= self.max_spread)

    def warning_text(self) -> str:
        """A WARNING line naming the culprits and the likely causes ('' when ok)."""
        if self.ok:
            return ""
        culprits = ", ".join(f"{name} ({100 * share:.0f} %)" for name, share in self.culprits)
        causes = "; ".join(self.causes) or "the motion does not excite them"
        return (
            f"WARNING: poorly determined parameters: torque predictions on motions up to half the joint "
            f"limits are uncertain by {self.spread:.3g}× the fit's residual σ {self.residual_std:.3g} N·m "
            f"(median; above {self.max_spread:g} the parameters' noise, not the physics, sets them). "
            f"Most of it from {culprits}. Likely: {causes}. Use a richer motion (task=excitation) or "
            "an estimator with a prior (estimator=sdp)."
        )

    def metrics(self) -> dict[str, float]:
        """``prediction_spread`` for the run's metrics."""
        return {"prediction_spread": float(self.spread)}


def likely_causes(
    q: np.ndarray,
    dq: np.ndarray,
    duration_s: float,
    position_range: np.ndarray,
    velocity_limit: np.ndarray,
    slow_fraction: float = 0.25,
    short_s: float = 5.0,
    still_fraction: float = 0.05,
) -> tuple[str, ...]:
    """What in the data may leave parameters undetermined: slow, short, joints barely moving."""
    causes = []
    peak_speed = np.abs(dq).max(axis=0)
    finite = np.isfinite(velocity_limit) & (velocity_limit > 0)
    if finite.any():
        fractions = peak_speed[finite] / velocity_limit[finite]
        if np.median(fractions) < slow_fraction:
            causes.append(
                f"too slow (peak joint speeds {100 * np.median(fractions):.0f} % of the limits, median)"
            )
    if duration_s < short_s:
        causes.append(f"too short ({duration_s:.3g} s)")
    spans = np.ptp(q, axis=0) / np.where(position_range > 0, position_range, np.inf)
    barely = [f"q{j + 1}" for j in np.flatnonzero(spans < still_fraction)]
    if barely:
        causes.append(f"joints barely moving: {', '.join(barely)}")
    return tuple(causes)


def assess_extrapolation(
    base_regressor: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
    names: Sequence[str],
    covariance: np.ndarray,
    residual_std: float,
    lower: np.ndarray,
    upper: np.ndarray,
    velocity: np.ndarray,
    acceleration: np.ndarray,
    causes: tuple[str, ...] = (),
    samples: int = 1000,
    seed: int = 0,
    max_spread: float = DEFAULT_MAX_SPREAD,
) -> ExtrapolationReport:
    """The spread of predictions over states within the limits.

    Parameters
    ----------
    base_regressor : ``(q, q̇, q̈) -> W_b`` sample-major stacked base regressor rows.
    names : base parameter names.
    covariance : (N_B, N_B) the estimate's covariance.
    residual_std : σ of the fit's residual (N·m).
    lower, upper : (N_J,) position limits (rad); velocity, acceleration : (N_J,) limits (rad/s,
        rad/s²); states are drawn up to half of them.
    """
    rng = np.random.default_rng(seed)
    n_joints = lower.size
    q = rng.uniform(lower, upper, (samples, n_joints))
    dq = rng.uniform(-0.5 * velocity, 0.5 * velocity, (samples, n_joints))
    ddq = rng.uniform(-0.5 * acceleration, 0.5 * acceleration, (samples, n_joints))
    rows = base_regressor(q, dq, ddq)
    weighted = rows @ covariance
    variance = np.einsum("ij,ij->i", weighted, rows).reshape(samples, n_joints)
    prediction_std = np.sqrt(np.median(np.clip(variance, 0.0, None), axis=0))
    spread = float(np.median(prediction_std) / residual_std) if residual_std > 0 else float("inf")
    # each parameter's part of the variance: its own term wᵢ²·Σᵢᵢ, the usual attribution
    own = np.mean(rows**2, axis=0) * np.clip(np.diag(covariance), 0.0, None)
    shares = own / own.sum() if own.sum() > 0 else own
    top = np.argsort(shares)[::-1][:5]
    return ExtrapolationReport(
        prediction_std=prediction_std,
        residual_std=float(residual_std),
        spread=spread,
        culprits=tuple((names[i], float(shares[i])) for i in top if shares[i] > 0.01),
        causes=causes,
        max_spread=max_spread,
    )


def validation_warning(
    fit_error: float,
    validation_error: float,
    causes: tuple[str, ...],
    max_ratio: float = DEFAULT_MAX_VALIDATION_RATIO,
    floor: float = 0.01,
) -> str:
    """A WARNING line when the validation error is many times the fit error ('' otherwise).

    Errors are relative (‖τ − τ̂‖/‖τ‖); below ``floor`` a ratio means nothing (both at the noise).
    """
    if not (validation_error > floor and validation_error > max_ratio * fit_error):
        return ""
    reason = "; ".join(causes) or "the validation motion leaves the fit's range (faster, other poses)"
    return (
        f"WARNING: the validation error {100 * validation_error:.3g} % is "
        f"{validation_error / fit_error:.3g}× the fit error {100 * fit_error:.3g} %: the model does not "
        f"carry over to the validation motion (extrapolation or over-fitting). Likely: {reason}."
    )
