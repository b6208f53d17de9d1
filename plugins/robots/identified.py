"""A robot rebuilt from an earlier run's identified parameters (config group ``robot``).

``source`` is the path of an ``identified_model.yaml`` (or of the run folder holding it), or the id
of an MLflow run that logged one. The file carries the robot description it refined; the robot is
rebuilt from it and given the identified standard parameters (inertial and friction), which
reproduce the identified base parameters exactly.

Building a description from its ``_target_`` and looking a run up in MLflow belong to the edges
(Hydra, tracking): the config ``conf/robot/identified.yaml`` hands them in as ``build_robot``
(``hydra.utils.instantiate``) and ``fetch_run_artifact``
(:func:`lwrlab.tracking.run_artifacts.download_run_artifact`), so this plugin needs neither.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from lwrlab.io.artifacts import IDENTIFIED_MODEL_FILE, identified_model_path, load_identified_model
from lwrlab.model.robot import RobotModel

RobotBuilder = Callable[[Mapping[str, Any]], RobotModel]
"""Builds a robot from a description with a ``_target_`` (``hydra.utils.instantiate``)."""
RunArtifactFetcher = Callable[[str, str, str | None], str | Path]
"""(run id, artifact path, tracking URI) → local path of the downloaded artifact."""

_ALLOWED_TARGET_PREFIX = "plugins.robots."


def _is_file_reference(source: str) -> bool:
    """A path (a separator or a YAML suffix) rather than an MLflow run id."""
    return "/" in source or Path(source).suffix in {".yaml", ".yml"} or Path(source).expanduser().exists()


def _locate(source: str, tracking_uri: str | None, fetch_run_artifact: RunArtifactFetcher | None) -> Path:
    if _is_file_reference(source):
        return identified_model_path(source)
    if fetch_run_artifact is None:
        raise FileNotFoundError(
            f"identified model {source!r} is not a file or run folder, "
            "and no run look-up was given (fetch_run_artifact)"
        )
    return Path(fetch_run_artifact(source, IDENTIFIED_MODEL_FILE, tracking_uri))


_KEYS_ADDED_SINCE: dict[str, dict[str, object]] = {
    "build_robot": {"collision_urdf": None},
    "load_robot_yaml": {},
    "load_urdf_robot": {
        "package_dirs": [],
        "srdf": None,
        "joint_limits": None,
        "collision_geometry": True,
        "missing_meshes": "error",
    },
}
"""Robot settings added after a model may have been saved, with the value that keeps its behaviour:
an ``identified_model.yaml`` written before them still loads."""


def load_identified_robot(
    source: str,
    *,
    tracking_uri: str | None,
    build_robot: RobotBuilder,
    fetch_run_artifact: RunArtifactFetcher | None,
) -> RobotModel:
    """The robot identified by an earlier run.

    Every argument is required: conf/robot/identified.yaml gives their values.

    Parameters
    ----------
    source : an ``identified_model.yaml``, the run folder holding it, or an MLflow run id.
    tracking_uri : the store a run id is looked up in (``None``: MLflow's default).
    build_robot : builds the robot description stored in the file (e.g. ``hydra.utils.instantiate``);
        only robot plugins (``_target_: plugins.robots.*``) are built.
    fetch_run_artifact : downloads a run's artifact (needed for a run id only; None: no look-up).

    Examples
    --------
    >>> import hydra.utils  # doctest: +SKIP
    >>> load_identified_robot(
    ...     "outputs/runs/<run>",
    ...     tracking_uri=None,
    ...     build_robot=hydra.utils.instantiate,
    ...     fetch_run_artifact=None,
    ... )  # doctest: +SKIP
    """
    path = _locate(str(source), tracking_uri, fetch_run_artifact)
    identified, robot_config = load_identified_model(path)
    target = str(robot_config.get("_target_", ""))
    # The description comes from a file that may be shared: build only known robot plugins.
    if not target.startswith(_ALLOWED_TARGET_PREFIX):
        raise ValueError(
            f"{path}: robot _target_ {target!r} is not a robot plugin ({_ALLOWED_TARGET_PREFIX}*)"
        )
    defaults = _KEYS_ADDED_SINCE.get(target.rsplit(".", 1)[-1], {})
    prior = build_robot({**defaults, **robot_config})
    if tuple(prior.parameter_names) != identified.standard_names:
        raise ValueError(
            f"{path}: its standard parameters do not match the robot it describes ({prior.name})"
        )
    robot = prior.with_parameters(identified.standard_values)
    return replace(robot, name=f"{prior.name}_identified")
