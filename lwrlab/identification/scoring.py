"""The scoring stages of an identification: predictions with intervals, the tables, the metrics.

:func:`predict` predicts every identification and validation log with a band
(:func:`prediction_interval`); :func:`tabulate` gives the parameter table (CAD, truth, estimate, σ,
bootstrap intervals) and the per-joint validation errors; :func:`extrapolate` says how uncertain the
model is over the joint limits (and :func:`likely_causes_of_poor_validation` why a validation may be
poor); :func:`score` gathers the headline metrics.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd

from lwrlab.dynamics.base_parameters import BaseParameters
from lwrlab.dynamics.regressor import regressor
from lwrlab.identification.bootstrap import block_bootstrap
from lwrlab.identification.consistency import min_pseudo_inertia_eigenvalues
from lwrlab.identification.context import IdentificationContext
from lwrlab.identification.core import Estimator, torque_errors
from lwrlab.identification.coverage_check import FitMotion, coverage_warning
from lwrlab.identification.extrapolation import ExtrapolationReport, assess_extrapolation, likely_causes
from lwrlab.identification.fitting import Fit
from lwrlab.identification.friction_choice import FrictionChoice
from lwrlab.identification.holding_band import HoldingBand
from lwrlab.identification.identifiability import IdentifiabilityReport
from lwrlab.identification.log_predictions import (
    LogPrediction,
    PredictionInterval,
    ResidualSums,
    joint_coverage,
    predict_measurement,
)
from lwrlab.identification.measuring import Measured
from lwrlab.identification.prediction_error import conformal_scale, drift_parameters, held_out_log_error
from lwrlab.identification.row_statistics import RowStatistics
from lwrlab.identification.rows import IdentificationRows
from lwrlab.model.friction_laws import drifting_terms
from lwrlab.model.position_ranges import finite_range, range_span
from lwrlab.model.robot import RobotModel
from lwrlab.plants.core import Measurement, Plant
from lwrlab.signal.processing import ProcessedData


def prediction_interval(
    estimator: Estimator,
    fit_predictions: list[LogPrediction],
    in_sample: np.ndarray,
    level: float = 0.95,
    held_out_logs: np.ndarray | None = None,
    gap_scale: np.ndarray | None = None,
) -> PredictionInterval:
    """The interval of the model's predictions on a new motion, from its fit.

    Per joint, the model error ``s_j`` is the residual on the identification logs as logged (sensor
    noise and unmodelled dynamics), plus what cross-validation adds beyond ``in_sample`` (N·m², the
    mean square residual per joint on the fitted rows) over its held-out blocks, when the estimator
    measured it (``cv_joint_rms_``), or, where larger, what the model errs on each identification log
    when refitted without it (``held_out_logs``, N·m², per joint:
    :func:`~lwrlab.identification.prediction_error.held_out_log_error`). The friction drift widens it
    where the model predicts friction (:mod:`lwrlab.identification.prediction_error`: in the variance
    each prediction carries); the conformal scale makes the identification logs (``fit_predictions``,
    predicted with their variance) fall inside at ``level``. Measured on motions unlike the fit's
    (``benchmarks/zoo.py --choice intervals``): the held-out blocks alone cover a new motion's torques
    on the real LWR4+ 43–60 % of the time on its worst joint, with the drift of one log 89–97 %.
    ``gap_scale`` (N_J,): the cross-validation's excess was measured on weighted rows (the rows near
    rest weighted down, :mod:`lwrlab.identification.rest_weights`); it is taken relative to their
    in-sample error and applied to the unweighted one (``gap_scale`` = unweighted / weighted in-sample
    mean square), as the logs' residual is.
    """
    error_variance = ResidualSums.of(fit_predictions).mean_square
    held_out = getattr(estimator, "cv_joint_rms_", None)
    held_out_square = None if held_out is None else np.asarray(held_out) ** 2
    if held_out_logs is not None:
        held_out_square = np.maximum(held_out_logs, 0.0 if held_out_square is None else held_out_square)
    if held_out_square is not None:
        gap = np.clip(held_out_square - in_sample, 0.0, None)
        error_variance = error_variance + (gap if gap_scale is None else gap * gap_scale)
    interval = PredictionInterval(np.sqrt(error_variance), level)
    n_joints = len(error_variance)
    scores = [
        s for p in fit_predictions if p.prediction_variance is not None for s in interval.normalised_errors(p)
    ]
    return replace(interval, scale=conformal_scale(scores, n_joints, level)) if scores else interval


def _as_chosen(processing: dict[str, Any], data: ProcessedData) -> dict[str, Any]:
    """``processing`` with the cut-off and velocity source that ``data``'s processing chose."""
    return {
        **processing,
        "cutoff_hz": data.cutoff_hz,
        "velocity": "logged" if data.velocity.logged else "differentiated",
    }


def _in_sample(statistics: RowStatistics, phi: np.ndarray) -> np.ndarray:
    """(N_J,) mean square residual per joint of the rows behind ``statistics`` at ``phi`` (N²·m²)."""
    return statistics.residual_squares(phi).sum(axis=0) / (statistics.rows // statistics.n_joints)


@dataclass(frozen=True)
class Predictions:
    """The model's predictions of the identification logs and of the validation logs, with bands."""

    fit: list[LogPrediction]
    validation: list[LogPrediction]

    @property
    def all(self) -> list[LogPrediction]:
        """Identification logs first, then validation logs."""
        return self.fit + self.validation


def predict(
    robot: RobotModel,
    base: BaseParameters,
    estimator: Estimator,
    measured: Measured,
    processed: list[ProcessedData],
    processing: dict[str, Any],
    rows: IdentificationRows,
    fitted: np.ndarray | None,
    friction_drift: float = 0.0,
) -> Predictions:
    """Every log predicted by the fitted ``estimator``, inside the band :func:`prediction_interval` gives
    (with the ``friction_drift``, ρ, of the ``statistics`` settings).

    An identification log is predicted with the cut-off and velocity source its fit used; a
    validation log gets its own, as a new log would.
    """
    covariance = np.asarray(estimator.covariance_)
    drifting = drifting_terms(robot.friction_law)
    drifting_values = drift_parameters(base.names, estimator.phi_, drifting) if friction_drift > 0 else None
    friction = None if drifting_values is None else friction_drift * drifting_values  # ρ·φ_f: ρ·τ̂_f
    holding = HoldingBand.of(robot, base.names, estimator.phi_)
    fit_predictions = [
        replace(
            predict_measurement(
                robot, base, estimator.phi_, m, _as_chosen(processing, data), covariance, friction, holding
            ),
            role="identification",
            joints=fitted,
        )
        for m, data in zip(measured.measurements, processed, strict=True)
    ]
    in_sample = _in_sample(rows.statistics, estimator.phi_)
    gap_scale = None
    if rows.rest is not None and rows.classed is not None:  # every row alike: the classes' sums
        samples = rows.statistics.rows // rows.statistics.n_joints
        unweighted = rows.classed.residual_squares(estimator.phi_).sum(axis=1) / samples
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = unweighted / in_sample
        gap_scale = np.where(np.isfinite(ratio), ratio, 1.0)
    held_out_logs = held_out_log_error(rows.log_grams, rows.log_samples, estimator.phi_)
    if held_out_logs is not None and fitted is not None:
        held_out_logs = np.where(fitted, held_out_logs, 0.0)
    band = prediction_interval(
        estimator, fit_predictions, in_sample, held_out_logs=held_out_logs, gap_scale=gap_scale
    )
    fit_predictions = [band.around(p) for p in fit_predictions]
    validation_predictions = [
        band.around(
            replace(
                predict_measurement(
                    robot, base, estimator.phi_, m, processing, covariance, friction, holding
                ),
                role="validation",
                joints=fitted,
            )
        )
        for m in measured.validation_measurements
    ]
    return Predictions(fit_predictions, validation_predictions)


@dataclass(frozen=True)
class Tables:
    """The parameter table, the per-joint validation errors, and the errors they come from."""

    parameters: pd.DataFrame
    """Per base parameter: cad, truth (simulation), estimate, std, %σ, bootstrap interval, error."""
    validation: pd.DataFrame
    """Per joint: RMS (N·m), NRMS (%), noise σ_τ if known, whether the joint was fitted."""
    errors: dict[str, np.ndarray]
    """Per joint ``rms`` and ``nrms`` over the validation samples."""
    scored: np.ndarray
    """(N_J,) bool: the joints the errors are averaged over."""
    base_parameter_error: float | None
    """‖φ̂ − φ‖ / ‖φ‖ against the simulated truth (None without one)."""


def _validation_table(
    robot: RobotModel, measured: Measured, predictions: Predictions, fitted: np.ndarray | None
) -> tuple[pd.DataFrame, dict[str, np.ndarray], np.ndarray]:
    measured_torque = np.vstack([p.measured[p.scored] for p in predictions.validation])
    estimated = np.vstack([p.predicted[p.scored] for p in predictions.validation])
    errors = torque_errors(measured_torque, estimated)
    noise = measured.validation_measurements[0].metadata.get("torque_noise_std")
    validation = pd.DataFrame(
        {"rms": errors["rms"], "nrms": errors["nrms"]},
        index=pd.Index(range(1, robot.n_joints + 1), name="joint"),
    )
    if noise is not None:
        validation["noise_std"] = noise
    scored = np.ones(robot.n_joints, dtype=bool) if fitted is None else fitted
    validation["fitted"] = scored
    validation["coverage"] = joint_coverage(predictions.validation)  # of the 95 % interval
    return validation, errors, scored


def tabulate(
    robot: RobotModel,
    base: BaseParameters,
    estimator: Estimator,
    measured: Measured,
    predictions: Predictions,
    rows: IdentificationRows,
    first: ProcessedData,
    context: IdentificationContext,
    plant: Plant,
    statistics: dict[str, Any] | None,
    fitted: np.ndarray | None,
) -> Tables:
    """The per-joint validation errors and the parameter table (with block bootstrap intervals when
    ``statistics`` asks for resamples, with the truth and each estimate's error for a simulation)."""
    validation, errors, scored = _validation_table(robot, measured, predictions, fitted)
    parameters = pd.DataFrame(
        {
            "cad": base.base_values(robot.parameters),
            "estimate": estimator.phi_,
            "std": estimator.std_,
            "relative_std": estimator.relative_std_,
        },
        index=pd.Index(base.names, name="parameter"),
    )
    share = getattr(estimator, "prior_share_", None)
    if share is not None:
        parameters["prior_share"] = share
    bootstrap = statistics is not None and statistics["resamples"] > 0
    if statistics is not None and rows.w_base is not None and rows.tau is not None and bootstrap:
        interval = block_bootstrap(
            estimator,
            rows.w_base,
            rows.tau,
            robot.n_joints,
            block_samples=max(1, round(statistics["block_s"] * first.rate_hz)),
            resamples=int(statistics["resamples"]),
            confidence=float(statistics["confidence"]),
            seed=int(statistics["seed"]),
            context=context,
        )
        parameters["ci_lower"], parameters["ci_upper"], parameters["bootstrap_std"] = (
            interval.lower,
            interval.upper,
            interval.std,
        )
    error = None
    truth = getattr(plant, "truth", None)
    if truth is not None:
        true_base = base.base_values(truth.robot.parameters)
        parameters.insert(1, "truth", true_base)
        with np.errstate(divide="ignore", invalid="ignore"):
            parameters["relative_error"] = np.abs(estimator.phi_ - true_base) / np.abs(true_base)
        error = float(np.linalg.norm(estimator.phi_ - true_base) / np.linalg.norm(true_base))
    return Tables(parameters, validation, errors, scored, error)


def likely_causes_of_poor_validation(
    robot: RobotModel, measured: Measured, rows: IdentificationRows
) -> tuple[str, ...]:
    """What the identification motions lack, should the model validate poorly (too short, too small a
    range, too slow)."""
    limits = robot.limits
    return likely_causes(
        rows.q,
        rows.dq,
        duration_s=float(sum(m.t[-1] - m.t[0] for m in measured.measurements)),
        position_range=range_span(limits.position_lower, limits.position_upper),  # continuous: 2π
        velocity_limit=limits.velocity,
    )


def _speed(measurement: Measurement, joint: int, smoothing: int = 5) -> np.ndarray:
    """(M,) a joint's speeds in a log: as logged, else differentiated and averaged over ``smoothing``
    samples (enough to compare the speed ranges of two logs of one robot)."""
    if measurement.dq is not None:
        return np.asarray(measurement.dq[:, joint])
    kernel = np.ones(smoothing) / smoothing
    return np.convolve(np.gradient(measurement.q[:, joint], measurement.t), kernel, mode="same")


def coverage_checks(measured: Measured, predictions: Predictions, level: float = 0.95) -> list[str]:
    """A WARNING per validation log on which a joint's interval covers less than it should
    (:func:`~lwrlab.identification.coverage_check.coverage_warning`), naming what the log does that
    the identification logs did not."""
    if not measured.measurements:
        return []
    fits = measured.measurements
    fit = FitMotion.of([m.q for m in fits], lambda k, j: _speed(fits[k], j))
    lines = []
    for m, p in zip(measured.validation_measurements, predictions.validation, strict=True):
        coverage = joint_coverage([p])
        if np.all(~np.isfinite(coverage)):
            continue
        speeds = np.column_stack([_speed(m, j) for j in range(m.q.shape[1])])
        line = coverage_warning(p.name, coverage, level, fit.novelty(m.q, speeds))
        lines += [] if line is None else [line]
    return lines


def coverage_metrics(predictions: Predictions) -> dict[str, float]:
    """Per joint, the validation samples inside their interval (pooled over the validation logs and
    per log), and the worst joint's."""
    if not predictions.validation:
        return {}
    pooled = joint_coverage(predictions.validation)
    metrics = {f"validation_coverage_joint{j}": float(c) for j, c in enumerate(pooled, start=1)}
    if np.any(np.isfinite(pooled)):
        metrics["validation_worst_joint_coverage"] = float(np.nanmin(pooled))
    for p in predictions.validation:
        per_log = joint_coverage([p])
        metrics |= {
            f"validation_coverage_{p.name}_joint{j}": float(c) for j, c in enumerate(per_log, start=1)
        }
    return metrics


def extrapolate(
    robot: RobotModel,
    base: BaseParameters,
    estimator: Estimator,
    causes: tuple[str, ...],
) -> ExtrapolationReport:
    """The spread of the model's predictions over the joint limits (unknown acceleration limits:
    5 × the velocity limit per second, about what arms reach), with the likely ``causes`` of a poor
    validation."""
    limits = robot.limits
    velocity = np.where(np.isfinite(limits.velocity), limits.velocity, 2.0)
    acceleration = np.where(np.isfinite(limits.acceleration), limits.acceleration, 5.0 * velocity)
    return assess_extrapolation(
        lambda q, dq, ddq: base.base_regressor(regressor(robot, q, dq, ddq)),
        base.names,
        np.asarray(estimator.covariance_),
        float(estimator.residual_std_),
        *finite_range(limits.position_lower, limits.position_upper),  # continuous: one turn
        velocity,
        acceleration,
        causes=causes,
    )


def _friction_metrics(choice: FrictionChoice | None) -> dict[str, float]:
    """The chosen candidate's held-out NRMS (%) and whether it has rotor inertias, when the data chose."""
    if choice is None:
        return {}
    return {
        "friction_cv_nrms": float(100.0 * np.sqrt(choice.scores[choice.chosen])),
        "friction_candidates": float(len(choice.candidates)),
        "rotor_inertia_columns": float(choice.candidate.rotor),
    }


def score(
    robot: RobotModel,
    base: BaseParameters,
    estimator: Estimator,
    rows: IdentificationRows,
    fit: Fit,
    predictions: Predictions,
    tables: Tables,
    identifiability: IdentifiabilityReport,
    friction_choice: FrictionChoice | None,
    extrapolation: ExtrapolationReport,
) -> dict[str, float]:
    """The identification's metrics: conditioning, validation errors, interval coverage, sizes, timing,
    identifiability, the estimator's diagnostics, the friction choice, per-joint errors, the error
    against the truth (simulation) and the extrapolation's spread."""
    errors, scored = tables.errors, tables.scored
    metrics = {
        "cond_W_b": float(estimator.cond_),
        "residual_std": float(estimator.residual_std_),
        "rms_mean": float(errors["rms"][scored].mean()),
        "nrms_mean": float(np.nanmean(errors["nrms"][scored])),
        "fit_rel_error": ResidualSums.of(predictions.fit).relative_error,
        "validation_rel_error": float(np.mean([p.relative_error for p in predictions.validation])),
        "validation_interval_coverage": ResidualSums.of(predictions.validation).coverage,
        "fit_interval_coverage": ResidualSums.of(predictions.fit).coverage,
        **{f"validation_rel_error_{p.name}": p.relative_error for p in predictions.validation},
        "n_base_parameters": float(base.count),
        "n_rows": float(rows.statistics.rows),
        "fit_cpu_s": fit.cpu_s,
        "min_pseudo_inertia_eigenvalue": float(
            min_pseudo_inertia_eigenvalues(fit.standard, robot.n_links).min()
        ),
        **identifiability.metrics(),
        **{key: float(value) for key, value in getattr(estimator, "diagnostics_", {}).items()},
        **_friction_metrics(friction_choice),
        **coverage_metrics(predictions),
        **{f"rms_joint{j}": float(v) for j, v in enumerate(errors["rms"], start=1)},
        **{f"nrms_joint{j}": float(v) for j, v in enumerate(errors["nrms"], start=1)},
    }
    if tables.base_parameter_error is not None:
        metrics["base_parameter_error"] = tables.base_parameter_error
    return metrics | extrapolation.metrics()
