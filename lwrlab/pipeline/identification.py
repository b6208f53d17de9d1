"""Identification stage: motion → plant → processing → base-parameter estimation → cross-validation.

``identify`` is pure computation on configured objects and returns an :class:`IdentificationReport`;
``write_report`` puts its tables, arrays and figures on disk. The tracking callback logs that
directory to MLflow, so nothing here knows about MLflow or Hydra.
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from lwrlab.dynamics.base_parameters import BaseParameters, compute_base_parameters
from lwrlab.dynamics.regressor import regressor
from lwrlab.identification.bootstrap import block_bootstrap
from lwrlab.identification.consistency import min_pseudo_inertia_eigenvalues
from lwrlab.identification.context import IdentificationContext, bind_estimator
from lwrlab.identification.core import Estimator, torque_errors
from lwrlab.identification.identified import IdentifiedModel, standard_from_base
from lwrlab.io.artifacts import save_identified_model, save_measurement, save_trajectory_csv
from lwrlab.io.urdf_export import export_urdf
from lwrlab.model.robot import RobotModel
from lwrlab.plants.core import Measurement, Plant
from lwrlab.signal.processing import ProcessedData, process
from lwrlab.tracking.figures import error_per_joint, torque_overlay
from lwrlab.trajectory.core import MotionSource, Trajectory, check_limits

log = logging.getLogger(__name__)


@dataclass
class IdentificationReport:
    """Everything an identification produced, in memory."""

    robot: RobotModel
    base: BaseParameters
    identified: IdentifiedModel
    motion: Trajectory
    validation_motion: Trajectory
    measurement: Measurement
    validation_measurement: Measurement
    parameters: pd.DataFrame
    """Per base parameter: cad, truth (simulation), estimate, std, %σ, relative error."""
    validation: pd.DataFrame
    """Per joint: RMS (N·m) and NRMS (%) on the cross-validation motion, noise σ_τ if known."""
    validation_times: np.ndarray
    validation_measured: np.ndarray
    validation_estimated: np.ndarray
    metrics: dict[str, float] = field(default_factory=dict)


def _sample_checked(source: MotionSource, robot: RobotModel, rate_hz: float, what: str, role: str) -> Trajectory:
    motion = source.sample(robot, rate_hz)
    check_limits(motion, robot, torque=robot.inverse_dynamics(motion.q, motion.dq, motion.ddq), what=what)
    # the role tells a plant replaying recorded logs which log stands for this motion
    return replace(motion, metadata={**motion.metadata, "role": role})


def _base_regressor(robot: RobotModel, base: BaseParameters, data: ProcessedData) -> np.ndarray:
    return base.base_regressor(regressor(robot, data.q, data.dq, data.ddq))


def _context(robot: RobotModel, base: BaseParameters, plant: Plant, motion: Trajectory, data: ProcessedData) -> IdentificationContext:
    """The estimator's context; the commanded motion's regressor only when the plant executed it."""
    reference = None
    if not getattr(plant, "recorded", False):
        reference = base.base_regressor(regressor(robot, motion.q[data.index], motion.dq[data.index], motion.ddq[data.index]))
    return IdentificationContext.from_robot(robot, base, reference)


def identify(
    robot: RobotModel,
    motion_source: MotionSource,
    validation_source: MotionSource,
    plant: Plant,
    estimator: Estimator | Callable[..., Estimator],
    rate_hz: float = 1000.0,
    processing: dict[str, Any] | None = None,
    statistics: dict[str, Any] | None = None,
) -> IdentificationReport:
    """Identify the base parameters of the robot behind ``plant`` and cross-validate them.

    Parameters
    ----------
    robot : the nominal (CAD) model: its structure gives the base parameters, its torques check
        the motions against the limits, its values are the prior of the standard set.
    motion_source, validation_source : the exciting motion and the cross-validation motion.
    plant : the robot (simulated or replayed) that executes them.
    estimator : fits base parameters to the processed data; a callable without ``fit`` (a
        ``_partial_`` config) is called with ``context=`` (:class:`IdentificationContext`) first.
    rate_hz : sampling rate of the measurement (Hz).
    processing : keyword arguments of :func:`lwrlab.signal.processing.process`.
    statistics : ``{"resamples": n, "block_s": s, "confidence": c, "seed": k}``: with n > 0, block
        bootstrap confidence intervals (:func:`lwrlab.identification.bootstrap.block_bootstrap`)
        are added to the parameter table.
    """
    processing = dict(processing or {})
    base = compute_base_parameters(robot)
    log.info("%s: %d base parameters", robot.name, base.count)
    motion = _sample_checked(motion_source, robot, rate_hz, "exciting motion", "excitation")
    validation_motion = _sample_checked(validation_source, robot, rate_hz, "cross-validation motion", "validation")

    measurement = plant.measure(motion)
    data = process(measurement.t, measurement.q, measurement.tau, **processing)
    w_base = _base_regressor(robot, base, data)
    if not hasattr(estimator, "fit"):  # a `_partial_` estimator config: it needs the context
        estimator = bind_estimator(estimator, _context(robot, base, plant, motion, data))
    cpu_start = time.process_time()
    estimator.fit(w_base, data.tau.ravel())
    fit_cpu_s = time.process_time() - cpu_start
    standard = getattr(estimator, "standard_phi_", None)  # physically consistent estimators give it
    if standard is None:
        standard = standard_from_base(base, estimator.phi_, robot.parameters)
    identified = IdentifiedModel(base.names, estimator.phi_.copy(), estimator.std_.copy(), robot.parameter_names, standard)

    validation_measurement = plant.measure(validation_motion)
    validation_data = process(validation_measurement.t, validation_measurement.q, validation_measurement.tau, **processing)
    estimated = estimator.predict(_base_regressor(robot, base, validation_data)).reshape(-1, robot.n_joints)
    measured = validation_measurement.tau[validation_data.index]  # raw: the noise floor is σ_τ
    errors = torque_errors(measured, estimated)

    noise = validation_measurement.metadata.get("torque_noise_std")
    validation = pd.DataFrame(
        {"rms": errors["rms"], "nrms": errors["nrms"]}, index=pd.Index(range(1, robot.n_joints + 1), name="joint")
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
    statistics = dict(statistics or {})
    if statistics.get("resamples", 0) > 0:
        interval = block_bootstrap(
            estimator, w_base, data.tau.ravel(), robot.n_joints,
            block_samples=int(round(statistics.get("block_s", 1.0) / float(np.mean(np.diff(data.t))))),
            resamples=int(statistics["resamples"]), confidence=float(statistics.get("confidence", 0.95)), seed=int(statistics.get("seed", 0)),
        )
        parameters["ci_lower"], parameters["ci_upper"], parameters["bootstrap_std"] = interval.lower, interval.upper, interval.std
    metrics = {
        "cond_W_b": float(estimator.cond_),
        "residual_std": float(estimator.residual_std_),
        "rms_mean": float(errors["rms"].mean()),
        "nrms_mean": float(np.nanmean(errors["nrms"])),
        "n_base_parameters": float(base.count),
        "fit_cpu_s": fit_cpu_s,
        "min_pseudo_inertia_eigenvalue": float(min_pseudo_inertia_eigenvalues(standard, robot.n_links).min()),
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
        metrics["base_parameter_error"] = float(np.linalg.norm(estimator.phi_ - true_base) / np.linalg.norm(true_base))
    return IdentificationReport(
        robot=robot,
        base=base,
        identified=identified,
        motion=motion,
        validation_motion=validation_motion,
        measurement=measurement,
        validation_measurement=validation_measurement,
        parameters=parameters,
        validation=validation,
        validation_times=validation_data.t,
        validation_measured=measured,
        validation_estimated=estimated,
        metrics=metrics,
    )


def format_report(report: IdentificationReport) -> str:
    """The two tables of an identification as Markdown: base parameters, and cross-validation errors."""
    parameters = report.parameters.copy()
    parameters["relative_std"] = parameters["relative_std"].round(3)
    lines = [
        f"## Base parameters of {report.robot.name} ({report.base.count})",
        "",
        parameters.to_markdown(floatfmt=".5g"),
        "",
        "## Cross-validation torque error (20 s motion not used for identification)",
        "",
        report.validation.to_markdown(floatfmt=".4g"),
        "",
        f"mean RMS {report.metrics['rms_mean']:.4g} N·m, mean NRMS {report.metrics['nrms_mean']:.4g} %, "
        f"cond(W_b) {report.metrics['cond_W_b']:.4g}, smallest pseudo-inertia eigenvalue "
        f"{report.metrics['min_pseudo_inertia_eigenvalue']:.3g} of the reported standard set (< 0: not a rigid body)",
    ]
    if report.metrics.get("solver_fallback"):
        lines.append("WARNING: the estimator's primary solver failed; the result comes from its fallback solver")
    if "base_parameter_error" in report.metrics:
        lines.append(f"relative base-parameter error ‖β̂ − β‖/‖β‖ = {report.metrics['base_parameter_error']:.3g}")
    return "\n".join(lines)


def write_report(report: IdentificationReport, output_dir: Path, robot_config: dict[str, Any]) -> dict[str, Path]:
    """Write tables (CSV, Markdown), arrays (CSV, npz), the identified model (YAML) and figures."""
    output_dir.mkdir(parents=True, exist_ok=True)
    files = {
        "trajectory": save_trajectory_csv(report.motion, output_dir / "exciting_motion.csv"),
        "validation_trajectory": save_trajectory_csv(report.validation_motion, output_dir / "validation_motion.csv"),
        "measurement": save_measurement(report.measurement, output_dir / "measurement.npz"),
        "validation_measurement": save_measurement(report.validation_measurement, output_dir / "validation_measurement.npz"),
        "identified_model": save_identified_model(report.identified, robot_config, output_dir / "identified_model.yaml"),
    }
    if report.metrics["min_pseudo_inertia_eigenvalue"] >= 0.0:  # URDF only for real rigid bodies (e.g. estimator=sdp)
        identified_robot = report.robot.with_parameters(report.identified.standard_values)
        files["urdf"] = export_urdf(identified_robot, output_dir / "identified_model.urdf", f"{report.robot.name}_identified")
    files["parameters"] = output_dir / "base_parameters.csv"
    report.parameters.to_csv(files["parameters"])
    files["validation"] = output_dir / "cross_validation.csv"
    report.validation.to_csv(files["validation"])
    files["summary"] = output_dir / "summary.md"
    files["summary"].write_text(format_report(report) + "\n")
    files["metrics"] = output_dir / "metrics.json"
    files["metrics"].write_text(json.dumps(report.metrics, indent=2))
    files["torque_overlay"] = torque_overlay(
        report.validation_times,
        report.validation_measured,
        report.validation_estimated,
        output_dir / "torque_overlay.png",
        "Cross-validation: measured vs estimated joint torques",
    )
    noise = report.validation["noise_std"].to_numpy() if "noise_std" in report.validation else None
    files["error_per_joint"] = error_per_joint(
        report.validation["rms"].to_numpy(),
        report.validation["nrms"].to_numpy(),
        output_dir / "error_per_joint.png",
        "Cross-validation torque error per joint",
        noise,
    )
    return files


def identify_configured(cfg: Any) -> IdentificationReport:
    """:func:`identify` with the objects ``cfg`` configures (robot, motions, plant, estimator, processing)."""
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    robot = instantiate(cfg.robot)
    return identify(
        robot=robot,
        motion_source=instantiate(cfg.trajectory),
        validation_source=instantiate(cfg.validation),
        plant=instantiate(cfg.plant)(robot=robot),
        estimator=instantiate(cfg.estimator),
        rate_hz=cfg.measurement.rate_hz,
        processing=OmegaConf.to_container(cfg.measurement.processing, resolve=True),
        statistics=OmegaConf.to_container(cfg.statistics, resolve=True) if "statistics" in cfg else None,
    )


def run_identification(cfg: Any, output_dir: Path) -> dict[str, float]:
    """Task ``identification``: build the configured objects, identify, write and print the report."""
    from omegaconf import OmegaConf

    report = identify_configured(cfg)
    write_report(report, output_dir, OmegaConf.to_container(cfg.robot, resolve=True))
    print(format_report(report))
    return report.metrics
