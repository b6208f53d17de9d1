"""The contact-free logs a monitor's thresholds are calibrated on, and the calibration on them.

``task.calibration_paths`` when given; otherwise the logs the model's run identified from, or for a
simulated run its stored measurements (:func:`calibration_measurements`). ``task=monitor`` and
``task=live_monitor`` calibrate alike (:func:`calibrated_thresholds`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from lwrlab.errors import ConfigError
from lwrlab.model.robot import RobotModel
from lwrlab.monitoring.calibration import Calibration, StateCalibration
from lwrlab.monitoring.estimates import ExternalTorques, MonitorSettings, calibrate, estimate_external_torques
from lwrlab.pipeline.config_nodes import tracking_uri
from lwrlab.pipeline.tools.log_rows import read_logs
from lwrlab.plants.core import Measurement
from lwrlab.tracking.models.identified_model import ReadModel
from lwrlab.tracking.models.resolve import ResolvedModel, resolve_model

SIMULATED_RUN_LOGS = ("measurement.npz", "validation_measurement.npz")
"""What a simulated identification run keeps of its (contact-free) measurements."""


def _simulated_measurement(path: Path) -> Measurement:
    with np.load(path, allow_pickle=False) as stored:
        metadata = yaml.safe_load(str(stored["metadata"])) or {}
        return Measurement(
            t=stored["t"], q=stored["q"], tau=stored["tau"], metadata={**metadata, "name": path.stem}
        )


def calibration_measurements(
    cfg: Any,
    robot: RobotModel,
    calibration_paths: Sequence[str] | None,
    model: ResolvedModel | str | None,
) -> tuple[list[Measurement], str]:
    """The contact-free measurements thresholds are calibrated on, and where they came from.

    ``calibration_paths`` when given; otherwise the logs the model's run identified from (its
    ``data.paths`` and ``data.validation_paths``) or, for a simulated run, its stored measurements:
    beside the model's file, or among its MLflow run's artifacts.
    """
    if calibration_paths:
        return read_logs(cfg, robot, calibration_paths, "calibration"), "task.calibration_paths"
    if not model:
        raise ConfigError(
            "task=monitor calibrates its thresholds on contact-free logs: give 'task.calibration_paths=[…]' "
            "or task.model=<identification run>, whose identification logs are used"
        )
    resolved = model if isinstance(model, ResolvedModel) else resolve_model(model, tracking_uri(cfg))
    run = (
        resolved.path.parent
        if resolved.run_id is None
        else f"{resolved.source} (MLflow run {resolved.run_id})"
    )
    stored = resolved.run_file(".hydra/config.yaml")
    data = (yaml.safe_load(stored.read_text()) or {}).get("data") if stored is not None else None
    if data:
        paths = [*(data.get("paths") or [data.get("path")]), *(data.get("validation_paths") or [])]
        paths += [data["validation_path"]] if data.get("validation_path") else []
        paths = [str(p) for p in paths if p]
        if paths:
            return read_logs(cfg, robot, paths, "calibration"), f"the logs of the model's run {run}"
    simulated = [path for path in map(resolved.run_file, SIMULATED_RUN_LOGS) if path is not None]
    if simulated:
        return [_simulated_measurement(p) for p in simulated], f"the measurements of the model's run {run}"
    raise ConfigError(
        f"the model's run {run} keeps no log to calibrate on (no .hydra/config.yaml with data.paths, no "
        "measurement.npz): give 'task.calibration_paths=[…]'"
    )


def calibrated_thresholds(
    cfg: Any,
    robot: RobotModel,
    calibration_paths: Sequence[str] | None,
    read: ReadModel | None,
    settings: MonitorSettings,
) -> tuple[dict[str, Calibration | StateCalibration], str, list[ExternalTorques]]:
    """Both estimators' thresholds calibrated on the contact-free logs
    (:func:`calibration_measurements`), where they came from, and the logs' estimates."""
    contact_free, source = calibration_measurements(
        cfg, robot, calibration_paths, None if read is None else read.resolved
    )
    reference = [estimate_external_torques(robot, m, settings) for m in contact_free]
    return calibrate(reference, settings), source, reference


__all__ = ["SIMULATED_RUN_LOGS", "calibrated_thresholds", "calibration_measurements"]
