"""YAML descriptions read safely: ``safe_load`` (no code runs) and a clear error naming the file.

:func:`safe_yaml` is PyYAML's safe loader in C where PyYAML was built with libyaml (4× faster on an
identified model; the same documents), else in Python."""

from __future__ import annotations

from pathlib import Path
from typing import IO, Any

import yaml

from lwrlab.errors import ConfigError

_SAFE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def safe_yaml(text: str | IO[str]) -> Any:
    """The document ``text`` (a string or a stream) holds, read as ``yaml.safe_load`` reads it."""
    return yaml.load(text, Loader=_SAFE_LOADER)  # a safe loader: no object is built from tags


def read_yaml_mapping(path: str | Path, what: str) -> dict[str, Any]:
    """The mapping a YAML file holds; a ``ConfigError`` (a ``ValueError``) naming the file when it is not
    valid YAML or holds anything else.

    ``what`` names the kind of description in the message ("robot", "tool", …).
    """
    try:
        with Path(path).open() as stream:
            document = safe_yaml(stream)
    except yaml.YAMLError as error:
        raise ConfigError(f"{path}: not valid YAML ({' '.join(str(error).split())})") from error
    if not isinstance(document, dict):
        raise ConfigError(f"{path}: expected a mapping of {what} keys, got {type(document).__name__}")
    return document
