"""The first stages of an identification: the measurements of each motion, and their processing.

:func:`measure` plays the exciting and validation motions on the plant (or takes the logs a recorded
plant replays); :func:`process_measurements` filters, differentiates and decimates each
identification log (:func:`lwrlab.identification.log_predictions.process_measurement`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from lwrlab.identification.log_predictions import process_measurement
from lwrlab.model.robot import RobotModel
from lwrlab.plants.core import Measurement, Plant, is_recorded
from lwrlab.signal.processing import ProcessedData
from lwrlab.trajectory.core import MotionSource, Trajectory, check_limits


@dataclass(frozen=True)
class Measured:
    """The motions played and the measurements of each (one per log)."""

    motion: Trajectory | None
    """The exciting motion (None for recorded logs)."""
    validation_motion: Trajectory | None
    """The cross-validation motion (None for recorded logs)."""
    measurements: list[Measurement]
    """Identification measurements."""
    validation_measurements: list[Measurement]
    """Validation measurements."""


def _sample_checked(
    source: MotionSource, robot: RobotModel, rate_hz: float, what: str, role: str
) -> Trajectory:
    motion = source.sample(robot, rate_hz)
    check_limits(motion, robot, torque=robot.inverse_dynamics(motion.q, motion.dq, motion.ddq), what=what)
    # the role tells a plant replaying recorded logs which log stands for this motion
    return replace(motion, metadata={**motion.metadata, "role": role})


def _named(measurement: Measurement, name: str, role: str) -> Measurement:
    return replace(measurement, metadata={**measurement.metadata, "name": name, "role": role})


def measure(
    robot: RobotModel,
    motion_source: MotionSource | None,
    validation_source: MotionSource | None,
    plant: Plant,
    rate_hz: float,
) -> Measured:
    """Exciting and validation motions (None for recorded logs) and the measurements of each."""
    if is_recorded(plant):
        return Measured(None, None, plant.identification_measurements(), plant.validation_measurements())
    if motion_source is None or validation_source is None:
        raise ValueError("a simulated identification needs an exciting motion and a validation motion")
    motion = _sample_checked(motion_source, robot, rate_hz, "exciting motion", "excitation")
    validation_motion = _sample_checked(
        validation_source, robot, rate_hz, "cross-validation motion", "validation"
    )
    return Measured(
        motion,
        validation_motion,
        [_named(plant.measure(motion), "exciting_motion", "identification")],
        [_named(plant.measure(validation_motion), "validation_motion", "validation")],
    )


def process_measurements(measured: Measured, processing: dict[str, Any]) -> list[ProcessedData]:
    """Each identification measurement filtered, differentiated and decimated with ``processing``."""
    return [process_measurement(m, processing) for m in measured.measurements]
