"""Exciting-motion files: the parameters of an optimised motion, as YAML (``exciting_motion.yaml``).

The file holds what it takes to rebuild the motion exactly at any rate — the parameterisation
(``kind``, ``duration``, its settings such as ``via_point_spacing``) and its ``coefficients`` (rad, one
row per via point or coefficient, one column per joint) — plus a ``provenance`` block (robot,
criterion, cost, cond(W_b), constraint report, the command that made it). The 1 kHz samples go beside
it as CSV (:func:`lwrlab.io.artifacts.save_trajectory_csv`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from lwrlab.errors import MissingFileError

REPOSITORY = Path(__file__).resolve().parents[2]
"""The repository root: relative motion paths are looked up there too (e.g. the shipped ``lwrlab/data/``)."""


def resolve_motion_path(path: str | Path) -> Path:
    """``path`` as given if it exists, else relative to the repository root (``MissingFileError``, a
    ``FileNotFoundError``, if neither)."""
    path = Path(path).expanduser()
    for candidate in (path, REPOSITORY / path):
        if candidate.is_file():
            return candidate
    raise MissingFileError(
        f"exciting-motion file {path} not found (looked in the working directory and in {REPOSITORY})"
    )


def save_motion_description(
    description: dict[str, Any], path: Path, provenance: dict[str, Any] | None = None
) -> Path:
    """Write a parameterisation description (``LinearParameterisation.to_dict()``) and its provenance."""
    document = dict(description)
    if provenance:
        document["provenance"] = provenance
    # Flow style for lists of numbers: one line per via point (row), readable and diffable.
    path.write_text(
        yaml.safe_dump(document, sort_keys=False, width=200, default_flow_style=None, allow_unicode=True)
    )
    return path


def load_motion_description(path: str | Path, expected_kind: str | None = None) -> dict[str, Any]:
    """Read an exciting-motion file; check its keys and, if given, its parameterisation kind."""
    resolved = resolve_motion_path(path)
    document = yaml.safe_load(resolved.read_text())
    if not isinstance(document, dict):
        raise ValueError(f"{resolved}: expected a mapping, got {type(document).__name__}")
    missing = {"kind", "duration", "coefficients"} - set(document)
    if missing:
        raise ValueError(f"{resolved}: not an exciting-motion file, missing keys {sorted(missing)}")
    if expected_kind is not None and document["kind"] != expected_kind:
        raise ValueError(f"{resolved}: holds a {document['kind']!r} motion, expected {expected_kind!r}")
    document["path"] = str(resolved)
    return document
