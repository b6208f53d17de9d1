"""Runs recorded on disk while the tracking store was unreachable, for a later ``lwrlab sync``.

When the store cannot be reached (server down, database on a read-only disk), the tracking callback
writes everything it would have logged into ``mlflow_offline_run.json`` in the job output folder,
already redacted (see :mod:`lwrlab.tracking.job_config.redaction`). The file is plain JSON: reading it
executes nothing. ``lwrlab sync`` uploads such records and renames each to ``mlflow_synced_run.json``.

Record fields
-------------
record_id : str — unique id, also logged as tag ``offline_record_id`` so a sync is never doubled.
experiment, run_name : str
tags, params : dict[str, str]
metrics : dict[str, float]
status : ``RUNNING`` (the job never ended), ``FINISHED``, ``FAILED`` or ``KILLED`` (a stop signal).
start_time_ms, end_time_ms : int | None — Unix time in milliseconds.
sweep_dir : str | None — the Hydra sweep folder; jobs of one sweep are nested under one parent run.
sweep_overrides : str — the sweep's override string, for the parent run.
"""

from __future__ import annotations

import json
import time
import uuid
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

OFFLINE_RECORD = "mlflow_offline_run.json"
SYNCED_RECORD = "mlflow_synced_run.json"


def new_record(
    experiment: str,
    run_name: str,
    tags: Mapping[str, str],
    params: Mapping[str, str],
    start_time_ms: int,
    sweep_dir: str | None = None,
    sweep_overrides: str = "",
) -> dict[str, Any]:
    """A record of a run that has started but could not be logged."""
    return {
        "record_id": uuid.uuid4().hex,
        "experiment": experiment,
        "run_name": run_name,
        "tags": dict(tags),
        "params": dict(params),
        "metrics": {},
        "status": "RUNNING",
        "start_time_ms": start_time_ms,
        "end_time_ms": None,
        "sweep_dir": sweep_dir,
        "sweep_overrides": sweep_overrides,
    }


def finish_record(
    record: dict[str, Any], metrics: Mapping[str, float], status: str, error: str | None = None
) -> dict[str, Any]:
    """``record`` ended now with ``status`` (``FINISHED``, ``FAILED``, ``KILLED``), its metrics and error."""
    record.update(metrics=dict(metrics), status=status, end_time_ms=int(time.time() * 1000))
    if error is not None:
        record["tags"]["error"] = error
    return record


def write_record(output_dir: Path, record: Mapping[str, Any]) -> Path:
    """Write (or overwrite) the record into the job output folder."""
    path = output_dir / OFFLINE_RECORD
    output_dir.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(record, indent=1, sort_keys=True), encoding="utf-8")
    return path


def read_record(path: Path) -> dict[str, Any]:
    """Read a record; a file that is not one raises ``ValueError`` naming it."""
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as error:
        raise ValueError(f"{path}: not a readable offline run record ({error})") from error
    missing = {"record_id", "experiment", "run_name", "tags", "params", "metrics", "status"} - set(record)
    if missing:
        raise ValueError(f"{path}: offline run record lacks {sorted(missing)}")
    return record


def find_records(roots: Iterable[Path]) -> list[Path]:
    """Every offline record under ``roots`` (files or folders), sorted by path."""
    found: set[Path] = set()
    for root in roots:
        if root.is_file() and root.name == OFFLINE_RECORD:
            found.add(root)
        elif root.is_dir():
            found.update(root.rglob(OFFLINE_RECORD))
    return sorted(found)


def mark_synced(path: Path, run_id: str) -> Path:
    """Rename the record once uploaded, with the run id it got."""
    record = json.loads(path.read_text(encoding="utf-8"))
    record["synced_run_id"] = run_id
    synced = path.with_name(SYNCED_RECORD)
    synced.write_text(json.dumps(record, indent=1, sort_keys=True), encoding="utf-8")
    path.unlink()
    return synced


__all__ = [
    "OFFLINE_RECORD",
    "SYNCED_RECORD",
    "find_records",
    "finish_record",
    "mark_synced",
    "new_record",
    "read_record",
    "write_record",
]
