"""The one reader of an identified model: every task that reads one takes it whole from here.

:func:`read_identified_model` resolves a model setting (a path, a run folder, ``runs:/<run id>/model``,
``models:/<name>@<alias>``, a run id: :func:`~lwrlab.tracking.models.resolve.resolve_model`) and
rebuilds the robot it describes exactly as ``robot=identified robot.source=<model>`` does (the
shipped option ``conf/robot/identified.yaml``, whose plugin
:func:`plugins.robots.identified.load_identified_robot` builds the description stored in the file):
its kinematics, its drive train (gears, coupling, encoder offsets, the sides its logs were measured
on), the friction law it was identified with and its drive terms (rotor inertias, the law's own
terms), with the identified values. A task never rebuilds it from its own robot config or defaults:
``task=payload`` with ``task.unloaded_model``, ``task=monitor`` with ``task.model``, the MLflow
Model of an identification (:mod:`~lwrlab.tracking.models.identified_pyfunc`) all read through here.

Examples
--------
>>> model = read_identified_model("outputs/runs/<run>", setting="task.model")  # doctest: +SKIP
>>> model.describe()  # doctest: +SKIP
'kuka_lwr4_identified: friction law HoldingFriction(...), drive terms coulomb, viscous, breakaway; ...'
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from lwrlab.errors import ConfigError
from lwrlab.tracking.models.resolve import ResolvedModel, resolve_model

if TYPE_CHECKING:  # the dynamics load with the robot, not with the tracking that imports this module
    from lwrlab.dynamics.base_parameters import BaseParameters
    from lwrlab.dynamics.identified_torques import IdentifiedTorques
    from lwrlab.identification.identified import IdentifiedModel
    from lwrlab.model.robot import RobotModel

IDENTIFIED_ROBOT_OPTION = "identified"
"""The option of the ``robot`` group that rebuilds an identified robot (``robot=identified``)."""
IDENTIFIED_ROBOT_LOADER = "load_identified_robot"
"""The loader that option names (``plugins.robots.identified.load_identified_robot``)."""


@dataclass(frozen=True)
class ReadModel:
    """An identified model as a task reads it: where it came from, what was identified, its robot."""

    resolved: ResolvedModel
    """The setting resolved to a local file, with its lineage (run, registered name and version)."""
    identified: IdentifiedModel
    """The identified base parameters (with their standard deviations) and a standard set."""
    description: dict[str, Any]
    """The robot description the model refined, as stored with it: the friction law and terms it
    was identified with, the drive block, the files it names."""
    robot: RobotModel
    """The robot rebuilt from the description with the identified values: kinematics, drive train,
    friction law and drive terms all the model's own."""
    setting: str = "task.model"
    """The setting that named the model, for errors."""
    robot_settings: dict[str, Any] = field(default_factory=dict)
    """The robot settings the command gave beside the model, which its robot took (a flange frame, …;
    :func:`lwrlab.model.command_settings.with_command_settings`)."""

    @property
    def base(self) -> BaseParameters:
        """The base parameters that were identified (their columns of the robot's regressor)."""
        return self.torques().base

    def torques(self, rate_hz: float = 1000.0) -> IdentifiedTorques:
        """The model as a function of the joint states (``rate_hz``: of consecutive rows without
        times, read by a friction law with memory)."""
        from lwrlab.dynamics.identified_torques import IdentifiedTorques

        try:
            return IdentifiedTorques.of(
                self.robot, self.identified.base_names, self.identified.base_values, rate_hz
            )
        except ValueError as error:
            raise ConfigError(f"{self.setting}={self.resolved.source}: {error}") from error

    def record(self) -> dict[str, Any]:
        """What a task read (YAML-ready, for its output files): the model's source and lineage, the
        friction law, the drive terms and the drive train its robot was rebuilt with."""
        from lwrlab.model.friction_laws import describe_law

        robot = self.robot
        lineage = {
            key: value
            for key, value in (
                ("run_id", self.resolved.run_id),
                ("registered_name", self.resolved.name),
                ("registered_version", self.resolved.version),
            )
            if value
        }
        return {
            "source": self.resolved.source,
            **lineage,
            "robot": robot.name,
            "friction_law": describe_law(robot.friction_law),
            "friction_terms": list(robot.friction_terms),
            "drive_train": robot.drive_train.describe(),
        }

    def describe(self) -> str:
        """One line: the robot, its friction law and drive terms, its drive train."""
        from lwrlab.model.friction_laws import describe_law

        robot = self.robot
        return (
            f"{robot.name}: friction law {describe_law(robot.friction_law)}, drive terms "
            f"{', '.join(robot.friction_terms)}; {robot.drive_train.describe()}"
        )


def build_identified_robot(path: str | Path, robot_settings: Mapping[str, Any] | None = None) -> RobotModel:
    """The robot of a local ``identified_model.yaml``, built as ``robot=identified robot.source=<path>``
    builds it (the shipped option's own settings), its standard set kept as identified: a task that
    reads a model predicts its torques, which the base parameters decide (nothing to solve).
    ``robot_settings``: the command's robot settings, taken or refused by name
    (:func:`lwrlab.model.command_settings.with_command_settings`)."""
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    import lwrlab.conf  # noqa: F401  (registers the schemas the option's YAML links)
    from lwrlab.resources import config_group

    node = OmegaConf.load(config_group("robot")[IDENTIFIED_ROBOT_OPTION])
    node.source = str(path)
    node.rigid_bodies = False
    node.tracking_uri = None
    node.settings = dict(robot_settings or {})
    robot: RobotModel = instantiate(node)
    return robot


def read_identified_model(
    source: str | Path | ResolvedModel,
    tracking_uri: str | None = None,
    setting: str = "task.model",
    robot_settings: Mapping[str, Any] | None = None,
) -> ReadModel:
    """The identified model ``source`` names, with the robot it describes rebuilt whole.

    Parameters
    ----------
    source
        A path, a run folder, an MLflow model URI or run id (looked up in ``tracking_uri``; None:
        ``MLFLOW_TRACKING_URI`` or MLflow's default), or a model already resolved.
    tracking_uri
        The store a URI is looked up in.
    setting
        The setting that gave ``source``, named by every error.
    robot_settings
        The robot settings the command gives beside the model
        (:func:`lwrlab.pipeline.config_nodes.command_robot_settings`): a flange frame, limits,
        collision checks are taken; a setting that would change what was identified (another URDF,
        locked joints, …) must equal the model's, else the model is refused naming both.

    Raises
    ------
    ConfigError
        One line naming the setting: no such model (a
        :class:`~lwrlab.tracking.models.resolve.ModelNotFoundError`), a file that is no identified
        model, or a robot description that cannot be rebuilt.
    """
    from lwrlab.io.artifacts import load_identified_model

    resolved = source if isinstance(source, ResolvedModel) else resolve_model(source, tracking_uri, setting)
    try:
        identified, description = load_identified_model(resolved.path)
        robot = build_identified_robot(resolved.path, robot_settings)
    except ConfigError as error:
        if str(error).startswith(f"{setting}="):
            raise
        raise ConfigError(f"{setting}={resolved.source}: {error}") from error
    except Exception as error:  # Hydra wraps what the plugin raises: the cause is the user's
        cause = error.__cause__ if isinstance(error.__cause__, Exception) else error
        if isinstance(cause, FileNotFoundError | ValueError | KeyError):
            raise ConfigError(f"{setting}={resolved.source}: {cause}") from error
        raise
    from lwrlab.model.command_settings import COMMAND_SETTINGS

    taken = {k: v for k, v in (robot_settings or {}).items() if k in COMMAND_SETTINGS}
    return ReadModel(resolved, identified, dict(description), robot, setting, taken)


__all__ = [
    "IDENTIFIED_ROBOT_LOADER",
    "IDENTIFIED_ROBOT_OPTION",
    "ReadModel",
    "build_identified_robot",
    "read_identified_model",
]
