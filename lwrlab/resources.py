"""Files shipped inside the package (the config tree, the shipped exciting motions), found through it.

The config tree is the package :mod:`lwrlab.conf` (in the source tree ``lwrlab/conf`` is a link to the
top-level ``conf/``; in a wheel the YAML files are copied into the package), so Hydra reads it as
``pkg://lwrlab.conf`` and nothing depends on the working directory or on where the package sits.
Data files are named ``pkg://<package>/<path inside it>`` in configs, e.g.
``pkg://lwrlab/data/exciting_motions/kuka_lwr4_logdet_10s.yaml``; any other string is a user path.

Examples
--------
>>> CONFIG_SEARCH_PATH
'pkg://lwrlab.conf'
>>> resolve_data_path("pkg://lwrlab/data/exciting_motions/kuka_lwr4_logdet_10s.yaml").name
'kuka_lwr4_logdet_10s.yaml'
>>> sorted(config_group("criterion"))[:2]
['a_optimality', 'cond']
"""

from __future__ import annotations

import atexit
from contextlib import ExitStack
from importlib.resources import as_file, files
from importlib.resources.abc import Traversable
from pathlib import Path

PACKAGE_SCHEME = "pkg://"
"""Prefix of a path inside an importable package (Hydra's spelling for config search paths)."""

CONFIG_PACKAGE = "lwrlab.conf"
"""The package holding the config tree (``config.yaml`` and one folder per config group)."""

CONFIG_SEARCH_PATH = PACKAGE_SCHEME + CONFIG_PACKAGE
"""The config tree as Hydra's ``config_path``; user trees still join with ``hydra.searchpath``."""

_extracted = ExitStack()  # files copied out of a zipped package live until the interpreter exits
atexit.register(_extracted.close)


def _on_disk(resource: Traversable) -> Path:
    """A package file as a path on disk (a zipped package's file is copied out until exit)."""
    return resource if isinstance(resource, Path) else _extracted.enter_context(as_file(resource))


def config_group(group: str) -> dict[str, Path]:
    """The options of the shipped config group ``group`` (``tool``, ``robot``, …): name → YAML file."""
    folder = files(CONFIG_PACKAGE).joinpath(group)
    if not folder.is_dir():
        raise FileNotFoundError(f"no config group {group!r} in {CONFIG_SEARCH_PATH}")
    return {
        entry.name.removesuffix(".yaml"): _on_disk(entry)
        for entry in folder.iterdir()
        if entry.name.endswith(".yaml")
    }


def package_file(reference: str) -> Path:
    """The file (or folder) ``pkg://<package>/<path>`` names, as a path on disk (FileNotFoundError if
    absent)."""
    if not reference.startswith(PACKAGE_SCHEME):
        raise ValueError(f"{reference!r} does not start with {PACKAGE_SCHEME}")
    package, _, inner = reference.removeprefix(PACKAGE_SCHEME).partition("/")
    try:
        resource = files(package).joinpath(inner)
    except ModuleNotFoundError as error:
        raise FileNotFoundError(f"{reference}: no package {package!r}") from error
    if not inner or not (resource.is_file() or resource.is_dir()):
        raise FileNotFoundError(f"{reference}: no file {inner!r} in package {package!r}")
    return _on_disk(resource)


def resolve_data_path(path: str | Path) -> Path:
    """``pkg://`` references through their package; any other path as the user gave it (``~`` expanded)."""
    if isinstance(path, str) and path.startswith(PACKAGE_SCHEME):
        return package_file(path)
    return Path(path).expanduser()
