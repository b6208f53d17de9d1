"""Collision spheres fixed to the segments of a robot: its coarse self-collision model (eq. 11).

Each sphere is attached to a segment (``link`` j ≥ 1: the joint frame j; 0: the fixed base frame),
with its centre in that frame (m) and a radius (m). The robot config lists them under
``collision_spheres``; the excitation problem keeps relevant pairs apart and the spheres named in its
``ground_spheres`` (the elbow and the wrist) above a virtual floor.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class CollisionSphere:
    """A sphere fixed to one segment."""

    name: str
    """Unique name, e.g. ``elbow``."""
    link: int
    """Segment it is fixed to: 0 = the fixed base, j = segment j (moved by joint j)."""
    center: np.ndarray
    """(3,) centre in the segment's joint frame (m)."""
    radius: float
    """Radius (m)."""
    body: str = ""
    """The body it stands in for (a URDF link); empty: the sphere is a body of its own."""

    def __post_init__(self) -> None:
        if not self.body:
            object.__setattr__(self, "body", self.name)


def build_collision_spheres(
    entries: Sequence[Mapping[str, Any]] | None, n_links: int, robot: str
) -> tuple[CollisionSphere, ...]:
    """Spheres from config entries ``{name, link, center: [x, y, z], radius}``.

    Bad entries raise a clear error naming the robot and the sphere.
    """
    spheres = []
    for i, entry in enumerate(entries or ()):
        missing = {"name", "link", "center", "radius"} - set(entry)
        if missing:
            raise ValueError(f"robot {robot!r} collision_spheres[{i}] lacks {sorted(missing)}")
        center = np.asarray(entry["center"], dtype=float).ravel()
        if center.shape != (3,):
            raise ValueError(
                f"robot {robot!r} collision sphere {entry['name']!r}: "
                f"center needs 3 values, got {center.size}"
            )
        link, radius = int(entry["link"]), float(entry["radius"])
        if not 0 <= link <= n_links:
            raise ValueError(
                f"robot {robot!r} collision sphere {entry['name']!r}: link {link} outside 0…{n_links}"
            )
        if radius <= 0:
            raise ValueError(
                f"robot {robot!r} collision sphere {entry['name']!r}: radius must be positive, got {radius}"
            )
        spheres.append(CollisionSphere(str(entry["name"]), link, center, radius))
    names = [s.name for s in spheres]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise ValueError(f"robot {robot!r}: collision sphere names must be unique, repeated: {duplicates}")
    return tuple(spheres)
