"""The params of a job's run: the few settings that tell it apart, each a value that fits a table cell.

MLflow's runs table offers every param as a column and every param in its parallel-coordinates plot,
so a job logs only what identifies it (at most :data:`MAX_PARAMS`, in this order):

1. the keys the user overrode or swept (``plant.torque_noise_std=0.2``, ``x=3``; Hydra's own keys left
   out; a config-group choice is logged in 2.);
2. the short name of every plugin choice (``estimator=wls``, ``robot=kuka_lwr4``; see
   :func:`~lwrlab.tracking.job_config.config_params.plugin_choices`);
3. the knobs that change results most (:data:`KNOBS`: the seed, noise, motion durations, processing,
   the logs identified from), where the config has them.

Values are scalars: a list of scalars reads ``a, b, c`` (up to :data:`MAX_LIST_ITEMS` items), a mapping
gives one param per scalar leaf; longer lists, lists of mappings and anything cut by MLflow's length
limit are left out. The whole resolved config is logged beside as the artifact
:data:`RESOLVED_CONFIG_ARTIFACT`, named by the tag ``config_hash``.

Examples
--------
>>> config = {"seed": 1, "plant": {"torque_noise_std": 0.2, "mode": "playback"}, "robot": {"links": [{}]}}
>>> run_params(config, {"estimator": "wls"}, ["plant.torque_noise_std=0.2", "hydra.verbose=true"])
{'plant.torque_noise_std': '0.2', 'estimator': 'wls', 'seed': '1', 'plant.mode': 'playback'}
"""

from __future__ import annotations

import numbers
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

from omegaconf import DictConfig, OmegaConf

from lwrlab.tracking.job_config.config_params import (
    NOT_HASHED_KEYS,
    PARAM_VALUE_MAX_LENGTH,
    hashed_config_text,
    plugin_choices,
    runtime_choices,
    task_overrides,
    unique_keys,
)

MAX_PARAMS = 30
"""Params per job run: what a person can scan in the runs table's column picker."""
MAX_LIST_ITEMS = 8
"""A list of more scalars than this is no table cell: it stays in the resolved config only."""
RESOLVED_CONFIG_ARTIFACT = "resolved_config.yaml"
"""The job's whole config, resolved and redacted, as an artifact of its run."""

KNOBS: tuple[str, ...] = (
    "seed",
    "plant.mode",
    "plant.torque_noise_std",
    "trajectory.duration",
    "validation.duration",
    "measurement.processing.cutoff_hz",
    "measurement.processing.state_cutoff_hz",
    "measurement.processing.rate_hz",
    "robot.friction_terms",
    "data.paths",
    "data.validation_paths",
)
"""Dotted config keys that change a run's results most, logged as params wherever the config has them
(the rest of a config's settings follow from the plugin choices and the overrides)."""

_NOT_PARAMS = ("hydra.", "hydra/")


def _select(config: Mapping[str, Any], dotted: str) -> tuple[bool, Any]:
    node: Any = config
    for part in dotted.split("."):
        if not isinstance(node, Mapping) or part not in node:
            return False, None
        node = node[part]
    return True, node


def _is_scalar(value: Any) -> bool:
    return value is None or isinstance(value, (str, bool, numbers.Number))


def cell_params(key: str, value: Any) -> Iterator[tuple[str, str]]:
    """``(key, text)`` for a config value as table cells: one for a scalar or a short list of scalars,
    one per scalar leaf of a mapping, none for anything else.

    Examples
    --------
    >>> list(cell_params("data.paths", ["a.csv", "b.csv"]))
    [('data.paths', 'a.csv, b.csv')]
    >>> list(cell_params("data.column_map", {"t": "times", "q": ["x"], "links": [{"m": 1}]}))
    [('data.column_map.t', 'times'), ('data.column_map.q', 'x')]
    """
    if isinstance(value, Mapping):
        for sub_key, sub_value in value.items():
            yield from cell_params(f"{key}.{sub_key}", sub_value)
        return
    if isinstance(value, Sequence) and not isinstance(value, str):
        if len(value) > MAX_LIST_ITEMS or not all(_is_scalar(item) for item in value):
            return
        text = ", ".join(str(item) for item in value)
    elif _is_scalar(value):
        text = str(value)
    else:
        return
    if len(text) <= PARAM_VALUE_MAX_LENGTH:
        yield key, text


def _override_key(override: str) -> str:
    return override.partition("=")[0].lstrip("+~")


def run_params(
    job_config: Mapping[str, Any], choices: Mapping[str, str], overrides: Sequence[str]
) -> dict[str, str]:
    """A job's params: overridden keys, plugin choices, then :data:`KNOBS`; at most :data:`MAX_PARAMS`.

    Parameters
    ----------
    job_config
        The resolved config without its ``hydra`` node.
    choices
        The plugin choices by short name (``{"estimator": "wls"}``).
    overrides
        The job's task overrides as typed (``["estimator=wls", "seed=1"]``).
    """
    params: dict[str, str] = {}
    for override in overrides:
        key = _override_key(override)
        found, value = _select(job_config, key)
        if key.startswith(_NOT_PARAMS) or key in choices or not found:
            continue  # Hydra's own, a plugin choice (logged by its short name below), or a group
        params.update(cell_params(key, value))
    params.update({key: value for key, value in choices.items() if key not in params})
    for knob in KNOBS:
        found, value = _select(job_config, knob)
        if found and knob not in params:
            params.update(cell_params(knob, value))
    return dict(list(unique_keys(params).items())[:MAX_PARAMS])


def job_params(config: DictConfig, job_config: Mapping[str, Any]) -> dict[str, str]:
    """The params of a Hydra job's run (see :func:`run_params`), read from its full config.

    Examples
    --------
    >>> config = OmegaConf.create({"seed": 1, "hydra": {"runtime": {"choices": {"estimator": "wls"}}}})
    >>> job_params(config, {"seed": 1})
    {'estimator': 'wls', 'seed': '1'}
    """
    return run_params(job_config, plugin_choices(runtime_choices(config)), task_overrides(config))


def resolved_config_text(job_config: Mapping[str, Any], hashed_text: str | None = None) -> str:
    """The whole resolved config as YAML, keys sorted: the text whose hash is the tag ``config_hash``
    (the ``tracking`` node, which says where the run is logged, comes last and is not hashed);
    ``hashed_text``: that hashed part when already made (:func:`hashed_config_text`)."""
    kept = {key: value for key, value in job_config.items() if key in NOT_HASHED_KEYS}
    text = hashed_config_text(job_config) if hashed_text is None else hashed_text
    return text + (OmegaConf.to_yaml(OmegaConf.create(kept), sort_keys=True) if kept else "")


__all__ = [
    "KNOBS",
    "MAX_LIST_ITEMS",
    "MAX_PARAMS",
    "RESOLVED_CONFIG_ARTIFACT",
    "cell_params",
    "job_params",
    "resolved_config_text",
    "run_params",
]
