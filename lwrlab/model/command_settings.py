"""The robot settings a command gives beside an identified model that is read whole.

A task that reads an identified model (``task=payload task.unloaded_model=…``, ``task=monitor
task.model=…``, ``robot=identified``) rebuilds the robot the model describes, not the job's robot. The
command may still give robot settings beside it (``robot.flange_frame=tool0``): those that add a frame,
limits or collision checks (:data:`COMMAND_SETTINGS`) are taken; any other must say what the model's
description says, or the model is refused with the conflict named (:func:`with_command_settings`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from lwrlab.errors import ConfigError

COMMAND_SETTINGS = frozenset(
    {
        "name",
        "flange_frame",
        "acceleration_limits",
        "joint_limits",
        "srdf",
        "package_dirs",
        "collision_geometry",
        "collision_urdf",
        "missing_meshes",
    }
)
"""Robot settings a command gives a model read whole, which the rebuilt robot takes: a frame to mount a
tool on, limits and collision checks of new motions — none changes the dynamics that were identified.
Any other setting given (the description file, locked joints, gravity, the drive train, friction) must
equal the model's own, or the model is refused with the conflict named."""


BUILDER = "builder"
"""The key of a command's robot settings naming the ``_target_`` of its ``robot=<option>`` (not
``_target_`` itself, which Hydra would build)."""


def _same_setting(saved: Any, given: Any) -> bool:
    """Whether a setting given on the command line says what the model's saved one says (two names of
    one file, or files of the same content, are the same description)."""
    if saved == given:
        return True
    if isinstance(saved, str) and isinstance(given, str):
        first, second = Path(saved).expanduser(), Path(given).expanduser()
        if first.is_file() and second.is_file():
            return first.resolve() == second.resolve() or first.read_bytes() == second.read_bytes()
    return False


IDENTIFIED_PLUGIN = "plugins.robots.identified.load_identified_robot"
"""The builder of ``robot=identified``: a command naming it gives no robot description of its own."""


def with_command_settings(
    description: Mapping[str, Any], settings: Mapping[str, Any] | None, source: str | Path
) -> dict[str, Any]:
    """The model's robot ``description`` with the robot ``settings`` a command gives (``robot.<key>``
    values; :data:`BUILDER` the ``_target_`` of its ``robot=<option>``): those of
    :data:`COMMAND_SETTINGS` taken, any other checked against the model's.

    Raises
    ------
    ConfigError
        A setting that would change what was identified (another description file, locked joints,
        drive train, …) and differs from the model's, named with both values.

    Examples
    --------
    >>> saved = {"_target_": "plugins.robots.urdf.load_urdf_robot", "path": "arm.urdf", "flange_frame": None}
    >>> with_command_settings(saved, {"flange_frame": "tool0"}, "model.yaml")["flange_frame"]
    'tool0'
    """
    merged = dict(description)
    for key, given in (settings or {}).items():
        if key == BUILDER:
            if given not in (description.get("_target_"), IDENTIFIED_PLUGIN):
                raise ConfigError(
                    f"{source}: identified on a robot built by {description.get('_target_')}, while the "
                    f"command's robot=… is built by {given}: leave robot=… out (the model's robot is read "
                    "whole) or give a model of that robot"
                )
        elif key in COMMAND_SETTINGS:
            merged[key] = given
        elif not _same_setting(description.get(key), given):
            raise ConfigError(
                f"{source}: robot.{key}={given!r} conflicts with the model, identified with "
                f"robot.{key}={description.get(key)!r}: leave robot.{key} out (the model's robot is read "
                f"whole) or identify again with it; a command may set {', '.join(sorted(COMMAND_SETTINGS))}"
            )
    return merged


__all__ = ["BUILDER", "COMMAND_SETTINGS", "IDENTIFIED_PLUGIN", "with_command_settings"]
