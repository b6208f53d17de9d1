"""The tool library: an ordered set of tools, the look-up table of tool recognition.

The shipped library is one YAML file per tool in ``conf/tool/`` (config group ``tool``); building it
from those files is the config's business (Hydra's ``instantiate``), in
:mod:`lwrlab.pipeline.tools.library` (``load_tool(name)``, ``load_library()``).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from lwrlab.tools.model import GEOMETRY_NAMES, Tool

PAPER_TOOLS: tuple[str, str] = ("large_roller", "small_roller")
"""The two rollers of Katsumata et al. (§VI, Table III)."""


@dataclass(frozen=True)
class ToolLibrary:
    """An ordered set of tools: the look-up table of tool recognition."""

    tools: tuple[Tool, ...]

    def __post_init__(self) -> None:
        names = [tool.name for tool in self.tools]
        if len(set(names)) != len(names):
            raise ValueError(f"tool names must be unique, got {names}")
        if not self.tools:
            raise ValueError("a tool library needs at least one tool")

    def __len__(self) -> int:
        return len(self.tools)

    def __iter__(self) -> Iterator[Tool]:
        return iter(self.tools)

    def __getitem__(self, name: str) -> Tool:
        for tool in self.tools:
            if tool.name == name:
                return tool
        raise KeyError(f"no tool named {name!r}; the library holds {list(self.names)}")

    @property
    def names(self) -> tuple[str, ...]:
        """Tool names, in library order."""
        return tuple(tool.name for tool in self.tools)

    @property
    def parameters(self) -> np.ndarray:
        """(N_T, 10) flange-frame parameters of every tool (the paper's Φ̄ transposed)."""
        return np.stack([tool.parameters for tool in self.tools])

    @property
    def geometry(self) -> np.ndarray:
        """(N_T, 2) length and width of every tool (m), columns :data:`GEOMETRY_NAMES`."""
        return np.array([[tool.geometry[g] for g in GEOMETRY_NAMES] for tool in self.tools])

    @property
    def kinds(self) -> tuple[str, ...]:
        """Tool families, in library order."""
        return tuple(tool.kind for tool in self.tools)

    def without(self, name: str) -> ToolLibrary:
        """The library less one tool (to treat it as unknown)."""
        self[name]
        return ToolLibrary(tuple(tool for tool in self.tools if tool.name != name))
