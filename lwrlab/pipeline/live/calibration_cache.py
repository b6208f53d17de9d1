"""The thresholds a live monitor starts with, calibrated once per model, logs and settings.

Calibrating (the observer over the contact-free logs, the spread's fit per joint) takes a second
or two, which a monitor restarted beside a robot should not wait again. The calibration is kept in
lwrlab's cache folder (``LWRLAB_CACHE_DIR``, else ``~/.cache/lwrlab``) under a key of everything it
depends on: the calibration logs' samples, the model, the settings and the code that calibrates;
any change of one calibrates anew.
"""

from __future__ import annotations

import hashlib
import logging
import pickle
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import lwrlab
from lwrlab.model.robot import RobotModel
from lwrlab.monitoring.calibration import Calibration, StateCalibration
from lwrlab.monitoring.estimates import MonitorSettings, calibrate, estimate_external_torques
from lwrlab.pipeline.monitor import calibration_measurements
from lwrlab.tracking.models.identified_model import ReadModel
from lwrlab.tracking.store.schema_template import cache_folder

log = logging.getLogger(__name__)

CALIBRATING_MODULES = (
    "calibration",
    "counts",
    "estimates",
    "observer",
    "observer_inputs",
    "rest_residual",
    "spread",
    "direct_residual",
)
"""The modules of :mod:`lwrlab.monitoring` whose code a calibration depends on."""


def calibration_key(robot: RobotModel, measurements: Sequence[Any], settings: MonitorSettings) -> str:
    """A digest of what the thresholds depend on: samples, model, settings, code."""
    digest = hashlib.blake2b(digest_size=20)
    monitoring = Path(lwrlab.__file__).parent / "monitoring"
    for module in CALIBRATING_MODULES:
        digest.update((monitoring / f"{module}.py").read_bytes())
    digest.update(repr(settings).encode())
    digest.update(robot.name.encode())
    digest.update(robot.parameters.tobytes())
    for term in robot.friction_terms:
        digest.update(term.encode() + robot.friction.value(term).tobytes())
    digest.update(repr(robot.friction_law).encode() + robot.drive_train.describe().encode())
    for measurement in measurements:
        for array in (measurement.t, measurement.q, measurement.tau):
            digest.update(array.tobytes())
    return digest.hexdigest()


def cached_calibration(
    cfg: Any,
    robot: RobotModel,
    calibration_paths: Sequence[str] | None,
    read: ReadModel | None,
    settings: MonitorSettings,
) -> tuple[dict[str, Calibration | StateCalibration], str]:
    """Both estimators' thresholds as ``task=monitor`` calibrates them, and where they came from:
    from the cache when the same logs, model, settings and code were calibrated before."""
    measurements, source = calibration_measurements(
        cfg, robot, calibration_paths, None if read is None else read.resolved
    )
    path = cache_folder() / "calibrations" / f"{calibration_key(robot, measurements, settings)}.pickle"
    try:
        calibrations = pickle.loads(path.read_bytes())
        log.info("thresholds as calibrated before on %s (%s)", source, path)
        return calibrations, source
    except (OSError, pickle.UnpicklingError, EOFError, AttributeError):
        pass
    calibrations = calibrate([estimate_external_torques(robot, m, settings) for m in measurements], settings)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        kept = path.with_suffix(f".{id(calibrations)}.partial")
        kept.write_bytes(pickle.dumps(calibrations))
        kept.replace(path)
    except OSError as error:  # a read-only cache: calibrate again next time
        log.info("thresholds not kept in the cache (%s)", error)
    return calibrations, source


__all__ = ["CALIBRATING_MODULES", "cached_calibration", "calibration_key"]
