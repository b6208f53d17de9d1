"""Exact distances with coal on a collision scene's own geometry, one configuration at a time.

Shared by the exact check of a motion (:mod:`lwrlab.excitation.collision_check`) and the distance
bounds near contact (:mod:`lwrlab.excitation.sphere_distances`), below both.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from lwrlab.model.enclosing_spheres import hull_vertices

if TYPE_CHECKING:
    from lwrlab.excitation.collision_scene import CollisionScene


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
