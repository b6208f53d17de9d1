"""Runs holding what lwrlab derives from other runs (a report, a comparison): logged once, by their sources.

A derived run goes into the experiment of the runs it was made from (no stray ``reports`` experiment,
artifacts under that experiment's artifact location rather than ``./mlruns`` of the current folder),
nested under the sweep's parent run when it compares one sweep, and is logged once: the same
selection of the same runs finds the run logged before instead of adding another.

Examples
--------
>>> by = {"by": ["estimator"]}
>>> derived_key("compare", ["b", "a"], by) == derived_key("compare", ["a", "b"], by)
True
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import pandas as pd
from mlflow.tracking import MlflowClient

from lwrlab.tracking.runs.run_logging import log_metrics
from lwrlab.tracking.runs.run_queries import run_with_tag
from lwrlab.tracking.store.sqlite import retry_locked

DERIVED_KEY_TAG = "derived_key"
"""SHA-256 of the kind, the source run ids and the options: the identity of a derived run."""


def derived_key(kind: str, source_run_ids: Iterable[str], options: Mapping[str, Any]) -> str:
    """The identity of a derived run: its kind, the runs it was made from (order-free), its options."""
    text = json.dumps(
        {"kind": kind, "runs": sorted(map(str, source_run_ids)), "options": options},
        sort_keys=True,
        default=str,
    )
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def log_derived_run(
    client: MlflowClient,
    experiment_id: str,
    key: str,
    folder: Path,
    run_name: str,
    tags: Mapping[str, str],
    parent_run_id: str | None = None,
    metrics: Mapping[str, float] | None = None,
    tables: Mapping[str, pd.DataFrame] | None = None,
) -> tuple[str, bool]:
    """Log ``folder`` as a FINISHED run of ``experiment_id`` unless a run with ``key`` exists.

    ``metrics`` are logged on the run (what its row in the runs table shows), ``tables`` as MLflow
    table artifacts (``{"compare_table.json": frame}``), before the run ends.

    Returns
    -------
    tuple[str, bool]
        The run id, and whether it was logged now (``False``: an identical one was logged before).
    """
    found = run_with_tag(client, experiment_id, DERIVED_KEY_TAG, key)
    if found is not None:
        return found.info.run_id, False
    all_tags = {**tags, DERIVED_KEY_TAG: key}
    if parent_run_id is not None:
        all_tags["mlflow.parentRunId"] = parent_run_id
    run = retry_locked(client.create_run, experiment_id, run_name=run_name, tags=all_tags)
    client.log_artifacts(run.info.run_id, str(folder))
    log_metrics(client, run.info.run_id, metrics or {})
    for artifact_file, table in (tables or {}).items():
        client.log_table(run.info.run_id, table, artifact_file)
    retry_locked(client.set_terminated, run.info.run_id, status="FINISHED")
    return run.info.run_id, True


__all__ = ["DERIVED_KEY_TAG", "derived_key", "log_derived_run"]
