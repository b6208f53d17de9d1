"""A robot rebuilt from an earlier run's identified parameters (config group ``robot``).

``source`` is the path of an ``identified_model.yaml`` (or of the run folder holding it), or an
MLflow model: ``runs:/<run id>/model``, ``models:/<name>/<version>``, ``models:/<name>@<alias>``, a
bare run id. The file carries the robot description it refined; the robot is rebuilt from it and
given the identified standard parameters (inertial and friction), which reproduce the identified
base parameters exactly.

Building a description from its ``_target_`` and looking a model up in MLflow belong to the edges
(Hydra, tracking): the config ``conf/robot/identified.yaml`` hands them in as ``build_robot``
(``hydra.utils.instantiate``) and ``locate_model``
(:func:`lwrlab.tracking.models.resolve.identified_model_file`), so this plugin needs neither.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from lwrlab.errors import ConfigError, MissingFileError
from lwrlab.io.artifacts import identified_model_path, load_identified_model
from lwrlab.model.robot import RobotModel

RobotBuilder = Callable[[Mapping[str, Any]], RobotModel]
"""Builds a robot from a description with a ``_target_`` (``hydra.utils.instantiate``)."""
ModelLocator = Callable[[str, str | None], str | Path]
"""(model URI or run id, tracking URI) → local path of its downloaded ``identified_model.yaml``."""

_ALLOWED_TARGET_PREFIX = "plugins.robots."
_ALLOWED_LAW_PREFIX = ("plugins.friction.", "lwrlab.model.friction_laws.")


_MODEL_URI_SCHEMES = ("runs:/", "models:/")


def _is_file_reference(source: str) -> bool:
    """A path (a separator or a YAML suffix) rather than an MLflow model URI or run id."""
    if source.startswith(_MODEL_URI_SCHEMES):
        return Path(source).expanduser().exists()
    return "/" in source or Path(source).suffix in {".yaml", ".yml"} or Path(source).expanduser().exists()


def _locate(source: str, tracking_uri: str | None, locate_model: ModelLocator | None) -> Path:
    if _is_file_reference(source):
        return identified_model_path(source)
    if locate_model is None:
        raise MissingFileError(
            f"robot.source={source}: identified model {source!r} is not a file or run folder, "
            "and no model look-up was given (locate_model)"
        )
    return Path(locate_model(source, tracking_uri))


_KEYS_ADDED_SINCE: dict[str, dict[str, object]] = {
    "build_robot": {"collision_urdf": None, "drive": None, "friction_law": None},
    "load_robot_yaml": {},
    "load_urdf_robot": {
        "package_dirs": [],
        "srdf": None,
        "joint_limits": None,
        "collision_geometry": True,
        "missing_meshes": "error",
        "drive": None,
        "friction_law": None,
    },
    "load_example_robot": {"drive": None, "friction_law": None},
}
"""Robot settings added after a model may have been saved, with the value that keeps its behaviour:
an ``identified_model.yaml`` written before them still loads."""


def load_identified_robot(
    source: str,
    *,
    friction_terms: Sequence[str] | None,
    tracking_uri: str | None,
    build_robot: RobotBuilder,
    locate_model: ModelLocator | None,
) -> RobotModel:
    """The robot identified by an earlier run.

    Every argument is required: conf/robot/identified.yaml gives their values.

    Parameters
    ----------
    source : an ``identified_model.yaml``, the run folder holding it, or an MLflow model URI
        (``runs:/<run id>/model``, ``models:/<name>/<version>``, ``models:/<name>@<alias>``) or run id.
    friction_terms : friction columns added to those it was identified with (``None``: none); a
        term it was not identified with starts at zero (e.g. ``plant=log`` adds ``offset``). The
        terms it was identified with (its law's own, the rotor inertias) are always kept.
    tracking_uri : the store a model URI is looked up in (``None``: ``MLFLOW_TRACKING_URI`` or MLflow's
        default).
    build_robot : builds the robot description stored in the file (e.g. ``hydra.utils.instantiate``);
        only robot plugins (``_target_: plugins.robots.*``) are built.
    locate_model : downloads a model URI's ``identified_model.yaml`` (needed for a URI only; None: no
        look-up).

    Examples
    --------
    >>> import hydra.utils  # doctest: +SKIP
    >>> load_identified_robot(
    ...     "outputs/runs/<run>",
    ...     friction_terms=None,
    ...     tracking_uri=None,
    ...     build_robot=hydra.utils.instantiate,
    ...     locate_model=None,
    ... )  # doctest: +SKIP
    """
    path = _locate(str(source).strip(), tracking_uri, locate_model)
    identified, robot_config = load_identified_model(path)
    target = str(robot_config.get("_target_", ""))
    # The description comes from a file that may be shared: build only known robot plugins.
    if not target.startswith(_ALLOWED_TARGET_PREFIX):
        raise ConfigError(
            f"{path}: robot _target_ {target!r} is not a robot plugin ({_ALLOWED_TARGET_PREFIX}*)"
        )
    law = robot_config.get("friction_law") or {}
    law_target = str(law.get("_target_", "")) if isinstance(law, Mapping) else ""
    if law and not law_target.startswith(_ALLOWED_LAW_PREFIX):
        raise ConfigError(
            f"{path}: friction_law _target_ {law_target!r} is not a friction law plugin "
            f"({' or '.join(p + '*' for p in _ALLOWED_LAW_PREFIX)})"
        )
    defaults = _KEYS_ADDED_SINCE.get(target.rsplit(".", 1)[-1], {})
    description = {**defaults, **robot_config}
    if friction_terms is not None:  # added to the model's own: a model is never stripped of a term
        own = list(description.get("friction_terms") or [])
        description["friction_terms"] = own + [term for term in friction_terms if term not in own]
    prior = build_robot(description)
    inertial = slice(0, prior.n_parameters - prior.n_friction)
    if prior.parameter_names[inertial] != identified.standard_names[inertial]:
        raise ConfigError(
            f"{path}: its standard parameters do not match the robot it describes ({prior.name})"
        )
    identified_values = dict(zip(identified.standard_names, identified.standard_values, strict=True))
    robot = prior.with_parameters(np.array([identified_values.get(n, 0.0) for n in prior.parameter_names]))
    # its rotor-inertia columns were chosen when it was identified: kept as they are, never re-chosen
    drive = replace(robot.drive_train, rotor_inertia_columns="rotor" in robot.friction_terms)
    return replace(robot, name=f"{prior.name}_identified", drive=drive)
