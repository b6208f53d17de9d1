"""What data a job was fitted and validated on, read from its config and its output folder.

MLflow's runs table has a Dataset column: a run that records its data as dataset inputs shows there
what each model was fitted on. A job's data are

* the recorded logs of ``plant=log`` (``data.path``/``data.paths``: role ``identification``;
  ``data.validation_path``/``data.validation_paths``: role ``validation``; without validation logs the
  identification logs also validate, on their held-out end), each named by its file stem;
* for a simulated identification, the motions it played, written into its output folder
  (``exciting_motion.*``: ``identification``; ``validation_motion.*``: ``validation``), named after
  the trajectory plugin that made them (``optimal_motion``, ``multisine_validation_motion``). A task
  that writes an exciting motion without a validation motion (``task=excitation``) made it as its
  result, not as data, and records none.

Each has a digest of its content (:func:`content_digest`), so that two runs on the same log show the
same digest whatever its path.

Examples
--------
>>> uses = logged_datasets({"data": {"paths": ["logs/a.csv"], "validation_paths": None}}, Path("/lab"))
>>> [(use.name, str(use.path), use.role) for use in uses]
[('a', '/lab/logs/a.csv', 'identification'), ('a', '/lab/logs/a.csv', 'validation')]
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

IDENTIFICATION = "identification"
VALIDATION = "validation"
DIGEST_LENGTH = 8
"""Hex characters of a digest shown in the Dataset column (MLflow's own datasets use 8)."""
_MOTION_SUFFIXES = (".parquet", ".csv")


@dataclass(frozen=True)
class DatasetUse:
    """One dataset a job used, and in which role."""

    name: str
    path: Path
    role: str
    """``identification`` (fitted on) or ``validation`` (scored on)."""


def _paths(data: Mapping[str, Any], single: str, several: str) -> list[str]:
    values: list[str] = []
    for key in (single, several):
        value = data.get(key)
        if isinstance(value, Sequence) and not isinstance(value, str):
            values += [str(item) for item in value if item not in (None, "")]
        elif value not in (None, "", "???"):
            values.append(str(value))
    return list(dict.fromkeys(values))


def logged_datasets(job_config: Mapping[str, Any], cwd: Path) -> list[DatasetUse]:
    """The recorded logs a job's config names, relative paths taken from ``cwd`` (where it was launched)."""
    data = job_config.get("data")
    if not isinstance(data, Mapping):
        return []
    fitted = _paths(data, "path", "paths")
    validated = _paths(data, "validation_path", "validation_paths") or fitted  # held-out ends
    return [
        DatasetUse(Path(text).stem or Path(text).name, cwd / Path(text).expanduser(), role)
        for role, texts in ((IDENTIFICATION, fitted), (VALIDATION, validated))
        for text in texts
    ]


def _motion_file(output_dir: Path, stem: str) -> Path | None:
    return next(
        (
            output_dir / f"{stem}{suffix}"
            for suffix in _MOTION_SUFFIXES
            if (output_dir / f"{stem}{suffix}").is_file()
        ),
        None,
    )


def simulated_datasets(output_dir: Path, choices: Mapping[str, str]) -> list[DatasetUse]:
    """The motions a simulated identification played, from its output folder (none for other tasks)."""
    fitted, validated = (
        _motion_file(output_dir, "exciting_motion"),
        _motion_file(output_dir, "validation_motion"),
    )
    if fitted is None or validated is None:
        return []
    return [
        DatasetUse(f"{choices.get('trajectory', 'exciting')}_motion", fitted, IDENTIFICATION),
        DatasetUse(f"{choices.get('validation', 'validation')}_motion", validated, VALIDATION),
    ]


def job_datasets(
    job_config: Mapping[str, Any], choices: Mapping[str, str], cwd: Path, output_dir: Path
) -> list[DatasetUse]:
    """The datasets of a job: its logs (``plant=log``), else its simulated motions; existing files only."""
    uses = logged_datasets(job_config, cwd) if choices.get("plant") == "log" else []
    uses = uses or simulated_datasets(output_dir, choices)
    return [use for use in uses if use.path.exists()]


def content_digest(path: Path, chunk_bytes: int = 1 << 20) -> str:
    """The first :data:`DIGEST_LENGTH` hex characters of the SHA-256 of a file's content, or of a
    folder's (a ROS 2 bag): its files' relative names and contents in sorted order."""
    digest = hashlib.sha256()
    files = sorted(item for item in path.rglob("*") if item.is_file()) if path.is_dir() else [path]
    for file in files:
        if path.is_dir():
            digest.update(str(file.relative_to(path)).encode("utf-8") + b"\0")
        with file.open("rb") as stream:
            while chunk := stream.read(chunk_bytes):
                digest.update(chunk)
    return digest.hexdigest()[:DIGEST_LENGTH]


__all__ = [
    "DIGEST_LENGTH",
    "IDENTIFICATION",
    "VALIDATION",
    "DatasetUse",
    "content_digest",
    "job_datasets",
    "logged_datasets",
    "simulated_datasets",
]
