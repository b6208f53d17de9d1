"""Where a job is logged: the tracking callback's settings as each job's own config resolves them.

Hydra builds callbacks once, from the primary config, before any job runs. A sweep over
``experiment_name`` (or over experiment presets) must still log each job in its own experiment, so
the callback's config node is read again from every job's config (:func:`job_settings`); relative
paths are taken from the folder Hydra was started in, so the store does not move when
``hydra.job.chdir=true`` changes the working directory.

Examples
--------
>>> TrackingSettings("sqlite:////lab/outputs/mlflow.db", "identification", None, True).experiment
'identification'
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from hydra.utils import get_class
from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from lwrlab.tracking.job_config.config_params import (
    flatten_config,
    is_sweep_job,
    original_cwd,
    runtime_choices,
)
from lwrlab.tracking.job_config.redaction import Redactor
from lwrlab.tracking.store.sqlite import absolute_artifact_location, absolute_tracking_uri

log = logging.getLogger(__name__)

SETTING_FIELDS = ("tracking_uri", "experiment", "artifact_location", "log_artifacts")
"""The callback's config values that say where and how a run is logged."""
_UNNAMED_EXPERIMENT = (None, "", "None", "null")


@dataclass(frozen=True)
class TrackingSettings:
    """Where and how one run is logged, with paths already made absolute."""

    tracking_uri: str
    experiment: str
    artifact_location: str | None
    log_artifacts: bool


def own_config_node(config: DictConfig, callback_class: type) -> DictConfig | None:
    """The node under ``hydra.callbacks`` that instantiates ``callback_class``, if exactly one does."""
    callbacks = OmegaConf.select(config, "hydra.callbacks")
    if not isinstance(callbacks, DictConfig):
        return None
    matches = []
    for node in callbacks.values():
        try:
            if isinstance(node, DictConfig) and get_class(str(node["_target_"])) is callback_class:
                matches.append(node)
        except (ImportError, ValueError, OmegaConfBaseException):  # another callback, or a broken one
            continue
    return matches[0] if len(matches) == 1 else None


def job_settings(config: DictConfig, values: Mapping[str, Any], callback_class: type) -> TrackingSettings:
    """The callback's settings as ``config`` resolves them, with paths made absolute.

    Parameters
    ----------
    config
        A job's full config (with its ``hydra`` node). If exactly one node under
        ``hydra.callbacks`` targets ``callback_class``, its values are resolved in this config;
        otherwise (or where a value cannot be resolved) ``values`` are used. Relative paths are
        taken from ``hydra.runtime.cwd``.
    values
        The callback's constructor values of :data:`SETTING_FIELDS`.
    callback_class
        The callback's class.

    Returns
    -------
    TrackingSettings
        With the experiment named after the task when none is set (one experiment per task).
    """
    resolved = {field: values[field] for field in SETTING_FIELDS}
    own_node = own_config_node(config, callback_class)
    if own_node is not None:
        for field in SETTING_FIELDS:
            try:
                if field in own_node:
                    resolved[field] = own_node[field]
            except OmegaConfBaseException:  # e.g. ${hydra:...} outside a job: keep the constructor value
                log.debug("kept the constructor value of %s", field, exc_info=True)
    base_dir = original_cwd(config)
    experiment = resolved["experiment"]
    if experiment in _UNNAMED_EXPERIMENT:
        experiment = (
            runtime_choices(config).get("task")
            or OmegaConf.select(config, "hydra.job.name", default=None)
            or "lwrlab"
        )
    artifact_location = resolved["artifact_location"]
    return TrackingSettings(
        tracking_uri=absolute_tracking_uri(str(resolved["tracking_uri"]), base_dir),
        experiment=str(experiment),
        artifact_location=absolute_artifact_location(
            None if artifact_location is None else str(artifact_location), base_dir
        ),
        log_artifacts=bool(resolved["log_artifacts"]),
    )


def job_redactor(config: DictConfig, job_config: Mapping[str, Any], settings: TrackingSettings) -> Redactor:
    """Secrets of a job: URI passwords anywhere in its config, overrides or store, and the environment."""
    overrides = OmegaConf.select(config, "hydra.overrides", default=None)
    texts = [settings.tracking_uri, str(settings.artifact_location)]
    if OmegaConf.is_config(overrides):
        texts.append(json.dumps(OmegaConf.to_container(overrides, resolve=False)))
    return Redactor.from_config(flatten_config(job_config), texts)


__all__ = [
    "SETTING_FIELDS",
    "TrackingSettings",
    "is_sweep_job",
    "job_redactor",
    "job_settings",
    "original_cwd",
    "own_config_node",
]
