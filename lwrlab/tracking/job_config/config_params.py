"""A job as MLflow sees it: its config flattened into params, a hash naming it, metrics from its result.

Pure functions, no store access:

* :func:`flatten_config` flattens a config into dotted keys within MLflow's key and length limits
  (for offline records and callers that need every key; a job's params are the few of
  :mod:`.run_params`), :func:`plugin_choices` reads the short name of every plugin choice
  (``estimator=wls``, ``criterion=logdet``) from Hydra's runtime choices;
* :func:`config_hash` and :func:`sweep_identity` name a computation, so that a re-launched sweep
  recognises its finished jobs and its parent run;
* :func:`numeric_metrics` reads the metrics to log from a task function's return value;
* :func:`original_cwd` and :func:`is_sweep_job` read where and how Hydra runs the job.

Examples
--------
>>> flatten_config({"robot": {"dof": 7}, "seed": 0})
{'robot.dof': '7', 'seed': '0'}
>>> numeric_metrics({"metrics": {"rms_mean": 0.2}})
{'rms_mean': 0.2}
>>> plugin_choices({"estimator": "wls", "trajectory@validation": "multisine", "hydra/launcher": "basic"})
{'estimator': 'wls', 'validation': 'multisine'}
"""

from __future__ import annotations

import hashlib
import json
import numbers
import os
import re
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from mlflow.utils import validation as mlflow_limits
from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

# MLflow's own limits, read from the installed version (with mlflow 3's values as fallbacks).
PARAM_VALUE_MAX_LENGTH: int = getattr(mlflow_limits, "MAX_PARAM_VAL_LENGTH", 6000)
TAG_VALUE_MAX_LENGTH: int = getattr(mlflow_limits, "MAX_TAG_VAL_LENGTH", 8000)
KEY_MAX_LENGTH: int = getattr(mlflow_limits, "MAX_ENTITY_KEY_LENGTH", 250)
RUN_NAME_MAX_LENGTH = 250  # the runs.name column of MLflow's SQL stores

# Config keys that say where a run is logged, not what it computes: left out of the config hash.
NOT_HASHED_KEYS = frozenset({"tracking"})

# Characters MLflow accepts in param and metric keys (mlflow.utils.validation, POSIX flavour).
_INVALID_KEY_CHARACTERS = re.compile(r"[^/\w.\- :]")


def truncate(text: str, max_length: int) -> str:
    """Cut ``text`` to ``max_length`` characters, ending with ``...`` when it was cut."""
    return text if len(text) <= max_length else text[: max_length - 3] + "..."


def mlflow_key(name: str) -> str:
    """Turn ``name`` into a valid MLflow param/metric key (bad characters become ``_``)."""
    return _INVALID_KEY_CHARACTERS.sub("_", name)[:KEY_MAX_LENGTH]


def unique_keys(flat: Mapping[str, str]) -> dict[str, str]:
    """``flat`` with valid MLflow keys; of two keys that sanitise alike, the first one's value is kept.

    A batch with duplicate keys fails as a whole, so the duplicates are dropped here.
    """
    unique: dict[str, str] = {}
    for key, value in flat.items():
        unique.setdefault(mlflow_key(key), value)
    return unique


def flatten_config(node: Any, prefix: str = "") -> dict[str, str]:
    """Flatten a nested config into MLflow params.

    Parameters
    ----------
    node
        A plain container (as from ``OmegaConf.to_container(cfg, resolve=True)``).
    prefix
        Key of ``node`` itself; nested keys are joined to it with dots.

    Returns
    -------
    dict[str, str]
        ``{"robot.dof": "7", "trajectory.harmonics": "[1, 2, 3]", ...}``: lists as JSON strings,
        every value cut to MLflow's param length limit (``PARAM_VALUE_MAX_LENGTH``).

    Examples
    --------
    >>> flatten_config({"robot": {"dof": 7, "q_max": [1.0, 2.0]}, "seed": 0})
    {'robot.dof': '7', 'robot.q_max': '[1.0, 2.0]', 'seed': '0'}
    """
    if isinstance(node, Mapping):
        flat: dict[str, str] = {}
        if not node and prefix:
            flat[prefix] = "{}"  # keep the key visible even when its node is empty
        for key, value in node.items():
            flat.update(flatten_config(value, f"{prefix}.{key}" if prefix else str(key)))
        return flat
    text = json.dumps(node, default=str) if isinstance(node, (list, tuple)) else str(node)
    return {prefix: truncate(text, PARAM_VALUE_MAX_LENGTH)} if prefix else {}


def resolved_job_config(config: DictConfig) -> dict[str, Any]:
    """The job's config without the ``hydra`` node, resolved into plain containers.

    A key whose interpolation cannot be resolved (or a missing ``???`` value) is kept as written
    rather than failing the run.
    """
    resolved: dict[str, Any] = {}
    for key in config:
        if key == "hydra":
            continue
        try:
            value = config[key]
            resolved[str(key)] = (
                OmegaConf.to_container(value, resolve=True) if OmegaConf.is_config(value) else value
            )
        except OmegaConfBaseException:  # OmegaConf wraps a failing resolver's error in its own
            raw = OmegaConf.to_container(config, resolve=False)
            assert isinstance(raw, dict)
            resolved[str(key)] = raw[key]
    return resolved


def plugin_choices(choices: Mapping[str, Any]) -> dict[str, str]:
    """Config-group choices as params: ``{"estimator": "wls", …}``; ``group@package`` under its package.

    Hydra's own groups (``hydra/launcher``, …) are left out; an empty slot (``tool: null``) is ``none``.
    """
    params: dict[str, str] = {}
    for group, option in choices.items():
        if str(group).startswith("hydra/"):
            continue
        name = str(group).rsplit("@", 1)[-1] if "@" in str(group) else str(group)
        params[name.replace("/", ".")] = "none" if option is None else str(option)
    return params


def runtime_choices(config: DictConfig) -> dict[str, Any]:
    """Hydra's runtime choices of a job's config (``{}`` outside Hydra)."""
    choices = OmegaConf.select(config, "hydra.runtime.choices", default=None)
    if not OmegaConf.is_config(choices):
        return {}
    container = OmegaConf.to_container(choices, resolve=False)
    return {str(group): option for group, option in container.items()} if isinstance(container, dict) else {}


def task_overrides(config: DictConfig) -> list[str]:
    """The job's task overrides (``hydra.overrides.task``) as strings, ``[]`` outside Hydra."""
    return [str(item) for item in OmegaConf.select(config, "hydra.overrides.task", default=[]) or []]


def hashed_config_text(resolved_config: Mapping[str, Any]) -> str:
    """The resolved config as YAML, keys sorted, without the ``tracking`` node: the text
    :func:`config_hash` hashes (computed once per job: its YAML is the slowest part of a run's start)."""
    kept = {key: value for key, value in resolved_config.items() if key not in NOT_HASHED_KEYS}
    return OmegaConf.to_yaml(OmegaConf.create(kept), sort_keys=True)


def config_hash(resolved_config: Mapping[str, Any], text: str | None = None) -> str:
    """SHA-256 of the resolved config as YAML, keys sorted (so reordering defaults keeps the hash);
    ``text``: that YAML when already made (:func:`hashed_config_text`).

    The ``tracking`` node (where the run is logged) is left out: the hash names the computation, so a
    re-launched sweep recognises its finished jobs whatever store they went to.
    """
    text = hashed_config_text(resolved_config) if text is None else text
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def sweep_identity(
    primary_config: Mapping[str, Any], sweep_overrides: Sequence[str], sweeper_params: Any
) -> str:
    """SHA-256 naming a sweep: its primary config, overrides (order-free) and the sweeper's search space.

    A re-launched sweep has the same identity, so its jobs are nested under the same parent run.
    """
    text = json.dumps(
        {
            "config": config_hash(primary_config),
            "overrides": sorted(sweep_overrides),
            "params": sweeper_params,
        },
        sort_keys=True,
        default=str,
    )
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _numeric_leaves(value: Any, key: str) -> Iterator[tuple[str, float]]:
    if isinstance(value, (str, bytes, bool)) or value is None:
        return
    if hasattr(value, "tolist") and not isinstance(value, numbers.Real):
        value = value.tolist()  # numpy arrays (and 0-d arrays) → lists (or a scalar)
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        yield key, float(value)
    elif isinstance(value, Mapping):
        for sub_key, sub_value in value.items():
            yield from _numeric_leaves(sub_value, f"{key}.{sub_key}" if key else str(sub_key))
    elif isinstance(value, Sequence):
        for index, item in enumerate(value):
            yield from _numeric_leaves(item, f"{key}.{index}" if key else str(index))


def numeric_metrics(return_value: Any) -> dict[str, float]:
    """The metrics to log from a task function's return value.

    Parameters
    ----------
    return_value
        ``{"metrics": {...}, ...}`` (only the ``metrics`` entry is used), or a dict of metrics, or a
        single number (logged as ``return_value``, what a Hydra sweeper optimises).

    Returns
    -------
    dict[str, float]
        Every numeric leaf; nested keys joined by dots, sequence items by index
        (``rms.0``, ``rms.1``…); strings, booleans and ``None`` are skipped.

    Examples
    --------
    >>> numeric_metrics({"metrics": {"rms_mean": 0.2, "rms": [0.1, 0.3]}, "report": "text"})
    {'rms_mean': 0.2, 'rms.0': 0.1, 'rms.1': 0.3}
    """
    if isinstance(return_value, Mapping) and isinstance(return_value.get("metrics"), Mapping):
        return_value = return_value["metrics"]
    if isinstance(return_value, numbers.Real) and not isinstance(return_value, bool):
        return {"return_value": float(return_value)}
    if not isinstance(return_value, Mapping):
        return {}
    return {mlflow_key(key): value for key, value in _numeric_leaves(return_value, "")}


__all__ = [
    "KEY_MAX_LENGTH",
    "NOT_HASHED_KEYS",
    "PARAM_VALUE_MAX_LENGTH",
    "RUN_NAME_MAX_LENGTH",
    "TAG_VALUE_MAX_LENGTH",
    "config_hash",
    "flatten_config",
    "hashed_config_text",
    "mlflow_key",
    "numeric_metrics",
    "plugin_choices",
    "resolved_job_config",
    "runtime_choices",
    "sweep_identity",
    "task_overrides",
    "truncate",
    "unique_keys",
]


def original_cwd(config: DictConfig) -> Path:
    """The folder Hydra was started in (``hydra.runtime.cwd``), else the current one."""
    return Path(str(OmegaConf.select(config, "hydra.runtime.cwd", default=None) or os.getcwd()))


def is_sweep_job(config: DictConfig) -> bool:
    """Whether ``config`` is a job of a Hydra multirun."""
    return str(OmegaConf.select(config, "hydra.mode", default="")).endswith("MULTIRUN")
