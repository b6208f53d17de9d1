"""Each YAML file of a config tree parsed once per test session, however many compositions read it.

Hydra reads and parses every file a composition names again for each composition (its own cache lives
for one composition), and the suite composes the same ``conf/`` files hundreds of times: the parsing
is a fifth of each composition's time. :func:`parse_each_file_once` keeps the parsed file per path and
content (a file a test writes or edits is parsed afresh) and hands Hydra a deep copy of it, so that
what a composition changes stays its own: the composed configs are the same.
"""

from __future__ import annotations

import copy
import hashlib
import os
from collections.abc import Iterator
from contextlib import contextmanager

from hydra.core.plugins import Plugins
from hydra.plugins.config_source import ConfigResult, ConfigSource

FileKey = tuple[str, str, str, str]
"""A file as a source reads it: the source's provider and path, the file's path, its content's digest."""


@contextmanager
def parse_each_file_once() -> Iterator[dict[FileKey, ConfigResult]]:
    """Within the block, Hydra's ``file://`` config source parses each file once; yields the parsed files."""
    Plugins.instance()  # registers the config sources (Hydra loads its plugin modules by itself)
    from hydra._internal.sources_registry import SourcesRegistry

    source_class = SourcesRegistry.instance().resolve("file")
    parse = source_class.load_config
    parsed: dict[FileKey, ConfigResult] = {}

    def load_config(source: ConfigSource, config_path: str) -> ConfigResult:
        path = os.path.realpath(os.path.join(source.path, source._normalize_file_name(config_path)))
        try:
            with open(path, "rb") as file:
                digest = hashlib.blake2b(file.read(), digest_size=16).hexdigest()
        except OSError:
            return parse(source, config_path)  # Hydra's own error for a missing file
        key = (source.provider, source.path, path, digest)
        if key not in parsed:
            parsed[key] = parse(source, config_path)
        first = parsed[key]
        return ConfigResult(
            config=copy.deepcopy(first.config),
            path=first.path,
            provider=first.provider,
            header=dict(first.header),
        )

    source_class.load_config = load_config  # type: ignore[method-assign]
    try:
        yield parsed
    finally:
        source_class.load_config = parse  # type: ignore[method-assign]
