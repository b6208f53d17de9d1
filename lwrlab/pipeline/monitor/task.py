"""Task ``monitor``: external joint torques, contact forces and detected contacts of recorded logs.

A model (an earlier identification's ``identified_model.yaml`` or MLflow model, ``models:/<name>@champion``,
or the robot config's own CAD model)
and logs read like ``plant=log``'s give, per log, the momentum observer's and the direct residual's
external joint torques (:mod:`lwrlab.monitoring`); thresholds calibrated on contact-free logs (the
model run's identification logs by default) give the contacts, each with the wrench (or force) at
the configured frame::

    lwrlab task=monitor plant=log robot=… task.model=<run>/identified_model.yaml 'data.paths=[log.csv]'

Writes ``external_torque.parquet``, ``detections.csv``, ``calibration.csv``, ``external_torque.png``,
``summary.md`` and ``metrics.json`` (the tracking callback logs the folder to MLflow).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from lwrlab.errors import ConfigError
from lwrlab.figures.monitor import external_torques
from lwrlab.model.robot import RobotModel
from lwrlab.monitoring.calibration import Calibration, StateCalibration
from lwrlab.monitoring.contact_force import (
    default_frame,
    force_from_torques,
    frame_id,
    point_jacobians,
    wrench_from_torques,
)
from lwrlab.monitoring.detection import Detection, detection_flags, detections_frame
from lwrlab.monitoring.estimates import (
    ESTIMATORS,
    ExternalTorques,
    MonitorSettings,
    detect,
    estimate_external_torques,
    held_out_false_alarm_rate,
    thresholds_of,
    truth_as_estimated,
)
from lwrlab.monitoring.scoring import detectable_contacts, rms_error, score_detections
from lwrlab.pipeline.config_nodes import command_robot_settings, tracking_uri
from lwrlab.pipeline.monitor.calibration_logs import calibrated_thresholds
from lwrlab.pipeline.tools.log_rows import read_logs
from lwrlab.tracking.models.identified_model import ReadModel, read_identified_model

log = logging.getLogger(__name__)


def monitoring_robot(cfg: Any, model: ReadModel | None) -> RobotModel:
    """The robot the monitor reads the logs with and monitors: the identified model's own (its
    kinematics, drive train, friction law and drive terms), else the robot config's (CAD) model."""
    from hydra.utils import instantiate

    if model is not None:
        return model.robot
    robot: RobotModel = instantiate(cfg.robot)
    return robot


def _progress(name: str) -> Any:
    marks = iter(range(10, 101, 10))
    state = {"next": next(marks)}

    def report(done: int, total: int) -> None:
        if total >= 100_000 and 100 * done >= state["next"] * total:
            log.info("%s: %d %% of %d samples", name, 100 * done // total, total)
            state["next"] = next(marks, 101)

    return report


def _contact_mapping(robot: RobotModel, frame: str, point: Sequence[float] | None) -> tuple[str, list[str]]:
    try:
        frame_id(robot, frame)  # fails early naming the robot's frames
    except ValueError as error:
        raise ConfigError(f"task.frame: {error}") from error
    if point is None:
        return "wrench", ["force_x", "force_y", "force_z", "moment_x", "moment_y", "moment_z"]
    if len(point) != 3:
        raise ConfigError(f"task.point must be [x, y, z] in the frame {frame!r}, got {list(point)}")
    return "force", ["force_x", "force_y", "force_z"]


def contact_loads(
    robot: RobotModel,
    estimates: ExternalTorques,
    estimator: str,
    detections: Sequence[Detection],
    frame: str,
    point: Sequence[float] | None,
) -> np.ndarray:
    """(detections, 6 or 3) the wrench (or force) the robot exerts at the frame, at each detection's peak."""
    width = 6 if point is None else 3
    if not detections:
        return np.zeros((0, width))
    peaks = np.array([d.peak_index for d in detections])
    jacobians = point_jacobians(
        robot, estimates.q[peaks], frame, None if point is None else np.asarray(point)
    )
    torque = estimates.estimate(estimator)[peaks]
    return wrench_from_torques(jacobians, torque) if point is None else force_from_torques(jacobians, torque)


def _torque_frame(
    estimates: ExternalTorques,
    calibrations: dict[str, Calibration | StateCalibration],
    detections: dict[str, list[Detection]],
    stamps: np.ndarray | None = None,
) -> pd.DataFrame:
    """One row per sample; ``t`` the sample's logged stamp and, where ``stamps`` (the logged stamps
    of samples read on a regular grid) are given, ``t_grid`` the grid's time."""
    n = estimates.observer.shape[1]
    columns: dict[str, Any] = {
        "log": estimates.name,
        "t": estimates.t if stamps is None else stamps,
        **({} if stamps is None else {"t_grid": estimates.t}),
        "monitored": estimates.monitored,
        "signals_disagree": estimates.disagreeing,
    }
    for estimator in ESTIMATORS:
        values = estimates.estimate(estimator)
        columns |= {f"{estimator}{j + 1}": values[:, j] for j in range(n)}
    for estimator in ESTIMATORS:
        thresholds = thresholds_of(estimates, calibrations, estimator)
        suffix = "" if estimator == "observer" else "_residual"
        columns |= {f"threshold{suffix}{j + 1}": thresholds[:, j] for j in range(n)}
        columns[f"detected{suffix}"] = detection_flags(len(estimates.t), detections[estimator])
    return pd.DataFrame(columns)


def calibration_table(calibrations: dict[str, Calibration | StateCalibration]) -> pd.DataFrame:
    """Per joint and estimator, the calibrated terms: the constant thresholds (N·m), or the state
    thresholds' threshold at rest, floor, noise √a and friction band at rest (N·m), friction share ρ
    and level; and the contact-free RMS and peak (N·m)."""
    n = calibrations["observer"].rms.size
    table = pd.DataFrame({"joint": np.arange(1, n + 1)})
    for estimator, calibration in calibrations.items():
        for name, values in calibration.table().items():
            table[f"{name}_{estimator}"] = values
    return table


def _truth_metrics(
    estimates: ExternalTorques,
    found: dict[str, list[Detection]],
    calibrations: dict[str, Calibration | StateCalibration],
    settings: MonitorSettings,
    truth_contacts: str | None,
    truth_torque: str | None,
    min_force: float,
) -> dict[str, float]:
    metrics: dict[str, float] = {}
    truth = None
    if truth_torque:
        truth_frame = pd.read_parquet(truth_torque)
        n = estimates.observer.shape[1]
        truth = np.column_stack(
            [np.interp(estimates.t, truth_frame["t"], truth_frame[f"tau_ext{j}"]) for j in range(1, n + 1)]
        )
    if truth_contacts:
        contacts = pd.read_csv(truth_contacts)
        for estimator in ESTIMATORS:
            prefix = "" if estimator == "observer" else "residual_"
            detectable = None
            if truth is not None:  # which contacts these thresholds can see at all
                detectable = detectable_contacts(
                    estimates.t,
                    np.where(estimates.monitored[:, None], truth, 0.0),
                    contacts,
                    thresholds_of(estimates, calibrations, estimator),
                    min_duration=settings.min_duration,
                )
            score = score_detections(found[estimator], contacts, min_force=min_force, detectable=detectable)
            metrics |= score.metrics(prefix)
    if truth is not None:
        seen = truth_as_estimated(truth, estimates, settings)
        keep = estimates.monitored
        for estimator in ESTIMATORS:
            prefix = "" if estimator == "observer" else "residual_"
            value = estimates.estimate(estimator)[keep]
            metrics[f"{prefix}torque_rms_error"] = float(np.mean(rms_error(value, seen[estimator][keep])))
            metrics[f"{prefix}torque_rms_error_raw"] = float(np.mean(rms_error(value, truth[keep])))
    return metrics


def format_summary(
    source: str,
    calibration: pd.DataFrame,
    detections: pd.DataFrame,
    metrics: dict[str, float],
    settings: MonitorSettings,
) -> str:
    """The run as Markdown: calibration, detections, metrics."""
    lines = [
        f"## Thresholds per joint (N·m), calibrated on {source}",
        "",
        f"{settings.thresholds} thresholds"
        + (f" (friction drift {settings.friction_drift:g})" if settings.thresholds == "state" else "")
        + f"; stated false-alarm rate {settings.false_alarm_rate:g} per hour, margin {settings.margin:g} "
        f"(direct residual {settings.residual_margin:g}); "
        f"observer gain {settings.observer_gain:g} 1/s; "
        f"minimum duration {1000 * settings.min_duration:g} ms, "
        f"release at {settings.release:g} × threshold",
        "",
        calibration.to_markdown(index=False, floatfmt=".4g"),
        "",
        f"## Detected contacts ({len(detections)})",
        "",
        detections.to_markdown(index=False, floatfmt=".4g") if len(detections) else "none",
        "",
        "## Metrics",
        "",
        *(f"- {name}: {value:.4g}" for name, value in metrics.items()),
    ]
    return "\n".join(lines)


def _drift_note(read: ReadModel, settings: MonitorSettings) -> str:
    """What the model says of its friction's drift beside what the thresholds cover (state only)."""
    drift, source = read.identified.friction_drift, read.identified.friction_drift_source
    if drift is None or settings.thresholds != "state":
        return ""
    said = {"logs": "measured between its identification logs", "prior": "the prior for one log"}
    return (
        f"; friction drift {drift:.2g} ({said.get(source or '', 'as set')}), the thresholds cover "
        f"{settings.friction_drift:g} (task.friction_drift)"
    )


def run_monitor(
    cfg: Any,
    output_dir: Path,
    *,
    model: str | None,
    calibration_paths: Sequence[str] | None,
    observer_gain: float,
    velocity_cutoff_hz: float,
    coulomb_smoothing: float,
    false_alarm_rate: float,
    margin: float,
    residual_margin: float,
    min_duration: float,
    release: float,
    thresholds: str,
    friction_drift: float,
    rest_thresholds: str,
    frame: str | None,
    point: Sequence[float] | None,
    truth_contacts: str | None,
    truth_torque: str | None,
    min_force: float,
) -> dict[str, float]:
    """Task ``monitor``: external torques, contact forces and detections of logs.

    Every setting is required: conf/task/monitor.yaml gives their values.

    Parameters (the task config's)
    ----------
    model : an ``identified_model.yaml``, its run folder, or an MLflow model (``runs:/<run id>/model``,
        ``models:/<name>/<version>``, ``models:/<name>@<alias>``, a run id; looked up in the job's
        store, ``tracking.uri``); None: the robot config's model (CAD).
    calibration_paths : contact-free logs for the thresholds; None: the model's run's logs.
    observer_gain, velocity_cutoff_hz, coulomb_smoothing, false_alarm_rate, margin, residual_margin,
    min_duration, release, thresholds, friction_drift, rest_thresholds : see
        :class:`lwrlab.monitoring.estimates.MonitorSettings`.
    frame, point : where the contact load is mapped: the frame's wrench, or a pure force at ``point``
        (m, frame axes); frame None: the flange, or the last link's frame.
    truth_contacts : CSV of known contacts (``start``, ``end``, ``peak_force``): detection scores.
    truth_torque : Parquet of the true external torque (``t``, ``tau_ext1…``): RMS errors.
    min_force : contacts weaker than this (N) are not counted as missed.
    """
    from omegaconf import OmegaConf

    output_dir.mkdir(parents=True, exist_ok=True)
    settings = MonitorSettings(
        observer_gain,
        velocity_cutoff_hz,
        coulomb_smoothing,
        false_alarm_rate,
        margin,
        min_duration,
        release,
        residual_margin,
        thresholds,
        friction_drift,
        rest_thresholds,
    )
    paths = OmegaConf.select(cfg, "data.paths") or (
        [OmegaConf.select(cfg, "data.path")] if OmegaConf.select(cfg, "data.path") else []
    )
    if not paths:
        raise ConfigError("task=monitor needs the log(s) to monitor: plant=log 'data.paths=[log.csv, …]'")
    read = (
        read_identified_model(model, tracking_uri(cfg), "task.model", command_robot_settings(cfg))
        if model
        else None
    )
    monitor_robot = monitoring_robot(cfg, read)
    frame = frame or default_frame(monitor_robot)
    mapping, load_columns = _contact_mapping(monitor_robot, frame, point)
    calibrations, source, reference = calibrated_thresholds(
        cfg, monitor_robot, calibration_paths, read, settings
    )
    monitored = read_logs(cfg, monitor_robot, list(paths), "monitored")
    if (truth_contacts or truth_torque) and len(monitored) != 1:
        raise ConfigError("task.truth_contacts and task.truth_torque score one monitored log: give one")
    metrics: dict[str, float] = {"false_alarm_rate": held_out_false_alarm_rate(reference, settings)}
    frames, tables, alarms, hours, seconds, samples = [], [], dict.fromkeys(ESTIMATORS, 0), 0.0, 0.0, 0
    suspect = 0  # observer detections where the log's velocities contradict its positions
    for measurement in monitored:
        estimates = estimate_external_torques(
            monitor_robot, measurement, settings, progress=_progress(measurement.name)
        )
        found = detect(estimates, calibrations, settings)
        frames.append(_torque_frame(estimates, calibrations, found, measurement.stamps))
        for estimator in ESTIMATORS:
            table = detections_frame(found[estimator])
            loads = contact_loads(monitor_robot, estimates, estimator, found[estimator], frame, point)
            table[load_columns] = loads
            table.insert(0, "estimator", estimator)
            table.insert(0, "log", estimates.name)
            tables.append(table)
            alarms[estimator] += len(found[estimator])
        suspect += sum(d.signals_disagree for d in found["observer"])
        hours += estimates.monitored_hours
        seconds += estimates.seconds
        samples += len(estimates.t)
        if measurement is monitored[0]:
            metrics |= _truth_metrics(
                estimates, found, calibrations, settings, truth_contacts, truth_torque, min_force
            )
            true_spans = []
            if truth_contacts:
                true_spans = list(pd.read_csv(truth_contacts)[["start", "end"]].itertuples(index=False))
            external_torques(
                estimates.t,
                estimates.observer,
                estimates.residual,
                thresholds_of(estimates, calibrations, "observer"),
                [(d.start, d.end) for d in found["observer"]],
                output_dir / "external_torque.png",
                f"{estimates.name}: external joint torques ({monitor_robot.name})",
                [(float(s), float(e)) for s, e in true_spans],
            )
    detections = pd.concat(tables, ignore_index=True)
    metrics |= {
        "detections": float(alarms["observer"]),
        "detections_signals_disagree": float(suspect),
        "residual_detections": float(alarms["residual"]),
        "monitored_alarm_rate": alarms["observer"] / hours if hours > 0 else float("nan"),
        "monitored_hours": hours,
        "observer_us_per_sample": 1e6 * seconds / max(samples, 1),
    }
    torques = pd.concat(frames, ignore_index=True)
    if "t_grid" in torques:  # the logs read on their stamps' grid, and the others' stamps
        torques["t_grid"] = torques["t_grid"].fillna(torques["t"])
    torques.to_parquet(output_dir / "external_torque.parquet", index=False)
    detections.to_csv(output_dir / "detections.csv", index=False)
    calibration = calibration_table(calibrations)
    calibration.to_csv(output_dir / "calibration.csv", index=False)
    summary = format_summary(
        source, calibration, detections[detections.estimator == "observer"], metrics, settings
    )
    if read is not None:
        summary += f"\n\nmodel {read.resolved.source}: {read.describe()}" + _drift_note(read, settings)
    (output_dir / "summary.md").write_text(summary + "\n")
    (output_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    print(summary)
    log.info("contact loads: the %s at %s", mapping, frame)
    return metrics
