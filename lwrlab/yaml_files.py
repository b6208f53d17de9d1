"""YAML descriptions read safely: ``safe_load`` (no code runs) and a clear error naming the file."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from lwrlab.errors import ConfigError


def read_yaml_mapping(path: str | Path, what: str) -> dict[str, Any]:
    """The mapping a YAML file holds; a ``ConfigError`` (a ``ValueError``) naming the file when it is not
    valid YAML or holds anything else.

    ``what`` names the kind of description in the message ("robot", "tool", …).
    """
    try:
        with Path(path).open() as stream:
            document = yaml.safe_load(stream)
    except yaml.YAMLError as error:
        raise ConfigError(f"{path}: not valid YAML ({' '.join(str(error).split())})") from error
    if not isinstance(document, dict):
        raise ConfigError(f"{path}: expected a mapping of {what} keys, got {type(document).__name__}")
    return document
