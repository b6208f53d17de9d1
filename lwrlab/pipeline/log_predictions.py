"""An identified model's torque predictions on each measurement, at its samples as logged, and their tables.

:func:`predict_measurement` filters a measurement's states as the fit did and predicts τ̂ = W·φ at
every logged sample; :func:`prediction_table` and :func:`predicted_torque_frame` put the predictions
of an identification in tables (the report's per-log errors, ``predicted_torque.parquet``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from lwrlab.dynamics.base_parameters import BaseParameters
from lwrlab.dynamics.regressor import regressor
from lwrlab.model.robot import RobotModel
from lwrlab.plants.core import Measurement
from lwrlab.signal.processing import ProcessedData, process


@dataclass(frozen=True)
class LogPrediction:
    """The model's torque prediction on one measurement, at its samples as logged."""

    name: str
    """The log's name (file stem), or the motion's role for simulated data."""
    role: str
    """``identification`` or ``validation``."""
    t: np.ndarray
    """(M,) times as logged (s)."""
    measured: np.ndarray
    """(M, N_J) measured torques as logged (N·m)."""
    predicted: np.ndarray
    """(M, N_J) predicted torques τ̂ = W(q, q̇, q̈)·φ̂ (N·m)."""
    scored: np.ndarray
    """(M,) samples inside the trimmed span, where the filtered states are free of edge transients."""
    processing: str
    """What the processing chose for this log (cut-off, velocity source)."""

    @property
    def relative_error(self) -> float:
        """‖τ − τ̂‖/‖τ‖ over all joints and scored samples."""
        measured = self.measured[self.scored]
        return float(np.linalg.norm(measured - self.predicted[self.scored]) / np.linalg.norm(measured))


def process_measurement(
    measurement: Measurement, processing: dict[str, Any], every_sample: bool = False
) -> ProcessedData:
    """``measurement`` processed with ``processing`` (keyword arguments of :func:`process`)."""
    return process(
        measurement.t, measurement.q, measurement.tau, measurement.dq, every_sample=every_sample, **processing
    )


def predict_measurement(
    robot: RobotModel,
    base: BaseParameters,
    phi: np.ndarray,
    measurement: Measurement,
    processing: dict[str, Any],
) -> LogPrediction:
    """τ̂ = W(q, q̇, q̈)·φ at every sample of ``measurement`` as logged (states filtered as for the fit)."""
    data = process_measurement(measurement, processing, every_sample=True)
    predicted = base.torques(regressor(robot, data.q, data.dq, data.ddq), phi).reshape(-1, robot.n_joints)
    t, measured = measurement.as_logged()
    if t is not measurement.t:  # resampled log: back to the logged samples
        predicted = np.column_stack([np.interp(t, data.t, predicted[:, j]) for j in range(robot.n_joints)])
    span = data.row_times
    scored = (t >= span[0] - 1e-9) & (t <= span[-1] + 1e-9)
    cutoff = "no filter" if data.cutoff_hz is None else f"{data.cutoff_hz:.3g} Hz"
    velocity = "logged q̇" if data.velocity.logged else "q̇ = d/dt q"
    return LogPrediction(
        measurement.name,
        str(measurement.metadata.get("role", "")),
        t,
        measured,
        predicted,
        scored,
        f"{cutoff}, {velocity}",
    )


def prediction_table(predictions: Sequence[LogPrediction]) -> pd.DataFrame:
    """Per measurement: role, samples, ‖τ − τ̂‖/‖τ‖ (%) and what the processing chose."""
    return pd.DataFrame(
        {
            "role": [p.role for p in predictions],
            "samples": [int(p.scored.sum()) for p in predictions],
            "rel_error_%": [100 * p.relative_error for p in predictions],
            "cut-off, velocity": [p.processing for p in predictions],
        },
        index=pd.Index([p.name for p in predictions], name="log"),
    )


def predicted_torque_frame(predictions: Sequence[LogPrediction]) -> pd.DataFrame:
    """Measured and predicted torques of every log at its logged samples.

    Columns ``log, role, t, scored, tau1…N, tau_hat1…N``.
    """
    frames = []
    for p in predictions:
        n = p.measured.shape[1]
        frame = pd.DataFrame({"log": p.name, "role": p.role, "t": p.t, "scored": p.scored})
        frame[[f"tau{j}" for j in range(1, n + 1)]] = p.measured
        frame[[f"tau_hat{j}" for j in range(1, n + 1)]] = p.predicted
        frames.append(frame)
    return pd.concat(frames, ignore_index=True)
