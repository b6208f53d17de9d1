"""The robot's world: the surface it is mounted on and the obstacles around it, in the base frame.

A :class:`WorldObject` is a plane (a half-space: the mounting surface, a wall), a box, a sphere, a
cylinder (axis along its local z) or a triangle mesh, placed by a pose in the robot's base frame. Each
gives, for points, the signed distance to its surface with the gradient (what the optimiser keeps
positive for the links' enclosing spheres), and a coal geometry for the exact check. Meshes give
enclosing spheres instead of a signed distance.

The config (``trajectory.constraints.world``) lists them::

    mounting_surface: {height: 0.0, normal: [0, 0, 1]}     # null: none
    obstacles:
      - {name: table, shape: box, size: [1.2, 0.8, 0.02], xyz: [0.5, 0, -0.01], rpy: [0, 0, 0]}
      - {name: pillar, shape: cylinder, radius: 0.1, length: 1.5, xyz: [0, 0.6, 0.75]}
      - {name: ball, shape: sphere, radius: 0.2, xyz: [0.6, 0.3, 0.4]}
      - {name: fixture, shape: mesh, path: /path/fixture.stl, scale: [1, 1, 1], xyz: [...], rpy: [...]}
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pinocchio as pin

Shape = Literal["plane", "box", "sphere", "cylinder", "mesh"]
SHAPES: tuple[str, ...] = ("plane", "box", "sphere", "cylinder", "mesh")
LOWEST_CHUNK = 2_000_000
"""Heights (poses × points) computed at once by :meth:`WorldObject.lowest` (16 MB)."""


@dataclass(frozen=True)
class WorldObject:
    """A fixed object of the robot's world."""

    name: str
    shape: Shape
    pose: np.ndarray
    """(4, 4) pose in the base frame (m). A plane's normal is the pose's z axis, through its origin."""
    size: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """box: half extents (3,); sphere: (radius,); cylinder: (radius, half length); else empty (m)."""
    geometry: Any = None
    """coal geometry for the exact check (None for a plane, checked by its support function)."""
    vertices: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    """(V, 3) base-frame vertices of a mesh containing the object (not for a plane), for figures."""
    faces: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=int))
    spheres: tuple[np.ndarray, np.ndarray] | None = None
    """For a mesh: centres (k, 3) in the base frame and radii (k,) of spheres containing it."""

    def signed_distance(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance (N,) of points (N, 3) to the surface (m, negative inside) and its gradient
        (N, 3), for every shape but a mesh."""
        rotation, origin = self.pose[:3, :3], self.pose[:3, 3]
        local = (points - origin) @ rotation
        if self.shape == "plane":
            return local[:, 2], np.broadcast_to(rotation[:, 2], points.shape).copy()
        if self.shape == "sphere":
            gap = local
            norm = np.maximum(np.linalg.norm(gap, axis=1), 1e-12)
            return norm - self.size[0], (gap / norm[:, None]) @ rotation.T
        if self.shape == "box":
            distance, gradient = _box_distance(local, self.size)
        elif self.shape == "cylinder":
            distance, gradient = _cylinder_distance(local, self.size[0], self.size[1])
        else:
            raise ValueError(f"world object {self.name!r}: a mesh has no signed distance, use its spheres")
        return distance, gradient @ rotation.T

    def lowest(self, points: np.ndarray, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For a plane: the height (N,) above it of the lowest of ``points`` (V, 3, a body's frame)
        carried by each of ``poses`` (N, 4, 4), and that point (N, 3, base frame).

        Heights are ``n·(R·v + p − o) = (Rᵀn)·v + n·(p − o)``: one product, for at most
        :data:`LOWEST_CHUNK` heights at a time (a smooth CAD hull has thousands of vertices)."""
        normal, origin = self.pose[:3, 2], self.pose[:3, 3]
        directions = poses[:, :3, :3].transpose(0, 2, 1) @ normal  # (N, 3): Rᵀn
        offsets = (poses[:, :3, 3] - origin) @ normal
        lowest = np.empty(len(poses), dtype=int)
        heights = np.empty(len(poses))
        rows = max(1, LOWEST_CHUNK // max(len(points), 1))
        for start in range(0, len(poses), rows):
            chunk = slice(start, start + rows)
            all_heights = directions[chunk] @ points.T + offsets[chunk, None]  # (chunk, V)
            lowest[chunk] = np.argmin(all_heights, axis=1)
            heights[chunk] = all_heights[np.arange(len(all_heights)), lowest[chunk]]
        posed = np.einsum("nij,nj->ni", poses[:, :3, :3], points[lowest]) + poses[:, :3, 3]
        return heights, posed


def _box_distance(p: np.ndarray, half: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance to an axis-aligned box centred at 0 and its gradient (exact, outside and in)."""
    excess = np.abs(p) - half
    outside = np.maximum(excess, 0.0)
    out_norm = np.linalg.norm(outside, axis=1)
    sign = np.where(p >= 0, 1.0, -1.0)
    gradient = np.where(out_norm[:, None] > 0, sign * outside / np.maximum(out_norm, 1e-12)[:, None], 0.0)
    inside = out_norm == 0
    axis = np.argmax(excess, axis=1)
    gradient[inside] = 0.0
    gradient[inside, axis[inside]] = sign[inside, axis[inside]]
    distance = np.where(inside, excess.max(axis=1), out_norm)
    return distance, gradient


def _cylinder_distance(p: np.ndarray, radius: float, half_length: float) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance to a capped cylinder along z centred at 0 and its gradient."""
    rho = np.linalg.norm(p[:, :2], axis=1)
    radial = np.zeros_like(p)
    radial[:, :2] = p[:, :2] / np.maximum(rho, 1e-12)[:, None]
    radial[rho < 1e-12, 0] = 1.0
    axial = np.zeros_like(p)
    axial[:, 2] = np.where(p[:, 2] >= 0, 1.0, -1.0)
    d_r, d_z = rho - radius, np.abs(p[:, 2]) - half_length
    both = (d_r > 0) & (d_z > 0)
    corner = np.sqrt(np.maximum(d_r, 0) ** 2 + np.maximum(d_z, 0) ** 2)
    distance = np.where(both, corner, np.maximum(d_r, d_z))
    gradient = np.where((d_r >= d_z)[:, None], radial, axial)
    with np.errstate(invalid="ignore", divide="ignore"):
        gradient[both] = (d_r[both, None] * radial[both] + d_z[both, None] * axial[both]) / corner[both, None]
    return distance, gradient


def pose_from(xyz: Sequence[float] | None, rpy: Sequence[float] | None) -> np.ndarray:
    """(4, 4) pose from a position (m) and roll-pitch-yaw angles (rad), as URDF writes them."""
    pose = np.eye(4)
    pose[:3, :3] = pin.rpy.rpyToMatrix(*np.asarray(rpy if rpy is not None else (0.0, 0.0, 0.0), dtype=float))
    pose[:3, 3] = np.asarray(xyz if xyz is not None else (0.0, 0.0, 0.0), dtype=float)
    return pose


def mounting_surface(height: float = 0.0, normal: Sequence[float] = (0.0, 0.0, 1.0)) -> WorldObject:
    """The plane the robot stands on: points with ``normal·x < height`` (base frame) are beneath it."""
    n = np.asarray(normal, dtype=float)
    if n.shape != (3,) or np.linalg.norm(n) == 0:
        raise ValueError(f"mounting_surface.normal must be a non-zero 3-vector, got {list(normal)}")
    n = n / np.linalg.norm(n)
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, n)
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, :3] = np.column_stack([x, np.cross(n, x), n])
    pose[:3, 3] = height * n
    return WorldObject("mounting surface", "plane", pose)


def _posed(vertices: np.ndarray, pose: np.ndarray) -> np.ndarray:
    return vertices @ pose[:3, :3].T + pose[:3, 3]


def build_obstacle(entry: Mapping[str, Any], index: int) -> WorldObject:
    """A world object from a config entry (module docstring); errors name the entry and the key."""
    import coal

    from lwrlab.model.collision_geometry import box_mesh, enclosing_mesh, prism_mesh, sphere_mesh
    from lwrlab.model.enclosing_spheres import enclosing_spheres

    where = f"trajectory.constraints.world.obstacles[{index}]"
    name = str(entry.get("name", f"obstacle {index}"))
    shape = entry.get("shape")
    if shape not in SHAPES or shape == "plane":
        raise ValueError(f"{where} ({name}): shape must be one of box, sphere, cylinder, mesh, got {shape!r}")
    unknown = set(entry) - {"name", "shape", "size", "radius", "length", "path", "scale", "xyz", "rpy"}
    if unknown:
        raise ValueError(f"{where} ({name}): unknown keys {sorted(unknown)}")
    pose = pose_from(entry.get("xyz"), entry.get("rpy"))

    def positive(key: str, count: int) -> np.ndarray:
        if key not in entry:
            raise ValueError(f"{where} ({name}): a {shape} needs `{key}`")
        values = np.asarray(entry[key], dtype=float).ravel()
        if values.shape != (count,) or not np.all(values > 0):
            raise ValueError(f"{where} ({name}): `{key}` needs {count} positive value(s), got {entry[key]}")
        return values

    if shape == "box":
        half = positive("size", 3) / 2
        vertices, faces = box_mesh(half)
        return WorldObject(name, "box", pose, half, coal.Box(*(2 * half)), _posed(vertices, pose), faces)
    if shape == "sphere":
        (radius,) = positive("radius", 1)
        vertices, faces = sphere_mesh(radius)
        return WorldObject(
            name, "sphere", pose, np.array([radius]), coal.Sphere(radius), _posed(vertices, pose), faces
        )
    if shape == "cylinder":
        (radius,), (length,) = positive("radius", 1), positive("length", 1)
        vertices, faces = prism_mesh(radius, length / 2)
        return WorldObject(
            name, "cylinder", pose, np.array([radius, length / 2]), coal.Cylinder(radius, length),
            _posed(vertices, pose), faces,
        )  # fmt: skip
    path = Path(str(entry.get("path", "")))
    if not path.is_file():
        raise ValueError(f"{where} ({name}): mesh file {path} does not exist")
    scale = np.asarray(entry.get("scale", (1.0, 1.0, 1.0)), dtype=float)
    loader = coal.MeshLoader()
    geometry = loader.load(str(path), scale)
    vertices, faces, _ = enclosing_mesh(geometry, str(path))
    posed = _posed(vertices, pose)
    return WorldObject(
        name, "mesh", pose, np.zeros(0), geometry, posed, faces, enclosing_spheres(posed, faces)
    )


def build_world(
    mounting: Mapping[str, Any] | None, obstacles: Sequence[Mapping[str, Any]] | None
) -> tuple[WorldObject, ...]:
    """The mounting surface (unless None) and the obstacles of the config."""
    world = []
    if mounting is not None:
        unknown = set(mounting) - {"height", "normal"}
        if unknown:
            raise ValueError(f"trajectory.constraints.world.mounting_surface: unknown keys {sorted(unknown)}")
        world.append(mounting_surface(float(mounting.get("height", 0.0)), mounting.get("normal", (0, 0, 1))))
    world += [build_obstacle(entry, i) for i, entry in enumerate(obstacles or ())]
    names = [w.name for w in world]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ValueError(f"trajectory.constraints.world: object names must be unique, repeated: {repeated}")
    return tuple(world)
