"""The optimiser's distance columns, and their values measured only where a window's smallest can be.

**Columns.** Each column's value is the smallest distance of its member pairs, a minimum of minima:
a column of several pairs allows the same motions as a column per pair, and SLSQP, whose time grows
with the number of constraints, gets fewer. A column is one pair, except:

* a moving body's pairs with two or more fixed boxes, cylinders or spheres (the URDF's fixed
  primitive links, configured obstacles: TIAGo Pro's base with its wheels and lasers) are one column;
* for the arm of a bigger robot (``robot.chain``, ``robot.group``: ``RobotModel.mounted_on`` set), a
  joint's bodies are one side of a column: TALOS's wrist, force sensor, palm and fingers, which one
  joint moves together, are one column against the pelvis (not ten), one against the head. The
  bodies fixed to the arm's root that meshes describe (a torso, legs, a head, the other arm) stay
  one column each: one column for a torso and a pelvis the arm passes between sends SLSQP's steps
  into the other.

An arm alone (no ``mounted_on``) keeps a column per body pair, and its fixed primitives join only
as above: with at most one, an arm on a table gets the same motion as with a column per pair.

**Values.** Within a time window only a column's smallest value counts
(:mod:`lwrlab.excitation.problem`). A member pair's distance has a lower bound that costs one
distance per sample: the gap between the two bodies' bounding spheres (a body's spheres, its convex
hull and its meshes lie inside it), or for a fixed box, cylinder or sphere the signed distance of
the body's bounding sphere (a signed distance is 1-Lipschitz). Given the windows, the column is
measured at the sample of its smallest bound in each window; its value there is at least the
window's smallest; a member is then measured only at the samples where its bound comes within it
(by :data:`TOLERANCE`), and elsewhere its bound stands in, above the window's smallest. Every
window's smallest value, and the sample where it is reached, are those of measuring every pair at
every sample (tested equal), at a fraction of the cost: on TALOS's arm a fifth of the sphere pairs.
A pair against a plane (its hull's lowest point) is measured at every sample (it costs no more than
its bound).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from lwrlab.excitation.collision_scene import CollisionScene
from lwrlab.excitation.sphere_distances import SphereDistances
from lwrlab.excitation.sphere_layout import gaps_within
from lwrlab.kinematics.tree import posed_points

Pair = tuple[int, int]
Side = tuple[str, int]
ANALYTIC = ("box", "sphere", "cylinder")
"""World objects with an exact signed distance (1-Lipschitz: the bound of a body's bounding sphere holds)."""
TOLERANCE = 1e-6
"""m: a member pair is skipped only where its bound exceeds the window's distance by more (rounding,
and the convex hulls' GJK, good to 1e-9 m)."""


@dataclass(frozen=True)
class DistanceColumns:
    """The columns of one family (``"self"`` or ``"world"``): each a tuple of pairs, its value the
    smallest of their distances (module docstring), and what each is, for reports."""

    family: str
    columns: tuple[tuple[Pair, ...], ...]
    labels: tuple[str, ...]
    """``body–object`` for a pair's column; ``body–n fixed objects``, ``body and k more–body`` for a
    column of several."""


def distance_columns(scene: CollisionScene, family: str) -> DistanceColumns:
    """The optimiser's columns of ``family`` ("self" or "world") for ``scene`` (module docstring); a
    column of several pairs stands where its first pair stood."""
    pairs = scene.self_pairs if family == "self" else scene.world_pairs
    by_joint = scene.robot.mounted_on is not None and scene.geometry is not None

    def side(body: int) -> Side:
        joint = int(scene.body_joints[body])
        return ("joint", joint) if by_joint and joint > 0 else ("body", body)

    def joins(pair: Pair) -> bool:
        return (
            family == "world"
            and (family, pair) not in scene.hull_pairs
            and scene.world[pair[1]].shape in ANALYTIC
        )

    counts = Counter(side(p[0]) for p in pairs if joins(p))

    def key(pair: Pair) -> tuple[Side, Side]:
        a, b = pair
        if family == "self":
            first, second = sorted((side(a), side(b)))
            return first, second
        if joins(pair) and counts[side(a)] > 1:
            return side(a), ("objects", 0)
        return side(a), ("object", b)

    columns: dict[tuple[Side, Side], list[Pair]] = {}
    for pair in pairs:
        columns.setdefault(key(pair), []).append(pair)
    members = tuple(tuple(c) for c in columns.values())
    return DistanceColumns(family, members, tuple(_label(scene, family, c) for c in members))


def _label(scene: CollisionScene, family: str, members: tuple[Pair, ...]) -> str:
    """``left–right``: a side's one body (or object), or its first and how many more."""

    def named(names: list[str]) -> str:
        return names[0] if len(names) == 1 else f"{names[0]} and {len(names) - 1} more"

    first = members[0][0]
    joint = scene.body_joints[first]
    if family == "world":
        left = list(dict.fromkeys(scene.bodies[a] for a, _ in members))
        objects = list(dict.fromkeys(b for _, b in members))
        right = scene.world[objects[0]].name if len(objects) == 1 else f"{len(objects)} fixed objects"
        return f"{named(left)}–{right}"
    # a self column's two sides: the bodies on the side of the first pair's first body, the others
    bodies = list(dict.fromkeys(b for pair in members for b in pair))
    same = [b for b in bodies if b == first or (joint > 0 and scene.body_joints[b] == joint)]
    other = [b for b in bodies if b not in same]
    return f"{named([scene.bodies[b] for b in same])}–{named([scene.bodies[b] for b in other])}"


def _members(columns: DistanceColumns) -> tuple[tuple[Pair, ...], np.ndarray]:
    """Every column's pairs in one tuple, and where each column's run starts."""
    members = tuple(p for c in columns.columns for p in c)
    starts = np.cumsum([0] + [len(c) for c in columns.columns[:-1]])
    return members, starts


class _Members:
    """Lower bounds and exact distances of member pairs at chosen samples (module docstring):
    joint poses (N_J, N, 4, 4), configurations q (N, N_J)."""

    def __init__(
        self,
        distances: SphereDistances,
        family: str,
        members: tuple[Pair, ...],
        poses: np.ndarray,
        q: np.ndarray,
        centres: np.ndarray | None = None,
    ) -> None:
        self.distances, self.family, self.members, self.poses, self.q = distances, family, members, poses, q
        if centres is not None:
            self.__dict__["centres"] = centres
        scene = distances.scene
        refined = distances.use_hulls and scene.geometry is not None
        kinds = []
        for pair in members:
            shape = scene.world[pair[1]].shape if family == "world" else None
            if refined and shape == "plane":
                kinds.append("plane")
            elif refined and (family, pair) in scene.hull_pairs:
                kinds.append("hull")
            elif shape in ANALYTIC or shape == "plane":
                kinds.append("analytic")
            else:
                kinds.append("spheres")
        self.kinds = np.array(kinds)
        self.dense = np.isin(self.kinds, ("plane", "hull"))
        """Members measured at every sample (:attr:`measured`)."""

    @cached_property
    def centres(self) -> np.ndarray:
        """(S_all, N, 3) sphere centres."""
        return self.distances._centres(self.poses)

    @cached_property
    def measured(self) -> np.ndarray:
        """(M, N) the distances of the members against a plane and between convex hulls at every
        sample (NaN for the others): a plane's costs no more than a bound, and the hulls' GJK, which
        starts from where the last sample's ended, gives the values of measuring every sample."""
        out = np.full((len(self.members), self.poses.shape[1]), np.nan)
        for m in np.flatnonzero(self.kinds == "plane"):
            body, plane = self.members[m]
            out[m] = self.distances._plane_heights(body, plane, self.poses)[0]
        hulls = np.flatnonzero(self.kinds == "hull")
        if hulls.size:
            found = self.distances.hull_distances(self.q)
            for m in hulls:
                out[m] = found[(self.family, self.members[m])][0]
        return out

    def bounds(self) -> np.ndarray:
        """(M, N) lower bounds of the members' distances: their distances where :attr:`measured`."""
        distances, scene = self.distances, self.distances.scene
        out = self.measured.copy()
        bounded = np.flatnonzero(~self.dense)
        if not bounded.size:
            return out
        centres = posed_points(distances._bound_centres, distances._bound_joints, self.poses)  # (G, N, 3)
        radii = distances._bound_radii
        groups: list[tuple[int, int, int]] = []
        by_object: dict[int, list[int]] = {}
        for m in map(int, bounded):
            body, other = self.members[m]
            if self.family == "world" and scene.world[other].shape in (*ANALYTIC, "plane"):
                by_object.setdefault(other, []).append(m)
            else:
                second = other if self.family == "self" else distances._world_groups[other]
                groups.append((m, body, second))
        for other, rows in by_object.items():  # every body's bounding sphere against one object at once
            bodies = [self.members[m][0] for m in rows]
            distance = scene.world[other].signed_distance(centres[bodies].reshape(-1, 3))[0]
            out[rows] = distance.reshape(len(rows), -1) - radii[bodies][:, None]
        if groups:
            at, a, b = (np.array(column) for column in zip(*groups, strict=True))
            apart = centres[a] - centres[b]
            out[at] = np.sqrt(np.einsum("cnk,cnk->cn", apart, apart)) - (radii[a] + radii[b])[:, None]
        return out

    def exact(self, chosen: np.ndarray, out: np.ndarray) -> None:
        """Write into ``out`` (M, N) the members' distances at the ``chosen`` (M, N) entries, measured
        as :meth:`SphereDistances.pair_distances` measures them (the same values)."""
        distances = self.distances
        for dense in np.flatnonzero(self.dense):
            out[dense, chosen[dense]] = self.measured[dense, chosen[dense]]
        by_object: dict[int, list[tuple[int, np.ndarray, np.ndarray]]] = {}
        for member in map(int, np.flatnonzero(self.kinds == "analytic")):
            samples = np.flatnonzero(chosen[member])
            if samples.size:
                body, other = self.members[member]
                by_object.setdefault(other, []).append((member, samples, distances._body_spheres[body]))
        for other, parts in by_object.items():  # every member against one object at once
            points = np.concatenate(
                [self.centres[spheres][:, samples].reshape(-1, 3) for _, samples, spheres in parts]
            )
            distance = distances.scene.world[other].signed_distance(points)[0]
            ends = np.cumsum([len(spheres) * len(samples) for _, samples, spheres in parts])
            for (m, samples, spheres), values in zip(parts, np.split(distance, ends[:-1]), strict=True):
                gaps = values.reshape(len(spheres), len(samples)) - distances.all_radii[spheres][:, None]
                out[m, samples] = np.min(gaps, axis=0)  # as SphereDistances._object_gaps
        rows = np.flatnonzero(self.kinds == "spheres")
        if rows.size:
            layout = distances._flat_layout(self.family, tuple(self.members[m] for m in rows))
            gaps_within(layout, self.centres, distances.all_radii, chosen[rows], out, rows)


@dataclass(frozen=True)
class NearestMembers:
    """Which member pair is nearest, where a :func:`column_distances` call knows it for sure: at the
    (sample, column) entries ``known`` (N, C), the index ``member`` (N, C) into the columns' pairs
    (all columns' pairs in order) of the first of the nearest, as
    :func:`column_derivatives` would find by measuring them again."""

    q: np.ndarray
    """(N, N_J) the configurations they were measured at."""
    member: np.ndarray
    known: np.ndarray


def column_distances(
    distances: SphereDistances,
    columns: DistanceColumns,
    poses: np.ndarray,
    q: np.ndarray,
    windows: np.ndarray | None = None,
    centres: np.ndarray | None = None,
) -> tuple[np.ndarray, NearestMembers]:
    """Each column's distance (N, C) at joint poses (N_J, N, 4, 4), configurations q (N, N_J), and its
    nearest member pair wherever that is certain. With ``windows`` (the first sample of each), exact
    where it can be its window's smallest and a lower bound above that elsewhere (module docstring);
    ``centres``: the sphere centres at the poses, when the caller has them. The nearest member is
    certain where every member left unmeasured has a lower bound above the column's value (every
    window's smallest among them): there :func:`column_derivatives` need not measure them again."""
    members, starts = _members(columns)
    if windows is None:
        values = distances.pair_distances(columns.family, members, poses, q)[0].T
        return _reduced(values, starts, np.ones(values.shape, dtype=bool), q)
    n = poses.shape[1]
    measure = _Members(distances, columns.family, members, poses, q, centres)
    bound = measure.bounds()  # (M, N)
    column_of = np.repeat(np.arange(len(starts)), np.diff(np.append(starts, len(members))))
    # each window's sample of the smallest bound, where the column is measured: an upper bound of the
    # window's smallest
    column_bound = np.minimum.reduceat(bound, starts, axis=0)  # (C, N)
    at = np.stack(
        [
            start + np.argmin(column_bound[:, start:stop], axis=1)
            for start, stop in zip(windows, np.append(windows[1:], n), strict=True)
        ],
        axis=1,
    )  # (C, W)
    probed = np.zeros_like(bound, dtype=bool)
    probed[np.arange(len(members))[:, None], at[column_of]] = True
    values = bound.copy()
    measure.exact(probed, values)
    reach = np.minimum.reduceat(values, starts, axis=0)[np.arange(len(starts))[:, None], at]  # (C, W)
    window_of = np.searchsorted(windows, np.arange(n), side="right") - 1
    chosen = (bound <= reach[column_of][:, window_of] + TOLERANCE) & ~probed & ~measure.dense[:, None]
    measure.exact(chosen, values)
    return _reduced(values, starts, probed | chosen | measure.dense[:, None], q)


def _reduced(
    values: np.ndarray, starts: np.ndarray, exact: np.ndarray, q: np.ndarray
) -> tuple[np.ndarray, NearestMembers]:
    """Each column's smallest (N, C) of the members' ``values`` (M, N), some ``exact`` (M, N) and the
    others lower bounds, and its nearest member where no bound can undercut it."""
    smallest = np.minimum.reduceat(values, starts, axis=0)  # (C, N)
    index = np.arange(len(values))[:, None]
    # the first member reaching the column's smallest, as argmin over a column's members picks it
    sizes = np.diff(np.append(starts, len(values)))
    reaching = values == np.repeat(smallest, sizes, axis=0)
    member = np.minimum.reduceat(np.where(reaching, index, len(values)), starts, axis=0)
    # no member measured only by its bound may be nearer, nor tie: a bound is at most its distance
    unmeasured = np.minimum.reduceat(np.where(exact, np.inf, values), starts, axis=0)
    return smallest.T, NearestMembers(q.copy(), member.T, (smallest < unmeasured).T)


def column_derivatives(
    distances: SphereDistances,
    columns: DistanceColumns,
    q: np.ndarray,
    samples: np.ndarray,
    chosen: np.ndarray,
    nearest: NearestMembers | None = None,
) -> np.ndarray:
    """∂distance/∂q (m, N_J) of the (sample, column) entries: a column of several pairs takes that of
    its member pair nearest at the sample, the first of equals (:meth:`SphereDistances.derivatives`);
    ``nearest``: what a :func:`column_distances` call at these ``q`` found, used where it
    is certain (those members are not measured again)."""
    members, starts = _members(columns)
    sizes = np.diff(np.append(starts, len(members)))
    pair_of = starts[chosen]
    several = np.flatnonzero(sizes[chosen] > 1)
    if nearest is not None and several.size and np.array_equal(nearest.q, q):
        known = nearest.known[samples[several], chosen[several]]
        pair_of[several[known]] = nearest.member[samples[several[known]], chosen[several[known]]]
        several = several[~known]
    if several.size:
        unique, inverse = np.unique(samples[several], return_inverse=True)
        measure = _Members(distances, columns.family, members, distances.scene.poses(q[unique]), q[unique])
        wanted = np.zeros((len(members), len(unique)), dtype=bool)
        for c in np.unique(chosen[several]):
            wanted[starts[c] : starts[c] + sizes[c], inverse[chosen[several] == c]] = True
        values = np.full(wanted.shape, np.inf)
        measure.exact(wanted, values)
        for c in np.unique(chosen[several]):
            rows = several[chosen[several] == c]
            run = values[starts[c] : starts[c] + sizes[c]][:, inverse[np.searchsorted(several, rows)]]
            pair_of[rows] = starts[c] + np.argmin(run, axis=0)
    return distances.derivatives(columns.family, members, q, samples, pair_of)
