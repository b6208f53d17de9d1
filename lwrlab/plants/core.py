"""Value objects and protocol of plants (simulated robots, recorded logs)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, TypeGuard

import numpy as np

from lwrlab.model.robot import RobotModel
from lwrlab.trajectory.core import Trajectory


@dataclass(frozen=True)
class Measurement:
    """What a robot's sensors give: sampled positions and joint torques. No ground truth here."""

    t: np.ndarray
    """(N,) sample times (s), uniform."""
    q: np.ndarray
    """(N, N_J) measured joint positions (rad)."""
    tau: np.ndarray
    """(N, N_J) measured joint torques (N·m)."""
    metadata: dict[str, Any] = field(default_factory=dict)
    """Source, rate, noise settings, … (free-form, logged with the run)."""
    dq: np.ndarray | None = None
    """(N, N_J) logged joint velocities (rad/s), when the sensors give them."""
    logged_t: np.ndarray | None = None
    """(M,) sample times as logged (s), when the log was resampled onto the uniform ``t``; else None."""
    logged_tau: np.ndarray | None = None
    """(M, N_J) torques at ``logged_t`` (N·m): what a prediction is scored against after resampling."""
    stamps: np.ndarray | None = None
    """(N,) each sample's time stamp as logged (s), when the samples were kept and read on the
    regular grid ``t`` their jittered stamps stand for; else None (the stamps are ``t``)."""

    def __post_init__(self) -> None:
        n = self.t.shape[0]
        if self.q.shape != self.tau.shape or self.q.shape[0] != n:
            raise ValueError(
                f"Measurement shapes disagree: t {self.t.shape}, q {self.q.shape}, tau {self.tau.shape}"
            )
        if self.dq is not None and self.dq.shape != self.q.shape:
            raise ValueError(f"Measurement shapes disagree: q {self.q.shape}, dq {self.dq.shape}")
        if self.stamps is not None and self.stamps.shape != self.t.shape:
            raise ValueError(f"Measurement shapes disagree: t {self.t.shape}, stamps {self.stamps.shape}")

    @property
    def name(self) -> str:
        """Short name of the measurement (the log's file stem, else its role)."""
        return str(self.metadata.get("name", self.metadata.get("role", "measurement")))

    def as_logged(self) -> tuple[np.ndarray, np.ndarray]:
        """Times (s) and torques (N·m) as the sensors logged them (before any resampling)."""
        if self.logged_t is not None and self.logged_tau is not None:
            return self.logged_t, self.logged_tau
        return self.t, self.tau

    @property
    def sample_stamps(self) -> np.ndarray:
        """(N,) each sample's time as logged (s): :attr:`stamps`, else ``t``."""
        return self.t if self.stamps is None else self.stamps

    @property
    def rate_hz(self) -> float:
        """Sampling rate (Hz)."""
        return float((self.t.shape[0] - 1) / (self.t[-1] - self.t[0]))


@dataclass(frozen=True)
class PlantTruth:
    """The simulated robot's true model: used only to score an identification, never to fit it."""

    robot: RobotModel
    """Robot with the true standard parameters and true friction."""


class Plant(Protocol):
    """A plant plugin: executes a motion and returns what the sensors saw."""

    def measure(self, trajectory: Trajectory) -> Measurement:
        """Execute ``trajectory`` (sampled at the measurement rate) and return the measurement."""
        ...

    @property
    def truth(self) -> PlantTruth | None:
        """The true model when simulated; None for real data."""
        ...


class RecordedPlant(Plant, Protocol):
    """A plant that replays recorded logs: the logs are the motions, nothing is sampled or played."""

    def load(self, path: str | Path, role: str) -> Measurement:
        """One log as a measurement, tagged with its ``role`` (identification or validation)."""
        ...

    def identification_measurements(self) -> list[Measurement]:
        """The measurements to identify from."""
        ...

    def validation_measurements(self) -> list[Measurement]:
        """The measurements to validate on, each scored on its own."""
        ...


def is_recorded(plant: Plant) -> TypeGuard[RecordedPlant]:
    """Whether ``plant`` replays recorded logs (its class says ``recorded = True``)."""
    return bool(getattr(plant, "recorded", False))
