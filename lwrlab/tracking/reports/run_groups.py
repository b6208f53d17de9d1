"""Which parameters a set of runs differ in, with the seed as replication: the groups of a comparison.

A table of runs (``mlflow.search_runs`` layout, ``params.*`` columns) is split into the parameters that
vary across runs (swept, or launched separately with other values) and replication (the seed, and any
parameter that just repeats it, such as ``trajectory.seed: ${seed}``). Where a config-group choice
varies (``estimator``), the keys under it (``estimator._target_``, ``estimator.weights``) are not
listed again where they follow from it (one value per choice; ``robot.path`` of two URDF robots does
not follow from ``robot=urdf``). Keys that say where a run is logged (``tracking.*``,
``experiment_name``) or how it shows progress (``*.show_progress``) never count.

What a run is *of* (its robot, its data: ``robot``, ``plant``, ``data`` and the keys under them,
:func:`subject_parameters`) is never pooled: a comparison grouped by other keys is grouped by those
too where runs differ in them.

Runs launched separately (the lessons of the manual, one after the other) differ in many keys at
once; :func:`telling_parameters` keeps the few that tell them apart: plugin choices first
(``estimator``, ``friction``, ``robot``), then the keys under them, the shallowest first, a key kept
only where it splits runs the kept ones leave together. How a log's columns are read
(``data.column_map.*``) never counts; paths come last (a comparison shows them by file name).

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
from collections.abc import Sequence

import pandas as pd

PARAM_PREFIX = "params."
SEED = "seed"
_NOT_COMPUTATION = re.compile(r"^(tracking(\..*)?|experiment_name|hydra\..*|(.*\.)?show_progress)$")
_SUBJECT = re.compile(r"^(robot|plant|data)(\..*)?$")
_READING = re.compile(r"^data\.column_map(\..*)?$")
"""How a log's columns are read: not what the run is of, nor how it computes."""
_PATH = re.compile(r"(^|\.|_)paths?$")


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
        if _READING.match(key):
            continue
        if seed is not None and (values == seed).all():
            continue  # a copy of the seed (``${seed}``): replication, not a parameter
        varying.append(key)
    # Keys under a varying choice that follow from it: `estimator` explains `estimator._target_`.
    return [
        key
        for key in varying
        if not any(
            key.startswith(other + ".") and _follows(runs, key, other) for other in varying if other != key
        )
    ]


def _follows(runs: pd.DataFrame, key: str, choice: str) -> bool:
    """Whether ``key`` has one value for each value of ``choice`` across ``runs``."""
    values = _values(runs, PARAM_PREFIX + key)
    return bool((values.groupby(_values(runs, PARAM_PREFIX + choice)).nunique() <= 1).all())


def _telling_order(key: str) -> tuple[int, int, str]:
    """Plugin choices first, then keys under them (shallowest first), paths last."""
    return (2 if _PATH.search(key) else 0 if "." not in key else 1, key.count("."), key)


def telling_parameters(
    runs: pd.DataFrame, candidates: list[str] | None = None, given: Sequence[str] = ()
) -> list[str]:
    """The few of ``candidates`` (default: :func:`swept_parameters`) that tell ``runs`` apart.

    Taken in :func:`_telling_order` after the ``given`` keys (kept, first), a key is kept when it
    splits runs that the keys kept before it leave in one group, so the kept keys group the runs
    exactly as all of them do.

    Examples
    --------
    >>> import pandas as pd
    >>> runs = pd.DataFrame({
    ...     "params.estimator": ["ols", "sdp", "ols", "ols"],
    ...     "params.plant": ["sim", "sim", "log", "log"],
    ...     "params.data.paths": ["<unset>", "<unset>", "a.csv", "b.csv"],
    ...     "params.plant.rate_hz": ["1000", "1000", "100", "100"],
    ... })
    >>> telling_parameters(runs)
    ['estimator', 'plant', 'data.paths']
    """
    candidates = swept_parameters(runs) if candidates is None else candidates
    kept = list(given)
    groups = len(runs[[PARAM_PREFIX + k for k in kept]].drop_duplicates()) if kept else 1
    for key in sorted((k for k in candidates if k not in kept), key=_telling_order):
        split = runs[[PARAM_PREFIX + k for k in (*kept, key)]].fillna("<unset>").astype(str)
        count = len(split.drop_duplicates())
        if count > groups:
            kept.append(key)
            groups = count
    return kept


def subject_parameters(runs: pd.DataFrame, groups: list[str] | tuple[str, ...] = ()) -> list[str]:
    """The parameters saying what runs are of (robot, plant, data) that differ across ``runs`` and are
    not in ``groups``: what a comparison by ``groups`` alone would pool."""
    found = [key for key in swept_parameters(runs) if _SUBJECT.match(key) and key not in groups]
    order = ("robot", "plant", "data")
    return sorted(found, key=lambda key: (order.index(key.split(".")[0]), key.count("."), key))


def value_summary(runs: pd.DataFrame, parameter: str, limit: int = 6) -> str:
    """The distinct values of a parameter, e.g. ``ols, sdp, wls``."""
    values = sorted(_values(runs, PARAM_PREFIX + parameter).unique())
    return ", ".join(values[:limit]) + (", …" if len(values) > limit else "")


def short_name(parameter: str) -> str:
    """The last component of a dotted parameter (``plant.torque_noise_std`` → ``torque_noise_std``)."""
    return parameter.rsplit(".", 1)[-1]


__all__ = ["short_name", "subject_parameters", "swept_parameters", "telling_parameters", "value_summary"]
