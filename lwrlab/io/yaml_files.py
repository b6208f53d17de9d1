"""YAML descriptions read safely: ``safe_load`` (no code runs) and a clear error naming the file."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml


def read_yaml_mapping(path: str | Path, what: str) -> dict[str, Any]:
    """The mapping a YAML file holds; ``ValueError`` naming the file when it holds anything else.

    ``what`` names the kind of description in the message ("robot", "tool", …).
    """
    with Path(path).open() as stream:
        document = yaml.safe_load(stream)
    if not isinstance(document, dict):
        raise ValueError(f"{path}: expected a mapping of {what} keys, got {type(document).__name__}")
    return document
