"""Plugins built in Python from their shipped YAML: ``build("estimator", "wls", n_joints=7)``.

The YAML of an option (``conf/<group>/<option>.yaml``) is the one place of its settings' values: a
plugin's constructor takes every setting as a keyword argument without a Python default. Code that
builds a plugin outside a job (tests, benchmarks, notebooks) takes the shipped values from here and
names only what it changes. The option is composed as ``lwrlab <group>=<option>`` composes it: the
primary config's defaults for the rest, so ``${criterion}``, ``${optimizer}`` or ``${seed}`` resolve to
the shipped defaults. The tree is read through the package (``pkg://lwrlab.conf``), so this works
from an installed wheel as from the source tree.

Examples
--------
>>> build("estimator", "wls", n_joints=2)
WeightedLeastSquares(min_relative_std=1e-06, n_joints=2, near_rest='weighted', reweight_steps=2)
>>> build("trajectory", "optimal", duration=4.0, constraints={"torque": False}).constraints.torque
False
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from typing import Any

from hydra import compose, initialize_config_module
from hydra.core.global_hydra import GlobalHydra
from hydra.errors import InstantiationException
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf

from lwrlab.resources import CONFIG_PACKAGE, config_group


@functools.cache
def _composed(group: str, option: str) -> DictConfig:
    """The primary config composed with ``<group>=<option>`` (cached: a composition takes ~0.3 s)."""
    if option not in config_group(group):
        raise ValueError(
            f"no option {option!r} in config group {group!r}; options: {sorted(config_group(group))}"
        )
    if GlobalHydra.instance().is_initialized():
        raise RuntimeError(
            f"build({group!r}, {option!r}) composes the shipped config tree itself and cannot run inside "
            f"a Hydra job or compose context: instantiate the job's cfg.{group} there"
        )
    with initialize_config_module(config_module=CONFIG_PACKAGE, version_base=None):
        return compose(config_name="config", overrides=[f"{group}={option}"])


def shipped_config(group: str, option: str) -> DictConfig:
    """The composed node of option ``option`` of config group ``group`` (interpolations resolvable)."""
    return _composed(group, option)[group]


def _cleared(config: DictConfig, overrides: Mapping[str, Any]) -> DictConfig:
    """A copy of ``config`` whose keys that ``overrides`` replace (all but mappings updating a mapping) are
    None, so that Hydra's merge of the overrides replaces them instead of merging a list into a mapping."""
    copy = config.copy()  # shallow: the nodes left alone stay shared, the parent (interpolations) too
    for key, value in overrides.items():
        if not (isinstance(value, Mapping) and OmegaConf.is_dict(config[key])):
            copy[key] = None
    return copy


def build(group: str, option: str, /, **overrides: Any) -> Any:
    """The plugin ``conf/<group>/<option>.yaml`` builds, with ``overrides`` of its keys.

    Parameters
    ----------
    group, option : the config group and its option, e.g. ``"estimator"``, ``"wls"``.
    **overrides : new values of the option's keys. A mapping given for a nested node updates the keys
        it names (``constraints={"torque": False}``); built objects are passed through
        (``criterion=LogDet()``).

    Returns
    -------
    The instantiated plugin (a partial for ``_partial_`` options, as in a job).

    Raises
    ------
    ValueError
        For an unknown option, or an override naming no key of the option (the keys are listed).
    Exception
        What the plugin itself raises on building (a ``ValueError`` for a bad setting, …), as a direct
        call would, not wrapped in Hydra's ``InstantiationException``.
    """
    config = shipped_config(group, option)
    unknown = sorted(set(overrides) - {str(key) for key in config})
    if unknown:
        settings = sorted(str(key) for key in config if not str(key).startswith("_"))
        raise ValueError(f"{group}/{option} has no setting {unknown}; its settings: {settings}")
    try:
        return instantiate(_cleared(config, overrides), **overrides)
    except InstantiationException as error:
        cause = error.__cause__
        if not isinstance(cause, Exception):
            raise
        cause.add_note(f"building {group}/{option}: {str(error).splitlines()[0]}")
        raise cause from None  # the plugin's own error, as a direct call raises it
