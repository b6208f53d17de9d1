"""Recorded logs as a plant (config group ``plant``): identify a real robot from its logs.

The motions were executed when the logs were recorded, so nothing is sampled or optimised: the
identification reads the identification logs (``data.paths``, processed one by one and stacked)
and the validation logs (``data.validation_paths``, each scored on its own). Without a validation
log, the last ``validation_fraction`` of each identification log is held out. Formats, schema,
units, column mapping, validation and resampling are those of :mod:`lwrlab.io.logs`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from functools import partial
from pathlib import Path

import numpy as np

from lwrlab.io.logs import LogError, load_log
from lwrlab.model.robot import RobotModel
from lwrlab.plants.core import Measurement
from lwrlab.trajectory.core import Trajectory


def joint_mask(robot: RobotModel, joints: Sequence[str | int]) -> np.ndarray:
    """(N_J,) True for the joints named (by name or 1-based number); a ``LogError`` for any other."""
    names = robot.joint_names
    mask = np.zeros(robot.n_joints, dtype=bool)
    for joint in joints:
        if isinstance(joint, int) or str(joint).isdigit():
            index = int(joint) - 1
            if not 0 <= index < robot.n_joints:
                raise LogError(f"data.fitted_joints: joint {joint} is not in 1…{robot.n_joints}")
        elif joint in names:
            index = names.index(str(joint))
        else:
            raise LogError(
                f"data.fitted_joints: {joint!r} is not a joint of {robot.name}; joints: {list(names)}"
            )
        mask[index] = True
    if not mask.any():
        raise LogError("data.fitted_joints names no joint: at least one joint's torques must be fitted")
    return mask


def _as_list(single: str | None, several: Sequence[str] | None) -> list[Path]:
    if several:
        return [Path(str(p)) for p in several]
    return [Path(str(single))] if single else []


class LogPlant:
    """Measurements read from recorded logs (no ground truth).

    Parameters
    ----------
    robot : the robot model (its joint count and names fix what is read).
    path, paths : identification log, or several (processed separately, stacked after processing).
    validation_path, validation_paths : validation log(s), each scored on its own; none: hold out
        the last ``validation_fraction`` of each identification log.
    validation_fraction : share of each identification log held out when there is no validation log.
    column_map, time_unit, position_unit, drive_gains, rate_hz, min_samples, topic : see
        :func:`lwrlab.io.logs.load_log`.
    fitted_joints : the joints whose torques are fitted and scored, by name or 1-based number; None:
        every joint. The others' torques (a gripper's, a wrist whose effort reads zero) are read but
        left out of the fit and the errors.
    """

    recorded = True
    """The plant replays recorded data: no motion is sampled, the logs are the measurements."""

    def __init__(
        self,
        robot: RobotModel,
        path: str | None = None,
        paths: Sequence[str] | None = None,
        validation_path: str | None = None,
        validation_paths: Sequence[str] | None = None,
        validation_fraction: float = 0.3,
        column_map: Mapping[str, str] | None = None,
        time_unit: str = "s",
        position_unit: str = "rad",
        drive_gains: Sequence[float] | None = None,
        rate_hz: float | None = None,
        min_samples: int = 100,
        topic: str | None = None,
        fitted_joints: Sequence[str | int] | None = None,
    ) -> None:
        if not 0.0 < validation_fraction < 1.0:
            raise ValueError(f"data.validation_fraction must lie in (0, 1), got {validation_fraction}")
        self.robot = robot
        self.fitted_joints = None if fitted_joints is None else joint_mask(robot, fitted_joints)
        """(N_J,) bool: the joints whose torques are fitted and scored, or None: every joint."""
        self.paths = _as_list(path, paths)
        if not self.paths:
            raise LogError(
                "plant=log needs the identification log(s): set data.paths=[log.csv, …] "
                "(or data.path=log.csv)"
            )
        self.validation_paths = _as_list(validation_path, validation_paths)
        self.validation_fraction = validation_fraction
        self.min_samples = min_samples
        self._read_log = partial(
            load_log,
            n_joints=robot.n_joints,
            column_map=dict(column_map or {}),
            time_unit=time_unit,
            position_unit=position_unit,
            drive_gains=None if drive_gains is None else list(drive_gains),
            rate_hz=rate_hz,
            min_samples=min_samples,
            joint_names=robot.joint_names,
            topic=topic,
            limits=robot.limits,
            drive=robot.drive,
            fitted_joints=self.fitted_joints,
        )
        self._loaded: dict[Path, Measurement] = {}

    @property
    def truth(self) -> None:
        """A real robot's parameters are unknown."""
        return None

    @property
    def path(self) -> Path:
        """The first identification log."""
        return self.paths[0]

    def load(self, path: str | Path, role: str) -> Measurement:
        """One log as a measurement, tagged with its ``role`` (identification or validation).

        Each file is read once.
        """
        key = Path(path)
        if key not in self._loaded:
            self._loaded[key] = self._read_log(key).to_measurement()
        measurement = self._loaded[key]
        return replace(measurement, metadata={**measurement.metadata, "role": role})

    def _split(self, whole: Measurement, validation: bool) -> Measurement:
        n = len(whole.t)
        split = round(n * (1.0 - self.validation_fraction))
        if min(split, n - split) < self.min_samples:
            raise LogError(
                f"{whole.metadata['path']}: {n} samples cannot be split into identification and validation "
                "parts; give data.validation_paths"
            )
        part = slice(split, None) if validation else slice(None, split)
        t = whole.t[part]
        logged = {}
        if whole.logged_t is not None and whole.logged_tau is not None:
            keep = (whole.logged_t >= t[0]) & (whole.logged_t <= t[-1])
            logged = {"logged_t": whole.logged_t[keep], "logged_tau": whole.logged_tau[keep]}
        name = f"{whole.name}_{'tail' if validation else 'head'}"
        share = self.validation_fraction if validation else 1 - self.validation_fraction
        return replace(
            whole,
            t=t,
            q=whole.q[part],
            tau=whole.tau[part],
            dq=None if whole.dq is None else whole.dq[part],
            stamps=None if whole.stamps is None else whole.stamps[part],
            **logged,
            metadata={
                **whole.metadata,
                "name": name,
                "role": "validation" if validation else "identification",
                "part": f"{'last' if validation else 'first'} {100 * share:.0f} %",
            },
        )

    def identification_measurements(self) -> list[Measurement]:
        """The identification logs (their first part when there is no validation log)."""
        whole = [self.load(p, "identification") for p in self.paths]
        return whole if self.validation_paths else [self._split(m, validation=False) for m in whole]

    def validation_measurements(self) -> list[Measurement]:
        """The validation logs (the held-out last part of each identification log when none is given)."""
        if self.validation_paths:
            return [self.load(p, "validation") for p in self.validation_paths]
        return [self._split(self.load(p, "identification"), validation=True) for p in self.paths]

    def measure(self, trajectory: Trajectory) -> Measurement:
        """The first log standing for ``trajectory``'s role (a stage that plays one motion at a time)."""
        validation = trajectory.metadata.get("role") == "validation"
        return (self.validation_measurements() if validation else self.identification_measurements())[0]
