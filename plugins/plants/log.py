"""Recorded logs as a plant (config group ``plant``): identify a real robot from its logs.

The motion was executed when the log was recorded: ``measure`` returns the log standing for the
motion's role — the identification log for the exciting motion, the validation log for the
cross-validation motion (or, without a validation log, the last ``validation_fraction`` of the
identification log, the first part then being used for identification). The schema, units,
column mapping, validation and resampling are those of :mod:`lwrlab.io.logs`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path

from lwrlab.io.logs import LogError, load_log
from lwrlab.model.robot import RobotModel
from lwrlab.plants.core import Measurement
from lwrlab.trajectory.core import Trajectory


class LogPlant:
    """Measurements read from recorded logs (no ground truth).

    Parameters
    ----------
    robot : the robot model (its joint count fixes the expected columns).
    path : identification log (.csv or .parquet).
    validation_path : cross-validation log, or None to split ``path``.
    validation_fraction : share of ``path`` kept for validation when ``validation_path`` is None.
    column_map, time_unit, position_unit, drive_gains, rate_hz, min_samples : see
        :func:`lwrlab.io.logs.load_log`.
    """

    recorded = True
    """The plant replays recorded data: the configured motion is not what the robot executed."""

    def __init__(
        self,
        robot: RobotModel,
        path: str,
        validation_path: str | None = None,
        validation_fraction: float = 0.3,
        column_map: Mapping[str, str] | None = None,
        time_unit: str = "s",
        position_unit: str = "rad",
        drive_gains: Sequence[float] | None = None,
        rate_hz: float | None = None,
        min_samples: int = 100,
    ) -> None:
        if not 0.0 < validation_fraction < 1.0:
            raise ValueError(f"validation_fraction must lie in (0, 1), got {validation_fraction}")
        self.robot = robot
        self.path = Path(path)
        self.validation_path = Path(validation_path) if validation_path else None
        self.validation_fraction = validation_fraction
        self._options = {
            "n_joints": robot.n_joints,
            "column_map": dict(column_map or {}),
            "time_unit": time_unit,
            "position_unit": position_unit,
            "drive_gains": None if drive_gains is None else list(drive_gains),
            "rate_hz": rate_hz,
            "min_samples": min_samples,
        }

    @property
    def truth(self) -> None:
        """A real robot's parameters are unknown."""
        return None

    def _load(self, path: Path) -> Measurement:
        return load_log(path, **self._options).to_measurement()

    def measure(self, trajectory: Trajectory) -> Measurement:
        """The log standing for ``trajectory`` (by its ``metadata["role"]``)."""
        validation = trajectory.metadata.get("role") == "validation"
        if self.validation_path is not None:
            return self._load(self.validation_path if validation else self.path)
        whole = self._load(self.path)
        split = int(round(len(whole.t) * (1.0 - self.validation_fraction)))
        if min(split, len(whole.t) - split) < self._options["min_samples"]:
            raise LogError(f"{self.path}: {len(whole.t)} samples cannot be split into identification and validation parts")
        part = slice(split, None) if validation else slice(None, split)
        return replace(whole, t=whole.t[part], q=whole.q[part], tau=whole.tau[part],
                       metadata={**whole.metadata, "part": "validation" if validation else "identification"})
