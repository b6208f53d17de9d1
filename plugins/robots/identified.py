"""A robot rebuilt from an earlier run's identified parameters (config group ``robot``).

``source`` is the path of an ``identified_model.yaml`` (or of the run folder holding it), or the id
of an MLflow run that logged one. The file carries the robot description it refined; the robot is
rebuilt from it and given the identified standard parameters (inertial and friction), which
reproduce the identified base parameters exactly.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import hydra.utils

from lwrlab.io.artifacts import load_identified_model
from lwrlab.model.robot import RobotModel

ARTIFACT = "identified_model.yaml"
_ALLOWED_TARGET_PREFIX = "plugins.robots."


def _locate(source: str, tracking_uri: str | None) -> Path:
    path = Path(source).expanduser()
    if path.is_dir():
        path = path / ARTIFACT
    if path.is_file():
        return path
    if path.suffix in {".yaml", ".yml"} or "/" in source:
        raise FileNotFoundError(f"identified model {path} does not exist")
    import mlflow.artifacts  # only when the source is a run id: keeps file-based use light

    try:
        return Path(mlflow.artifacts.download_artifacts(run_id=source, artifact_path=ARTIFACT, tracking_uri=tracking_uri))
    except Exception as error:  # noqa: BLE001 - re-raised with the context a user needs
        raise FileNotFoundError(
            f"no {ARTIFACT} for MLflow run {source!r} in store {tracking_uri or '(default)'}: {error}"
        ) from error


def load_identified_robot(source: str, tracking_uri: str | None = None) -> RobotModel:
    """The robot identified by an earlier run (file path, run folder, or MLflow run id)."""
    path = _locate(str(source), tracking_uri)
    identified, robot_config = load_identified_model(path)
    target = str(robot_config.get("_target_", ""))
    # The description comes from a file that may be shared: build only known robot plugins.
    if not target.startswith(_ALLOWED_TARGET_PREFIX):
        raise ValueError(f"{path}: robot _target_ {target!r} is not a robot plugin ({_ALLOWED_TARGET_PREFIX}*)")
    prior: RobotModel = hydra.utils.instantiate(robot_config)
    if tuple(prior.parameter_names) != identified.standard_names:
        raise ValueError(f"{path}: its standard parameters do not match the robot it describes ({prior.name})")
    robot = prior.with_parameters(identified.standard_values)
    return replace(robot, name=f"{prior.name}_identified")
