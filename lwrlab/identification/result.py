"""The result of an identification, in memory: :class:`IdentificationReport`.

What :func:`lwrlab.pipeline.identification.task.identify` returns and
:mod:`lwrlab.pipeline.identification.report` writes to disk: the model, its tables, its predictions
of every log, what the data can determine, and the notes to print with it.
"""

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from lwrlab.dynamics.base_parameters import BaseParameters
from lwrlab.identification.extrapolation import (
    ExtrapolationReport,
)
from lwrlab.identification.friction_choice import FrictionChoice
from lwrlab.identification.identifiability import (
    IdentifiabilityReport,
)
from lwrlab.identification.identified import IdentifiedModel
from lwrlab.identification.log_predictions import (
    LogPrediction,
)
from lwrlab.model.robot import RobotModel
from lwrlab.plants.core import Measurement
from lwrlab.trajectory.core import Trajectory


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
    extrapolation: ExtrapolationReport | None = None
    """How uncertain the predictions are on motions within the limits (None: not assessed)."""
    friction_choice: FrictionChoice | None = None
    """The friction law and rotor columns the data chose, with every candidate's held-out error
    (None: the law was fixed)."""
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
