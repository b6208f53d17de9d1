"""A payload run's files that rebuild its model anywhere: the parameters and the robot description.

A payload run (``task=payload``) writes, beside ``payload.yaml`` (the payload's 10 parameters in the
flange frame, :func:`payload_parameters` reads them back):

* :data:`PAYLOAD_ROBOT_FILE`, the description of the robot the payload was identified on, as its
  config gave it (``_target_`` and settings). A description that names a file (a URDF robot's or a
  modified-DH file's ``path``) gets a copy of that file beside it, :data:`ROBOT_COPY_STEM` plus its
  suffix, and names the copy: the folder holds all it needs (:func:`write_robot_description`);
* :data:`PAYLOAD_PARAMETERS_FILE`, the parameter table (value, σ, %σ of each parameter).

:func:`read_robot_description` gives the description back ready to build where the folder now
lies, with the settings that only motions need (collision geometry, SRDF, MoveIt limits, mesh
folders) left out: the kinematics and gravity are what the payload's torques read.
"""

from __future__ import annotations

import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from lwrlab.errors import ConfigError, MissingFileError
from lwrlab.model.inertia import LINK_PARAMETER_NAMES

PAYLOAD_FILE = "payload.yaml"
"""The payload's mass, centre of mass, inertia and 10 standard parameters (flange frame)."""
PAYLOAD_ROBOT_FILE = "payload_robot.yaml"
"""The description of the robot a payload was identified on."""
PAYLOAD_PARAMETERS_FILE = "payload_parameters.csv"
"""The payload's parameter table: ``parameter, value, std, relative_std_pct`` (flange frame, SI)."""
ROBOT_COPY_STEM = "payload_robot_description"
"""The copy of the file a description names (``payload_robot_description.urdf``, ``….yaml``)."""
MOTION_ONLY_SETTINGS: dict[str, dict[str, Any]] = {
    "load_urdf_robot": {"collision_geometry": False, "srdf": None, "joint_limits": None, "package_dirs": []},
    "build_robot": {"collision_urdf": None},
    "load_robot_yaml": {"collision_urdf": None},
}
"""Per robot loader: the settings that read files only motions need, and their value without them."""


def payload_parameters(path: str | Path) -> np.ndarray:
    """(10,) the standard parameters of a ``payload.yaml`` (flange frame), in
    :data:`~lwrlab.model.inertia.LINK_PARAMETER_NAMES` order."""
    document = yaml.safe_load(Path(path).read_text(encoding="utf-8")) or {}
    parameters = document.get("parameters") or {}
    missing = [name for name in LINK_PARAMETER_NAMES if name not in parameters]
    if missing:
        raise ConfigError(f"{path}: not a payload, its parameters lack {missing}")
    return np.array([float(parameters[name]) for name in LINK_PARAMETER_NAMES])


def write_robot_description(description: Mapping[str, Any], folder: Path) -> Path:
    """Write ``description`` into ``folder``/:data:`PAYLOAD_ROBOT_FILE`, with a copy of the file
    its ``path`` names (a path relative to the working folder, as the config read it)."""
    written = dict(description)
    source = written.get("path")
    if source is not None:
        original = Path(str(source)).expanduser()
        if not original.is_file():
            raise MissingFileError(f"robot.path={source}: the robot description does not exist")
        copy = folder / f"{ROBOT_COPY_STEM}{original.suffix}"
        shutil.copyfile(original, copy)
        written["path"] = copy.name
    path = folder / PAYLOAD_ROBOT_FILE
    path.write_text(yaml.safe_dump(written, sort_keys=False, allow_unicode=True), encoding="utf-8")
    return path


def read_robot_description(path: str | Path, robot_file: str | Path | None = None) -> dict[str, Any]:
    """The description of a :data:`PAYLOAD_ROBOT_FILE`, its ``path`` made absolute (``robot_file``,
    else the copy beside it) and the settings of :data:`MOTION_ONLY_SETTINGS` cleared."""
    path = Path(path)
    description: dict[str, Any] = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    if not isinstance(description, dict) or "_target_" not in description:
        raise ConfigError(f"{path}: not a robot description (no _target_)")
    if description.get("path") is not None:
        local = Path(robot_file) if robot_file is not None else path.parent / str(description["path"])
        description["path"] = str(local.resolve())
    loader = str(description["_target_"]).rsplit(".", 1)[-1]
    return {**description, **MOTION_ONLY_SETTINGS.get(loader, {})}


__all__ = [
    "MOTION_ONLY_SETTINGS",
    "PAYLOAD_FILE",
    "PAYLOAD_PARAMETERS_FILE",
    "PAYLOAD_ROBOT_FILE",
    "ROBOT_COPY_STEM",
    "payload_parameters",
    "read_robot_description",
    "write_robot_description",
]
