"""An identified model's torque predictions on each measurement, at its samples as logged, and their tables.

:func:`predict_measurement` filters a measurement's states as the fit did and predicts τ̂ = W·φ at
every logged sample; :func:`prediction_table` and :func:`predicted_torque_frame` (block by block:
:func:`predicted_torque_blocks`) put the predictions of an identification in tables (the report's
per-log errors, the rows of ``predicted_torque.parquet``, which the report writes).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd

from lwrlab.dynamics.base_parameters import BaseParameters
from lwrlab.dynamics.regressor import LogRegressor
from lwrlab.identification.holding_band import HoldingBand
from lwrlab.model.robot import RobotModel
from lwrlab.numerics.threads import dense_algebra
from lwrlab.plants.core import Measurement
from lwrlab.signal.processing import ProcessedData, process

REGRESSOR_BLOCK_SAMPLES = 4096
"""Samples whose full regressor is built at a time when predicting (4096 × 7 joints × 91 columns:
21 MB; a long log's peak memory is one such block, with its products, above its predictions)."""
SUMMARY_BLOCK_SAMPLES = 1 << 16
"""Samples summed at a time for the errors and the coverage (a copy of a long log's arrays would not fit)."""


@dataclass(frozen=True)
class LogPrediction:
    """The model's torque prediction on one measurement, at its samples as logged."""

    name: str
    """The log's name (file stem), or the motion's role for simulated data."""
    role: str
    """``identification`` or ``validation``."""
    t: np.ndarray
    """(M,) times as logged (s): each sample's logged stamp."""
    measured: np.ndarray
    """(M, N_J) measured torques as logged (N·m)."""
    predicted: np.ndarray
    """(M, N_J) predicted torques τ̂ = W(q, q̇, q̈)·φ̂ (N·m)."""
    scored: np.ndarray
    """(M,) samples inside the trimmed span, where the filtered states are free of edge transients."""
    processing: str
    """What the processing chose for this log (cut-off, velocity source)."""
    prediction_variance: np.ndarray | None = None
    """(M, N_J) the variance of τ̂ known at the prediction (N·m²): ``wᵀ·Σ·w`` of the parameters'
    covariance plus ``(ρ·τ̂_f)²`` of the friction drift (see :func:`predict_measurement`), or None (also
    once :meth:`PredictionInterval.around` has turned it into :attr:`half_width`)."""
    half_width: np.ndarray | None = None
    """(M, N_J) half-width of the prediction interval ``τ̂ ± half_width`` (N·m), or None."""
    joints: np.ndarray | None = None
    """(N_J,) the joints scored (``data.fitted_joints``), or None: every joint."""
    grid_t: np.ndarray | None = None
    """(M,) the regular grid (s) the samples were read on, when their logged stamps jitter around it
    (:attr:`lwrlab.plants.core.Measurement.stamps`); else None (the stamps are the grid)."""

    @property
    def interval_coverage(self) -> float:
        """Share of the scored samples and joints whose measured torque lies in the interval (NaN: none)."""
        return ResidualSums.of([self]).coverage

    @property
    def relative_error(self) -> float:
        """‖τ − τ̂‖/‖τ‖ over all joints and scored samples."""
        return ResidualSums.of([self]).relative_error

    def scored_blocks(self) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray | None]]:
        """``(measured, predicted, half_width)`` at the scored samples, in blocks of
        :data:`SUMMARY_BLOCK_SAMPLES` samples (half_width None without an interval)."""
        for first in range(0, len(self.t), SUMMARY_BLOCK_SAMPLES):
            part = slice(first, first + SUMMARY_BLOCK_SAMPLES)
            keep = self.scored[part]
            half_width = None if self.half_width is None else self.half_width[part][keep]
            yield self.measured[part][keep], self.predicted[part][keep], half_width

    def residual(self, dtype: type = np.float32) -> np.ndarray:
        """(M, N_J) τ − τ̂ at every sample, in ``dtype`` (single precision: for drawing)."""
        residual: np.ndarray = np.empty(self.measured.shape, dtype=dtype)
        for first in range(0, len(self.t), SUMMARY_BLOCK_SAMPLES):
            part = slice(first, first + SUMMARY_BLOCK_SAMPLES)
            residual[part] = self.measured[part] - self.predicted[part]
        return residual


@dataclass(frozen=True)
class ResidualSums:
    """Sums over the scored samples of predictions: what their errors and coverage are computed from."""

    measured: np.ndarray
    """(N_J,) Σ τ² per joint (N²·m²)."""
    residual: np.ndarray
    """(N_J,) Σ (τ − τ̂)² per joint (N²·m²)."""
    samples: int
    """Scored samples."""
    inside: np.ndarray
    """(N_J,) scored samples of each joint inside its prediction interval."""
    with_interval: np.ndarray
    """(N_J,) scored samples of each joint that have an interval (0: a joint not scored)."""

    @classmethod
    def of(cls, predictions: Sequence[LogPrediction]) -> ResidualSums:
        """The sums over every scored sample of ``predictions``, block by block."""
        n_joints = predictions[0].measured.shape[1] if predictions else 0
        measured, residual = np.zeros(n_joints), np.zeros(n_joints)
        inside, with_interval = np.zeros(n_joints, dtype=int), np.zeros(n_joints, dtype=int)
        samples = 0
        for p in predictions:
            scored = np.ones(n_joints, dtype=bool) if p.joints is None else p.joints  # fitted joints only
            for tau, tau_hat, half_width in p.scored_blocks():
                error = (tau - tau_hat) * scored
                measured += np.sum((tau * scored) ** 2, axis=0)
                residual += np.sum(error**2, axis=0)
                samples += tau.shape[0]
                if half_width is not None:
                    inside += np.count_nonzero(np.abs(error) <= half_width, axis=0) * scored
                    with_interval += tau.shape[0] * scored
        return cls(measured, residual, samples, inside, with_interval)

    @property
    def relative_error(self) -> float:
        """‖τ − τ̂‖/‖τ‖ over all joints and scored samples."""
        return float(np.sqrt(self.residual.sum()) / np.sqrt(self.measured.sum()))

    @property
    def mean_square(self) -> np.ndarray:
        """(N_J,) mean square residual per joint (N²·m²)."""
        return self.residual / self.samples

    @property
    def coverage(self) -> float:
        """Share of scored samples and joints inside their prediction interval (NaN: no interval)."""
        counted = int(self.with_interval.sum())
        return int(self.inside.sum()) / counted if counted else float("nan")

    @property
    def joint_coverage(self) -> np.ndarray:
        """(N_J,) share of each joint's scored samples inside its interval (NaN: a joint not scored,
        or no interval)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.with_interval > 0, self.inside / np.maximum(self.with_interval, 1), np.nan)


@dataclass(frozen=True)
class PredictionInterval:
    """What makes a prediction on a new motion uncertain beyond its parameters: the model's error.

    The interval of τ̂_j at a sample x is ``τ̂_j ± z·c_j·√(wᵀ·Σ·w + s_j² + (ρ·τ̂_f,j(x))² + h_j(x)²)``:
    ``wᵀ·Σ·w`` the parameters' part (from the base parameters' covariance Σ at the sample's regressor
    row w), ``ρ·τ̂_f,j(x)`` the friction drift (friction changes between motions with temperature and
    speed range by a share ρ of the friction torque τ̂_f at the state), ``h_j(x)²`` what a joint that
    does not slide may hold within its friction band (:mod:`lwrlab.identification.holding_band`) —
    the three known at the prediction (:attr:`LogPrediction.prediction_variance`) —, ``s_j`` the
    torque error the model makes on joint j on samples it was not fitted on (sensor noise,
    unmodelled dynamics), ``z`` the normal
    quantile of ``level`` and ``c_j ≥ 1`` the conformal scale that makes the identification logs'
    residuals fall inside at ``level`` (heavy tails).
    """

    error_std: np.ndarray
    """(N_J,) model error per joint (N·m)."""
    level: float = 0.95
    """Probability the interval is meant to cover."""
    scale: np.ndarray | None = None
    """(N_J,) conformal scale c_j ≥ 1, or None: 1."""

    @property
    def z(self) -> float:
        """The normal quantile of :attr:`level` (two-sided)."""
        from scipy.special import ndtri

        return float(ndtri(0.5 + self.level / 2))

    def variance(self, prediction: LogPrediction, out: np.ndarray | None = None) -> np.ndarray:
        """(M, N_J) ``wᵀ·Σ·w + (ρ·τ̂_f)² + h² + s_j²`` of ``prediction`` (written into ``out`` if given)."""
        if prediction.prediction_variance is None:
            raise ValueError(f"{prediction.name}: predicted without the parameters' covariance")
        return np.add(prediction.prediction_variance, self.error_std**2, out=out)

    def normalised_errors(self, prediction: LogPrediction) -> Iterator[np.ndarray]:
        """``|τ − τ̂| / (z·√variance)`` (n, N_J) at the scored samples of ``prediction``, block by block
        (:data:`SUMMARY_BLOCK_SAMPLES`; NaN on a joint not scored): the conformal scale's scores,
        computed as :meth:`variance` is without a long log's (M, N_J) copies."""
        if prediction.prediction_variance is None:
            raise ValueError(f"{prediction.name}: predicted without the parameters' covariance")
        for first in range(0, len(prediction.t), SUMMARY_BLOCK_SAMPLES):
            part = slice(first, first + SUMMARY_BLOCK_SAMPLES)
            keep = prediction.scored[part]
            half_width = np.sqrt(prediction.prediction_variance[part][keep] + self.error_std**2) * self.z
            error = np.abs(prediction.measured[part][keep] - prediction.predicted[part][keep])
            score = error / np.maximum(half_width, 1e-12)
            if prediction.joints is not None:
                score[:, ~prediction.joints] = np.nan
            yield score

    def around(self, prediction: LogPrediction) -> LogPrediction:
        """``prediction`` with the interval's half-width at every sample.

        The prediction's variance becomes the half-width in place (a long log's array is not copied):
        ``prediction`` itself is not to be used afterwards.
        """
        half_width = self.variance(prediction, out=prediction.prediction_variance)
        np.sqrt(half_width, out=half_width)
        half_width *= self.z if self.scale is None else self.z * self.scale
        return replace(prediction, prediction_variance=None, half_width=half_width)


def joint_coverage(predictions: Sequence[LogPrediction]) -> np.ndarray:
    """(N_J,) :attr:`ResidualSums.joint_coverage` over ``predictions``."""
    return ResidualSums.of(predictions).joint_coverage


def process_measurement(
    measurement: Measurement, processing: dict[str, Any], every_sample: bool = False
) -> ProcessedData:
    """``measurement`` processed with ``processing`` (keyword arguments of :func:`process`)."""
    return process(
        measurement.t, measurement.q, measurement.tau, measurement.dq, every_sample=every_sample, **processing
    )


def predict_measurement(
    robot: RobotModel,
    base: BaseParameters,
    phi: np.ndarray,
    measurement: Measurement,
    processing: dict[str, Any],
    covariance: np.ndarray | None = None,
    friction: np.ndarray | None = None,
    holding: HoldingBand | None = None,
) -> LogPrediction:
    """τ̂ = W(q, q̇, q̈)·φ at every sample of ``measurement`` as logged (states filtered as for the fit).

    With the base parameters' ``covariance``, also the variance of τ̂ at every sample: ``wᵀ·Σ·w``, plus
    with ``friction`` the square of the torque it gives (base values of the drifting friction terms
    alone, times the drift ρ: ``(ρ·τ̂_f)²``), plus with ``holding`` the variance of the friction a
    joint that does not slide may hold (:mod:`lwrlab.identification.holding_band`), added here rather
    than kept as further arrays of a long log (:class:`PredictionInterval` turns the variance into an
    interval).
    """
    data = process_measurement(measurement, processing, every_sample=True)
    predicted = np.empty((data.n_working, robot.n_joints))
    variance = None if covariance is None else np.empty_like(predicted)
    # Block by block: the full regressor of every sample of a long log would not fit in memory.
    # One BLAS thread: products of this size lose to a second thread on a busy core.
    # a friction law with memory reads its columns from the whole log, by sample index
    log_regressor = LogRegressor.of(robot, data.velocities, data.working_rate_hz)
    with dense_algebra():
        for block in data.state_blocks():
            for first in range(0, len(block.t), REGRESSOR_BLOCK_SAMPLES):
                part = slice(first, first + REGRESSOR_BLOCK_SAMPLES)
                full = log_regressor(
                    block.q[part], block.dq[part], block.ddq[part], block.start + first, stacked=False
                )
                samples = slice(block.start + first, block.start + first + full.shape[0])
                predicted[samples] = base.torques(full, phi)
                if covariance is not None and variance is not None:
                    variance[samples] = _parameter_variance(base.base_regressor(full), covariance)
                    if friction is not None:
                        variance[samples] += base.torques(full, friction) ** 2
                    if holding is not None:
                        variance[samples] += holding.variance(block.dq[part][: full.shape[0]])
    t, measured = measurement.as_logged()
    on_grid = t  # the times the trimmed span is compared with
    grid_t = None
    if t is measurement.t and measurement.stamps is not None:  # the samples as logged, stamps beside
        grid_t, t = t, measurement.stamps
    elif t is not measurement.t:  # resampled log: back to the logged samples
        predicted = np.column_stack([np.interp(t, data.t, predicted[:, j]) for j in range(robot.n_joints)])
        if variance is not None:
            variance = np.column_stack([np.interp(t, data.t, variance[:, j]) for j in range(robot.n_joints)])
    span = data.row_times
    scored = (on_grid >= span[0] - 1e-9) & (on_grid <= span[-1] + 1e-9)
    cutoff = "no filter" if data.state_cutoff_hz is None else f"q at {data.state_cutoff_hz:.3g} Hz"
    velocity = "logged q̇" if data.velocity.logged else "q̇ = d/dt q"
    return LogPrediction(
        measurement.name,
        str(measurement.metadata.get("role", "")),
        t,
        measured,
        predicted,
        scored,
        f"{cutoff}, {velocity}",
        None if variance is None else np.clip(variance, 0.0, None, out=variance),
        grid_t=grid_t,
    )


def _parameter_variance(rows: np.ndarray, covariance: np.ndarray) -> np.ndarray:
    """(n, N_J) ``wᵀ·Σ·w`` of the base regressor rows ``rows`` (n, N_J, N_B) of every sample and joint.

    Joint by joint over the columns not zero in the block: a joint's torque does not depend on the
    links before it, so its rows are zero in about half the columns (a third of the products).
    """
    variance = np.empty(rows.shape[:2])
    for j in range(rows.shape[1]):
        joint_rows = rows[:, j]
        used = np.flatnonzero(np.any(joint_rows != 0.0, axis=0))
        w = np.take(joint_rows, used, axis=1)
        variance[:, j] = np.einsum("ij,ij->i", w @ covariance[np.ix_(used, used)], w)
    return variance


def prediction_table(predictions: Sequence[LogPrediction]) -> pd.DataFrame:
    """Per measurement: role, samples, ‖τ − τ̂‖/‖τ‖ (%) and what the processing chose."""
    return pd.DataFrame(
        {
            "role": [p.role for p in predictions],
            "samples": [int(p.scored.sum()) for p in predictions],
            "rel_error_%": [100 * p.relative_error for p in predictions],
            "cut-off, velocity": [p.processing for p in predictions],
        },
        index=pd.Index([p.name for p in predictions], name="log"),
    )


def predicted_torque_frame(predictions: Sequence[LogPrediction]) -> pd.DataFrame:
    """Measured and predicted torques of every log at its scored samples: the rows its errors come from.

    Columns ``log, role, t`` (each sample's stamp as logged), ``t_grid`` (only where a log's
    jittered stamps were read on a regular grid: that grid's time; the other logs' stamps),
    ``tau1…N, tau_hat1…N`` and, where the model carries its uncertainty, ``tau_lo1…N, tau_hi1…N``
    (the prediction interval, 95 % by default). The samples before and
    after the trimmed span are left out: there the filtered states carry the filter's edge
    transients, their predictions are several times worse than the rest and no metric scores them,
    so ‖τ − τ̂‖/‖τ‖ over a log's rows
    is its ``validation_rel_error_<log>`` (over the identification logs' rows, ``fit_rel_error``).
    """
    return pd.concat(predicted_torque_blocks(predictions, block_samples=None), ignore_index=True)


def predicted_torque_blocks(
    predictions: Sequence[LogPrediction], block_samples: int | None
) -> Iterator[pd.DataFrame]:
    """The rows of :func:`predicted_torque_frame`, log by log in blocks of ``block_samples`` samples."""
    with_grid = any(p.grid_t is not None for p in predictions)  # one schema for every block
    for p in predictions:
        n = p.measured.shape[1]
        scored = np.flatnonzero(p.scored)
        step = scored.size if block_samples is None else block_samples
        for first in range(0, max(scored.size, 1), max(step, 1)):
            rows = scored[first : first + step]
            frame = pd.DataFrame({"log": p.name, "role": p.role, "t": p.t[rows]})
            if with_grid:
                frame["t_grid"] = (p.t if p.grid_t is None else p.grid_t)[rows]
            frame[[f"tau{j}" for j in range(1, n + 1)]] = p.measured[rows]
            frame[[f"tau_hat{j}" for j in range(1, n + 1)]] = p.predicted[rows]
            if p.half_width is not None:
                frame[[f"tau_lo{j}" for j in range(1, n + 1)]] = p.predicted[rows] - p.half_width[rows]
                frame[[f"tau_hi{j}" for j in range(1, n + 1)]] = p.predicted[rows] + p.half_width[rows]
            yield frame
