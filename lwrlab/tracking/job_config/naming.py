"""What a reader of the MLflow store sees first: experiment kind and description, run names.

* Experiments are created as model-development experiments (tag ``mlflow.experimentKind``), so that
  MLflow 3's UI opens on their runs rather than on an empty GenAI traces page, and their description
  lists the headline metrics with their units.
* A run is named by what differs: the swept overrides first (a config-group choice by its option
  alone: ``wls · seed=1``), then the other overrides, and for a recorded log the log file's stem.

Examples
--------
>>> run_name(
...     ["estimator=wls", "seed=1", "task=identification"],
...     swept={"estimator", "seed"},
...     groups={"estimator", "task"},
... )
'wls · seed=1 · identification'
"""

from __future__ import annotations

import logging
import re
from collections.abc import Collection, Iterable, Mapping, Sequence
from pathlib import PurePath
from typing import Any

from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from lwrlab.tracking.job_config.config_params import (
    RUN_NAME_MAX_LENGTH,
    runtime_choices,
    task_overrides,
    truncate,
)
from lwrlab.tracking.job_config.metric_sections import ACCURACY, TIMING, metric_section

log = logging.getLogger(__name__)

EXPERIMENT_KIND_TAG = "mlflow.experimentKind"
EXPERIMENT_KIND = "custom_model_development"
"""The value MLflow 3's UI reads as "model training" (its other kinds are GenAI ones)."""
DESCRIPTION_TAG = "mlflow.note.content"
"""The experiment (and run) description shown by the MLflow UI."""
NAME_SEPARATOR = " · "

HEADLINE_METRICS: dict[str, tuple[str, str]] = {
    "rms_mean": (
        "N·m",
        "cross-validation RMS torque error, mean over joints (per joint: rms_joint1, rms_joint2, …)",
    ),
    "nrms_mean": (
        "%",
        "the same error as a percentage of each joint's measured torque range, mean over joints",
    ),
    "validation_rel_error": ("1", "‖τ − τ̂‖/‖τ‖ on the validation logs (0.05 = 5 %)"),
    "base_parameter_error": (
        "1",
        "‖β̂ − β‖/‖β‖ against the simulated robot's true base parameters (simulated plants only)",
    ),
    "poorly_known_after": ("1", "base parameters still poorly known after the designed exciting motion"),
    "target_torque_std_after": (
        "N·m",
        "expected std of the torque predicted along the target motions after the designed exciting motion",
    ),
}
"""Metric name → (unit, meaning): what ``lwrlab compare`` tabulates and the experiment description lists."""
PER_JOINT_RMS = re.compile(r"^rms_joint(\d+)$")

# Overrides that say where or how a run is logged or launched, not what it computes: left out of names.
_NOT_NAMED = re.compile(r"^(hydra[./]|tracking[./]|tracking$|experiment_name$)")


def is_timing_metric(name: str) -> bool:
    """Whether a plain metric name is a duration in seconds (``fit_cpu_s``, ``stage_identification_s``, …)."""
    return metric_section(name) == TIMING


def experiment_description(name: str) -> str:
    """The description of a new experiment: what its runs are and the headline metrics with units."""
    lines = [
        f"lwrlab runs of `{name}`: one run per Hydra job; "
        "a sweep is a parent run with one nested run per job.",
        "Run names start with what differs (swept overrides first); config-group choices are params "
        "(estimator, criterion, robot, trajectory, plant, …).",
        "",
        f"Headline metrics (section `{ACCURACY}/`, first in the chart view):",
        *(
            f"- `{ACCURACY}/{metric}` [{unit}]: {meaning}"
            for metric, (unit, meaning) in HEADLINE_METRICS.items()
        ),
        "- other sections: `joints/` (per joint), `diagnostics/` (conditioning, identifiability), "
        f"`{TIMING}/` [s] (`fit_cpu_s`: estimator fit, `stage_*_s`: stages of the whole chain); "
        "a sweep's parent run: `summary/` (jobs, failures, best and mean of each headline metric)",
        "",
        "Compare runs grouped by what was swept, seeds as replication: "
        f"`lwrlab compare --experiment {name}`.",
    ]
    return "\n".join(lines)


def _key_and_value(override: str) -> tuple[str, str]:
    key, _, value = override.partition("=")
    return key.lstrip("+~"), value


def swept_keys(sweep_overrides: Iterable[str], sweeper_params: Mapping[str, Any] | None = None) -> list[str]:
    """The keys a sweep varies: overrides with several values (``a,b``, ``range()``…) and sweeper params."""
    keys: list[str] = []
    overrides = [str(item) for item in sweep_overrides]
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.errors import OverrideParseException

    try:
        for parsed in OverridesParser.create().parse_overrides(overrides):
            if parsed.is_sweep_override():
                keys.append(parsed.get_key_element().lstrip("+~"))
    except OverrideParseException:  # an override Hydra's grammar rejects here: fall back on commas
        keys = [key for key, value in map(_key_and_value, overrides) if "," in value]
    keys += [str(key) for key in (sweeper_params or {})]
    return list(dict.fromkeys(keys))


def log_file_stem(config: DictConfig) -> str | None:
    """The stem of a recorded log's file (``data.path``, or the first of ``data.paths``), if any."""
    for key in ("data.path", "data.paths"):
        try:
            value = OmegaConf.select(config, key, default=None, throw_on_missing=False)
        except OmegaConfBaseException:  # an interpolation that does not resolve here
            continue
        if OmegaConf.is_list(value) or isinstance(value, (list, tuple)):
            value = value[0] if len(value) else None
        if value not in (None, "", "???"):
            return PurePath(str(value)).stem
    return None


def _shown(key: str, value: str, groups: Collection[str]) -> str:
    if key in groups:
        return value  # a plugin choice reads best as its name: `wls`, not `estimator=wls`
    if key in ("data.path", "data.paths"):
        return PurePath(value.strip("[]'\" ").split(",")[0]).stem
    return f"{key}={value}"


def run_name(
    task_overrides: Sequence[str],
    swept: Collection[str] = (),
    groups: Collection[str] = (),
    fallback: str = "job",
    log_stem: str | None = None,
) -> str:
    """A run's name: swept overrides first, then the other overrides, joined by `` · ``.

    Parameters
    ----------
    task_overrides
        The job's task overrides (``hydra.overrides.task``), e.g. ``["estimator=wls", "seed=1"]``.
    swept
        Keys the sweep varies (see :func:`swept_keys`).
    groups
        Config groups (keys of Hydra's runtime choices): shown by their option alone.
    fallback
        The name when nothing is overridden (the task's name).
    log_stem
        A recorded log's file stem, shown after the swept overrides unless an override shows it.
    """
    parts = [_key_and_value(item) for item in task_overrides]
    parts = [(key, value) for key, value in parts if not _NOT_NAMED.match(key)]
    first = [_shown(key, value, groups) for key, value in parts if key in swept]
    rest = [_shown(key, value, groups) for key, value in parts if key not in swept]
    if log_stem and log_stem not in first + rest:
        first.append(log_stem)
    return NAME_SEPARATOR.join(first + rest) or fallback


def job_run_name(config: DictConfig, swept: Collection[str] = ()) -> str:
    """The name of a job's run (see :func:`run_name`), read from its config and cut to MLflow's limit."""
    choices = runtime_choices(config)
    fallback = str(choices.get("task") or OmegaConf.select(config, "hydra.job.name", default="job"))
    log_stem = log_file_stem(config) if choices.get("plant") == "log" else None
    name = run_name(task_overrides(config), swept, set(choices), fallback, log_stem)
    return truncate(name, RUN_NAME_MAX_LENGTH)


__all__ = [
    "DESCRIPTION_TAG",
    "EXPERIMENT_KIND",
    "EXPERIMENT_KIND_TAG",
    "HEADLINE_METRICS",
    "PER_JOINT_RMS",
    "experiment_description",
    "is_timing_metric",
    "job_run_name",
    "log_file_stem",
    "run_name",
    "swept_keys",
]
