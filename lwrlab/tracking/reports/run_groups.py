"""Which parameters a set of runs differ in, with the seed as replication: the groups of a comparison.

A table of runs (``mlflow.search_runs`` layout, ``params.*`` columns) is split into the parameters that
vary across runs (swept, or launched separately with other values) and replication (the seed, and any
parameter that just repeats it, such as ``trajectory.seed: ${seed}``). Where a config-group choice
varies (``estimator``), the keys under it (``estimator._target_``, ``estimator.weights``) are not
listed again. Keys that say where a run is logged (``tracking.*``, ``experiment_name``) never count.

Examples
--------
>>> import pandas as pd
>>> runs = pd.DataFrame({
...     "params.estimator": ["ols", "wls", "ols"],
...     "params.estimator._target_": ["a.OLS", "a.WLS", "a.OLS"],
...     "params.seed": ["0", "0", "1"],
...     "params.trajectory.seed": ["0", "0", "1"],
...     "params.x": ["1", "1", "1"],
... })
>>> swept_parameters(runs)
['estimator']
"""

from __future__ import annotations

import re

import pandas as pd

PARAM_PREFIX = "params."
SEED = "seed"
_NOT_COMPUTATION = re.compile(r"^(tracking(\..*)?|experiment_name|hydra\..*)$")


def _values(runs: pd.DataFrame, column: str) -> pd.Series:
    return runs[column].fillna("<unset>").astype(str)


def swept_parameters(runs: pd.DataFrame) -> list[str]:
    """Parameters (without the ``params.`` prefix) whose values differ across ``runs``, seed excluded."""
    if runs.empty:
        return []
    columns = [column for column in runs.columns if column.startswith(PARAM_PREFIX)]
    seed = _values(runs, PARAM_PREFIX + SEED) if PARAM_PREFIX + SEED in runs else None
    varying = []
    for column in columns:
        key = column[len(PARAM_PREFIX) :]
        values = _values(runs, column)
        if values.nunique() <= 1 or _NOT_COMPUTATION.match(key) or key.rsplit(".", 1)[-1] == SEED:
            continue
        if seed is not None and (values == seed).all():
            continue  # a copy of the seed (``${seed}``): replication, not a parameter
        varying.append(key)
    # Keys under a varying choice follow from it: `estimator` explains `estimator._target_`.
    return [
        key for key in varying if not any(key.startswith(other + ".") for other in varying if other != key)
    ]


def value_summary(runs: pd.DataFrame, parameter: str, limit: int = 6) -> str:
    """The distinct values of a parameter, e.g. ``ols, sdp, wls``."""
    values = sorted(_values(runs, PARAM_PREFIX + parameter).unique())
    return ", ".join(values[:limit]) + (", …" if len(values) > limit else "")


def short_name(parameter: str) -> str:
    """The last component of a dotted parameter (``plant.torque_noise_std`` → ``torque_noise_std``)."""
    return parameter.rsplit(".", 1)[-1]


__all__ = ["short_name", "swept_parameters", "value_summary"]
