"""The comparison table of ``lwrlab compare``: runs grouped by what was swept, each headline metric's
mean ± standard deviation per group.

:func:`compare_runs` builds a :class:`Comparison` from the runs (a ``search_runs`` frame);
:func:`to_markdown` and :func:`comparison_metrics` render it as a Markdown table and as the metrics
``<group>/<metric>`` of the comparison run; :func:`per_joint_rms` gathers the per-joint RMS the
figure draws. Pure pandas: no store is read or written here.
"""

from __future__ import annotations

import hashlib
import logging
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import PurePath

import numpy as np
import pandas as pd

from lwrlab.tracking.job_config.config_params import mlflow_key
from lwrlab.tracking.job_config.naming import HEADLINE_METRICS, PER_JOINT_RMS, is_timing_metric
from lwrlab.tracking.reports.run_groups import PARAM_PREFIX, subject_parameters, telling_parameters

log = logging.getLogger(__name__)


METRIC_PREFIX = "metrics."
ALL_RUNS = "all runs"
METRIC_KEY = "metric_key"
"""The table's column naming each group's metrics on the comparison run (``<metric_key>/rms_mean``)."""
SHOWN_VALUE_LENGTH = 32
"""Characters of a parameter value a group's metric key and figure legend show (a list of logs: their
file names; else its end); the table keeps the whole value."""
GROUP_KEY_LENGTH = 160
"""Characters of a group's metric key: with ``/<metric>`` within MLflow's 250 for a metric name."""


@dataclass
class Comparison:
    """What :func:`compare_runs` found."""

    runs: pd.DataFrame
    groups: list[str]
    """Parameters the rows are grouped by (``[]``: one row, every run)."""
    table: pd.DataFrame
    """One row per group: its parameters' values, ``runs``, ``seeds``, ``<metric>`` (mean) and
    ``<metric>_std`` per metric, and :data:`METRIC_KEY` (the group's key on the comparison run)."""
    metrics: list[str]
    notes: list[str] = field(default_factory=list)
    """What the reader must know about the grouping (keys added so that runs are not pooled)."""


def headline_metrics(runs: pd.DataFrame) -> list[str]:
    """The headline and timing metrics present in ``runs``, headline ones first."""
    present = [column[len(METRIC_PREFIX) :] for column in runs.columns if column.startswith(METRIC_PREFIX)]
    ordered = [metric for metric in HEADLINE_METRICS if metric in present]
    return ordered + sorted(metric for metric in present if is_timing_metric(metric))


def _group_labels(runs: pd.DataFrame, groups: Sequence[str], short: bool = False) -> pd.Series:
    """Each run's group, ``key=value, …`` (``short``: values as :func:`shown_value` shows them)."""
    if not groups:
        return pd.Series(ALL_RUNS, index=runs.index)
    parts = [
        (groups_value(runs, group).map(shown_value) if short else groups_value(runs, group)).radd(f"{group}=")
        for group in groups
    ]
    label = parts[0]
    for part in parts[1:]:
        label = label + ", " + part
    return label


def shown_value(value: str) -> str:
    """A parameter value as a group's metric key and a legend show it: whole when short, a list of
    paths by its file names, else its last :data:`SHOWN_VALUE_LENGTH` characters.

    Examples
    --------
    >>> shown_value("/data/robot_logs/campaign_2024/kuka/measurements_2.npz, /data/robot_logs/m_3.npz")
    'measurements_2.npz, m_3.npz'
    """
    if len(value) <= SHOWN_VALUE_LENGTH:
        return value
    names = ", ".join(PurePath(part).name for part in value.split(", "))
    return names if len(names) <= SHOWN_VALUE_LENGTH else "…" + names[-(SHOWN_VALUE_LENGTH - 1) :]


def groups_value(runs: pd.DataFrame, group: str) -> pd.Series:
    """A group parameter's values as text (``<unset>`` where a run lacks it)."""
    return runs[PARAM_PREFIX + group].fillna("<unset>").astype(str)


def compare_runs(runs: pd.DataFrame, groups: Sequence[str] | None = None) -> Comparison:
    """Group ``runs`` by ``groups`` (default: the parameters they differ in) and summarise their metrics.

    Parameters
    ----------
    runs
        FINISHED job runs (``mlflow.search_runs`` layout).
    groups
        Parameter keys to group by; ``None`` finds the few that tell the runs apart
        (:func:`~lwrlab.tracking.reports.run_groups.telling_parameters`).

    Returns
    -------
    Comparison
        ``table`` has one row per group, in the groups' sorted order: ``runs`` (count), ``seeds``
        (distinct seeds), and for each metric its mean and its sample standard deviation over the
        group's runs (``nan`` for a single run).
    """
    notes = []
    if groups is None:
        groups = telling_parameters(runs)
    else:
        groups = list(groups)
        missing = [group for group in groups if PARAM_PREFIX + group not in runs]
        if missing:
            known = sorted(
                column[len(PARAM_PREFIX) :] for column in runs.columns if column.startswith(PARAM_PREFIX)
            )
            raise ValueError(f"no run has the parameter(s) {missing}; parameters: {known[:40]}")
        subjects = telling_parameters(runs, subject_parameters(runs, groups), given=groups)[len(groups) :]
        if subjects:  # a robot, a data set, is never pooled with another
            notes.append(
                f"runs differ in {', '.join(subjects)} (what they are of): grouped by them too, never "
                f"pooled; --param {subjects[0]}=… compares one"
            )
            groups += subjects
    metrics = headline_metrics(runs)
    labels = _group_labels(runs, groups)
    shown = _group_labels(runs, groups, short=True)
    seeds = runs["params.seed"] if "params.seed" in runs else pd.Series("", index=runs.index)
    rows = []
    # a group is named by its short values (file names, ends of long values) where those tell it apart
    named = shown if shown.nunique() == labels.nunique() else labels
    for label in sorted(labels.unique()):
        members = runs[labels == label]
        row: dict[str, object] = {"group": str(named[labels == label].iloc[0])}
        row.update({group: groups_value(members, group).iloc[0] for group in groups})
        row.update(runs=len(members), seeds=int(seeds[labels == label].nunique()))
        for metric in metrics:
            values = pd.to_numeric(members[METRIC_PREFIX + metric], errors="coerce").dropna()
            row[metric] = float(values.mean()) if len(values) else np.nan
            row[f"{metric}_std"] = float(values.std(ddof=1)) if len(values) > 1 else np.nan
        row[METRIC_KEY] = group_key(
            str(shown[labels == label].iloc[0]), label
        )  # last: a reader's columns stay
        rows.append(row)
    table = pd.DataFrame(rows).set_index("group")
    return Comparison(runs=runs, groups=groups, table=table, metrics=metrics, notes=notes)


def _unit(metric: str) -> str:
    if metric in HEADLINE_METRICS:
        return HEADLINE_METRICS[metric][0]
    return "s" if is_timing_metric(metric) else ""


def to_markdown(comparison: Comparison) -> str:
    """The comparison as a Markdown table: mean ± std with units in the headers."""
    table = comparison.table
    shown = pd.DataFrame(index=table.index)
    shown["runs"] = table["runs"]
    shown["seeds"] = table["seeds"]
    for metric in comparison.metrics:
        mean, std = table[metric], table[f"{metric}_std"]
        shown[f"{metric} [{_unit(metric)}]"] = [
            "–" if np.isnan(m) else (f"{m:.4g}" if np.isnan(s) else f"{m:.4g} ± {s:.2g}")
            for m, s in zip(mean, std, strict=True)
        ]
    return shown.to_markdown()


def per_joint_rms(runs: pd.DataFrame, labels: pd.Series) -> tuple[np.ndarray, np.ndarray, list[str]] | None:
    """Mean and std over each group's runs of ``rms_joint1…N``; ``None`` if the runs have no per-joint RMS."""
    columns = sorted(
        (int(match.group(1)), column)
        for column in runs.columns
        if column.startswith(METRIC_PREFIX) and (match := PER_JOINT_RMS.match(column[len(METRIC_PREFIX) :]))
    )
    if not columns:
        return None
    names = [column for _, column in columns]
    groups = sorted(labels.unique())
    values = [runs.loc[labels == group, names].apply(pd.to_numeric, errors="coerce") for group in groups]
    mean = np.array([frame.mean().to_numpy() for frame in values])
    spread = np.array(
        [frame.std(ddof=1).to_numpy() if len(frame) > 1 else np.full(len(names), np.nan) for frame in values]
    )
    return mean, spread, groups


def _shown_column(column: str) -> str:
    """A ``search_runs`` column as a reader names it: ``params.seed`` → ``seed``, the run name → ``run``."""
    if column == "tags.mlflow.runName":
        return "run"
    for prefix in (PARAM_PREFIX, METRIC_PREFIX):
        if column.startswith(prefix):
            return column[len(prefix) :]
    return column


def group_key(label: str, full_label: str | None = None) -> str:
    """A group's label as the first part of an MLflow metric key: ``estimator=ols`` → ``estimator:ols``.

    ``label`` may show shortened values (:func:`shown_value`) of ``full_label``; a key shortened, or
    longer than :data:`GROUP_KEY_LENGTH`, ends with a digest of the full label, so that two groups
    never share a key.

    Examples
    --------
    >>> group_key("estimator=ols, plant.torque_noise_std=0.1")
    'estimator:ols plant.torque_noise_std:0.1'
    >>> group_key("data.paths=m_2.npz", "data.paths=/logs/m_2.npz")
    'data.paths:m_2.npz_43763350'
    """
    key = mlflow_key(label.replace("=", ":").replace(", ", " "))
    full = label if full_label is None else full_label
    if full == label and len(key) <= GROUP_KEY_LENGTH:
        return key
    digest = hashlib.sha256(full.encode("utf-8")).hexdigest()[:8]
    return f"{key[: GROUP_KEY_LENGTH - len(digest) - 1]}_{digest}"


def _json_table(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` with ``nan`` as ``None``: MLflow's table artifact is JSON, which has no NaN."""
    return table.astype(object).where(pd.notna(table), None)


def comparison_metrics(comparison: Comparison) -> dict[str, float]:
    """The table as metrics of the comparison run: ``<group>/<metric>`` (the mean) and ``<group>/runs``."""
    metrics: dict[str, float] = {}
    for _, row in comparison.table.iterrows():
        key = str(row[METRIC_KEY])
        metrics[f"{key}/runs"] = float(row["runs"])
        for metric in comparison.metrics:
            if pd.notna(row[metric]):
                metrics[f"{key}/{metric}"] = float(row[metric])
    return metrics
