"""A robot rebuilt from an earlier run's identified parameters (config group ``robot``).

``source`` is the path of an ``identified_model.yaml`` (or of the run folder holding it), or an
MLflow model: ``runs:/<run id>/model``, ``models:/<name>/<version>``, ``models:/<name>@<alias>``, a
bare run id. The file carries the robot description it refined; the robot is rebuilt from it and
given the identified standard parameters (inertial and friction), which reproduce the identified
base parameters exactly. Where that standard set is not a set of rigid bodies (a least-squares fit's
choice among the equivalent sets), the robot gets the rigid bodies whose torques are nearest
(:func:`lwrlab.identification.rigid_bodies.nearest_rigid_bodies`): the same torques when some rigid
bodies reproduce the base parameters, else a warning saying how much they change. A simulated plant
drawing a true robot around it, MuJoCo and a prior need bodies.

A model identified on such a robot (``robot=identified`` again) is saved with the description this
one was built from (:func:`underlying_description`), so that it loads without the model it refined;
a model saved before that, whose description is this plugin's own settings, loads as well.

Building a description from its ``_target_`` and looking a model up in MLflow belong to the edges
(Hydra, tracking): the config ``conf/robot/identified.yaml`` hands them in as ``build_robot``
(``hydra.utils.instantiate``) and ``locate_model``
(:func:`lwrlab.tracking.models.resolve.identified_model_file`), so this plugin needs neither.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from lwrlab.errors import ConfigError, MissingFileError
from lwrlab.identification.rigid_bodies import are_rigid_bodies, nearest_rigid_bodies
from lwrlab.io.artifacts import identified_model_path, load_identified_model
from lwrlab.model.command_settings import with_command_settings
from lwrlab.model.robot import RobotModel

log = logging.getLogger(__name__)

RobotBuilder = Callable[[Mapping[str, Any]], RobotModel]
"""Builds a robot from a description with a ``_target_`` (``hydra.utils.instantiate``)."""
ModelLocator = Callable[[str, str | None], str | Path]
"""(model URI or run id, tracking URI) → local path of its downloaded ``identified_model.yaml``."""

_ALLOWED_TARGET_PREFIX = "plugins.robots."
_THIS_PLUGIN = "plugins.robots.identified.load_identified_robot"
_FITTED_WITH = ("friction_terms", "friction_law")
"""Keys a model's saved description adds to its robot's: what it was identified with."""
_MAX_NESTING = 16
SAME_TORQUES = 1e-6
"""Relative torque change below which rigid bodies count as reproducing the model (solver accuracy)."""
NOTICEABLE_CHANGE = 1e-3
"""Relative torque change from which replacing the identified set by rigid bodies is a warning."""
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
    rigid_bodies: bool,
    settings: Mapping[str, Any] | None,
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
    rigid_bodies : replace a standard set that is not rigid bodies by the nearest rigid bodies (what a
        simulated plant, MuJoCo and a prior need); False: keep the set as identified, for a task that
        only predicts its torques (a monitor, an MLflow Model), which the base parameters decide.
    settings : robot settings given beside the model (``robot.flange_frame=tool0``; a task reading a
        model whole hands in its command's), taken or refused by
        :func:`lwrlab.model.command_settings.with_command_settings` (None: the model's own).

    Examples
    --------
    >>> import hydra.utils  # doctest: +SKIP
    >>> load_identified_robot(
    ...     "outputs/runs/<run>",
    ...     friction_terms=None,
    ...     tracking_uri=None,
    ...     build_robot=hydra.utils.instantiate,
    ...     locate_model=None,
    ...     rigid_bodies=True,
    ...     settings=None,
    ... )  # doctest: +SKIP
    """
    path = _locate(str(source).strip(), tracking_uri, locate_model)
    identified, saved = load_identified_model(path)
    robot_config = underlying_description(saved, tracking_uri=tracking_uri, locate_model=locate_model)
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
    description = with_command_settings({**defaults, **robot_config}, settings, path)
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
    if rigid_bodies:
        robot = _as_rigid_bodies(robot, path)
    # its rotor-inertia columns were chosen when it was identified: kept as they are, never re-chosen
    drive = replace(robot.drive_train, rotor_inertia_columns="rotor" in robot.friction_terms)
    return replace(robot, name=f"{prior.name}_identified", drive=drive)


def underlying_description(
    robot_config: Mapping[str, Any],
    *,
    tracking_uri: str | None,
    locate_model: ModelLocator | None,
) -> dict[str, Any]:
    """The robot description behind a model's saved robot config.

    A model identified on a robot description is saved with that description: it is returned as is.
    A model identified on an identified robot (this plugin's settings: ``source`` …) stands on the
    description the source model holds, followed to the end, with the friction terms and law the
    model itself was identified with (``friction_terms``, ``friction_law`` of ``robot_config``).

    Parameters
    ----------
    robot_config : the ``robot`` entry of an ``identified_model.yaml``, or a job's robot settings.
    tracking_uri, locate_model : how a source given as an MLflow model URI is found, as in
        :func:`load_identified_robot` (``tracking_uri`` of the settings, where given, wins).
    """
    config = dict(robot_config)
    fitted_with = {key: config[key] for key in _FITTED_WITH if config.get(key) is not None}
    for _ in range(_MAX_NESTING):
        if str(config.get("_target_", "")) != _THIS_PLUGIN:
            return {**config, **fitted_with}
        source = config.get("source")
        if not source:
            raise ConfigError(f"an identified robot's description names no source model: {config}")
        uri = config.get("tracking_uri") or tracking_uri
        _, config = load_identified_model(_locate(str(source).strip(), uri, locate_model))
        fitted_with = {**{k: config[k] for k in _FITTED_WITH if config.get(k) is not None}, **fitted_with}
    raise ConfigError(f"identified robots nested more than {_MAX_NESTING} deep (a model refining itself?)")


def _as_rigid_bodies(robot: RobotModel, path: Path) -> RobotModel:
    """``robot``, or the rigid bodies nearest it where its segments are not rigid bodies."""
    if are_rigid_bodies(robot.parameters, robot.n_links):
        return robot
    fitted = nearest_rigid_bodies(robot)
    found = (
        f"{path}: the identified standard parameters are not rigid bodies (smallest pseudo-inertia "
        f"eigenvalue {fitted.min_eigenvalue:.3g} kg·m², segment {fitted.worst_segment})"
    )
    if fitted.torque_change < SAME_TORQUES:
        log.info("%s; the robot gets rigid bodies with the same torques (the same base parameters)", found)
        return robot.with_parameters(fitted.standard)
    report = log.warning if fitted.torque_change >= NOTICEABLE_CHANGE else log.info
    report(
        "%s, and no rigid bodies reproduce its base parameters exactly: the robot gets the nearest rigid "
        "bodies, whose torques differ by %.3g %% (RMS over random states); estimator=sdp identifies "
        "rigid bodies directly",
        found,
        100 * fitted.torque_change,
    )
    return robot.with_parameters(fitted.standard)
