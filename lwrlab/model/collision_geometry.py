"""A robot's collision geometry from its URDF: the ``<collision>`` meshes and primitives, and its SRDF.

The URDF's ``<collision>`` elements become coal geometries (through Pinocchio's geometry parser) fixed
to the robot's joints: each element keeps the URDF link it belongs to (the unit of an SRDF and of the
collision pairs) and its placement in the frame of the joint that moves it (joint 0: the fixed base,
so the base link and any fixed link such as a table or a stand are *world*). Continuous joints are
read as revolute ones, one angle, as the robot's model reads them (:mod:`lwrlab.model.urdf_description`).

Mesh file names resolve as ROS resolves them:

* ``package://NAME/rest`` — ``DIR/NAME/rest`` for the first ``DIR`` among ``package_dirs``, then the
  folders of ``ROS_PACKAGE_PATH``, then the ``share`` folder of packages installed by pip as cmeel
  wheels (``example-robot-data``) that holds ``NAME/``;
* ``file:///abs/path`` and absolute paths as they are; relative paths from the URDF's folder.

A mesh that cannot be found stops the load with one error naming every missing file, the link and the
folders searched (``missing_meshes="drop"`` drops those elements instead, with a warning).

Every element also gets a triangle mesh that *contains* it (the mesh itself, a box's 12 triangles, a
prism around a cylinder or capsule, a polyhedron around a sphere): what the enclosing spheres
(:mod:`lwrlab.model.enclosing_spheres`), the mounting-surface check and the preview figure use.
"""

from __future__ import annotations

import logging
import os
import sys
import xml.etree.ElementTree as ElementTree
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pinocchio as pin

from lwrlab.errors import UserError
from lwrlab.model.urdf_description import (
    check_srdf_names,
    description_names,
    reduced_model,
    revolute_for_continuous,
)

log = logging.getLogger(__name__)

ROUND_SEGMENTS = 24
"""Sides of the prisms and polyhedra that enclose round primitives (cylinder, capsule, sphere)."""


class CollisionGeometryError(UserError, ValueError):
    """The collision geometry of a robot description cannot be loaded; the message says why."""


@dataclass(frozen=True)
class CollisionSource:
    """Where a robot's collision geometry comes from.

    Parameters
    ----------
    urdf : the URDF whose ``<collision>`` elements are read.
    package_dirs : folders holding ROS packages (``DIR/NAME/…`` for ``package://NAME/…``), searched
        before ``ROS_PACKAGE_PATH``.
    srdf : a MoveIt SRDF whose ``disable_collisions`` pairs are never checked, or None.
    missing_meshes : ``error`` (default) stops on a mesh that cannot be found; ``drop`` leaves such
        elements out with a warning (the motion is then not checked against them).
    """

    urdf: Path | str
    """The URDF file, or ``package://NAME/…`` resolved as mesh names are."""
    package_dirs: tuple[Path, ...] = ()
    srdf: Path | str | None = None
    missing_meshes: Literal["error", "drop"] = "error"
    locked_joints: tuple[tuple[str, float], ...] = ()
    """URDF joints merged into their parent at these positions (as the robot's model merged them)."""


@dataclass(frozen=True)
class CollisionShape:
    """One ``<collision>`` element, fixed to a joint of the robot."""

    name: str
    link: str
    """URDF link it belongs to."""
    joint: int
    """Robot joint whose motion moves it (1 … N_J), 0 for the fixed base (world)."""
    placement: np.ndarray
    """(4, 4) pose in the joint's frame (m)."""
    geometry: Any
    """The coal collision geometry (mesh or primitive), for the exact check."""
    vertices: np.ndarray
    """(V, 3) vertices (m, shape frame) of a triangle mesh containing the shape."""
    faces: np.ndarray
    """(F, 3) vertex indices of its triangles."""
    sphere_radius: float | None = None
    """The radius (m) when the shape is a sphere (centred on its frame), else None."""

    def vertices_in_joint_frame(self) -> np.ndarray:
        """(V, 3) vertices of the enclosing mesh in the joint's frame (m)."""
        return self.vertices @ self.placement[:3, :3].T + self.placement[:3, 3]


@dataclass(frozen=True)
class RobotGeometry:
    """The collision shapes of a robot and what its SRDF says never to check."""

    shapes: tuple[CollisionShape, ...]
    disabled_pairs: frozenset[frozenset[str]] = field(default_factory=frozenset)
    """Link pairs the SRDF disables (``disable_collisions``)."""
    source: str = ""
    """Where the geometry came from (for reports)."""
    joint_names: tuple[str, ...] = ()
    """The URDF's names of the robot's joints, in the robot's order (what its controller calls them)."""

    @property
    def links(self) -> tuple[str, ...]:
        """Links with geometry, in the order of their first shape."""
        return tuple(dict.fromkeys(s.link for s in self.shapes))

    def link_joint(self, link: str) -> int:
        """The joint that moves ``link`` (0: the base)."""
        return next(s.joint for s in self.shapes if s.link == link)

    def shapes_of(self, link: str) -> tuple[CollisionShape, ...]:
        return tuple(s for s in self.shapes if s.link == link)


# --- package resolution ----------------------------------------------------------------------------


def package_search_path(package_dirs: Sequence[str | Path] = ()) -> list[Path]:
    """Folders searched for ``package://NAME/…``: ``package_dirs``, ``ROS_PACKAGE_PATH``, cmeel shares."""
    folders = [Path(d).expanduser() for d in package_dirs]
    folders += [Path(d) for d in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if d]
    for entry in sys.path:  # pip-installed ROS data (cmeel wheels such as example-robot-data)
        share = Path(entry) / "cmeel.prefix" / "share"
        if share.is_dir() and share not in folders:
            folders.append(share)
    return folders


def _package_folder(name: str, folders: Sequence[Path]) -> Path | None:
    for folder in folders:
        if (folder / name).is_dir():
            return folder / name
        if folder.name == name and folder.is_dir():  # ROS_PACKAGE_PATH may name the package itself
            return folder
    return None


def resolve_mesh(uri: str, urdf_dir: Path, folders: Sequence[Path]) -> Path | None:
    """The file a URDF mesh name refers to, or None if it does not exist."""
    if uri.startswith("package://"):
        name, _, rest = uri[len("package://") :].partition("/")
        package = _package_folder(name, folders)
        path = None if package is None else package / rest
    elif uri.startswith("file://"):
        path = Path(uri[len("file://") :])
    else:
        path = Path(uri) if Path(uri).is_absolute() else urdf_dir / uri
    return path if path is not None and path.is_file() else None


def urdf_path(source: CollisionSource) -> Path:
    """The URDF file of ``source`` (a ``package://`` name resolved); CollisionGeometryError if absent."""
    folders = package_search_path(source.package_dirs)
    name = str(source.urdf)
    path = resolve_mesh(name, Path.cwd(), folders)
    if path is None:
        searched = ", ".join(str(f) for f in folders) or "none"
        raise CollisionGeometryError(
            f"collision URDF {name} not found (folders searched for package://NAME/…: {searched})"
        )
    return path


def _resolved_urdf(source: CollisionSource) -> tuple[str, tuple[str, ...], tuple[str, ...]]:
    """The URDF text with every collision mesh made an absolute path (missing meshes raise or drop) and
    its continuous joints made revolute, as the robot's model reads them; and the names of its links
    and joints."""
    urdf = urdf_path(source)
    try:
        tree = ElementTree.parse(urdf)
    except (ElementTree.ParseError, OSError) as error:
        raise CollisionGeometryError(f"{urdf}: cannot read the URDF ({error})") from error
    revolute_for_continuous(tree.getroot())
    links, joints = description_names(tree.getroot())
    folders = package_search_path(source.package_dirs)
    missing = []
    for link in tree.getroot().iter("link"):
        for collision in list(link.findall("collision")):
            mesh = collision.find("geometry/mesh")
            if mesh is None:
                continue
            uri = mesh.get("filename", "")
            path = resolve_mesh(uri, urdf.parent, folders)
            if path is None:
                missing.append(f"{uri} (link {link.get('name')})")
                if source.missing_meshes == "drop":
                    link.remove(collision)
            else:
                mesh.set("filename", str(path.resolve()))
    if missing and source.missing_meshes != "drop":
        searched = ", ".join(str(f) for f in folders) or "none"
        raise CollisionGeometryError(
            f"{urdf}: collision mesh(es) not found: {'; '.join(missing)}. Folders searched for "
            f"package://NAME/…: {searched}. Add the folder holding NAME/ to robot.package_dirs or "
            "ROS_PACKAGE_PATH, or set robot.missing_meshes=drop to leave these elements out"
        )
    if missing:
        log.warning(
            "%s: collision mesh(es) not found and left out (missing_meshes=drop): %s; "
            "the motion is not checked against them",
            urdf,
            "; ".join(missing),
        )
    return ElementTree.tostring(tree.getroot(), encoding="unicode"), links, joints


def disabled_pairs_from_srdf(srdf: Path) -> frozenset[frozenset[str]]:
    """The link pairs of an SRDF's ``disable_collisions`` elements."""
    try:
        root = ElementTree.parse(srdf).getroot()
    except (ElementTree.ParseError, OSError) as error:
        raise CollisionGeometryError(f"{srdf}: cannot read the SRDF ({error})") from error
    return frozenset(
        frozenset((element.get("link1", ""), element.get("link2", "")))
        for element in root.iter("disable_collisions")
    )


# --- meshes that contain each primitive ------------------------------------------------------------


def box_mesh(half: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The box of half extents ``half`` (m, centred): its 8 corners and 12 triangles (exact)."""
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float) * half
    faces = np.array(
        [
            [0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
            [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3],
        ]
    )  # fmt: skip
    return corners, faces


def prism_mesh(radius: float, half_length: float, n: int = ROUND_SEGMENTS) -> tuple[np.ndarray, np.ndarray]:
    """A prism along z containing the cylinder of this radius and half length (circumscribed polygon)."""
    angle = 2 * np.pi * np.arange(n) / n
    ring = radius / np.cos(np.pi / n) * np.column_stack([np.cos(angle), np.sin(angle)])
    vertices = np.vstack(
        [np.column_stack([ring, np.full(n, -half_length)]), np.column_stack([ring, np.full(n, half_length)])]
    )
    i = np.arange(n)
    j = (i + 1) % n
    sides = np.vstack([np.column_stack([i, j, j + n]), np.column_stack([i, j + n, i + n])])
    inner = i[1:-1]  # fans over the two caps
    bottom = np.column_stack([np.zeros(n - 2, int), inner + 1, inner])
    top = np.column_stack([np.full(n - 2, n), inner + n, inner + n + 1])
    caps = np.vstack([bottom, top])
    return vertices, np.vstack([sides, caps])


def sphere_mesh(radius: float, n: int = ROUND_SEGMENTS) -> tuple[np.ndarray, np.ndarray]:
    """A convex polyhedron containing the sphere: a UV sphere scaled until its faces clear the radius."""
    from scipy.spatial import ConvexHull

    rows = n // 2
    polar = np.pi * np.arange(1, rows) / rows
    azimuth = 2 * np.pi * np.arange(n) / n
    p, a = np.meshgrid(polar, azimuth, indexing="ij")
    points = np.column_stack(
        [np.sin(p).ravel() * np.cos(a).ravel(), np.sin(p).ravel() * np.sin(a).ravel(), np.cos(p).ravel()]
    )
    points = np.vstack([points, [[0, 0, 1], [0, 0, -1]]])
    hull = ConvexHull(points)
    inradius = float(np.min(-hull.equations[:, 3]))  # distance from the centre to the nearest face
    return points * radius / inradius, hull.simplices


def enclosing_mesh(geometry: Any, mesh_path: str) -> tuple[np.ndarray, np.ndarray, float | None]:
    """Vertices, faces of a mesh containing a coal geometry, and the radius if it is a sphere."""
    kind = type(geometry).__name__
    if kind == "Box":
        return (*box_mesh(np.asarray(geometry.halfSide, dtype=float)), None)
    if kind == "Cylinder":
        return (*prism_mesh(float(geometry.radius), float(geometry.halfLength)), None)
    if kind == "Capsule":
        r = float(geometry.radius)
        return (*prism_mesh(r, float(geometry.halfLength) + r), None)
    if kind == "Sphere":
        return (*sphere_mesh(float(geometry.radius)), float(geometry.radius))
    if kind.startswith("BVHModel") or kind.startswith("Convex"):
        vertices = np.asarray(geometry.vertices(), dtype=float).reshape(-1, 3)
        count = geometry.num_tris if kind.startswith("BVHModel") else geometry.num_polygons
        triangle = geometry.tri_indices if kind.startswith("BVHModel") else geometry.polygons
        faces = np.array([[triangle(i)[k] for k in range(3)] for i in range(count)], dtype=int).reshape(-1, 3)
        return vertices, faces, None
    raise CollisionGeometryError(f"collision geometry {kind} ({mesh_path}) is not supported")


# --- loading ---------------------------------------------------------------------------------------


def _joint_map(urdf_model: pin.Model, robot_model: pin.Model, urdf: Path) -> dict[int, int]:
    """URDF joint index → robot joint index: by name, else by order (for a robot built another way,
    e.g. a modified-DH table with the same frames)."""
    urdf_names, robot_names = list(urdf_model.names), list(robot_model.names)
    if set(robot_names[1:]) <= set(urdf_names[1:]):
        return {urdf_names.index(n): robot_names.index(n) for n in robot_names} | {0: 0}
    if urdf_model.njoints == robot_model.njoints:
        return {j: j for j in range(urdf_model.njoints)}
    raise CollisionGeometryError(
        f"{urdf}: its joints {urdf_names[1:]} do not match the robot's {robot_names[1:]} "
        "(by name, or in number and order)"
    )


def _check_same_frames(
    urdf_model: pin.Model, robot_model: pin.Model, joints: dict[int, int], urdf: Path
) -> None:
    """The URDF's joint frames must be the robot's, else its geometry would sit in the wrong place."""
    rng = np.random.default_rng(0)
    urdf_data, robot_data = urdf_model.createData(), robot_model.createData()
    lower, upper = robot_model.lowerPositionLimit, robot_model.upperPositionLimit
    for _ in range(5):
        q = rng.uniform(np.maximum(lower, -np.pi), np.minimum(upper, np.pi))
        q_urdf = pin.neutral(urdf_model)
        for u, r in joints.items():
            if u and r:
                q_urdf[urdf_model.joints[u].idx_q] = q[robot_model.joints[r].idx_q]
        pin.forwardKinematics(urdf_model, urdf_data, q_urdf)
        pin.forwardKinematics(robot_model, robot_data, q)
        for u, r in joints.items():
            gap = np.abs(urdf_data.oMi[u].homogeneous - robot_data.oMi[r].homogeneous).max()
            if gap > 1e-6:
                raise CollisionGeometryError(
                    f"{urdf}: joint {urdf_model.names[u]!r} is not where the robot's joint "
                    f"{robot_model.names[r]!r} is (frames differ by {gap:.3g}): its geometry cannot be used"
                )


def load_robot_geometry(source: CollisionSource, robot_model: pin.Model) -> RobotGeometry:
    """The collision shapes of ``source`` fixed to the joints of ``robot_model``."""
    locked_joints = dict(source.locked_joints)
    text, urdf_links, urdf_joints = _resolved_urdf(source)
    urdf = urdf_path(source)
    try:
        urdf_model = pin.buildModelFromXML(text)
        geometry_model = pin.buildGeomFromUrdfString(urdf_model, text, pin.GeometryType.COLLISION)
    except (ValueError, RuntimeError) as error:
        raise CollisionGeometryError(
            f"{source.urdf}: Pinocchio could not read its collision geometry ({error})"
        ) from error
    if locked_joints:
        q_reference = pin.neutral(urdf_model)
        ids = []
        for name, position in locked_joints.items():
            joint_id = urdf_model.getJointId(name)
            q_reference[urdf_model.joints[joint_id].idx_q] = position
            ids.append(joint_id)
        urdf_model, reduced_geometry = reduced_model(urdf_model, ids, q_reference, geometry_model)
        assert reduced_geometry is not None
        geometry_model = reduced_geometry
    joints = _joint_map(urdf_model, robot_model, urdf)
    _check_same_frames(urdf_model, robot_model, joints, urdf)
    shapes = []
    for obj in geometry_model.geometryObjects:
        vertices, faces, radius = enclosing_mesh(obj.geometry, obj.meshPath)
        shapes.append(
            CollisionShape(
                name=obj.name,
                link=urdf_model.frames[obj.parentFrame].name,
                joint=joints[obj.parentJoint],
                placement=obj.placement.homogeneous.copy(),
                geometry=obj.geometry,
                vertices=vertices,
                faces=faces,
                sphere_radius=radius,
            )
        )
    if not shapes:
        raise CollisionGeometryError(f"{urdf} has no <collision> geometry")
    srdf = None
    if source.srdf is not None:
        srdf = resolve_mesh(str(source.srdf), urdf.parent, package_search_path(source.package_dirs))
        if srdf is None:
            raise CollisionGeometryError(f"SRDF {source.srdf} not found")
        check_srdf_names(srdf, urdf, urdf_links, urdf_joints, "the collision SRDF")
    disabled = disabled_pairs_from_srdf(srdf) if srdf is not None else frozenset()
    described = f"{urdf}" + (f" + {srdf}" if srdf is not None else "")
    urdf_names = {r: str(urdf_model.names[u]) for u, r in joints.items() if r}
    names = tuple(urdf_names[j] for j in range(1, robot_model.njoints))
    return RobotGeometry(tuple(shapes), disabled, described, names)
