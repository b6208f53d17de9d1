"""Which job runs ``lwrlab report`` and ``lwrlab compare`` read: a filter and the runs it selects.

``--tag KEY=VALUE`` and ``--param KEY=VALUE`` become an MLflow filter string for FINISHED job runs
(:func:`parse_pairs`, :func:`selection_filter`); :func:`select_runs` runs it over named experiments
(or every one but the old reports experiment) and returns the ``search_runs`` table with each run's
experiment name.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import pandas as pd
from mlflow.tracking import MlflowClient

from lwrlab.tracking.provenance import RUN_KIND_TAG
from lwrlab.tracking.redaction import Redactor
from lwrlab.tracking.run_queries import search_runs_table
from lwrlab.tracking.store import retry_locked

REPORT_EXPERIMENT = "reports"  # where older versions logged reports: left out of "all experiments"


def _quoted(value: str) -> str:
    return "'" + value.replace("'", "\\'") + "'"


def selection_filter(
    tags: Mapping[str, str] | None = None, params: Mapping[str, str] | None = None, extra: str = ""
) -> str:
    """An MLflow filter string for FINISHED job runs with the given tags and params.

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
        clauses.append(extra.strip())
    return " and ".join(clauses)


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


__all__ = ["REPORT_EXPERIMENT", "parse_pairs", "select_runs", "selection_filter"]
