"""An identified payload as an MLflow Model (pyfunc flavour): joint states in, the payload's torques out.

``mlflow.pyfunc.load_model("runs:/<payload run id>/model")`` gives a model whose ``predict`` takes
the columns of an identified robot's model (``q1…qN`` rad, ``dq1…dqN`` rad/s, ``ddq1…ddqN`` rad/s²,
optionally ``t`` s, which it does not need) and returns ``tau1…tauN`` (N·m): the torques the payload
adds at the joints, ``W_L(q, q̇, q̈)·Φ_L`` with the columns of the flange-carrying segment the
payload identification fits (:class:`~lwrlab.dynamics.payload_torques.PayloadTorques`). Each row is
predicted on its own. Added to the unloaded robot's model (``runs:/<identification run id>/model``),
it predicts the loaded robot.

The model's artifacts are the run's ``payload.yaml`` (the parameters, flange frame),
``payload_robot.yaml`` (the robot's description, from which its kinematics are rebuilt) with the
file it names when it names one (a URDF, a modified-DH file), and ``payload_parameters.csv``
(:mod:`lwrlab.io.payload_model`). Loading needs lwrlab installed, nothing else: no Hydra app, no
config, no file of the machine that identified it.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import pandas as pd
from mlflow.pyfunc.model import PythonModel

from lwrlab.tracking.models.identified_pyfunc import state_blocks, torque_columns

if TYPE_CHECKING:  # the dynamics load with the model, not with the tracking that logs it
    from lwrlab.dynamics.payload_torques import PayloadTorques
    from lwrlab.model.robot import RobotModel

PAYLOAD_ARTIFACT = "payload"
"""Key of ``payload.yaml`` among the model's artifacts."""
ROBOT_ARTIFACT = "robot"
"""Key of ``payload_robot.yaml``."""
ROBOT_FILE_ARTIFACT = "robot_file"
"""Key of the file the robot description names, when it names one."""
TABLE_ARTIFACT = "payload_parameters"
ROBOT_PLUGINS = "plugins.robots."
"""The only loaders a stored description may name (the file may come from anywhere)."""
FRICTION_LAW_PLUGINS = ("plugins.friction.", "lwrlab.model.friction_laws.")


def build_payload_robot(path: str | Path, robot_file: str | Path | None = None) -> RobotModel:
    """The robot of a ``payload_robot.yaml`` (``robot_file``: the file it names, if elsewhere)."""
    from hydra.utils import instantiate

    from lwrlab.errors import ConfigError
    from lwrlab.io.payload_model import read_robot_description

    description = read_robot_description(path, robot_file)
    target = str(description["_target_"])
    law = description.get("friction_law") or {}
    law_target = str(law.get("_target_", "")) if isinstance(law, dict) else ""
    if not target.startswith(ROBOT_PLUGINS) or (law and not law_target.startswith(FRICTION_LAW_PLUGINS)):
        raise ConfigError(f"{path}: {target!r} (friction law {law_target!r}) is not a robot plugin's")
    robot: RobotModel = instantiate(description)
    return robot


def load_payload_torques(
    payload: str | Path, robot: str | Path, robot_file: str | Path | None = None
) -> PayloadTorques:
    """The torque model of a ``payload.yaml`` at the flange of the robot of a ``payload_robot.yaml``."""
    from lwrlab.dynamics.payload_torques import PayloadTorques
    from lwrlab.io.payload_model import payload_parameters

    return PayloadTorques.of(build_payload_robot(robot, robot_file), payload_parameters(payload))


def predict_payload_frame(model: PayloadTorques, frame: pd.DataFrame) -> pd.DataFrame:
    """The payload's torques ``tau1…tauN`` (N·m) at the states in ``frame``, same index."""
    n = model.robot.n_joints
    torques = model.predict(*state_blocks(frame, n, f"the payload model of {model.robot.name}"))
    return pd.DataFrame(torques, columns=torque_columns(n), index=frame.index)


class PayloadTorqueModel(PythonModel):
    """The pyfunc model of an identified payload (see the module docstring).

    ``load_context`` rebuilds the robot from the ``robot`` artifact and reads the parameters of the
    ``payload`` artifact.
    """

    def __init__(self) -> None:
        self.torques: PayloadTorques | None = None

    def load_context(self, context: Any) -> None:
        artifacts = context.artifacts
        self.torques = load_payload_torques(
            artifacts[PAYLOAD_ARTIFACT], artifacts[ROBOT_ARTIFACT], artifacts.get(ROBOT_FILE_ARTIFACT)
        )

    def predict(self, context: Any, model_input: pd.DataFrame, params: dict[str, Any] | None = None) -> Any:
        """Torques ``tau1…tauN`` (N·m) the payload adds at the rows of ``model_input``."""
        if self.torques is None:
            self.load_context(context)
        assert self.torques is not None
        return predict_payload_frame(self.torques, pd.DataFrame(model_input))


__all__ = [
    "PAYLOAD_ARTIFACT",
    "ROBOT_ARTIFACT",
    "ROBOT_FILE_ARTIFACT",
    "TABLE_ARTIFACT",
    "PayloadTorqueModel",
    "build_payload_robot",
    "load_payload_torques",
    "predict_payload_frame",
]
