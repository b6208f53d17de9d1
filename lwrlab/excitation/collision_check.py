"""The exact collision check of a motion: every sample (1 kHz) against the robot's own geometry.

For each checked pair (two bodies of the robot, or a body and a world object) the enclosing spheres
give, vectorised over all samples, a lower bound of the true distance
(:mod:`lwrlab.excitation.sphere_distances`). Only samples whose bound is within the clearance are
queried with coal on the exact geometry (meshes and primitives, with the clearance as security
margin); against a plane the exact distance is the lowest vertex of the body's meshes (exact for
meshes and boxes, the enclosing polyhedron for round primitives). The closest approach of every pair
is the smallest exact distance over the samples where its bound is smallest (a dozen, spread in time).

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
from lwrlab.excitation.sphere_distances import SphereDistances
from lwrlab.model.enclosing_spheres import hull_vertices

APPROACH_CANDIDATES = 12
"""Exact distances computed per pair for its closest approach: at the samples of smallest bound, no two
closer than 0.5 % of the motion (the contacts themselves are checked at every sample)."""


class ExactGeometry:
    """coal queries on a scene's exact geometry, at one configuration's joint poses."""

    def __init__(self, scene: CollisionScene) -> None:
        import coal

        self._coal = coal
        self.scene = scene
        geometry = scene.geometry
        self.shapes = {b: geometry.shapes_of(name) for b, name in enumerate(scene.bodies)} if geometry else {}
        self._convex: dict[int, object] = {}
        # hull vertices of each body in its joint frame: the plane test needs only them
        self.hull = {
            b: hull_vertices(np.vstack([s.vertices_in_joint_frame() for s in shapes]))
            for b, shapes in self.shapes.items()
        }

    def transform(self, pose: np.ndarray) -> object:
        """A (4, 4) pose as coal's transform."""
        return self._coal.Transform3s(pose[:3, :3].copy(), pose[:3, 3].copy())

    def body_pose(self, body: int, poses: np.ndarray) -> np.ndarray:
        """(4, 4) pose of a body's joint frame from one configuration's joint poses (N_J, 4, 4)."""
        joint = int(self.scene.body_joints[body])
        return np.eye(4) if joint == 0 else poses[joint - 1]

    def _objects(self, body: int, poses: np.ndarray) -> list[tuple[object, object]]:
        pose = self.body_pose(body, poses)
        return [(s.geometry, self.transform(pose @ s.placement)) for s in self.shapes[body]]

    def _other(self, family: str, pair: tuple[int, int], poses: np.ndarray) -> list[tuple[object, object]]:
        if family == "self":
            return self._objects(pair[1], poses)
        obj = self.scene.world[pair[1]]
        return [(obj.geometry, self.transform(obj.pose))]

    def distance(
        self, family: str, pair: tuple[int, int], poses: np.ndarray
    ) -> tuple[float, np.ndarray, np.ndarray]:
        """Exact distance (m) of a pair at one configuration (poses (N_J, 4, 4)) and the closest points."""
        coal = self._coal
        obj = self.scene.world[pair[1]] if family == "world" else None
        if obj is not None and obj.shape == "plane":
            heights, points = obj.lowest(self.hull[pair[0]], self.body_pose(pair[0], poses)[None])
            return float(heights[0]), points[0], points[0] - heights[0] * obj.pose[:3, 2]
        best = (np.inf, np.zeros(3), np.zeros(3))
        request = coal.DistanceRequest()
        request.enable_signed_distance = True
        for geometry_a, placement_a in self._objects(pair[0], poses):
            for geometry_b, placement_b in self._other(family, pair, poses):
                result = coal.DistanceResult()
                d = coal.distance(geometry_a, placement_a, geometry_b, placement_b, request, result)
                if d < best[0]:
                    best = (
                        float(d),
                        np.array(result.getNearestPoint1()),
                        np.array(result.getNearestPoint2()),
                    )
        return best

    def hull_distance(self, family: str, pair: tuple[int, int], poses: np.ndarray) -> float:
        """Signed distance (m) between the convex hulls of the pair (a world object: itself) at one
        configuration: a lower bound of their distance."""
        coal = self._coal
        pose_a = self.body_pose(pair[0], poses)
        if family == "self":
            other, pose_b = self.convex(pair[1]), self.body_pose(pair[1], poses)
        else:
            obj = self.scene.world[pair[1]]
            other, pose_b = obj.geometry, obj.pose
        request = coal.DistanceRequest()
        request.enable_signed_distance = True
        return float(
            coal.distance(
                self.convex(pair[0]), self.transform(pose_a), other, self.transform(pose_b),
                request, coal.DistanceResult(),
            )
        )  # fmt: skip

    def convex(self, body: int) -> object:
        """The convex hull of a body's geometry (joint frame), as a coal geometry."""
        if body not in self._convex:
            points = self._coal.StdVec_Vec3s()
            points.extend(list(self.hull[body]))
            self._convex[body] = self._coal.Convex.convexHull(points, False, "")
        return self._convex[body]

    def in_contact(self, family: str, pair: tuple[int, int], poses: np.ndarray, clearance: float) -> bool:
        """Whether the pair is within ``clearance`` (m) at one configuration."""
        coal = self._coal
        obj = self.scene.world[pair[1]] if family == "world" else None
        if obj is not None and obj.shape == "plane":
            return self.distance(family, pair, poses)[0] < clearance
        request = coal.CollisionRequest()
        request.security_margin = clearance
        for geometry_a, placement_a in self._objects(pair[0], poses):
            for geometry_b, placement_b in self._other(family, pair, poses):
                result = coal.CollisionResult()
                if coal.collide(geometry_a, placement_a, geometry_b, placement_b, request, result):
                    return True
        return False


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
        other_bounds = distances.pair_distances(family, others, poses)[0]  # (N, C')
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
            for k in _lowest_apart(bound, APPROACH_CANDIDATES, len(t) // 200 + 1):
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
