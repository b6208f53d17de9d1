"""Which job runs ``lwrlab report`` and ``lwrlab compare`` read: a filter and the runs it selects.

``--tag KEY=VALUE`` and ``--param KEY=VALUE`` become an MLflow filter string for FINISHED job runs
(:func:`parse_pairs`, :func:`selection_filter`); :func:`select_runs` runs it over named experiments
(or every one but the old reports experiment) and returns the ``search_runs`` table with each run's
experiment name, metric columns under their plain names (``metrics.rms_mean`` whether a run logged
it as ``accuracy/rms_mean`` or, before sections, as ``rms_mean``: :func:`plain_metric_columns`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import pandas as pd
from mlflow.tracking import MlflowClient

from lwrlab.tracking.job_config.metric_sections import plain_name, sectioned_filter
from lwrlab.tracking.job_config.provenance import RUN_KIND_TAG
from lwrlab.tracking.job_config.redaction import Redactor
from lwrlab.tracking.runs.run_queries import search_runs_table
from lwrlab.tracking.store.sqlite import retry_locked

METRIC_PREFIX = "metrics."
REPORT_EXPERIMENT = "reports"  # where older versions logged reports: left out of "all experiments"


def _quoted(value: str) -> str:
    return "'" + value.replace("'", "\\'") + "'"


def selection_filter(
    tags: Mapping[str, str] | None = None, params: Mapping[str, str] | None = None, extra: str = ""
) -> str:
    """An MLflow filter string for FINISHED job runs with the given tags and params.

    ``extra`` may name metrics plainly (``metrics.rms_mean < 0.5``): they become the keys runs log them
    under (``metrics.`accuracy/rms_mean```; see
    :func:`~lwrlab.tracking.job_config.metric_sections.sectioned_filter`).

    Examples
    --------
    >>> for clause in selection_filter({"seed": "1"}, {"plant.torque_noise_std": "0.1"}).split(" and "):
    ...     print(clause)
    attributes.status = 'FINISHED'
    tags.run_kind = 'job'
    tags.`seed` = '1'
    params.`plant.torque_noise_std` = '0.1'
    """
    clauses = ["attributes.status = 'FINISHED'", f"tags.{RUN_KIND_TAG} = 'job'"]
    clauses += [f"tags.`{key}` = {_quoted(str(value))}" for key, value in (tags or {}).items()]
    clauses += [f"params.`{key}` = {_quoted(str(value))}" for key, value in (params or {}).items()]
    if extra.strip():
        clauses.append(sectioned_filter(extra.strip()))
    return " and ".join(clauses)


def plain_metric_columns(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` with ``metrics.<section>/<name>`` columns named ``metrics.<name>``; where runs logged
    the same metric with and without a section (before and after sections existed), one column.

    Examples
    --------
    >>> table = pd.DataFrame({"metrics.accuracy/rms_mean": [0.1, None], "metrics.rms_mean": [None, 0.3]})
    >>> plain_metric_columns(table)["metrics.rms_mean"].tolist()
    [0.1, 0.3]
    """
    plain: dict[str, pd.Series] = {}
    others: dict[str, pd.Series] = {}
    for column in table.columns:
        if not column.startswith(METRIC_PREFIX):
            others[column] = table[column]
            continue
        name = METRIC_PREFIX + plain_name(column[len(METRIC_PREFIX) :])
        plain[name] = table[column] if name not in plain else plain[name].combine_first(table[column])
    return pd.DataFrame({**others, **plain}, index=table.index)


def select_runs(tracking_uri: str, experiments: Sequence[str] | None, filter_string: str) -> pd.DataFrame:
    """Runs of ``experiments`` (all but the reports experiment if ``None``) matching ``filter_string``.

    Returns the ``mlflow.search_runs`` table plus an ``experiment`` column (the experiment name).
    """
    client = MlflowClient(tracking_uri=tracking_uri)
    known = {
        experiment.name: experiment.experiment_id for experiment in retry_locked(client.search_experiments)
    }
    names = [name for name in known if name != REPORT_EXPERIMENT] if not experiments else list(experiments)
    missing = [name for name in names if name not in known]
    if missing:
        raise ValueError(
            f"no experiment named {missing} in {Redactor().redact(tracking_uri)}; "
            f"experiments: {sorted(known)}"
        )
    if not names:
        return pd.DataFrame()
    table = search_runs_table(tracking_uri, [known[name] for name in names], filter_string)
    if table.empty:
        return table
    table = plain_metric_columns(table)
    id_to_name = {value: key for key, value in known.items()}
    table.insert(1, "experiment", table["experiment_id"].map(id_to_name))
    return table


def parse_pairs(values: Sequence[str], what: str) -> dict[str, str]:
    """``["a=1", "b=x"]`` → ``{"a": "1", "b": "x"}``; a value without ``=`` exits naming ``--what``."""
    pairs = {}
    for value in values:
        key, separator, text = value.partition("=")
        if not separator:
            raise SystemExit(f"--{what} expects key=value, got {value!r}")
        pairs[key] = text
    return pairs


__all__ = ["REPORT_EXPERIMENT", "parse_pairs", "plain_metric_columns", "select_runs", "selection_filter"]
