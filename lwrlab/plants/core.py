"""Value objects and protocol of plants (simulated robots, recorded logs)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

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

    def __post_init__(self) -> None:
        n = self.t.shape[0]
        if self.q.shape != self.tau.shape or self.q.shape[0] != n:
            raise ValueError(f"Measurement shapes disagree: t {self.t.shape}, q {self.q.shape}, tau {self.tau.shape}")

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
