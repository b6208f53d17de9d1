"""Identification stage: motion → plant → processing → base-parameter estimation → cross-validation.

``identify`` is pure computation on configured objects and returns an :class:`IdentificationReport`;
:mod:`lwrlab.pipeline.identification_report` puts its tables, arrays and figures on disk, and
:mod:`lwrlab.pipeline.log_predictions` predicts each measurement. The tracking callback logs the
output directory to MLflow, so nothing here knows about MLflow or Hydra.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from lwrlab.dynamics.base_parameters import BaseParameters, compute_base_parameters
from lwrlab.dynamics.regressor import regressor
from lwrlab.errors import IdentifiabilityError
from lwrlab.identification.bootstrap import block_bootstrap
from lwrlab.identification.consistency import min_pseudo_inertia_eigenvalues
from lwrlab.identification.context import IdentificationContext
from lwrlab.identification.core import Estimator, torque_errors
from lwrlab.identification.extrapolation import (
    ExtrapolationReport,
    assess_extrapolation,
    likely_causes,
    validation_warning,
)
from lwrlab.identification.friction_choice import FrictionChoice, choose_friction
from lwrlab.identification.identifiability import (
    IdentifiabilityReport,
    assess_identifiability,
    format_prior_note,
)
from lwrlab.identification.identified import IdentifiedModel, standard_from_base
from lwrlab.identification.prior_weight import prior_doubts
from lwrlab.model.position_ranges import finite_range, range_span
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.config_nodes import processing_settings, resolved_mapping, statistics_settings
from lwrlab.pipeline.identification_report import format_report, write_report
from lwrlab.pipeline.identification_rows import identification_rows
from lwrlab.pipeline.log_predictions import (
    LogPrediction,
    PredictionInterval,
    ResidualSums,
    predict_measurement,
    process_measurement,
)
from lwrlab.plants.core import Measurement, Plant, is_recorded
from lwrlab.signal.processing import ProcessedData
from lwrlab.trajectory.core import MotionSource, Trajectory, check_limits

log = logging.getLogger(__name__)


@dataclass
class IdentificationReport:
    """Everything an identification produced, in memory."""

    robot: RobotModel
    base: BaseParameters
    identified: IdentifiedModel
    motion: Trajectory | None
    """The exciting motion played (None for recorded logs)."""
    validation_motion: Trajectory | None
    measurements: list[Measurement]
    """Identification measurements (one per log)."""
    validation_measurements: list[Measurement]
    parameters: pd.DataFrame
    """Per base parameter: cad, truth (simulation), estimate, std, %σ, relative error."""
    validation: pd.DataFrame
    """Per joint: RMS (N·m) and NRMS (%) over the validation samples, noise σ_τ if known."""
    predictions: list[LogPrediction]
    """The model's prediction on every identification and validation measurement."""
    identifiability: IdentifiabilityReport
    """What the data can determine (rank, cond, weak directions, still joints)."""
    extrapolation: ExtrapolationReport | None = None
    """How uncertain the predictions are on motions within the limits (None: not assessed)."""
    friction_choice: FrictionChoice | None = None
    """The friction law and rotor columns the data chose, with every candidate's held-out error
    (None: the law was fixed)."""
    notes: list[str] = field(default_factory=list)
    """What the processing chose per log, and the warnings to print with the result (identifiability,
    implausible logs)."""
    metrics: dict[str, float] = field(default_factory=dict)

    @property
    def measurement(self) -> Measurement:
        """The (first) identification measurement."""
        return self.measurements[0]

    @property
    def validation_measurement(self) -> Measurement:
        """The (first) validation measurement."""
        return self.validation_measurements[0]

    @property
    def validation_predictions(self) -> list[LogPrediction]:
        """Predictions on the validation measurements."""
        return [p for p in self.predictions if p.role == "validation"]

    @property
    def recorded(self) -> bool:
        """Whether the data came from recorded logs."""
        return self.motion is None

    @property
    def validation_times(self) -> np.ndarray:
        """Scored sample times (s) of the first validation measurement."""
        first = self.validation_predictions[0]
        return first.t[first.scored]

    @property
    def validation_measured(self) -> np.ndarray:
        """Measured torques (N·m) at :attr:`validation_times`."""
        first = self.validation_predictions[0]
        return first.measured[first.scored]

    @property
    def validation_estimated(self) -> np.ndarray:
        """Predicted torques (N·m) at :attr:`validation_times`."""
        first = self.validation_predictions[0]
        return first.predicted[first.scored]


def _sample_checked(
    source: MotionSource, robot: RobotModel, rate_hz: float, what: str, role: str
) -> Trajectory:
    motion = source.sample(robot, rate_hz)
    check_limits(motion, robot, torque=robot.inverse_dynamics(motion.q, motion.dq, motion.ddq), what=what)
    # the role tells a plant replaying recorded logs which log stands for this motion
    return replace(motion, metadata={**motion.metadata, "role": role})


def _named(measurement: Measurement, name: str, role: str) -> Measurement:
    return replace(measurement, metadata={**measurement.metadata, "name": name, "role": role})


def _as_chosen(processing: dict[str, Any], data: ProcessedData) -> dict[str, Any]:
    """``processing`` with the cut-off and velocity source that ``data``'s processing chose."""
    return {
        **processing,
        "cutoff_hz": data.cutoff_hz,
        "velocity": "logged" if data.velocity.logged else "differentiated",
    }


def _context(
    robot: RobotModel, base: BaseParameters, motion: Trajectory | None, data: ProcessedData
) -> IdentificationContext:
    """The estimator's context; the commanded motion's regressor only when the plant executed it."""
    reference = None
    if motion is not None:
        rows = data.raw_index
        reference = base.base_regressor(regressor(robot, motion.q[rows], motion.dq[rows], motion.ddq[rows]))
    return IdentificationContext.from_robot(robot, base, reference)


def _measurements(
    robot: RobotModel,
    motion_source: MotionSource | None,
    validation_source: MotionSource | None,
    plant: Plant,
    rate_hz: float,
) -> tuple[Trajectory | None, Trajectory | None, list[Measurement], list[Measurement]]:
    """Exciting and validation motions (None for recorded logs) and the measurements of each."""
    if is_recorded(plant):
        return None, None, plant.identification_measurements(), plant.validation_measurements()
    if motion_source is None or validation_source is None:
        raise ValueError("a simulated identification needs an exciting motion and a validation motion")
    motion = _sample_checked(motion_source, robot, rate_hz, "exciting motion", "excitation")
    validation_motion = _sample_checked(
        validation_source, robot, rate_hz, "cross-validation motion", "validation"
    )
    return (
        motion,
        validation_motion,
        [_named(plant.measure(motion), "exciting_motion", "identification")],
        [_named(plant.measure(validation_motion), "validation_motion", "validation")],
    )


def identify(
    robot: RobotModel,
    motion_source: MotionSource | None,
    validation_source: MotionSource | None,
    plant: Plant,
    estimator: Estimator,
    rate_hz: float = 1000.0,
    processing: dict[str, Any] | None = None,
    statistics: dict[str, Any] | None = None,
) -> IdentificationReport:
    """Identify the base parameters of the robot behind ``plant`` and validate them.

    Parameters
    ----------
    robot : the nominal (CAD) model: its structure gives the base parameters, its torques check
        the motions against the limits, its values are the prior of the standard set.
    motion_source, validation_source : the exciting motion and the validation motion; not used
        (may be None) for a plant that replays recorded logs: the logs are the motions.
    plant : the robot (simulated, or recorded logs) that executes them.
    estimator : fits base parameters to the processed data, as ``estimator.fit(W_b, τ, context=...)``
        with the :class:`IdentificationContext` of this identification.
    rate_hz : sampling rate of a simulated measurement (Hz).
    processing : keyword arguments of :func:`lwrlab.signal.processing.process`.
    statistics : ``{"resamples": n, "block_s": s, "confidence": c, "seed": k}`` (the ``statistics``
        group's settings, all four): with n > 0, block bootstrap confidence intervals
        (:func:`lwrlab.identification.bootstrap.block_bootstrap`) are added to the parameter table.
    """
    processing = dict(processing or {})
    base = compute_base_parameters(robot)
    motion, validation_motion, measurements, validation_measurements = _measurements(
        robot, motion_source, validation_source, plant, rate_hz
    )

    processed = [process_measurement(m, processing) for m in measurements]
    fitted = getattr(plant, "fitted_joints", None)  # (N_J,) bool, or None: every joint
    chosen, friction_choice = choose_friction(robot, base, processed, joints=fitted)
    if chosen.friction_terms != robot.friction_terms:  # a law's own terms, rotor inertias
        base = compute_base_parameters(chosen)
    robot = chosen
    if fitted is not None:
        base = _seen_by(base, robot, fitted)
    log.info("%s: %d base parameters", robot.name, base.count)
    bootstrap = statistics is not None and statistics["resamples"] > 0
    rows = identification_rows(robot, base, processed, estimator, keep_rows=bootstrap)
    if fitted is not None:
        rows = rows.only_joints(fitted)
    q, dq, ddq = rows.q, rows.dq, rows.ddq  # the joint states at the rows
    identifiability = assess_identifiability(
        rows.statistics.factor()[: base.count, : base.count],
        base.names,
        q,
        dq,
        ddq,
        robot.limits,
        factor=True,
    )
    has_prior = bool(getattr(estimator, "uses_prior", False))
    if identifiability.status == "rank_deficient" and not has_prior:
        raise IdentifiabilityError(
            f"{identifiability.warning_text().removeprefix('WARNING: ')}\n"
            "The data cannot determine these parameters: excite the named joints more, or use an "
            "estimator with a prior (estimator=sdp)."
        )
    context = _context(robot, base, motion, processed[0])
    cpu_start = time.process_time()
    rows.fit(estimator, context)
    fit_cpu_s = time.process_time() - cpu_start
    standard = getattr(estimator, "standard_phi_", None)  # physically consistent estimators give it
    if standard is None:
        standard = standard_from_base(base, estimator.phi_, robot.parameters)
    identified = IdentifiedModel(
        base.names, estimator.phi_.copy(), estimator.std_.copy(), robot.parameter_names, standard
    )

    # An identification log is predicted with the cut-off and velocity source its fit used; a
    # validation log gets its own, as a new log would.
    covariance = np.asarray(estimator.covariance_)
    fit_predictions = [
        replace(
            predict_measurement(robot, base, estimator.phi_, m, _as_chosen(processing, data), covariance),
            role="identification",
            joints=fitted,
        )
        for m, data in zip(measurements, processed, strict=True)
    ]
    in_sample = rows.statistics.residual_squares(estimator.phi_).sum(axis=0) / (
        rows.statistics.rows // robot.n_joints
    )
    band = prediction_interval(estimator, fit_predictions, in_sample)
    fit_predictions = [band.around(p) for p in fit_predictions]
    validation_predictions = [
        band.around(
            replace(
                predict_measurement(robot, base, estimator.phi_, m, processing, covariance),
                role="validation",
                joints=fitted,
            )
        )
        for m in validation_measurements
    ]
    predictions = fit_predictions + validation_predictions
    measured = np.vstack([p.measured[p.scored] for p in validation_predictions])
    estimated = np.vstack([p.predicted[p.scored] for p in validation_predictions])
    errors = torque_errors(measured, estimated)

    noise = validation_measurements[0].metadata.get("torque_noise_std")
    validation = pd.DataFrame(
        {"rms": errors["rms"], "nrms": errors["nrms"]},
        index=pd.Index(range(1, robot.n_joints + 1), name="joint"),
    )
    if noise is not None:
        validation["noise_std"] = noise
    scored = np.ones(robot.n_joints, dtype=bool) if fitted is None else fitted
    validation["fitted"] = scored

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
    if statistics is not None and rows.w_base is not None and rows.tau is not None and bootstrap:
        interval = block_bootstrap(
            estimator,
            rows.w_base,
            rows.tau,
            robot.n_joints,
            block_samples=max(1, round(statistics["block_s"] * processed[0].rate_hz)),
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
    metrics = {
        "cond_W_b": float(estimator.cond_),
        "residual_std": float(estimator.residual_std_),
        "rms_mean": float(errors["rms"][scored].mean()),
        "nrms_mean": float(np.nanmean(errors["nrms"][scored])),
        "fit_rel_error": ResidualSums.of(fit_predictions).relative_error,
        "validation_rel_error": float(np.mean([p.relative_error for p in validation_predictions])),
        "validation_interval_coverage": ResidualSums.of(validation_predictions).coverage,
        "fit_interval_coverage": ResidualSums.of(fit_predictions).coverage,
        **{f"validation_rel_error_{p.name}": p.relative_error for p in validation_predictions},
        "n_base_parameters": float(base.count),
        "n_rows": float(rows.statistics.rows),
        "fit_cpu_s": fit_cpu_s,
        "min_pseudo_inertia_eigenvalue": float(min_pseudo_inertia_eigenvalues(standard, robot.n_links).min()),
        **identifiability.metrics(),
        **{key: float(value) for key, value in getattr(estimator, "diagnostics_", {}).items()},
        **_friction_metrics(friction_choice),
        **{f"rms_joint{j}": float(v) for j, v in enumerate(errors["rms"], start=1)},
        **{f"nrms_joint{j}": float(v) for j, v in enumerate(errors["nrms"], start=1)},
    }
    truth = getattr(plant, "truth", None)
    if truth is not None:
        true_base = base.base_values(truth.robot.parameters)
        parameters.insert(1, "truth", true_base)
        with np.errstate(divide="ignore", invalid="ignore"):
            parameters["relative_error"] = np.abs(estimator.phi_ - true_base) / np.abs(true_base)
        metrics["base_parameter_error"] = float(
            np.linalg.norm(estimator.phi_ - true_base) / np.linalg.norm(true_base)
        )
    causes = _likely_causes(robot, measurements, q, dq)
    extrapolation = _extrapolation(robot, base, estimator, causes)
    metrics |= extrapolation.metrics()
    notes = [
        f"processing of {m.name}: {data.describe()}" for m, data in zip(measurements, processed, strict=True)
    ]
    notes += (
        []
        if robot.drive_train.is_direct and not robot.drive_train.motor_side
        else [f"drive train: {robot.drive_train.describe()}"]
    )
    notes += [friction_choice.describe()] if friction_choice is not None else []
    if fitted is not None:
        notes.append(
            "joints left out of the fit and the errors (data.fitted_joints): "
            + ", ".join(name for name, kept in zip(robot.joint_names, fitted, strict=True) if not kept)
        )
    notes += [] if identifiability.ok else [identifiability.warning_text()]
    notes += [
        extrapolation.warning_text(),
        validation_warning(metrics["fit_rel_error"], metrics["validation_rel_error"], causes),
    ]
    if not identifiability.ok and has_prior:
        notes.append(format_prior_note(identifiability))
    notes.append(_prior_note(base.names, share))
    doubts = prior_doubts(robot.parameters, robot.n_links) if has_prior else []
    if doubts:
        notes.append(
            f"NOTE: the robot's inertials look like placeholders ({'; '.join(doubts)}): the prior only "
            "regularises what the data leave open; parameters said to come from it carry its values"
        )
    notes += [
        f"WARNING: {w}"
        for m in [*measurements, *validation_measurements]
        for w in m.metadata.get("warnings", [])
    ]
    return IdentificationReport(
        robot=robot,
        base=base,
        identified=identified,
        identifiability=identifiability,
        extrapolation=extrapolation,
        friction_choice=friction_choice,
        notes=[n for n in notes if n],
        motion=motion,
        validation_motion=validation_motion,
        measurements=measurements,
        validation_measurements=validation_measurements,
        parameters=parameters,
        validation=validation,
        predictions=predictions,
        metrics=metrics,
    )


def _seen_by(base: BaseParameters, robot: RobotModel, fitted: np.ndarray) -> BaseParameters:
    """``base`` without the per-drive parameters of drives that load only joints left out of the fit
    (their friction cannot be seen, and is not needed to predict the fitted joints: it stays at the
    robot's values)."""
    coupling = robot.drive_train.coupling
    unseen_drives = ~np.any((coupling != 0.0) & fitted[None, :], axis=1)
    first = 10 * robot.n_links
    unseen = {
        first + t * robot.n_joints + m
        for t in range(len(robot.friction_terms))
        for m in np.flatnonzero(unseen_drives)
    }
    keep = np.array([column not in unseen for column in base.columns])
    return replace(
        base,
        columns=base.columns[keep],
        regrouping=base.regrouping[keep],
        names=tuple(name for name, kept in zip(base.names, keep, strict=True) if kept),
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


def _likely_causes(
    robot: RobotModel, measurements: list[Measurement], q: np.ndarray, dq: np.ndarray
) -> tuple[str, ...]:
    limits = robot.limits
    return likely_causes(
        q,
        dq,
        duration_s=float(sum(m.t[-1] - m.t[0] for m in measurements)),
        position_range=range_span(limits.position_lower, limits.position_upper),  # continuous: 2π
        velocity_limit=limits.velocity,
    )


def _extrapolation(
    robot: RobotModel, base: BaseParameters, estimator: Estimator, causes: tuple[str, ...]
) -> ExtrapolationReport:
    """The spread of the model's predictions over the joint limits (unknown acceleration limits:
    5 × the velocity limit per second, about what arms reach)."""
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


def prediction_interval(
    estimator: Estimator, fit_predictions: list[LogPrediction], in_sample: np.ndarray
) -> PredictionInterval:
    """The interval of the model's predictions on a new motion, from its fit.

    Per joint, the model error is the residual on the identification logs as logged (sensor noise
    and unmodelled dynamics), plus what cross-validation adds beyond ``in_sample`` (N·m², the mean
    square residual per joint on the fitted rows) in the worst held-out block of the joint, when the
    estimator measured it (``cv_worst_joint_rms_``): a motion not in the fit is taken to be as new as
    the block of the fit least like the rest (measured on the real LWR4+: the pooled blocks instead
    cover 83 % of new motions' samples with a 95 % band, the worst block 89 %). Without it the
    interval is the in-sample one, and its coverage on the validation logs says how far that is from
    the truth.
    """
    error_variance = ResidualSums.of(fit_predictions).mean_square
    held_out = getattr(estimator, "cv_worst_joint_rms_", None)
    if held_out is not None:
        error_variance = error_variance + np.clip(np.asarray(held_out) ** 2 - in_sample, 0.0, None)
    return PredictionInterval(np.sqrt(error_variance))


def _prior_note(names: tuple[str, ...] | list[str], share: np.ndarray | None, threshold: float = 0.5) -> str:
    """A line naming the base parameters whose estimate came mostly from the prior ('' if none)."""
    if share is None:
        return ""
    leaning = [f"{name} ({100 * s:.0f} %)" for name, s in zip(names, share, strict=True) if s > threshold]
    if not leaning:
        return ""
    return (
        f"{len(leaning)} of {len(names)} base parameters come mostly from the prior (the robot's CAD/URDF "
        f"inertials), not the data — the motion barely excites them: {', '.join(leaning)}"
    )


def configured_robot(cfg: Any) -> RobotModel:
    """The robot ``cfg.robot`` builds, with the friction law of ``cfg.friction`` (``auto``: the
    candidates :func:`identify` chooses from); a robot description that names its own law keeps it."""
    from hydra.utils import instantiate

    robot: RobotModel = instantiate(cfg.robot)
    law = cfg.get("friction")
    if law is None or cfg.robot.get("friction_law") is not None:
        return robot
    return robot.with_friction_law(instantiate(law))


def identify_configured(cfg: Any) -> IdentificationReport:
    """:func:`identify` with the objects ``cfg`` configures (robot, motions, plant, estimator, processing)."""
    from hydra.utils import instantiate

    robot = configured_robot(cfg)
    plant = instantiate(cfg.plant)(robot=robot)
    recorded = is_recorded(plant)  # logs: no motion is sampled, optimised or checked
    return identify(
        robot=robot,
        motion_source=None if recorded else instantiate(cfg.trajectory),
        validation_source=None if recorded else instantiate(cfg.validation),
        plant=plant,
        estimator=instantiate(cfg.estimator),
        rate_hz=cfg.measurement.rate_hz,
        processing=processing_settings(cfg),
        statistics=statistics_settings(cfg),
    )


def run_identification(cfg: Any, output_dir: Path, motion_format: str = "parquet") -> dict[str, float]:
    """Task ``identification``: build the configured objects, identify, write and print the report."""
    report = identify_configured(cfg)
    write_report(report, output_dir, resolved_mapping(cfg.robot, "robot"), motion_format)
    print(format_report(report))
    return report.metrics
