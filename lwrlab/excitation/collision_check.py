"""The exact collision check of a motion: every sample (1 kHz) against the robot's own geometry.

For each checked pair (two bodies of the robot, or a body and a world object) the enclosing spheres
give, vectorised over all samples, a lower bound of the true distance
(:mod:`lwrlab.excitation.sphere_distances`; where the two bodies' bounding spheres are more than a
horizon apart, their gap is the bound, looser but as safe). Only samples whose bound is within the
clearance are queried with coal on the exact geometry (meshes and primitives, with the clearance as security
margin); against a plane the exact distance is the lowest vertex of the body's meshes (exact for
meshes and boxes, the enclosing polyhedron for round primitives). The closest approach of every pair
is the smallest exact distance over the samples where its bound is smallest (a dozen, spread in time;
one for a pair whose bound never comes within 10 cm of the clearance).

The bound is the larger of the spheres' and the convex hulls' distances (both contain the bodies; the
hulls' by coal's GJK, computed only near contact and near each pair's closest approach). A robot described by
hand-written spheres only has no other geometry: its spheres are checked as the optimiser sees them.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Literal

import numpy as np

from lwrlab.excitation.approaches import ClosestApproach
from lwrlab.excitation.collision_scene import CollisionScene
from lwrlab.excitation.exact_geometry import ExactGeometry
from lwrlab.excitation.sphere_distances import CHECK_HORIZON, SphereDistances

APPROACH_CANDIDATES = 12
"""Exact distances computed per pair for its closest approach: at the samples of smallest bound, no two
closer than 0.5 % of the motion (the contacts themselves are checked at every sample); one for a pair
whose bound never comes within the horizon (10 cm past the clearance)."""


@dataclass(frozen=True)
class PairContact:
    """Samples where a pair comes within the clearance."""

    kind: str
    bodies: str
    samples: int
    first_s: float
    last_s: float
    deepest: float
    """Smallest exact distance (m) over those samples (negative: penetration)."""


@dataclass(frozen=True)
class CollisionCheck:
    """The result of :func:`check_collisions`."""

    approaches: tuple[ClosestApproach, ...]
    """Closest approach of every checked pair, nearest first."""
    contacts: tuple[PairContact, ...]
    """Pairs within the clearance somewhere (empty: the motion is free)."""
    exact: bool
    """True when the robot's own geometry was checked (False: its hand-written spheres)."""
    pairs_checked: int
    exact_queries: int
    seconds: float

    @property
    def free(self) -> bool:
        return not self.contacts

    def closest(self, kind: str) -> ClosestApproach | None:
        return next((a for a in self.approaches if a.kind == kind), None)

    def describe(self) -> str:
        """One line per contact: which bodies, when, by how much."""
        return "\n  ".join(
            f"{c.kind} collision {c.bodies}: within the clearance at {c.samples} sample(s) from "
            f"t = {c.first_s:.3f} s to {c.last_s:.3f} s, closest {1000 * c.deepest:.1f} mm"
            for c in self.contacts
        )


def check_collisions(scene: CollisionScene, t: np.ndarray, q: np.ndarray, clearance: float) -> CollisionCheck:
    """Check every sample of a motion (t (N,) s, q (N, N_J)) against the scene's exact geometry."""
    clock = time.perf_counter()
    distances = SphereDistances(scene)
    # hand-written spheres are the collision model itself: their distances stay exact at any range
    horizon = clearance + CHECK_HORIZON if scene.geometry is not None else None
    poses = scene.poses(q)
    exact = ExactGeometry(scene) if scene.geometry is not None else None
    approaches, contacts, queries = [], [], 0
    for family, pairs in (("self", scene.checked_self_pairs), ("world", scene.checked_world_pairs)):
        if not pairs:
            continue
        planes = [
            exact is not None and family == "world" and scene.world[p[1]].shape == "plane" for p in pairs
        ]
        others = tuple(p for p, plane in zip(pairs, planes, strict=True) if not plane)
        # beyond the horizon the bodies' bounding spheres bound them (looser, far cheaper)
        other_bounds = distances.pair_distances(family, others, poses, horizon=horizon)[0]
        for c, pair in enumerate(pairs):
            if planes[c] and exact is not None:
                approach, contact = _plane_check(exact, scene, pair, poses, t, clearance)
                approaches.append(approach)
                contacts += [contact] if contact is not None else []
                continue
            bound = other_bounds[:, others.index(pair)]
            if exact is not None and not (family == "world" and scene.world[pair[1]].shape == "plane"):
                # the convex hulls bound tighter than the spheres where it matters: near contact
                near = np.flatnonzero(bound < clearance)
                hull = [exact.hull_distance(family, pair, poses[:, k]) for k in near]
                bound[near] = np.maximum(bound[near], hull)
            label_b = scene.world[pair[1]].name if family == "world" else scene.bodies[pair[1]]
            kind: Literal["self", "world"] = "world" if family == "world" else "self"
            if exact is None:
                k = int(np.argmin(bound))
                centres = scene.sphere_centres(poses[:, k : k + 1])[:, 0]
                approaches.append(_sphere_approach(scene, family, pair, k, t, bound, centres, clearance))
                near = np.flatnonzero(bound < clearance)
                if near.size:
                    contacts.append(
                        PairContact(
                            kind,
                            f"{scene.bodies[pair[0]]}–{label_b}",
                            near.size,
                            t[near[0]],
                            t[near[-1]],
                            float(bound.min()),
                        )
                    )
                continue
            best: tuple[float, np.ndarray, np.ndarray, int] = (np.inf, np.zeros(3), np.zeros(3), 0)
            # a pair never within the horizon: one exact distance, where its bound is least
            candidates = APPROACH_CANDIDATES if horizon is None or bound.min() < horizon else 1
            for k in _lowest_apart(bound, candidates, len(t) // 200 + 1):
                d, pa, pb = exact.distance(family, pair, poses[:, k])
                queries += 1
                if d < best[0]:
                    best = (d, pa, pb, int(k))
            d, pa, pb, k_best = best
            approaches.append(
                ClosestApproach(kind, scene.bodies[pair[0]], label_b, d, float(t[k_best]), pa, pb, clearance)
            )
            near = np.flatnonzero(bound < clearance)
            hits: list[int] = []
            for sample in near:
                queries += 1
                if exact.in_contact(family, pair, poses[:, sample], clearance):
                    hits.append(int(sample))
            if hits:
                deepest = min(
                    exact.distance(family, pair, poses[:, k])[0] for k in hits[:: max(1, len(hits) // 20)]
                )
                contacts.append(
                    PairContact(
                        kind,
                        f"{scene.bodies[pair[0]]}–{label_b}",
                        len(hits),
                        float(t[hits[0]]),
                        float(t[hits[-1]]),
                        min(deepest, d),
                    )
                )
    approaches.sort(key=lambda a: a.distance)
    return CollisionCheck(
        tuple(approaches), tuple(contacts), exact is not None,
        len(scene.checked_self_pairs) + len(scene.checked_world_pairs), queries, time.perf_counter() - clock,
    )  # fmt: skip


def _lowest_apart(values: np.ndarray, count: int, spacing: int) -> list[int]:
    """Indices of the ``count`` smallest values, no two closer than ``spacing`` samples."""
    chosen: list[int] = []
    for k in np.argsort(values):
        if all(abs(int(k) - c) >= spacing for c in chosen):
            chosen.append(int(k))
            if len(chosen) == count:
                break
    return chosen


def _plane_check(
    exact: ExactGeometry,
    scene: CollisionScene,
    pair: tuple[int, int],
    poses: np.ndarray,
    t: np.ndarray,
    clearance: float,
) -> tuple[ClosestApproach, PairContact | None]:
    """A body against a plane at every sample at once: the lowest vertex of its hull is exact."""
    body, plane = pair[0], scene.world[pair[1]]
    joint = int(scene.body_joints[body])
    distance, points = plane.lowest(exact.hull[body], poses[joint - 1])
    k = int(np.argmin(distance))
    point = points[k]
    approach = ClosestApproach(
        "world", scene.bodies[body], plane.name, float(distance[k]), float(t[k]), point,
        point - distance[k] * plane.pose[:3, 2], clearance,
    )  # fmt: skip
    near = np.flatnonzero(distance < clearance)
    if not near.size:
        return approach, None
    label = f"{scene.bodies[body]}–{plane.name}"
    return approach, PairContact(
        "world", label, near.size, float(t[near[0]]), float(t[near[-1]]), float(distance[k])
    )


def _sphere_approach(
    scene: CollisionScene,
    family: str,
    pair: tuple[int, int],
    k: int,
    t: np.ndarray,
    bound: np.ndarray,
    centres: np.ndarray,
    clearance: float,
) -> ClosestApproach:
    """The closest approach of a pair of hand-written spheres (or sphere and world) at sample k."""
    a = int(np.flatnonzero(scene.sphere_bodies == pair[0])[0])
    point_a = centres[a]
    if family == "world":
        obj = scene.world[pair[1]]
        distance, gradient = obj.signed_distance(point_a[None])
        point_b = point_a - distance[0] * gradient[0]
        point_a = point_a - scene.spheres[a].radius * gradient[0]
        return ClosestApproach(
            "world",
            scene.bodies[pair[0]],
            obj.name,
            float(bound[k]),
            float(t[k]),
            point_a,
            point_b,
            clearance,
        )
    b = int(np.flatnonzero(scene.sphere_bodies == pair[1])[0])
    direction = centres[b] - centres[a]
    direction /= max(float(np.linalg.norm(direction)), 1e-12)
    point_a = centres[a] + scene.spheres[a].radius * direction
    point_b = centres[b] - scene.spheres[b].radius * direction
    return ClosestApproach(
        "self", scene.bodies[pair[0]], scene.bodies[pair[1]], float(bound[k]), float(t[k]), point_a, point_b,
        clearance,
    )  # fmt: skip
