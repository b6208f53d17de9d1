"""Identification stage: motion → plant → processing → base-parameter estimation → cross-validation.

``identify`` is pure computation on configured objects and returns an :class:`IdentificationReport`;
``write_report`` puts its tables, arrays and figures on disk. The tracking callback logs that
directory to MLflow, so nothing here knows about MLflow or Hydra.
"""

from __future__ import annotations

import json
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
from lwrlab.figures.residuals import residuals_per_log
from lwrlab.figures.torques import error_per_joint, torque_overlay
from lwrlab.identification.bootstrap import block_bootstrap
from lwrlab.identification.consistency import min_pseudo_inertia_eigenvalues
from lwrlab.identification.context import IdentificationContext
from lwrlab.identification.core import Estimator, torque_errors
from lwrlab.identification.identifiability import (
    IdentifiabilityReport,
    assess_identifiability,
    format_prior_note,
)
from lwrlab.identification.identified import IdentifiedModel, standard_from_base
from lwrlab.io.artifacts import save_identified_model, save_measurement, save_trajectory
from lwrlab.io.urdf_export import export_urdf
from lwrlab.model.robot import RobotModel
from lwrlab.plants.core import Measurement, Plant
from lwrlab.signal.processing import ProcessedData, process
from lwrlab.trajectory.core import MotionSource, Trajectory, check_limits

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class LogPrediction:
    """The model's torque prediction on one measurement, at its samples as logged."""

    name: str
    """The log's name (file stem), or the motion's role for simulated data."""
    role: str
    """``identification`` or ``validation``."""
    t: np.ndarray
    """(M,) times as logged (s)."""
    measured: np.ndarray
    """(M, N_J) measured torques as logged (N·m)."""
    predicted: np.ndarray
    """(M, N_J) predicted torques τ̂ = W(q, q̇, q̈)·φ̂ (N·m)."""
    scored: np.ndarray
    """(M,) samples inside the trimmed span, where the filtered states are free of edge transients."""
    processing: str
    """What the processing chose for this log (cut-off, velocity source)."""

    @property
    def relative_error(self) -> float:
        """‖τ − τ̂‖/‖τ‖ over all joints and scored samples."""
        measured = self.measured[self.scored]
        return float(np.linalg.norm(measured - self.predicted[self.scored]) / np.linalg.norm(measured))


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


def _process(
    measurement: Measurement, processing: dict[str, Any], every_sample: bool = False
) -> ProcessedData:
    return process(
        measurement.t, measurement.q, measurement.tau, measurement.dq, every_sample=every_sample, **processing
    )


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


def predict_measurement(
    robot: RobotModel,
    base: BaseParameters,
    phi: np.ndarray,
    measurement: Measurement,
    processing: dict[str, Any],
) -> LogPrediction:
    """τ̂ = W(q, q̇, q̈)·φ at every sample of ``measurement`` as logged (states filtered as for the fit)."""
    data = _process(measurement, processing, every_sample=True)
    predicted = (base.base_regressor(regressor(robot, data.q, data.dq, data.ddq)) @ phi).reshape(
        -1, robot.n_joints
    )
    t, measured = measurement.as_logged()
    if t is not measurement.t:  # resampled log: back to the logged samples
        predicted = np.column_stack([np.interp(t, data.t, predicted[:, j]) for j in range(robot.n_joints)])
    span = data.row_times
    scored = (t >= span[0] - 1e-9) & (t <= span[-1] + 1e-9)
    cutoff = "no filter" if data.cutoff_hz is None else f"{data.cutoff_hz:.3g} Hz"
    velocity = "logged q̇" if data.velocity.logged else "q̇ = d/dt q"
    return LogPrediction(
        measurement.name,
        str(measurement.metadata.get("role", "")),
        t,
        measured,
        predicted,
        scored,
        f"{cutoff}, {velocity}",
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
    log.info("%s: %d base parameters", robot.name, base.count)
    if getattr(plant, "recorded", False):
        motion = validation_motion = None
        measurements = plant.identification_measurements()
        validation_measurements = plant.validation_measurements()
    else:
        if motion_source is None or validation_source is None:
            raise ValueError("a simulated identification needs an exciting motion and a validation motion")
        motion = _sample_checked(motion_source, robot, rate_hz, "exciting motion", "excitation")
        validation_motion = _sample_checked(
            validation_source, robot, rate_hz, "cross-validation motion", "validation"
        )
        measurements = [_named(plant.measure(motion), "exciting_motion", "identification")]
        validation_measurements = [
            _named(plant.measure(validation_motion), "validation_motion", "validation")
        ]

    processed = [_process(m, processing) for m in measurements]
    rows = [
        data.rows(lambda q, dq, ddq: base.base_regressor(regressor(robot, q, dq, ddq))) for data in processed
    ]
    w_base = np.vstack([w for w, _ in rows])
    tau = np.concatenate([t for _, t in rows])
    identifiability = assess_identifiability(
        w_base,
        base.names,
        *(np.vstack([getattr(d, name)[d.index] for d in processed]) for name in ("q", "dq", "ddq")),
        robot.limits,
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
    estimator.fit(w_base, tau, context=context)
    fit_cpu_s = time.process_time() - cpu_start
    standard = getattr(estimator, "standard_phi_", None)  # physically consistent estimators give it
    if standard is None:
        standard = standard_from_base(base, estimator.phi_, robot.parameters)
    identified = IdentifiedModel(
        base.names, estimator.phi_.copy(), estimator.std_.copy(), robot.parameter_names, standard
    )

    # An identification log is predicted with the cut-off and velocity source its fit used; a
    # validation log gets its own, as a new log would.
    fit_predictions = [
        replace(
            predict_measurement(robot, base, estimator.phi_, m, _as_chosen(processing, data)),
            role="identification",
        )
        for m, data in zip(measurements, processed, strict=True)
    ]
    validation_predictions = [
        replace(predict_measurement(robot, base, estimator.phi_, m, processing), role="validation")
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

    parameters = pd.DataFrame(
        {
            "cad": base.base_values(robot.parameters),
            "estimate": estimator.phi_,
            "std": estimator.std_,
            "relative_std": estimator.relative_std_,
        },
        index=pd.Index(base.names, name="parameter"),
    )
    if statistics is not None and statistics["resamples"] > 0:
        interval = block_bootstrap(
            estimator,
            w_base,
            tau,
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
    fit_measured = np.vstack([p.measured[p.scored] for p in fit_predictions])
    fit_estimated = np.vstack([p.predicted[p.scored] for p in fit_predictions])
    metrics = {
        "cond_W_b": float(estimator.cond_),
        "residual_std": float(estimator.residual_std_),
        "rms_mean": float(errors["rms"].mean()),
        "nrms_mean": float(np.nanmean(errors["nrms"])),
        "fit_rel_error": float(np.linalg.norm(fit_measured - fit_estimated) / np.linalg.norm(fit_measured)),
        "validation_rel_error": float(np.mean([p.relative_error for p in validation_predictions])),
        **{f"validation_rel_error_{p.name}": p.relative_error for p in validation_predictions},
        "n_base_parameters": float(base.count),
        "n_rows": float(w_base.shape[0]),
        "fit_cpu_s": fit_cpu_s,
        "min_pseudo_inertia_eigenvalue": float(min_pseudo_inertia_eigenvalues(standard, robot.n_links).min()),
        **identifiability.metrics(),
        **{key: float(value) for key, value in getattr(estimator, "diagnostics_", {}).items()},
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
    notes = [
        f"processing of {m.name}: {data.describe()}" for m, data in zip(measurements, processed, strict=True)
    ]
    notes += [] if identifiability.ok else [identifiability.warning_text()]
    if not identifiability.ok and has_prior:
        notes.append(format_prior_note(identifiability))
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


def _data_heading(report: IdentificationReport) -> str:
    if report.recorded:
        return "validation logs, not used for identification"
    duration = report.validation_motion.t[-1] - report.validation_motion.t[0]
    return f"{duration:.0f} s motion not used for identification"


def prediction_table(report: IdentificationReport) -> pd.DataFrame:
    """Per measurement: role, samples, ‖τ − τ̂‖/‖τ‖ (%) and what the processing chose."""
    return pd.DataFrame(
        {
            "role": [p.role for p in report.predictions],
            "samples": [int(p.scored.sum()) for p in report.predictions],
            "rel_error_%": [100 * p.relative_error for p in report.predictions],
            "cut-off, velocity": [p.processing for p in report.predictions],
        },
        index=pd.Index([p.name for p in report.predictions], name="log"),
    )


def format_report(report: IdentificationReport) -> str:
    """The tables of an identification as Markdown: base parameters, per-log errors, validation per joint."""
    parameters = report.parameters.copy()
    parameters["relative_std"] = parameters["relative_std"].round(3)
    fit_names = ", ".join(p.name for p in report.predictions if p.role == "identification")
    validation_names = ", ".join(p.name for p in report.validation_predictions)
    lines = [
        f"## Base parameters of {report.robot.name} ({report.base.count}), identified from {fit_names}",
        "",
        parameters.to_markdown(floatfmt=".5g"),
        "",
        "## Torque prediction per log (‖τ − τ̂‖/‖τ‖ at the logged samples)",
        "",
        prediction_table(report).to_markdown(floatfmt=".4g"),
        "",
        f"## Validation torque error per joint ({validation_names}: {_data_heading(report)})",
        "",
        report.validation.to_markdown(floatfmt=".4g"),
        "",
        f"fit ‖τ−τ̂‖/‖τ‖ {100 * report.metrics['fit_rel_error']:.3g} %, validation ‖τ−τ̂‖/‖τ‖ "
        f"{100 * report.metrics['validation_rel_error']:.3g} % (mean over validation logs); "
        f"mean RMS {report.metrics['rms_mean']:.4g} N·m, mean NRMS "
        f"{report.metrics['nrms_mean']:.4g} % (RMS over the measured range), "
        f"cond(W_b) {report.metrics['cond_W_b']:.4g}, smallest pseudo-inertia eigenvalue "
        f"{report.metrics['min_pseudo_inertia_eigenvalue']:.3g} of the reported standard set (< 0: "
        "not a rigid body)",
    ]
    resampled = [
        m.name for m in [*report.measurements, *report.validation_measurements] if m.metadata.get("resampled")
    ]
    if resampled:
        lines.append(
            f"NOTE: irregular time stamps in {', '.join(resampled)}: processed on a uniform grid, "
            "scored at the logged samples"
        )
    lines.append(report.identifiability.summary())
    lines += report.notes
    if report.metrics.get("solver_fallback"):
        lines.append(
            "WARNING: the estimator's primary solver failed; the result comes from its fallback solver"
        )
    if "base_parameter_error" in report.metrics:
        lines.append(
            f"relative base-parameter error ‖β̂ − β‖/‖β‖ = {report.metrics['base_parameter_error']:.3g}"
        )
    return "\n".join(lines)


def predicted_torque_frame(report: IdentificationReport) -> pd.DataFrame:
    """Measured and predicted torques of every log at its logged samples.

    Columns ``log, role, t, scored, tau1…N, tau_hat1…N``.
    """
    n = report.robot.n_joints
    frames = []
    for p in report.predictions:
        frame = pd.DataFrame({"log": p.name, "role": p.role, "t": p.t, "scored": p.scored})
        frame[[f"tau{j}" for j in range(1, n + 1)]] = p.measured
        frame[[f"tau_hat{j}" for j in range(1, n + 1)]] = p.predicted
        frames.append(frame)
    return pd.concat(frames, ignore_index=True)


RUN_TAGS_FILE = "tags.json"
"""Tags a run carries beside its metrics: what a reader must know before trusting the numbers."""


def run_tags(report: IdentificationReport) -> dict[str, str]:
    """Run tags: ``identifiability`` (good, poor, rank_deficient), ``warnings`` (count), ``data``
    (logs or simulation)."""
    warnings = sum(
        len(m.metadata.get("warnings", [])) for m in [*report.measurements, *report.validation_measurements]
    )
    return {
        "identifiability": report.identifiability.status,
        "warnings": str(warnings + (0 if report.identifiability.ok else 1)),
        "data": "logs" if report.recorded else "simulation",
    }


def write_report(
    report: IdentificationReport,
    output_dir: Path,
    robot_config: dict[str, Any],
    motion_format: str = "parquet",
) -> dict[str, Path]:
    """Write tables (CSV, Markdown), predicted torques (Parquet), the identified model (YAML) and figures.

    ``motion_format``: ``parquet`` (default) or ``csv`` for the 1 kHz motions played (CSV: what a
    robot controller reads).
    """
    if motion_format not in ("parquet", "csv"):
        raise ValueError(f"motion_format must be parquet or csv, got {motion_format!r}")
    output_dir.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}
    if (
        not report.recorded
    ):  # simulated: the motions played and what the sensors gave (a log holds them already)
        files["trajectory"] = save_trajectory(report.motion, output_dir / f"exciting_motion.{motion_format}")
        files["validation_trajectory"] = save_trajectory(
            report.validation_motion, output_dir / f"validation_motion.{motion_format}"
        )
        files["measurement"] = save_measurement(report.measurement, output_dir / "measurement.npz")
        files["validation_measurement"] = save_measurement(
            report.validation_measurement, output_dir / "validation_measurement.npz"
        )
    files["identified_model"] = save_identified_model(
        report.identified, robot_config, output_dir / "identified_model.yaml"
    )
    if (
        report.metrics["min_pseudo_inertia_eigenvalue"] >= 0.0
    ):  # URDF only for real rigid bodies (e.g. estimator=sdp)
        identified_robot = report.robot.with_parameters(report.identified.standard_values)
        files["urdf"] = export_urdf(
            identified_robot, output_dir / "identified_model.urdf", f"{report.robot.name}_identified"
        )
    files["parameters"] = output_dir / "base_parameters.csv"
    report.parameters.to_csv(files["parameters"])
    files["validation"] = output_dir / "cross_validation.csv"
    report.validation.to_csv(files["validation"])
    files["predictions"] = output_dir / "prediction_errors.csv"
    prediction_table(report).to_csv(files["predictions"])
    files["predicted_torque"] = output_dir / "predicted_torque.parquet"
    predicted_torque_frame(report).to_parquet(files["predicted_torque"], index=False)
    files["summary"] = output_dir / "summary.md"
    files["summary"].write_text(format_report(report) + "\n")
    files["metrics"] = output_dir / "metrics.json"
    files["metrics"].write_text(json.dumps(report.metrics, indent=2))
    files["tags"] = output_dir / RUN_TAGS_FILE  # the tracking callback tags the run with these
    files["tags"].write_text(json.dumps(run_tags(report), indent=2))
    first = report.validation_predictions[0]
    files["torque_overlay"] = torque_overlay(
        report.validation_times,
        report.validation_measured,
        report.validation_estimated,
        output_dir / "torque_overlay.png",
        f"Validation ({first.name}): measured vs estimated joint torques",
    )
    noise = report.validation["noise_std"].to_numpy() if "noise_std" in report.validation else None
    files["error_per_joint"] = error_per_joint(
        report.validation["rms"].to_numpy(),
        report.validation["nrms"].to_numpy(),
        output_dir / "error_per_joint.png",
        "Validation torque error per joint",
        noise,
    )
    files["residuals"] = residuals_per_log(
        [p.name for p in report.predictions],
        [p.role for p in report.predictions],
        [p.t for p in report.predictions],
        [p.measured - p.predicted for p in report.predictions],
        output_dir / "residuals_per_log.png",
    )
    return files


def identify_configured(cfg: Any) -> IdentificationReport:
    """:func:`identify` with the objects ``cfg`` configures (robot, motions, plant, estimator, processing)."""
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    robot = instantiate(cfg.robot)
    plant = instantiate(cfg.plant)(robot=robot)
    recorded = getattr(plant, "recorded", False)  # logs: no motion is sampled, optimised or checked
    return identify(
        robot=robot,
        motion_source=None if recorded else instantiate(cfg.trajectory),
        validation_source=None if recorded else instantiate(cfg.validation),
        plant=plant,
        estimator=instantiate(cfg.estimator),
        rate_hz=cfg.measurement.rate_hz,
        processing=OmegaConf.to_container(cfg.measurement.processing, resolve=True),
        statistics=OmegaConf.to_container(cfg.statistics, resolve=True) if "statistics" in cfg else None,
    )


def run_identification(cfg: Any, output_dir: Path, motion_format: str = "parquet") -> dict[str, float]:
    """Task ``identification``: build the configured objects, identify, write and print the report."""
    from omegaconf import OmegaConf

    report = identify_configured(cfg)
    write_report(report, output_dir, OmegaConf.to_container(cfg.robot, resolve=True), motion_format)
    print(format_report(report))
    return report.metrics
