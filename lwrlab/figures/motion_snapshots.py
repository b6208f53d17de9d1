"""What a motion preview draws: the posed meshes of each snapshot, the times chosen, the thinning.

:class:`BodyMesh` (one body's triangles, posed in the base frame) and :class:`Snapshot` (the bodies at
one time) are what the caller hands :func:`lwrlab.figures.motion_preview.motion_preview_figure`;
:func:`key_times` picks the times worth a panel (the start, the closest approaches, spread out), and
:func:`decimate_meshes` thins large meshes so a panel draws fast. No drawing here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from lwrlab.excitation.approaches import ClosestApproach

if TYPE_CHECKING:
    pass


KEEP_WHOLE = 64
"""Meshes of at most this many triangles (boxes, the table) are never thinned: they cost nothing."""


@dataclass(frozen=True)
class BodyMesh:
    """One body's triangle mesh, already posed in the base frame."""

    name: str
    """Body name, e.g. ``upper_arm_link`` or ``table``; the colour of a robot body follows its name."""
    vertices: np.ndarray
    """(V, 3) vertices in the base frame (m)."""
    faces: np.ndarray
    """(F, 3) integer vertex indices of the triangles."""
    world: bool = False
    """True for fixed world objects (table, base, obstacles): drawn grey and translucent."""


@dataclass(frozen=True)
class Snapshot:
    """The robot (and the world) at one time of the motion: one panel of the preview."""

    t: float
    """Time (s)."""
    meshes: tuple[BodyMesh, ...]
    """Every body drawn in the panel, posed at ``t``."""
    label: str = ""
    """Why this time, e.g. ``start pose``, ``closest to itself``; shown in the panel's title."""


def key_times(t: np.ndarray, approaches: Sequence[ClosestApproach], n: int = 6) -> list[tuple[float, str]]:
    """Times worth a snapshot, with their labels, sorted by time.

    The start pose ``t[0]``, the time of the closest self approach (``closest to itself``) and of the
    closest world approach (``closest to the world``) are always kept (the first ``n`` of them; an
    approach at the same sample as an earlier time only adds its label to it). The remaining places up
    to ``n`` go to the samples farthest from every time already chosen (the end pose first, then
    the middles of the widest gaps), as long as they are at least 5 % of the duration from all of
    them: a short motion or a large ``n`` may give fewer than ``n`` times. Every time is a sample of
    ``t`` (the approach times are rounded to the nearest one).

    Parameters
    ----------
    t : (N,) sample times of the motion (s), increasing.
    approaches : the closest approaches of the motion, self and world, in any order.
    n : most times returned.

    Examples
    --------
    >>> t = np.linspace(0.0, 10.0, 1001)
    >>> near = ClosestApproach("self", "link2", "link5", 0.012, 3.414, np.zeros(3), np.zeros(3))
    >>> [(round(time, 2), label) for time, label in key_times(t, [near], n=4)]
    [(0.0, 'start pose'), (3.41, 'closest to itself'), (6.7, ''), (10.0, 'end pose')]
    """
    if n < 1:
        raise ValueError(f"n = {n}: at least one time (the start pose) is needed")
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or len(t) == 0:
        raise ValueError(f"t has shape {t.shape}: one or more sample times expected")
    chosen: dict[int, str] = {0: "start pose"}
    for kind, label in (("self", "closest to itself"), ("world", "closest to the world")):
        of_kind = [a for a in approaches if a.kind == kind]
        if not of_kind or len(chosen) >= n:
            continue
        closest = min(of_kind, key=lambda a: a.distance)
        index = int(np.argmin(np.abs(t - closest.t)))
        chosen[index] = f"{chosen[index]} · {label}" if index in chosen else label
    min_gap = 0.05 * (t[-1] - t[0])
    gap = np.min(np.abs(t[:, None] - t[list(chosen)][None, :]), axis=1)  # to the nearest chosen time
    while len(chosen) < n:
        index = int(np.argmax(gap))
        if gap[index] < min_gap or gap[index] == 0.0:
            break
        chosen[index] = "end pose" if index == len(t) - 1 else ""
        gap = np.minimum(gap, np.abs(t - t[index]))
    return [(float(t[index]), chosen[index]) for index in sorted(chosen)]


def decimate_meshes(meshes: Sequence[BodyMesh], max_faces: int) -> tuple[BodyMesh, ...]:
    """The meshes thinned to at most ``max_faces`` triangles in all, by keeping every k-th face.

    Meshes of at most :data:`KEEP_WHOLE` triangles are kept whole; the others all keep every k-th
    triangle (the first one included), with the smallest k that fits the budget left. Every mesh
    keeps at least one triangle, so a budget below the number of meshes is exceeded. Meshes already
    within the budget are returned unchanged.

    Examples
    --------
    >>> faces = np.zeros((1000, 3), dtype=int)
    >>> links = [BodyMesh(f"link{i}", np.zeros((1, 3)), faces) for i in range(7)]
    >>> thinned = decimate_meshes(links, max_faces=4000)
    >>> [len(m.faces) for m in thinned], sum(len(m.faces) for m in thinned) <= 4000
    ([500, 500, 500, 500, 500, 500, 500], True)
    """
    if max_faces < 1:
        raise ValueError(f"max_faces = {max_faces}: at least one triangle must be drawn")
    sizes = [len(m.faces) for m in meshes]
    if sum(sizes) <= max_faces:
        return tuple(meshes)
    large = [size for size in sizes if size > KEEP_WHOLE]
    budget = max(max_faces - (sum(sizes) - sum(large)), len(large))
    step = max(1, math.ceil(sum(large) / budget))
    while sum(-(-size // step) for size in large) > budget:
        step += 1
    return tuple(replace(m, faces=m.faces[::step]) if len(m.faces) > KEEP_WHOLE else m for m in meshes)
