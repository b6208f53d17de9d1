"""Solid primitives a tool is assembled from, and their inertial parameters.

Every shape is a homogeneous solid of given mass placed in the *flange frame* (origin on the
tool-mounting face of the robot, z along the tool, away from the robot). Its 10 standard
parameters ``[M, MSX, MSY, MSZ, XX, YY, ZZ, XY, XZ, YZ]`` (kg, kg·m, kg·m²) are about the flange
origin, so a composite tool's parameters are the sum over its parts.

Closed-form inertia about the centre of mass (e.g. Gieck, *Engineering Formulas*):

- cylinder (solid or hollow tube) of outer radius R, inner radius r, length h about its axis:
  ``m·(R² + r²)/2``; about a diameter through its centre: ``m·(3·(R² + r²) + h²)/12``;
- box of sizes (a, b, c) along (x, y, z): ``Ixx = m·(b² + c²)/12`` and cyclically;
- sphere of radius R: ``2/5·m·R²``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from lwrlab.model.inertia import standard_parameters

_AXES = {"x": np.array([1.0, 0.0, 0.0]), "y": np.array([0.0, 1.0, 0.0]), "z": np.array([0.0, 0.0, 1.0])}


def _unit_axis(axis: str | Sequence[float]) -> np.ndarray:
    if isinstance(axis, str):
        if axis not in _AXES:
            raise ValueError(f"unknown axis {axis!r}; use one of {sorted(_AXES)} or a 3-vector")
        return _AXES[axis]
    vector = np.asarray(axis, dtype=float)
    if vector.shape != (3,) or not np.linalg.norm(vector) > 0:
        raise ValueError(f"an axis must be 'x', 'y', 'z' or a non-zero 3-vector, got {axis!r}")
    return vector / np.linalg.norm(vector)


def _positive(value: float, what: str, allow_zero: bool = False) -> float:
    value = float(value)
    if value < 0 or (value == 0 and not allow_zero) or not np.isfinite(value):
        raise ValueError(f"{what} must be {'non-negative' if allow_zero else 'positive'}, got {value}")
    return value


class Shape(Protocol):
    """A homogeneous solid in the flange frame (read-only: the solids are frozen)."""

    @property
    def mass(self) -> float:
        """Mass (kg)."""
        ...

    @property
    def center(self) -> np.ndarray:
        """Centre of mass in the flange frame (m)."""
        ...

    def inertia_about_com(self) -> np.ndarray:
        """3×3 inertia tensor about the shape's centre of mass, flange axes (kg·m²)."""
        ...

    def parameters(self) -> np.ndarray:
        """The 10 standard parameters about the flange origin."""
        ...


@dataclass(frozen=True)
class _Solid:
    mass: float
    """Mass (kg)."""
    center: np.ndarray
    """Centre of mass in the flange frame (m)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "mass", _positive(self.mass, f"{type(self).__name__} mass"))
        center = np.asarray(self.center, dtype=float)
        if center.shape != (3,):
            raise ValueError(f"{type(self).__name__} center must be a 3-vector (m), got {self.center!r}")
        object.__setattr__(self, "center", center)

    def inertia_about_com(self) -> np.ndarray:  # pragma: no cover - every solid overrides it
        raise NotImplementedError

    def parameters(self) -> np.ndarray:
        """The 10 standard parameters about the flange origin (parallel-axis theorem)."""
        return standard_parameters(self.mass, self.center, self.inertia_about_com())


@dataclass(frozen=True)
class Cylinder(_Solid):
    """Solid cylinder, or tube when ``inner_radius > 0`` (a roller cover, a handle, a fixing plate)."""

    radius: float = 0.01
    """Outer radius R (m)."""
    length: float = 0.1
    """Length h along the axis (m)."""
    axis: str | Sequence[float] = "z"
    """Axis direction in the flange frame: 'x', 'y', 'z' or a 3-vector."""
    inner_radius: float = 0.0
    """Inner radius r (m), 0 for a solid cylinder."""

    def __post_init__(self) -> None:
        super().__post_init__()
        _positive(self.radius, "cylinder radius")
        _positive(self.length, "cylinder length")
        if not 0.0 <= self.inner_radius < self.radius:
            raise ValueError(f"cylinder inner radius {self.inner_radius} m must lie in [0, {self.radius}) m")

    def inertia_about_com(self) -> np.ndarray:
        a = _unit_axis(self.axis)
        squares = self.radius**2 + self.inner_radius**2
        about_axis = self.mass * squares / 2.0
        about_diameter = self.mass * (3.0 * squares + self.length**2) / 12.0
        return about_diameter * (np.eye(3) - np.outer(a, a)) + about_axis * np.outer(a, a)


@dataclass(frozen=True)
class Box(_Solid):
    """Rectangular block with edges along the flange axes (bristles, a ferrule, a plate)."""

    size: Sequence[float] = (0.01, 0.01, 0.01)
    """Edge lengths along x, y, z (m)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        size = np.asarray(self.size, dtype=float)
        if size.shape != (3,) or np.any(size <= 0):
            raise ValueError(f"box size must be three positive lengths (m), got {self.size!r}")
        object.__setattr__(self, "size", size)

    def inertia_about_com(self) -> np.ndarray:
        a2, b2, c2 = np.asarray(self.size) ** 2
        return self.mass / 12.0 * np.diag([b2 + c2, a2 + c2, a2 + b2])


@dataclass(frozen=True)
class Sphere(_Solid):
    """Solid ball (a knob, a counterweight)."""

    radius: float = 0.01
    """Radius (m)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        _positive(self.radius, "sphere radius")

    def inertia_about_com(self) -> np.ndarray:
        return 0.4 * self.mass * self.radius**2 * np.eye(3)


SHAPES: dict[str, type[_Solid]] = {"cylinder": Cylinder, "box": Box, "sphere": Sphere}
"""Shape names accepted in tool descriptions (``shape: cylinder``)."""


def shape_from_mapping(description: Mapping[str, Any]) -> _Solid:
    """A shape from a mapping such as ``{shape: cylinder, mass: 0.1, center: [0, 0, 0.2], radius: …}``."""
    description = dict(description)
    kind = description.pop("shape", None)
    description.pop("name", None)  # a label for the reader
    if kind not in SHAPES:
        raise ValueError(f"unknown shape {kind!r} in {dict(description)}; valid shapes: {sorted(SHAPES)}")
    try:
        return SHAPES[kind](**description)
    except TypeError as error:
        raise ValueError(f"bad {kind} description {description}: {error}") from None


def composite_parameters(parts: Sequence[Shape]) -> np.ndarray:
    """The 10 standard parameters of a rigid assembly: the sum of its parts' (all about one origin)."""
    if not parts:
        raise ValueError("a tool needs at least one part")
    return np.sum([part.parameters() for part in parts], axis=0)
