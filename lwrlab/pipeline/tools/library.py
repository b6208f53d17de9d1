"""The tool library read from its YAML files: one file per tool in ``conf/tool/`` (config group ``tool``).

The library is read through the package (:func:`lwrlab.resources.config_group`), so it loads the same
from the source tree and from an installed wheel; each file is built with ``hydra.utils.instantiate``.

A tool file names its builder with ``_target_`` and passes it keyword arguments, e.g.::

    # conf/tool/large_roller.yaml
    _target_: lwrlab.tools.painting.paint_roller
    name: large_roller
    length: 0.35          # m
    width: 0.20           # m
    cover_mass: 0.08      # kg
    …

so adding a tool to the library (and making ``tool=<name>`` attach it to the simulated robot) is
one new YAML file. Builders: :func:`lwrlab.tools.painting.paint_roller`,
:func:`lwrlab.tools.painting.paint_brush`, :func:`lwrlab.tools.model.composite_tool` (part by part),
or any importable function returning a :class:`~lwrlab.tools.model.Tool`.

Examples
--------
>>> roller = load_tool("large_roller")
>>> roller.width, round(roller.mass, 3)
(0.2, 0.2)
>>> roller.parameters.shape   # flange frame, [M, MSX, MSY, MSZ, XX, YY, ZZ, XY, XZ, YZ]
(10,)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from hydra.errors import InstantiationException
from hydra.utils import instantiate

from lwrlab.errors import MissingFileError, UnknownNameError
from lwrlab.resources import config_group
from lwrlab.tools.library import ToolLibrary
from lwrlab.tools.model import Tool
from lwrlab.yaml_files import read_yaml_mapping

LIBRARY_GROUP = "tool"
"""The config group holding the shipped library (``conf/tool/``, shipped in the package ``lwrlab.conf``)."""


def build_tool(description: Mapping[str, Any], source: str = "tool description") -> Tool:
    """Build a tool from a mapping with a ``_target_`` builder and its keyword arguments (``instantiate``)."""
    target = description.get("_target_")
    if not isinstance(target, str) or "." not in target:
        raise ValueError(
            f"{source}: needs `_target_: module.builder` (e.g. lwrlab.tools.painting.paint_roller), "
            f"got {target!r}"
        )
    try:
        tool = instantiate(description, _convert_="all")
    except InstantiationException as error:
        cause = error.__cause__
        if isinstance(cause, TypeError):
            raise ValueError(f"{source}: bad arguments for {target}: {cause}") from None
        if isinstance(cause, ValueError):  # the builder refused a value: its message names it
            raise ValueError(f"{source}: {cause}") from cause
        raise ValueError(f"{source}: cannot import builder {target!r}: {cause or error}") from None
    if not isinstance(tool, Tool):
        raise TypeError(f"{source}: {target} returned {type(tool).__name__}, not a Tool")
    return tool


def _library_files(directory: str | Path | None) -> dict[str, Path]:
    """Tool name → YAML file: the shipped library (``directory=None``) or a folder of the user's."""
    if directory is None:
        return config_group(LIBRARY_GROUP)
    folder = Path(directory)
    if not folder.is_dir():
        raise MissingFileError(f"tool library folder {folder} does not exist")
    return {path.stem: path for path in folder.glob("*.yaml")}


def tool_names(directory: str | Path | None = None) -> list[str]:
    """Names of the tools in the shipped library or in a folder (the YAML file stems), sorted."""
    return sorted(_library_files(directory))


def load_tool(name: str, directory: str | Path | None = None) -> Tool:
    """The tool ``name`` of the library (``conf/tool/<name>.yaml``): geometry and flange-frame parameters."""
    library = _library_files(directory)
    if name not in library:
        where = directory if directory is not None else f"the tool library ({LIBRARY_GROUP} config group)"
        raise UnknownNameError(f"no tool named {name!r} in {where}; available: {sorted(library)}")
    source = library[name]
    description = read_yaml_mapping(source, "tool")
    description.setdefault("name", name)
    return build_tool(description, source=str(source))


def load_library(names: Sequence[str] | None = None, directory: str | Path | None = None) -> ToolLibrary:
    """The tools ``names`` (default: every tool in the folder) as a :class:`ToolLibrary`."""
    names = list(names) if names is not None else tool_names(directory)
    return ToolLibrary(tuple(load_tool(name, directory) for name in names))
