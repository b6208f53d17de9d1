"""The optimiser's distance columns: one per pair, but one per moving body for the fixed objects.

The arm of a bigger robot (``robot.chain``, ``robot.group``) keeps clear of the boxes, cylinders and
spheres of the links fixed to its root (a mobile base, its wheels and lasers, a head), and of the
configured obstacles: TIAGo Pro's left arm has some eighty such (body, object) pairs, each a
constraint per time window of the optimiser, few of them ever binding, and SLSQP's time grows with
their number. A moving body's pairs with two or more such objects are therefore one column: the
smallest of their distances, a minimum of minima, so the motions it allows are the same. A body with
at most one keeps its pair's column: an arm alone on a table is optimised as before. (The bodies
fixed to the root that meshes describe, a humanoid's torso and legs, keep their pairs: one column
for a torso and a pelvis the arm passes between sends SLSQP's steps into the other.)

Within a time window only a column's smallest value counts (:mod:`lwrlab.excitation.problem`).
Given the windows, a member pair is measured only at the samples where a lower bound, the signed
distance of the body's bounding sphere to the object, comes within the column's distance at one
sample of the window (the sample of the smallest bound); elsewhere the bound stands in, above the
window's minimum. Every window's minimum, and the sample where it is reached, are those of measuring
every pair at every sample (tested equal), at a fraction of the cost.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from lwrlab.excitation.collision_scene import CollisionScene
from lwrlab.excitation.sphere_distances import SphereDistances
from lwrlab.kinematics.tree import posed_points

Pair = tuple[int, int]
ANALYTIC = ("box", "sphere", "cylinder")
"""World objects with an exact signed distance (1-Lipschitz: the bound of a body's bounding sphere holds)."""
TOLERANCE = 1e-9
"""m: a member pair is skipped only where its bound exceeds the window's distance by more (rounding)."""


@dataclass(frozen=True)
class DistanceColumns:
    """The columns of one family (``"self"`` or ``"world"``): each a tuple of pairs, its value the
    smallest of their distances (module docstring)."""

    family: str
    columns: tuple[tuple[Pair, ...], ...]

    def labels(self, scene: CollisionScene) -> list[str]:
        """``body–object`` for a pair's column, ``body–n fixed objects`` for a merged one."""
        return [
            scene.pair_label(self.family, members[0])
            if len(members) == 1
            else f"{scene.bodies[members[0][0]]}–{len(members)} fixed objects"
            for members in self.columns
        ]


def distance_columns(scene: CollisionScene, family: str) -> DistanceColumns:
    """The optimiser's columns of ``family`` ("self" or "world") for ``scene`` (module docstring): a
    moving body's pairs with two or more fixed objects of :data:`ANALYTIC` shape (not measured
    between hulls) are one column, where its first such pair stood; every other pair is a column."""
    pairs = scene.self_pairs if family == "self" else scene.world_pairs

    def joins(pair: Pair) -> bool:
        return (
            family == "world"
            and (family, pair) not in scene.hull_pairs
            and scene.world[pair[1]].shape in ANALYTIC
        )

    counts = Counter(p[0] for p in pairs if joins(p))
    columns: list[list[Pair]] = []
    merged: dict[int, list[Pair]] = {}
    for pair in pairs:
        if joins(pair) and counts[pair[0]] > 1:
            if pair[0] not in merged:
                merged[pair[0]] = []
                columns.append(merged[pair[0]])
            merged[pair[0]].append(pair)
        else:
            columns.append([pair])
    return DistanceColumns(family, tuple(tuple(c) for c in columns))


def column_distances(
    distances: SphereDistances,
    columns: DistanceColumns,
    poses: np.ndarray,
    q: np.ndarray,
    windows: np.ndarray | None = None,
) -> np.ndarray:
    """Each column's distance (N, C) at joint poses (N_J, N, 4, 4), configurations q (N, N_J). With
    ``windows`` (the first sample of each), a merged column's value is exact where it can be its
    window's smallest and a lower bound above that elsewhere (module docstring)."""
    n = poses.shape[1]
    out = np.empty((n, len(columns.columns)))
    single = [c for c, members in enumerate(columns.columns) if len(members) == 1]
    if single:
        pairs = tuple(columns.columns[c][0] for c in single)
        out[:, single] = distances.pair_distances(columns.family, pairs, poses, q)[0]
    merged = [c for c, members in enumerate(columns.columns) if len(members) > 1]
    if not merged:
        return out
    members = tuple(p for c in merged for p in columns.columns[c])
    starts = np.cumsum([0] + [len(columns.columns[c]) for c in merged[:-1]])
    if windows is None:
        values = distances.pair_distances(columns.family, members, poses, q)[0]
        out[:, merged] = np.minimum.reduceat(values, starts, axis=1)
        return out
    centres = distances._centres(poses)
    bound = _member_bounds(distances, members, poses)  # (M, N)
    # the column's value at the sample of its smallest bound in each window: an upper bound of the
    # window's minimum
    column_bound = np.minimum.reduceat(bound, starts, axis=0)  # (C_m, N)
    window_of = np.searchsorted(windows, np.arange(n), side="right") - 1
    first = np.zeros_like(bound, dtype=bool)
    at = np.empty((len(merged), len(windows)), dtype=int)
    for w, start in enumerate(windows):
        stop = windows[w + 1] if w + 1 < len(windows) else n
        at[:, w] = start + np.argmin(column_bound[:, start:stop], axis=1)
    rows = np.repeat(np.arange(len(merged)), np.diff(np.append(starts, len(members))))
    first[np.arange(len(members))[:, None], at[rows]] = True
    probe = np.full_like(bound, np.inf)
    _exact_within(distances, members, centres, first, probe)
    reach = np.minimum.reduceat(probe, starts, axis=0)[np.arange(len(merged))[:, None], at]  # (C_m, W)
    chosen = bound <= reach[rows][:, window_of] + TOLERANCE
    values = bound.copy()
    _exact_within(distances, members, centres, chosen, values)
    out[:, merged] = np.minimum.reduceat(values, starts, axis=0).T
    return out


def _member_bounds(distances: SphereDistances, members: tuple[Pair, ...], poses: np.ndarray) -> np.ndarray:
    """(M, N) lower bounds of the (body, object) member pairs: the signed distance of the body's
    bounding sphere to the object (a signed distance is 1-Lipschitz)."""
    centres = posed_points(distances._bound_centres, distances._bound_joints, poses)  # (G, N, 3)
    out = np.empty((len(members), poses.shape[1]))
    for m, (body, w) in enumerate(members):
        out[m] = distances.scene.world[w].signed_distance(centres[body])[0] - distances._bound_radii[body]
    return out


def _exact_within(
    distances: SphereDistances,
    members: tuple[Pair, ...],
    centres: np.ndarray,
    chosen: np.ndarray,
    out: np.ndarray,
) -> None:
    """Write into ``out`` (M, N) the member pairs' distances by the body's spheres at the ``chosen``
    (M, N) entries only (``centres`` (S, N, 3))."""
    for m, (body, w) in enumerate(members):
        samples = np.flatnonzero(chosen[m])
        if samples.size:
            spheres = distances._body_spheres[body]
            out[m, samples] = np.min(distances._object_gaps(w, spheres, centres[:, samples]), axis=0)


def column_derivatives(
    distances: SphereDistances,
    columns: DistanceColumns,
    q: np.ndarray,
    samples: np.ndarray,
    chosen: np.ndarray,
) -> np.ndarray:
    """∂distance/∂q (m, N_J) of the (sample, column) entries: a merged column's is that of its member
    pair nearest at the sample (:meth:`SphereDistances.derivatives`)."""
    members = tuple(p for c in columns.columns for p in c)
    first = np.cumsum([0] + [len(c) for c in columns.columns[:-1]])
    pair_of = first[chosen]
    for c in np.unique(chosen):
        group = columns.columns[c]
        if len(group) == 1:
            continue
        rows = np.flatnonzero(chosen == c)
        poses = distances.scene.poses(q[samples[rows]])
        values = distances.pair_distances(columns.family, group, poses, q[samples[rows]])[0]
        pair_of[rows] = first[c] + np.argmin(values, axis=1)
    return distances.derivatives(columns.family, members, q, samples, pair_of)
