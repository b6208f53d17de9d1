"""Distances between the bodies of a :class:`~lwrlab.excitation.collision_scene.CollisionScene`, by
their enclosing spheres, for many configurations at once, with their derivatives.

* a body pair's distance is the smallest gap ``‖c_i − c_j‖ − r_i − r_j`` over their sphere pairs;
* a (body, world object) distance is the smallest ``sdf(c_i) − r_i`` over the body's spheres (plane,
  box, sphere, cylinder: exact signed distances), or the smallest gap to a mesh object's spheres.

Since the spheres contain the bodies, these distances are lower bounds of the true ones. The sphere
pairs of all columns are flattened into one array and reduced per column, and the samples processed in
chunks, so memory stays bounded on a 1 kHz motion.

Far pairs cost as much as near ones, and matter less to the exact check, which needs the bound only
to find the samples near contact: an arm on a humanoid has five hundred pairs with its torso, legs and
other arm, most of them far apart at most samples. Each body's spheres lie inside one bounding
sphere; given a ``horizon`` (m; :data:`CHECK_HORIZON` past the clearance), where two bodies' bounding
spheres are further apart than it, the pair's bound is the gap between the bounding spheres (a lower
bound too, looser) and no sphere pair is measured, and likewise a body's bounding sphere against a
fixed box, cylinder or sphere; within it, the spheres' distance as without a horizon (tested equal).

Spheres overshoot a link's surface by a centimetre or two: too much for links that are always close
(a wrist next to the forearm, an upper arm next to the base), where the spheres would overlap in
most configurations although the links rarely touch. With the robot's geometry at hand and
``use_hulls`` set (the optimiser), the scene's ``hull_pairs`` are therefore measured between the
convex hulls of the two bodies instead (coal's GJK, a few µs a sample; a hull contains its body, so
this is a lower bound too, and a continuous one), and a body against a plane by the exact height of
its hull's lowest vertex, for every sample at once.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from lwrlab.excitation.exact_geometry import ExactGeometry
from lwrlab.excitation.sphere_layout import SphereLayout, gaps_within, nearest_pairs, sphere_layout
from lwrlab.kinematics.tree import point_jacobians, posed_points
from lwrlab.model.enclosing_spheres import bounding_sphere

if TYPE_CHECKING:
    from lwrlab.excitation.collision_scene import CollisionScene

CHUNK = 2000
"""Samples per chunk."""
GATHER_CHUNK = 128
"""Samples whose sphere pairs are gathered at once: a humanoid arm's few thousand pairs then stay in
cache (twice as fast as a chunk at once; the same values)."""
CHECK_HORIZON = 0.1
"""m past the clearance beyond which the exact check bounds a pair by its bodies' bounding spheres
(module docstring)."""
PLANE_POINTS = 256
"""Hull vertices kept per body for its height above a plane in the optimiser."""


class SphereDistances:
    """Body–body and body–world distances of a scene by its spheres (module docstring)."""

    def __init__(self, scene: CollisionScene) -> None:
        self.scene = scene
        self.radii = scene.radii
        n_robot = len(scene.spheres)
        # spheres of mesh world objects, appended after the robot's (fixed in the base frame)
        fixed_centres: list[np.ndarray] = []
        fixed_radii: list[np.ndarray] = []
        self._world_spheres: dict[int, np.ndarray] = {}
        for w, obj in enumerate(scene.world):
            if obj.shape == "mesh" and obj.spheres is not None:
                start = n_robot + int(sum(len(r) for r in fixed_radii))
                self._world_spheres[w] = np.arange(start, start + len(obj.spheres[1]))
                fixed_centres.append(obj.spheres[0])
                fixed_radii.append(obj.spheres[1])
        self.fixed_centres = np.vstack(fixed_centres) if fixed_centres else np.zeros((0, 3))
        self.all_radii = np.concatenate([self.radii, *fixed_radii])
        self._body_spheres = [np.flatnonzero(scene.sphere_bodies == b) for b in range(len(scene.bodies))]
        # one bounding sphere per body (in its joint's frame), then per mesh world object (base frame)
        groups = [*self._body_spheres, *self._world_spheres.values()]
        self._world_groups = {w: len(self._body_spheres) + i for i, w in enumerate(self._world_spheres)}
        frames = np.array([s.link for s in scene.spheres] + [0] * len(self.fixed_centres), dtype=int)
        in_frame = np.vstack([np.reshape([s.center for s in scene.spheres], (-1, 3)), self.fixed_centres])
        rigid = [len(g) > 0 and bool(np.all(frames[g] == frames[g[0]])) for g in groups]
        bounds = [  # a group on several joints has no rigid bounding sphere: never pruned
            bounding_sphere(in_frame[g], self.all_radii[g]) if ok else (np.zeros(3), np.inf)
            for g, ok in zip(groups, rigid, strict=True)
        ]
        self._bound_centres = np.reshape([c for c, _ in bounds], (-1, 3))
        self._bound_radii = np.array([r for _, r in bounds])
        self._bound_joints = np.array(
            [frames[g[0]] if ok else 0 for g, ok in zip(groups, rigid, strict=True)]
        )
        self._exact: ExactGeometry | None = None
        self._plane_subsets: dict[int, tuple[np.ndarray, float]] = {}
        self._layouts: dict[tuple[str, tuple[tuple[int, int], ...]], Any] = {}
        self.use_hulls = False
        """Measure the scene's hull pairs and plane pairs on convex hulls (module docstring)."""
        self._hull_geometry: dict[
            frozenset[Any], tuple[Any, Any, dict[tuple[str, tuple[int, int]], int]]
        ] = {}
        self._pin_data: Any = None

    # --- layout ---------------------------------------------------------------------------------

    def _centres(self, poses: np.ndarray) -> np.ndarray:
        """(S_all, N, 3): the robot's sphere centres then the fixed world spheres."""
        robot = self.scene.sphere_centres(poses)
        fixed = np.broadcast_to(self.fixed_centres[:, None, :], (len(self.fixed_centres), poses.shape[1], 3))
        return np.concatenate([robot, fixed], axis=0)

    # --- values ---------------------------------------------------------------------------------

    def self_distances(
        self, pairs: tuple[tuple[int, int], ...], poses: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Smallest sphere gap (N, C) of each body pair (m), and how it was measured (see
        :meth:`pair_distances`)."""
        return self.pair_distances("self", pairs, poses)

    def world_distances(
        self, pairs: tuple[tuple[int, int], ...], poses: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Smallest distance (N, C) of each (body, world object) pair (m) and where it is reached."""
        return self.pair_distances("world", pairs, poses)

    def pair_distances(
        self,
        family: str,
        pairs: tuple[tuple[int, int], ...],
        poses: np.ndarray,
        q: np.ndarray | None = None,
        horizon: float | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Smallest distance (N, C) of each pair, and how it was measured (0: spheres, −1: convex hulls,
        −2: a plane's height above the hull); ``q`` (N, N_J) is needed when ``use_hulls``. With a
        ``horizon`` (m), the bodies' bounding spheres' gap past it (module docstring)."""
        n = poses.shape[1]
        values = np.empty((n, len(pairs)))
        where = np.zeros((n, len(pairs)), dtype=int)
        refined = self.use_hulls and self.scene.geometry is not None
        by_spheres = [
            c
            for c, pair in enumerate(pairs)
            if not (
                refined
                and (
                    (family, pair) in self.scene.hull_pairs
                    or (family == "world" and self.scene.world[pair[1]].shape == "plane")
                )
            )
        ]
        if by_spheres:
            layout = self._flat_layout(family, tuple(pairs[c] for c in by_spheres))
            for start in range(0, n, CHUNK):
                chunk = slice(start, min(n, start + CHUNK))
                values[chunk, by_spheres] = self._flat_distances(family, layout, poses[:, chunk], horizon).T
        if refined:
            self._refine(family, pairs, poses, values, where, q)
        return values, where

    def _flat_layout(self, family: str, pairs: tuple[tuple[int, int], ...]) -> SphereLayout:
        """Every sphere pair of the columns, flattened (:mod:`lwrlab.excitation.sphere_layout`)."""
        key = (family, pairs)
        if key not in self._layouts:
            self._layouts[key] = sphere_layout(
                family, pairs, self._body_spheres, self._world_spheres, self._world_groups
            )
        return self._layouts[key]

    def _flat_distances(
        self,
        family: str,
        layout: SphereLayout,
        poses: np.ndarray,
        horizon: float | None = None,
    ) -> np.ndarray:
        """(C, N) smallest gap per column from the flattened sphere pairs (and analytic objects), at
        joint poses (N_J, N, 4, 4); past a ``horizon`` (m), the bounding spheres' gap, or a body's
        bounding sphere's signed distance to an analytic object."""
        centres = self._centres(poses)
        out = np.full((layout.n_columns, centres.shape[1]), np.inf)
        if len(layout.first) and horizon is not None:
            self._sphere_distances_within(layout, poses, centres, horizon, out)
        elif len(layout.first):
            for start in range(0, centres.shape[1], GATHER_CHUNK):
                part = slice(start, start + GATHER_CHUNK)
                gaps = self._sphere_gaps(layout.first, layout.second, centres[:, part])
                out[layout.sphere_columns, part] = np.minimum.reduceat(gaps, layout.starts, axis=0)
        # past a horizon, a body's bounding sphere bounds its distance to an object (1-Lipschitz)
        far = horizon is not None and layout.analytic
        bound = posed_points(self._bound_centres, self._bound_joints, poses) if far else None
        for c, w, spheres, body in layout.analytic:
            near: slice | np.ndarray = slice(None)
            if bound is not None:
                out[c] = self.scene.world[w].signed_distance(bound[body])[0] - self._bound_radii[body]
                near = np.flatnonzero(out[c] < horizon)
            out[c, near] = np.min(self._object_gaps(w, spheres, centres[:, near]), axis=0)
        return out

    def _bounding_gaps(self, groups: np.ndarray, poses: np.ndarray) -> np.ndarray:
        """Gaps (R, N) between the bounding spheres of the (R, 2) ``groups`` at joint poses
        (N_J, N, 4, 4)."""
        bound_centres = posed_points(self._bound_centres, self._bound_joints, poses)  # (G, N, 3)
        a, b = groups[:, 0], groups[:, 1]
        apart = bound_centres[a] - bound_centres[b]
        radii = self._bound_radii[a] + self._bound_radii[b]
        return np.sqrt(np.einsum("cnk,cnk->cn", apart, apart)) - radii[:, None]

    def _sphere_distances_within(
        self, layout: SphereLayout, poses: np.ndarray, centres: np.ndarray, horizon: float, out: np.ndarray
    ) -> None:
        """Fill ``out`` (C, N) for the sphere columns: the smallest sphere gap where the two bodies'
        bounding spheres are within the ``horizon``, their gap past it (module docstring)."""
        bound = self._bounding_gaps(layout.groups, poses)
        out[layout.sphere_columns] = bound
        gaps_within(layout, centres, self.all_radii, bound < horizon, out)

    def _sphere_gaps(self, first: np.ndarray, second: np.ndarray, centres: np.ndarray) -> np.ndarray:
        """(M, N) gaps ``‖c_a − c_b‖ − r_a − r_b`` of the sphere pairs (first, second)."""
        gap = centres[first] - centres[second]  # (M, N, 3)
        gaps = np.sqrt(np.einsum("mnk,mnk->mn", gap, gap))
        return gaps - (self.all_radii[first] + self.all_radii[second])[:, None]

    def _object_gaps(self, world: int, spheres: np.ndarray, centres: np.ndarray) -> np.ndarray:
        """(S, N) signed distances of the spheres to an analytic world object, minus their radii."""
        points = centres[spheres].reshape(-1, 3)
        distance = self.scene.world[world].signed_distance(points)[0].reshape(len(spheres), -1)
        return distance - self.all_radii[spheres][:, None]

    # --- refinement by convex hulls -------------------------------------------------------------

    def _exact_geometry(self) -> ExactGeometry:
        if self._exact is None:
            self._exact = ExactGeometry(self.scene)
        return self._exact

    def _hull(self, body: int) -> object:
        return self._exact_geometry().convex(body)

    def _hull_model(
        self, keys: frozenset[tuple[str, tuple[int, int]]] | None = None
    ) -> tuple[Any, Any, dict[tuple[str, tuple[int, int]], int]]:
        """A Pinocchio geometry model of the bodies' convex hulls and the world objects, with one
        collision pair per (family, pair) of ``keys`` (default: the scene's hull pairs): Pinocchio
        computes all their distances in C++ per configuration."""
        keys = self.scene.hull_pairs if keys is None else keys
        if keys not in self._hull_geometry:
            model = self.scene.robot.model
            geometry_model = pin.GeometryModel()
            index: dict[tuple[str, int], int] = {}

            def add(key: tuple[str, int], joint: int, placement: np.ndarray, geometry: Any) -> int:
                if key not in index:
                    obj = pin.GeometryObject(f"{key[0]}{key[1]}", joint, pin.SE3(placement), geometry)
                    index[key] = geometry_model.addGeometryObject(obj)
                return index[key]

            pair_index = {}
            for family, (a, b) in sorted(keys):
                first = add(("body", a), int(self.scene.body_joints[a]), np.eye(4), self._hull(a))
                if family == "self":
                    second = add(("body", b), int(self.scene.body_joints[b]), np.eye(4), self._hull(b))
                else:
                    obj = self.scene.world[b]
                    if obj.shape == "plane":
                        continue
                    second = add(("world", b), 0, obj.pose, obj.geometry)
                geometry_model.addCollisionPair(pin.CollisionPair(first, second))
                pair_index[(family, (a, b))] = len(geometry_model.collisionPairs) - 1
            geometry_data = geometry_model.createData()
            for request in geometry_data.distanceRequests:
                request.enable_signed_distance = True
                request.gjk_tolerance = 1e-9  # smooth enough for finite differences and line searches
            self._hull_geometry[keys] = (geometry_model, geometry_data, pair_index)
            self._pin_data = model.createData()
        return self._hull_geometry[keys]

    def hull_distances(
        self,
        q: np.ndarray,
        with_points: bool = False,
        keys: frozenset[tuple[str, tuple[int, int]]] | None = None,
    ) -> dict[tuple[str, tuple[int, int]], tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Signed distances (N,) between the convex hulls of every hull pair (or of ``keys``) at
        configurations q (N, N_J), with the nearest points (N, 3) on each (base frame) when asked."""
        geometry_model, geometry_data, pair_index = self._hull_model(keys)
        model, data = self.scene.robot.model, self._pin_data
        n = q.shape[0]
        keys_in_order, indices = list(pair_index), list(pair_index.values())
        values = np.empty((n, len(indices)))
        points = np.empty((2, n, len(indices), 3))
        for request in geometry_data.distanceRequests:
            # GJK starts from the guess where the last sample's ended: from the same one at the first
            # sample, so that a call's distances depend on its configurations only (not on the calls
            # before it)
            request.cached_gjk_guess = np.array([1.0, 0.0, 0.0])
        results = geometry_data.distanceResults
        for k in range(n):
            pin.computeDistances(model, data, geometry_model, geometry_data, q[k])
            values[k] = [results[i].min_distance for i in indices]
            if with_points:
                for c, i in enumerate(indices):
                    points[0, k, c] = results[i].getNearestPoint1()
                    points[1, k, c] = results[i].getNearestPoint2()
        return {key: (values[:, c], points[0, :, c], points[1, :, c]) for c, key in enumerate(keys_in_order)}

    def _plane_points(self, body: int) -> tuple[np.ndarray, float]:
        """At most PLANE_POINTS of the body's hull vertices (farthest-point sampling) and the largest
        distance δ from any hull vertex to its nearest chosen one: the lowest chosen point, lowered by
        δ, is a lower bound of the body's lowest point (a smooth CAD hull has thousands of vertices)."""
        if body not in self._plane_subsets:
            hull = self._exact_geometry().hull[body]
            chosen = [0]
            nearest = np.linalg.norm(hull - hull[0], axis=1)
            while len(chosen) < min(PLANE_POINTS, len(hull)):
                chosen.append(int(np.argmax(nearest)))
                nearest = np.minimum(nearest, np.linalg.norm(hull - hull[chosen[-1]], axis=1))
            self._plane_subsets[body] = (hull[chosen], float(nearest.max()))
        return self._plane_subsets[body]

    def _plane_heights(self, body: int, plane_index: int, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Height (N,) of a body's hull above a plane at every sample — exact up to the δ of
        :meth:`_plane_points`, never above the true height — and the lowest point used (N, 3)."""
        hull, slack = self._plane_points(body)
        heights, points = self.scene.world[plane_index].lowest(
            hull, poses[int(self.scene.body_joints[body]) - 1]
        )
        return heights - slack, points

    def _refine(
        self,
        family: str,
        pairs: tuple[tuple[int, int], ...],
        poses: np.ndarray,
        values: np.ndarray,
        where: np.ndarray,
        q: np.ndarray | None,
    ) -> None:
        """Replace the columns of hull pairs and plane pairs in ``values`` (N, C) by hull distances
        (``where`` −1) and exact plane heights (``where`` −2)."""
        hulls = None
        for c, pair in enumerate(pairs):
            if family == "world" and self.scene.world[pair[1]].shape == "plane":
                values[:, c] = self._plane_heights(pair[0], pair[1], poses)[0]
                where[:, c] = -2
            elif (family, pair) in self.scene.hull_pairs:
                if q is None:
                    raise ValueError("hull distances need the configurations q")
                hulls = self.hull_distances(q) if hulls is None else hulls
                values[:, c] = hulls[(family, pair)][0]
                where[:, c] = -1

    # --- derivatives ----------------------------------------------------------------------------

    def derivatives(
        self,
        family: str,
        pairs: tuple[tuple[int, int], ...],
        q: np.ndarray,
        samples: np.ndarray,
        columns: np.ndarray,
    ) -> np.ndarray:
        """∂distance/∂q (m, N_J) of the (sample, column) entries, at what reaches the smallest distance
        (a sphere pair, the hulls' nearest points, the lowest hull vertex): the gradient of the minimum
        where it is unique. Entries are grouped by column, each column evaluated at its samples only."""
        scene, model = self.scene, self.scene.robot.model
        out = np.zeros((len(samples), scene.robot.n_joints))
        sphere_joints = np.array([s.link for s in scene.spheres] + [0] * len(self.fixed_centres), dtype=int)
        exact = self.use_hulls and scene.geometry is not None
        unique, inverse = np.unique(samples, return_inverse=True)
        all_poses = scene.poses(q[unique])  # once for every column
        all_centres: np.ndarray | None = None
        by_spheres: list[int] = []
        hull_columns = [c for c in np.unique(columns) if exact and (family, pairs[c]) in scene.hull_pairs]
        hulls = {}
        if hull_columns:  # every hull pair at once, at the samples of hull columns only
            needed = np.unique(inverse[np.isin(columns, hull_columns)])
            keys = frozenset((family, pairs[c]) for c in hull_columns)
            found = self.hull_distances(q[unique[needed]], with_points=True, keys=keys)
            position = {int(u): k for k, u in enumerate(needed)}
            hulls = {key: (values, position) for key, values in found.items()}
        for c in np.unique(columns):
            rows = np.flatnonzero(columns == c)
            pair = pairs[c]
            poses = all_poses[:, inverse[rows]]
            joint_a = np.full(len(rows), scene.body_joints[pair[0]])
            if exact and family == "world" and scene.world[pair[1]].shape == "plane":
                _, point = self._plane_heights(pair[0], pair[1], poses)
                jac = point_jacobians(model, poses, joint_a, point, scene.axes)
                out[rows] = np.einsum("i,mij->mj", scene.world[pair[1]].pose[:3, 2], jac)
                continue
            if c in hull_columns:
                (d, point_a, point_b), position = hulls[(family, pair)]
                picked = [position[int(k)] for k in inverse[rows]]
                d, point_a, point_b = d[picked], point_a[picked], point_b[picked]
                jac = point_jacobians(model, poses, joint_a, point_a, scene.axes)
                if family == "self":
                    joint_b = np.full(len(rows), scene.body_joints[pair[1]])
                    jac = jac - point_jacobians(model, poses, joint_b, point_b, scene.axes)
                gap = point_a - point_b
                normal = (
                    np.sign(d)[:, None] * gap / np.maximum(np.sqrt(np.sum(gap * gap, axis=1))[:, None], 1e-12)
                )
                out[rows] = np.einsum("mi,mij->mj", normal, jac)
                continue
            if all_centres is None:
                all_centres = self._centres(all_poses)  # (S_all, U, 3)
            if family == "self" or pair[1] in self._world_spheres:
                by_spheres.append(c)  # the sphere pairs of every such column at once, below
                continue
            # an analytic world object: the sphere nearest it
            spheres = self._body_spheres[pair[0]]
            centres = all_centres[:, inverse[rows]]
            a = spheres[np.argmin(self._object_gaps(pair[1], spheres, centres), axis=0)]
            point_a = centres[a, np.arange(len(rows))]
            jac_a = point_jacobians(model, poses, sphere_joints[a], point_a, scene.axes)
            gradient = scene.world[pair[1]].signed_distance(point_a)[1]
            out[rows] = np.einsum("mi,mij->mj", gradient, jac_a)
        if by_spheres:
            rows = np.flatnonzero(np.isin(columns, by_spheres))
            layout = self._flat_layout(family, tuple(pairs[c] for c in by_spheres))
            run = np.searchsorted(by_spheres, columns[rows])
            assert all_centres is not None
            a, b = nearest_pairs(layout, all_centres, self.all_radii, run, inverse[rows])
            poses, m = all_poses[:, inverse[rows]], inverse[rows]
            point_a, point_b = all_centres[a, m], all_centres[b, m]
            jac = point_jacobians(model, poses, sphere_joints[a], point_a, scene.axes)
            jac = jac - point_jacobians(model, poses, sphere_joints[b], point_b, scene.axes)
            gap = point_a - point_b
            normal = gap / np.maximum(np.sqrt(np.sum(gap * gap, axis=1))[:, None], 1e-12)
            out[rows] = np.einsum("mi,mij->mj", normal, jac)
        return out

    # --- exact contacts, for choosing pairs -----------------------------------------------------

    def exact_contact_fraction(
        self,
        family: str,
        pair: tuple[int, int],
        poses: np.ndarray,
        bound: np.ndarray,
        clearance: float,
    ) -> float:
        """Fraction of the configurations (poses (N_J, N, 4, 4)) where the pair's exact geometry is
        within ``clearance``; ``bound`` (N,): the spheres' lower bound, which rules most out."""
        exact = self._exact_geometry()
        near = np.flatnonzero(bound < clearance)
        hits = sum(exact.in_contact(family, pair, poses[:, k], clearance) for k in near)
        return hits / len(bound)
