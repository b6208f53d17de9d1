"""A tool: a rigid body fixed to the robot's flange, with its geometry and inertial parameters.

The tool's 10 standard parameters ``[M, MSX, MSY, MSZ, XX, YY, ZZ, XY, XZ, YZ]`` are expressed in
the flange frame, about its origin (kg, kg·m, kg·m²); they follow from the parts' sizes and masses
(:mod:`lwrlab.tools.shapes`). :func:`lwrlab.model.payload.attach_payload` moves them to the last
joint frame of a robot.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from lwrlab.model.inertia import LINK_PARAMETER_NAMES, is_physically_consistent, mass_com_inertia
from lwrlab.tools.shapes import Shape, composite_parameters, shape_from_mapping


@dataclass(frozen=True)
class Tool:
    """A painting tool (or any end-effector) as the robot carries it.

    The flange frame: origin on the mounting face, z along the tool away from the robot. A roller's
    axis lies along y; the wall is met at ``contact_point``.
    """

    name: str
    """Library name, e.g. ``large_roller``."""
    kind: str
    """Family: ``roller``, ``brush``, … (interpolation of an unknown tool stays within a family)."""
    length: float
    """Distance from the flange face to the contact line along z (m): the paper's tool length."""
    width: float
    """Width of the painted stripe: a roller's cover length, a brush's bristle width (m)."""
    parts: Mapping[str, Shape]
    """The solids the tool is made of, by name (flange frame)."""
    contact_point: np.ndarray = field(default_factory=lambda: np.zeros(3))
    """Middle of the contact line in the flange frame (m)."""
    contact_axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 1.0, 0.0]))
    """Direction of the contact line (a roller's axis) in the flange frame (unit)."""
    description: str = ""
    """Free text (what the tool is, where its numbers come from)."""

    def __post_init__(self) -> None:
        if not self.parts:
            raise ValueError(f"tool {self.name!r} has no parts")
        if self.length <= 0 or self.width <= 0:
            raise ValueError(
                f"tool {self.name!r}: length and width must be positive, got {self.length}, {self.width} m"
            )
        object.__setattr__(self, "contact_point", np.asarray(self.contact_point, dtype=float).reshape(3))
        axis = np.asarray(self.contact_axis, dtype=float).reshape(3)
        object.__setattr__(self, "contact_axis", axis / np.linalg.norm(axis))
        object.__setattr__(self, "parameters", composite_parameters(list(self.parts.values())))
        if not is_physically_consistent(self.parameters):
            raise ValueError(f"tool {self.name!r} is not a physically consistent rigid body")

    parameters: np.ndarray = field(init=False, repr=False, compare=False)
    """(10,) standard parameters in the flange frame about its origin (kg, kg·m, kg·m²)."""

    @property
    def mass(self) -> float:
        """Total mass (kg)."""
        return float(self.parameters[0])

    @property
    def center_of_mass(self) -> np.ndarray:
        """Centre of mass in the flange frame (m)."""
        return mass_com_inertia(self.parameters)[1]

    @property
    def geometry(self) -> dict[str, float]:
        """The geometry a classifier recovers: ``{"length": m, "width": m}``."""
        return {"length": float(self.length), "width": float(self.width)}

    def parameter_table(self) -> dict[str, float]:
        """Parameters by name (``M``, ``MSX``, …)."""
        return dict(zip(LINK_PARAMETER_NAMES, self.parameters.tolist(), strict=True))


GEOMETRY_NAMES: tuple[str, ...] = ("length", "width")
"""Geometric quantities of :attr:`Tool.geometry`, in this order in arrays (m)."""


def composite_tool(
    name: str,
    kind: str,
    length: float,
    width: float,
    parts: Mapping[str, Mapping[str, Any]] | Sequence[Mapping[str, Any]],
    contact_point: Sequence[float] | None = None,
    contact_axis: Sequence[float] = (0.0, 1.0, 0.0),
    description: str = "",
) -> Tool:
    """A tool described part by part (the generic ``_target_`` of a tool YAML).

    Parameters
    ----------
    name, kind, length, width, description : see :class:`Tool` (lengths in m).
    parts : ``{part_name: {shape: cylinder|box|sphere, mass: kg, center: [x, y, z] m, …}}`` (or a
        list of such mappings with a ``name`` key); sizes as in :mod:`lwrlab.tools.shapes`.
    contact_point : middle of the contact line in the flange frame (m); default ``(0, 0, length)``.
    contact_axis : direction of the contact line in the flange frame.

    Examples
    --------
    >>> tool = composite_tool("rod", "probe", 0.2, 0.01,
    ...     {"rod": {"shape": "cylinder", "mass": 0.1, "center": [0, 0, 0.1],
    ...              "radius": 0.005, "length": 0.2}})
    >>> round(float(tool.parameters[3]), 6)  # MSZ = 0.1 kg · 0.1 m
    0.01
    """
    if not isinstance(parts, Mapping):
        parts = {str(p.get("name", f"part{i}")): p for i, p in enumerate(parts)}
    shapes = {part_name: shape_from_mapping(description) for part_name, description in parts.items()}
    return Tool(
        name=name,
        kind=kind,
        length=float(length),
        width=float(width),
        parts=shapes,
        contact_point=np.array([0.0, 0.0, length])
        if contact_point is None
        else np.asarray(contact_point, dtype=float),
        contact_axis=np.asarray(contact_axis, dtype=float),
        description=description,
    )
