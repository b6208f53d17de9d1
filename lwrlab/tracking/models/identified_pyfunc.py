"""An identified model as an MLflow Model (pyfunc flavour): joint states in, joint torques out.

``mlflow.pyfunc.load_model("runs:/<run id>/model")`` (or ``models:/<name>@champion``) gives a model
whose ``predict`` takes a DataFrame with columns ``q1…qN`` (rad), ``dq1…dqN`` (rad/s), ``ddq1…ddqN``
(rad/s²) and, optionally, ``t`` (s), and returns the torques ``tau1…tauN`` (N·m) the identified model
predicts: rigid body, drive and friction terms, as the identification's own ``predicted_torque.parquet``
(:class:`~lwrlab.dynamics.identified_torques.IdentifiedTorques`, the same product). Given the states
an identification evaluated a log at, it returns that file's ``tau_hat1…`` to rounding.

Friction with memory (``friction=holding``): the rows are one motion's consecutive samples, starting
from rest, at the rate of ``t`` when given (``(n − 1) / (t_last − t_first)``), else at the rate of
the identification logs (``rate_hz`` of the model's config). A memoryless law predicts each row on
its own, in any order.

The model's artifacts are the run's ``identified_model.yaml`` (the robot description and the
identified parameters, from which the robot is rebuilt as ``robot=identified`` rebuilds it),
``identified_model.urdf`` when the run wrote one, and ``base_parameters.csv``. Loading needs lwrlab
installed, nothing else: no Hydra app, no config.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from mlflow.models.signature import ModelSignature
from mlflow.pyfunc.model import PythonModel
from mlflow.types.schema import ColSpec, Schema, TensorSpec

if TYPE_CHECKING:  # the dynamics load with the model, not with the tracking that logs it
    from lwrlab.dynamics.identified_torques import IdentifiedTorques

MODEL_ARTIFACT = "identified_model"
"""Key of ``identified_model.yaml`` among the model's artifacts."""
URDF_ARTIFACT = "urdf"
PARAMETERS_ARTIFACT = "base_parameters"
TIME_COLUMN = "t"
"""The optional input column of sample times (s): the rate of consecutive rows for a law with memory."""


def state_columns(n_joints: int) -> list[str]:
    """``q1…qN, dq1…dqN, ddq1…ddqN``: the input columns (rad, rad/s, rad/s²).

    Examples
    --------
    >>> state_columns(2)
    ['q1', 'q2', 'dq1', 'dq2', 'ddq1', 'ddq2']
    """
    return [f"{prefix}{j}" for prefix in ("q", "dq", "ddq") for j in range(1, n_joints + 1)]


def torque_columns(n_joints: int) -> list[str]:
    """``tau1…tauN``: the output columns (N·m)."""
    return [f"tau{j}" for j in range(1, n_joints + 1)]


def state_blocks(frame: pd.DataFrame, n_joints: int, model: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``q``, ``dq``, ``ddq`` (N, N_J) from the state columns of ``frame``; a column missing is a
    ValueError saying that ``model`` needs it."""
    missing = [name for name in state_columns(n_joints) if name not in frame]
    if missing:
        raise ValueError(f"{model} needs columns {missing}")
    q, dq, ddq = (
        frame[[f"{prefix}{j}" for j in range(1, n_joints + 1)]].to_numpy(dtype=float)
        for prefix in ("q", "dq", "ddq")
    )
    return q, dq, ddq


def model_signature(n_joints: int) -> ModelSignature:
    """Input: ``t`` (optional) and the state columns, output: the torque columns, all doubles."""
    inputs: list[ColSpec | TensorSpec] = [ColSpec("double", TIME_COLUMN, required=False)]
    inputs += [ColSpec("double", name) for name in state_columns(n_joints)]
    outputs: list[ColSpec | TensorSpec] = [ColSpec("double", name) for name in torque_columns(n_joints)]
    return ModelSignature(Schema(inputs), Schema(outputs))


def load_torque_model(path: str | Path, rate_hz: float) -> IdentifiedTorques:
    """The torque model of an ``identified_model.yaml``, read as every task reads one
    (:func:`~lwrlab.tracking.models.identified_model.read_identified_model`); ``rate_hz``: of rows
    without a ``t`` column."""
    from lwrlab.tracking.models.identified_model import read_identified_model
    from lwrlab.tracking.models.resolve import ResolvedModel

    local = Path(path)  # a file of the model's own: no look-up, not a model this process used
    return read_identified_model(ResolvedModel(str(local), local), setting="model").torques(rate_hz)


def rows_rate(frame: pd.DataFrame) -> float | None:
    """The rate (Hz) of the rows' ``t`` column, or None without one (or with fewer than two times)."""
    if TIME_COLUMN not in frame or frame[TIME_COLUMN].isna().any() or len(frame) < 2:
        return None
    t = frame[TIME_COLUMN].to_numpy(dtype=float)
    span = t[-1] - t[0]
    if not span > 0:
        raise ValueError(f"column {TIME_COLUMN!r} must increase (consecutive samples), got {t[0]} … {t[-1]}")
    return float((len(t) - 1) / span)


def predict_frame(model: IdentifiedTorques, frame: pd.DataFrame) -> pd.DataFrame:
    """The torques ``tau1…tauN`` (N·m) of the states in ``frame`` (see the module docstring), same index."""
    n = model.robot.n_joints
    q, dq, ddq = state_blocks(frame, n, f"the identified model of {model.robot.name}")
    torques = model.predict(q, dq, ddq, rows_rate(frame))
    return pd.DataFrame(torques, columns=torque_columns(n), index=frame.index)


class IdentifiedTorqueModel(PythonModel):
    """The pyfunc model of an identified robot (see the module docstring).

    ``load_context`` rebuilds the robot from the ``identified_model`` artifact; ``model_config``
    holds ``rate_hz``, the rate of consecutive rows without a ``t`` column.
    """

    def __init__(self) -> None:
        self.torques: IdentifiedTorques | None = None

    def load_context(self, context: Any) -> None:
        config = dict(context.model_config or {})
        self.torques = load_torque_model(context.artifacts[MODEL_ARTIFACT], float(config["rate_hz"]))

    def predict(self, context: Any, model_input: pd.DataFrame, params: dict[str, Any] | None = None) -> Any:
        """Torques ``tau1…tauN`` (N·m) of the rows of ``model_input`` (see the module docstring)."""
        if self.torques is None:
            self.load_context(context)
        assert self.torques is not None
        return predict_frame(self.torques, pd.DataFrame(model_input))


__all__ = [
    "MODEL_ARTIFACT",
    "PARAMETERS_ARTIFACT",
    "TIME_COLUMN",
    "URDF_ARTIFACT",
    "IdentifiedTorqueModel",
    "load_torque_model",
    "model_signature",
    "predict_frame",
    "rows_rate",
    "state_blocks",
    "state_columns",
    "torque_columns",
]
