"""Config nodes as the plain values the stages take (a mapping of settings, checked to be one), and the
configured ``plant=log`` reader of the logs a task is given."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from lwrlab.errors import ConfigError
from lwrlab.model.robot import RobotModel
from lwrlab.plants.core import Measurement, RecordedPlant, is_recorded


def plain(value: Any) -> Any:
    """``value`` with any config node in it resolved into plain dicts and lists."""
    from omegaconf import OmegaConf

    return OmegaConf.to_container(value, resolve=True) if OmegaConf.is_config(value) else value


def resolved_mapping(node: Any, key: str) -> dict[str, Any]:
    """The config node ``node`` (found at ``key``) resolved into a plain ``dict``.

    Raises
    ------
    ConfigError
        When the node is not a mapping (a list, a value, null), naming ``key``.
    """
    container = plain(node)
    if not isinstance(container, dict):
        raise ConfigError(f"{key} must be a mapping of settings, got {container!r}")
    return {str(name): value for name, value in container.items()}


def processing_settings(cfg: Any) -> dict[str, Any]:
    """``measurement.processing``: the keyword arguments of :func:`lwrlab.signal.processing.process`."""
    return resolved_mapping(cfg.measurement.processing, "measurement.processing")


def statistics_settings(cfg: Any) -> dict[str, Any] | None:
    """The ``statistics`` group's settings (bootstrap resamples, block, confidence, seed); None without it."""
    return resolved_mapping(cfg.statistics, "statistics") if "statistics" in cfg else None


def tracking_uri(cfg: Any) -> str | None:
    """``tracking.uri``: the job's MLflow store, where a model URI setting is looked up (None without
    tracking: ``MLFLOW_TRACKING_URI`` or MLflow's default)."""
    from omegaconf import OmegaConf

    value = OmegaConf.select(cfg, "tracking.uri", default=None) if OmegaConf.is_config(cfg) else None
    return None if value in (None, "") else str(value)


def command_overrides(cfg: Any) -> list[str]:
    """The overrides the job's command line gave (``hydra.overrides.task``): the config's own ``hydra``
    node where it kept one (a test's composition), else the running Hydra job's; [] outside Hydra."""
    from omegaconf import OmegaConf

    kept = OmegaConf.select(cfg, "hydra.overrides.task", default=None) if OmegaConf.is_config(cfg) else None
    if kept is not None:
        return [str(item) for item in kept]
    from hydra.core.hydra_config import HydraConfig

    return [str(item) for item in HydraConfig.get().overrides.task] if HydraConfig.initialized() else []


def command_robot_settings(cfg: Any) -> dict[str, Any]:
    """The robot settings the command line gives, with their resolved values: each ``robot.<key>=…``
    (a nested key as its whole top-level setting) and, for ``robot=<option>``, its ``_target_`` (under
    :data:`lwrlab.model.command_settings.BUILDER`).

    What a task reading an identified model whole hands its robot
    (:func:`lwrlab.tracking.models.identified_model.read_identified_model`): a frame to mount a tool on
    is taken, a setting that contradicts the model is refused by name. The robot's defaults (its
    option's YAML, ``plant=log``'s friction terms) are not the command's and are left out.
    """
    from lwrlab.model.command_settings import BUILDER

    keys: list[str] = []
    for item in command_overrides(cfg):
        key = item.split("=", 1)[0].lstrip("+~")
        if key == "robot":
            keys.append("_target_")
        elif key.startswith("robot."):
            keys.append(key.split(".")[1])
    if not keys or "robot" not in cfg:
        return {}
    robot = resolved_mapping(cfg.robot, "robot")
    given = {key: robot[key] for key in dict.fromkeys(keys) if key in robot}
    if "_target_" in given:  # named apart: Hydra would build a mapping holding a _target_
        given[BUILDER] = given.pop("_target_")
    return given


def shipped_log_reader() -> Any:
    """The ``plant`` node of the shipped ``plant=log`` option with its own ``data.*`` defaults: how logs
    are read where a setting implies them without ``plant=log`` (``task.known_logs``)."""
    from omegaconf import OmegaConf

    from lwrlab.resources import config_group

    option = OmegaConf.load(config_group("plant")["log"])
    return OmegaConf.create({"data": option.data, "plant": option.plant}).plant


def log_reader(
    cfg: Any, robot: RobotModel, paths: Sequence[str], unit_gains: bool = False, implied: bool = False
) -> RecordedPlant:
    """The configured ``plant=log`` reader (its ``data.*`` options), for ``paths``.

    ``unit_gains``: read motor currents (columns ``current1…N``) as they are (gain 1), whatever
    ``data.drive_gains`` says. ``implied``: the setting that gave ``paths`` implies logs, so without
    ``plant=log`` they are read with its defaults (:func:`shipped_log_reader`) rather than refused.
    """
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    plant = cfg.plant if OmegaConf.select(cfg, "data") is not None else None
    if plant is None and implied:
        plant = shipped_log_reader()
    if plant is None:
        raise ConfigError(
            "this task reads recorded logs: run it with plant=log (and the data.* options the logs need: "
            "data.column_map, data.time_unit, data.drive_gains, …)"
        )
    overrides: dict[str, Any] = {
        "path": None,
        "paths": [str(p) for p in paths],
        "validation_path": None,
        "validation_paths": None,
    }
    if unit_gains:
        overrides["drive_gains"] = [1.0] * robot.n_joints
    reader = instantiate(plant, **overrides)(robot=robot)
    if not is_recorded(reader):
        raise ConfigError(f"this task reads recorded logs: plant={type(reader).__name__} does not read them")
    return reader


def read_logs(
    cfg: Any,
    robot: RobotModel,
    paths: Sequence[str] | None,
    role: str,
    unit_gains: bool = False,
    implied: bool = False,
) -> list[Measurement]:
    """The logs ``paths`` (none: an empty list) as measurements tagged with ``role``; ``unit_gains``,
    ``implied``: as :func:`log_reader`."""
    paths = [str(p) for p in (paths or [])]
    if not paths:
        return []
    reader = log_reader(cfg, robot, paths, unit_gains, implied)
    return [reader.load(path, role) for path in paths]
