"""The robot's collision geometry: tree kinematics, meshes that contain primitives, enclosing spheres,
world objects, ``package://`` resolution, SRDF pairs and the pairs a scene checks.

Physics is checked against Pinocchio (poses, Jacobians) and coal (distances), and containment by
sampling points on the surfaces that must be contained.
"""

from __future__ import annotations

import logging
import sys
import xml.etree.ElementTree as ElementTree
from dataclasses import replace
from itertools import combinations
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial import ConvexHull, cKDTree

from lwrlab.excitation.collision_scene import build_scene
from lwrlab.kinematics.tree import joint_axes, joint_poses, point_jacobian, point_jacobians
from lwrlab.model.collision_geometry import (
    CollisionGeometryError,
    CollisionSource,
    box_mesh,
    disabled_pairs_from_srdf,
    load_robot_geometry,
    package_search_path,
    prism_mesh,
    resolve_mesh,
    sphere_mesh,
)
from lwrlab.model.enclosing_spheres import bisect_long_triangles, enclosing_spheres, smallest_ball
from lwrlab.model.world import build_obstacle, build_world, mounting_surface
from lwrlab.pipeline.build import build

REPOSITORY = Path(__file__).resolve().parents[1]
KUKA_HW = REPOSITORY.parent / "shared" / "data" / "kuka_lwr4_hw"


def _robot_data() -> Path | None:
    """example-robot-data's ``robots`` folder (the test extra), wherever pip installed it."""
    shares = [*package_search_path(), *Path(sys.prefix).glob("lib/python*/site-packages/cmeel.prefix/share")]
    return next(
        (
            s / "example-robot-data" / "robots"
            for s in shares
            if (s / "example-robot-data" / "robots").is_dir()
        ),
        None,
    )


ROBOTS = _robot_data()
needs_robot_data = pytest.mark.skipif(
    ROBOTS is None, reason="example-robot-data (test extra) is not installed: no real robot descriptions"
)
needs_kuka = pytest.mark.skipif(
    not (KUKA_HW / "kuka_lwr4.urdf").is_file(), reason=f"the real KUKA URDF is absent ({KUKA_HW})"
)


def ur10_urdf() -> Path:
    assert ROBOTS is not None
    return ROBOTS / "ur_description" / "urdf" / "ur10_robot.urdf"


def panda_urdf() -> Path:
    assert ROBOTS is not None
    return ROBOTS / "panda_description" / "urdf" / "panda.urdf"


def panda_srdf() -> Path:
    assert ROBOTS is not None
    return ROBOTS / "panda_description" / "srdf" / "panda.srdf"


PANDA_FINGERS = ["panda_finger_joint1", "panda_finger_joint2"]


def sample_on_triangles(
    vertices: np.ndarray, faces: np.ndarray, n: int, rng: np.random.Generator
) -> np.ndarray:
    """n points uniform on random triangles (barycentric), plus every vertex and edge middle."""
    corners = vertices[faces]  # (F, 3, 3)
    chosen = corners[rng.integers(len(faces), size=n)]
    u, v = rng.random(n), rng.random(n)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    inside = (
        chosen[:, 0] + u[:, None] * (chosen[:, 1] - chosen[:, 0]) + v[:, None] * (chosen[:, 2] - chosen[:, 0])
    )
    middles = 0.5 * (corners + corners[:, [1, 2, 0]])
    return np.vstack([inside, vertices[np.unique(faces)], middles.reshape(-1, 3)])


def uncovered(points: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Points inside none of the spheres (with 1e-12 m of rounding)."""
    gap = np.linalg.norm(points[:, None, :] - centres[None], axis=2) - radii[None]
    return points[gap.min(axis=1) > 1e-12]


def outside_hull(points: np.ndarray, vertices: np.ndarray, tolerance: float = 1e-12) -> np.ndarray:
    """Points outside the convex hull of ``vertices``."""
    equations = ConvexHull(vertices).equations  # outward normal · x + offset ≤ 0 inside
    return points[(points @ equations[:, :3].T + equations[:, 3]).max(axis=1) > tolerance]


def assert_closed(faces: np.ndarray) -> None:
    """Every edge of the mesh is shared by exactly two triangles (a closed surface, no holes)."""
    edges = np.sort(np.vstack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2), f"edges used {sorted(set(counts.tolist()))} times"


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    return pin.Quaternion(*rng.normal(size=4)).normalized().matrix()


# --- tree kinematics ------------------------------------------------------------------------------


def branching_tree() -> pin.Model:
    """A fixed-base tree with two branches and every joint kind the batched kinematics handles:
    aligned and unaligned revolute and prismatic joints."""
    rng = np.random.default_rng(3)
    model = pin.Model()

    def placement() -> pin.SE3:
        return pin.SE3(random_rotation(rng), rng.normal(scale=0.3, size=3))

    def unit(v: list[float]) -> np.ndarray:
        return np.asarray(v, dtype=float) / np.linalg.norm(v)

    j1 = model.addJoint(0, pin.JointModelRZ(), placement(), "rz")
    j2 = model.addJoint(
        j1, pin.JointModelRevoluteUnaligned(unit([1.0, 2.0, -0.5])), placement(), "r_unaligned"
    )
    j3 = model.addJoint(
        j1, pin.JointModelPrismaticUnaligned(unit([-0.3, 0.4, 1.0])), placement(), "p_unaligned"
    )
    j4 = model.addJoint(j2, pin.JointModelPY(), placement(), "py")
    model.addJoint(j3, pin.JointModelRX(), placement(), "rx")
    model.addJoint(j4, pin.JointModelRY(), placement(), "ry")
    model.addJoint(j2, pin.JointModelPX(), placement(), "px")
    return model


def kinematic_models() -> list:
    models = [
        pytest.param(pin.buildSampleModelManipulator, id="sample-manipulator"),
        pytest.param(branching_tree, id="branching-tree"),
    ]
    if ROBOTS is not None:
        models += [
            pytest.param(lambda: pin.buildModelFromUrdf(str(ur10_urdf())), id="ur10"),
            pytest.param(lambda: pin.buildModelFromUrdf(str(panda_urdf())), id="panda-with-fingers"),
        ]
    return models


def random_q(model: pin.Model, n: int, rng: np.random.Generator) -> np.ndarray:
    low = np.maximum(model.lowerPositionLimit, -np.pi)
    high = np.minimum(model.upperPositionLimit, np.pi)
    low, high = np.where(low < high, low, -1.0), np.where(low < high, high, 1.0)  # a built model: no limits
    return rng.uniform(low, high, size=(n, model.nq))


@pytest.mark.parametrize("make_model", kinematic_models())
def test_joint_poses_equal_pinocchio_forward_kinematics(make_model) -> None:
    model = make_model()
    assert model.nq == model.nv == model.njoints - 1
    q = random_q(model, 6, np.random.default_rng(0))
    poses = joint_poses(model, q)
    assert poses.shape == (model.njoints - 1, len(q), 4, 4)
    data = model.createData()
    for k in range(len(q)):
        pin.forwardKinematics(model, data, q[k])
        expected = np.array([data.oMi[j].homogeneous for j in range(1, model.njoints)])
        np.testing.assert_allclose(poses[:, k], expected, atol=1e-12)


def test_joint_axes_read_each_joint_kind() -> None:
    axes = joint_axes(branching_tree())
    assert [a.revolute for a in axes] == [True, True, False, False, True, True, False]
    np.testing.assert_allclose(axes[1].axis, np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5]))
    np.testing.assert_allclose(axes[3].axis, [0.0, 1.0, 0.0])


def test_joint_axes_refuse_a_spherical_joint_naming_it() -> None:
    model = pin.Model()
    model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "turn")
    model.addJoint(1, pin.JointModelSpherical(), pin.SE3.Identity(), "ball_joint")
    with pytest.raises(ValueError, match=r"'ball_joint'.*revolute and prismatic"):
        joint_axes(model)


@pytest.mark.parametrize("make_model", kinematic_models())
def test_point_jacobians_equal_pinocchio_and_finite_differences(make_model) -> None:
    model = make_model()
    rng = np.random.default_rng(1)
    data = model.createData()
    n_points = 5
    q = random_q(model, n_points, rng)
    poses = joint_poses(model, q)
    bodies = rng.integers(0, model.njoints, size=n_points)
    bodies[:2] = [model.njoints - 1, 0]  # the last body and the base itself
    local = rng.normal(scale=0.2, size=(n_points, 3))

    def point_at(q_k: np.ndarray, body: int, p_local: np.ndarray) -> np.ndarray:
        if body == 0:
            return p_local
        pose = joint_poses(model, q_k[None])[body - 1, 0]
        return pose[:3, :3] @ p_local + pose[:3, 3]

    points = np.array([point_at(q[k], int(bodies[k]), local[k]) for k in range(n_points)])
    batched = point_jacobians(model, poses, bodies, points)
    h = 1e-6
    for k in range(n_points):
        body = int(bodies[k])
        single = point_jacobian(model, poses[:, k : k + 1], body, points[k : k + 1])[0]
        np.testing.assert_allclose(batched[k], single, atol=1e-14)
        # Pinocchio: v_p = v_o + ω × (p − o) with the joint Jacobian in LOCAL_WORLD_ALIGNED
        pin.computeJointJacobians(model, data, q[k])
        if body == 0:
            expected = np.zeros((3, model.nv))
        else:
            jac = pin.getJointJacobian(model, data, body, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
            lever = points[k] - data.oMi[body].translation
            expected = jac[:3] - pin.skew(lever) @ jac[3:]
        np.testing.assert_allclose(single, expected, atol=1e-12)
        numeric = np.column_stack(
            [
                (point_at(q[k] + h * e, body, local[k]) - point_at(q[k] - h * e, body, local[k])) / (2 * h)
                for e in np.eye(model.nq)
            ]
        )
        np.testing.assert_allclose(single, numeric, atol=1e-8)
    assert np.abs(batched[1]).max() == 0.0  # a point on the base does not move
    assert np.abs(batched[0]).max() > 0.1


# --- enclosing spheres ----------------------------------------------------------------------------


def link_meshes(urdf: Path, locked: tuple[tuple[str, float], ...] = ()) -> list:
    model = pin.buildModelFromUrdf(str(urdf))
    if locked:
        ids = [model.getJointId(name) for name, _ in locked]
        model = pin.buildReducedModel(model, ids, pin.neutral(model))
    geometry = load_robot_geometry(CollisionSource(urdf, locked_joints=locked), model)
    return [(s.link, s.vertices, s.faces) for s in geometry.shapes if s.geometry.__class__.__name__ != "Box"]


def real_meshes() -> list:
    if ROBOTS is None:
        return [pytest.param(None, marks=needs_robot_data, id="example-robot-data-absent")]
    return [
        *(pytest.param(m, id=f"ur10-{m[0]}") for m in link_meshes(ur10_urdf())),
        *(
            pytest.param(m, id=f"panda-{m[0]}")
            for m in link_meshes(panda_urdf(), tuple((f, 0.0) for f in PANDA_FINGERS))
        ),
    ]


@pytest.mark.parametrize("mesh", real_meshes())
def test_enclosing_spheres_contain_every_triangle_of_real_link_meshes(mesh) -> None:
    link, vertices, faces = mesh
    assert len(faces) > 100, f"{link}: expected a real mesh"
    centres, radii = enclosing_spheres(vertices, faces)
    points = sample_on_triangles(vertices, faces, 20_000, np.random.default_rng(2))
    missed = uncovered(points, centres, radii)
    assert len(missed) == 0, f"{link}: {len(missed)} surface points outside every sphere, e.g. {missed[:3]}"
    # not absurdly loose: every sphere is smaller than the ball around the mesh's bounding box, and a
    # slender link is cut into several
    extents = np.ptp(vertices, axis=0)
    assert radii.max() < 0.5 * np.linalg.norm(extents), f"{link}: a sphere larger than the whole link"
    if extents.max() > 3 * np.median(extents):
        assert radii.max() < 0.3 * extents.max()
        assert len(radii) >= 4


@pytest.mark.parametrize(
    "primitive",
    [
        pytest.param(lambda: box_mesh(np.array([0.4, 0.05, 0.01])), id="flat-box"),
        pytest.param(lambda: box_mesh(np.array([0.01, 0.01, 0.01])), id="cube"),
        pytest.param(lambda: prism_mesh(0.07, 0.104), id="cylinder"),
        pytest.param(lambda: prism_mesh(0.02, 0.5), id="long-cylinder"),
        pytest.param(lambda: sphere_mesh(0.07), id="sphere"),
    ],
)
def test_enclosing_spheres_contain_the_meshes_of_primitives(primitive) -> None:
    vertices, faces = primitive()
    rng = np.random.default_rng(4)
    for n_spheres in (None, 1, 3):
        centres, radii = enclosing_spheres(vertices, faces, n_spheres=n_spheres)
        if n_spheres is not None:
            assert len(radii) <= n_spheres
        points = sample_on_triangles(vertices, faces, 5000, rng)
        missed = uncovered(points, centres, radii)
        assert len(missed) == 0, f"{n_spheres} spheres: {len(missed)} points outside, e.g. {missed[:3]}"
        assert radii.max() <= 0.5 * np.linalg.norm(np.ptp(vertices, axis=0)) * (1 + 1e-9)


def test_bisect_long_triangles_keeps_the_surface() -> None:
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 2, 0], [0, 0, 3]], dtype=float)
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])

    def areas(v: np.ndarray, f: np.ndarray) -> np.ndarray:
        return 0.5 * np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])

    new_vertices, new_faces = bisect_long_triangles(vertices, faces, 0.3)
    assert len(new_faces) > 50
    edges = np.linalg.norm(new_vertices[new_faces] - new_vertices[new_faces][:, [1, 2, 0]], axis=2)
    assert edges.max() <= 0.3
    # every piece lies in the plane of an original face, with that face's orientation, and the
    # pieces of each face add up to it
    normals = areas(vertices, faces)
    pieces = areas(new_vertices, new_faces)
    unit = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    parent = np.argmax(pieces @ unit.T, axis=1)
    np.testing.assert_allclose(np.cross(pieces, unit[parent]), 0.0, atol=1e-12)
    offsets = np.einsum("ij,ij->i", unit, vertices[faces[:, 0]])
    heights = np.einsum("fkj,fj->fk", new_vertices[new_faces], unit[parent]) - offsets[parent, None]
    np.testing.assert_allclose(heights, 0.0, atol=1e-12)
    for f in range(len(faces)):
        np.testing.assert_allclose(pieces[parent == f].sum(axis=0), normals[f], atol=1e-12)


def test_smallest_ball_contains_the_points_and_is_nearly_smallest() -> None:
    rng = np.random.default_rng(5)
    directions = rng.normal(size=(500, 3))
    on_sphere = 0.3 * directions / np.linalg.norm(directions, axis=1, keepdims=True) + [1.0, -2.0, 0.5]
    centre, radius = smallest_ball(on_sphere)
    assert np.linalg.norm(on_sphere - centre, axis=1).max() <= radius + 1e-15
    assert 0.3 * (1 - 1e-9) <= radius <= 0.3 * 1.01
    np.testing.assert_allclose(centre, [1.0, -2.0, 0.5], atol=0.3 * 0.15)
    flat = np.column_stack([rng.random((50, 2)), np.zeros(50)])  # coplanar: no 3-D hull
    centre, radius = smallest_ball(flat)
    assert np.linalg.norm(flat - centre, axis=1).max() <= radius + 1e-15


# --- meshes that contain primitives ---------------------------------------------------------------


def box_surface(half: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    points = rng.uniform(-half, half, size=(n, 3))
    axis = rng.integers(3, size=n)
    points[np.arange(n), axis] = half[axis] * rng.choice([-1.0, 1.0], size=n)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
    return np.vstack([points, corners])


def cylinder_surface(radius: float, half_length: float, n: int, rng: np.random.Generator) -> np.ndarray:
    angle = rng.uniform(0, 2 * np.pi, n)
    # the side, the rims (every angle, at both ends: where a prism is tightest) and the caps
    side = np.column_stack(
        [radius * np.cos(angle), radius * np.sin(angle), rng.uniform(-1, 1, n) * half_length]
    )
    rim = np.column_stack(
        [radius * np.cos(angle), radius * np.sin(angle), np.sign(rng.normal(size=n)) * half_length]
    )
    r = radius * np.sqrt(rng.random(n))
    cap = np.column_stack([r * np.cos(angle), r * np.sin(angle), np.sign(rng.normal(size=n)) * half_length])
    return np.vstack([side, rim, cap])


def sphere_surface(radius: float, n: int, rng: np.random.Generator) -> np.ndarray:
    d = rng.normal(size=(n, 3))
    axes = np.vstack([np.eye(3), -np.eye(3)])
    return radius * np.vstack([d / np.linalg.norm(d, axis=1, keepdims=True), axes])


def test_box_mesh_is_the_box() -> None:
    half = np.array([0.3, 0.1, 0.02])
    vertices, faces = box_mesh(half)
    assert_closed(faces)
    assert len(faces) == 12
    rng = np.random.default_rng(6)
    assert len(outside_hull(box_surface(half, 3000, rng), vertices)) == 0
    np.testing.assert_allclose(np.abs(vertices), np.broadcast_to(half, vertices.shape))
    # its triangles cover the box's six faces: total area
    area = 0.5 * np.linalg.norm(
        np.cross(*(vertices[faces[:, 1:]] - vertices[faces[:, :1]]).transpose(1, 0, 2)), axis=1
    )
    np.testing.assert_allclose(area.sum(), 8 * (half[0] * half[1] + half[1] * half[2] + half[0] * half[2]))


@pytest.mark.parametrize("segments", [8, 24])
def test_prism_mesh_contains_the_cylinder(segments: int) -> None:
    radius, half_length = 0.07, 0.15
    vertices, faces = prism_mesh(radius, half_length, segments)
    assert_closed(faces)
    surface = cylinder_surface(radius, half_length, 4000, np.random.default_rng(7))
    assert len(outside_hull(surface, vertices)) == 0
    # and not much more: the circumscribed polygon, the cylinder's length
    assert np.abs(vertices[:, 2]).max() == pytest.approx(half_length)
    assert np.linalg.norm(vertices[:, :2], axis=1).max() == pytest.approx(radius / np.cos(np.pi / segments))
    bigger = cylinder_surface(
        radius / np.cos(np.pi / segments) * 1.001, half_length, 4000, np.random.default_rng(8)
    )
    assert len(outside_hull(bigger, vertices)) > 0  # the check itself can fail


@pytest.mark.parametrize("segments", [8, 24])
def test_sphere_mesh_contains_the_sphere(segments: int) -> None:
    radius = 0.05
    vertices, faces = sphere_mesh(radius, segments)
    assert_closed(faces)
    assert len(outside_hull(sphere_surface(radius, 5000, np.random.default_rng(9)), vertices)) == 0
    inradius = -ConvexHull(vertices).equations[:, 3].max()
    assert inradius == pytest.approx(radius, rel=1e-9)  # tight: it touches the sphere
    assert np.linalg.norm(vertices, axis=1).max() < radius / np.cos(2 * np.pi / segments) ** 2


# --- world objects --------------------------------------------------------------------------------

OBSTACLES = [
    {
        "name": "table",
        "shape": "box",
        "size": [0.8, 0.4, 0.1],
        "xyz": [0.5, -0.2, 0.3],
        "rpy": [0.3, -0.2, 1.0],
    },
    {"name": "ball", "shape": "sphere", "radius": 0.15, "xyz": [-0.2, 0.4, 0.6]},
    {
        "name": "pillar",
        "shape": "cylinder",
        "radius": 0.1,
        "length": 0.9,
        "xyz": [0.1, 0.6, 0.4],
        "rpy": [1.1, 0.4, -0.7],
    },
]


def coal_signed_distance(geometry, pose: np.ndarray, points: np.ndarray) -> np.ndarray:
    """coal's signed distance of a point (a sphere of radius 0) to a geometry placed at ``pose``."""
    point = coal.Sphere(0.0)
    request = coal.DistanceRequest()
    request.enable_signed_distance = True
    placed = coal.Transform3s(pose[:3, :3].copy(), pose[:3, 3].copy())
    out = []
    for p in points:
        out.append(
            coal.distance(
                geometry, placed, point, coal.Transform3s(np.eye(3), p.copy()), request, coal.DistanceResult()
            )
        )
    return np.array(out)


def world_objects() -> list:
    plane = mounting_surface(0.25, (0.2, -0.1, 1.0))
    return [
        pytest.param(build_obstacle(entry, i), id=entry["shape"]) for i, entry in enumerate(OBSTACLES)
    ] + [pytest.param(plane, id="plane")]


@pytest.mark.parametrize("obj", world_objects())
def test_world_signed_distances_equal_coal_and_their_gradients_differences(obj) -> None:
    rng = np.random.default_rng(10)
    if obj.shape == "plane":
        half = np.full(3, 0.3)
    elif obj.shape == "cylinder":
        half = obj.size[[0, 0, 1]]
    else:
        half = np.broadcast_to(obj.size, 3)
    local = rng.uniform(-1.6 * half, 1.6 * half, size=(400, 3))  # a quarter of them inside or so
    points = local @ obj.pose[:3, :3].T + obj.pose[:3, 3]
    distance, gradient = obj.signed_distance(points)
    if obj.shape == "plane":
        normal, height = obj.pose[:3, 2], float(obj.pose[:3, 2] @ obj.pose[:3, 3])
        np.testing.assert_allclose(normal, np.array([0.2, -0.1, 1.0]) / np.linalg.norm([0.2, -0.1, 1.0]))
        assert height == pytest.approx(0.25)
        geometry, pose = coal.Halfspace(normal, height), np.eye(4)
    else:
        geometry, pose = obj.geometry, obj.pose
    reference = coal_signed_distance(geometry, pose, points)
    outside, inside = distance > 1e-6, distance < -1e-6
    assert outside.sum() > 50 and inside.sum() > 20
    np.testing.assert_allclose(distance[outside], reference[outside], atol=1e-7)
    assert np.all(reference[inside] < 0)
    if obj.shape != "cylinder":  # coal's penetration depth (EPA) is exact for flat faces and spheres
        np.testing.assert_allclose(distance[inside], reference[inside], atol=1e-6)
    # inside: the surface is |d| away along the gradient, and nothing of it nearer (coal's EPA cannot
    # tell for a cylinder: it returns the radial depth near a cap)
    depth = -distance[inside]
    surface = points[inside] + depth[:, None] * gradient[inside]
    beyond = coal_signed_distance(geometry, pose, surface + 1e-4 * gradient[inside])
    np.testing.assert_allclose(beyond, 1e-4, atol=1e-8)
    if obj.shape != "plane":
        sampler = {"box": box_surface, "sphere": lambda h, n, r: sphere_surface(h[0], n, r)}.get(
            obj.shape, lambda h, n, r: cylinder_surface(h[0], h[2], n, r)
        )
        samples = sampler(half, 200_000, rng) @ obj.pose[:3, :3].T + obj.pose[:3, 3]
        nearest = cKDTree(samples).query(points[inside])[0]
        assert np.all(depth <= nearest + 1e-12)
        assert np.all(depth >= nearest - 5e-3)
    np.testing.assert_allclose(np.linalg.norm(gradient, axis=1), 1.0, atol=1e-12)
    h = 1e-7
    numeric = np.column_stack(
        [
            (obj.signed_distance(points + h * e)[0] - obj.signed_distance(points - h * e)[0]) / (2 * h)
            for e in np.eye(3)
        ]
    )
    # away from the edges and medial surfaces where the distance has no gradient
    smooth = np.linalg.norm(numeric, axis=1) > 1 - 1e-6
    assert smooth.mean() > 0.9
    np.testing.assert_allclose(gradient[smooth], numeric[smooth], atol=1e-5)


def test_build_obstacle_gives_coal_geometry_of_the_configured_size() -> None:
    box, ball, pillar = (build_obstacle(entry, i) for i, entry in enumerate(OBSTACLES))
    np.testing.assert_allclose(box.geometry.halfSide, [0.4, 0.2, 0.05])
    np.testing.assert_allclose(box.pose[:3, :3], pin.rpy.rpyToMatrix(0.3, -0.2, 1.0))
    np.testing.assert_allclose(box.pose[:3, 3], [0.5, -0.2, 0.3])
    assert ball.geometry.radius == 0.15
    assert (pillar.geometry.radius, pillar.geometry.halfLength) == (0.1, 0.45)
    for obj in (box, ball, pillar):  # the figures' meshes are posed and contain the object
        local = (obj.vertices - obj.pose[:3, 3]) @ obj.pose[:3, :3]
        distance = obj.signed_distance(obj.vertices)[0]
        assert distance.min() >= -1e-12, obj.name
        assert np.linalg.norm(local, axis=1).max() < 1.0


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        (
            {"name": "pillar", "shape": "cylinder", "length": 1.0},
            r"obstacles\[1\] \(pillar\): a cylinder needs `radius`",
        ),
        (
            {"name": "pillar", "shape": "cylinder", "radius": -0.1, "length": 1.0},
            r"obstacles\[1\].*`radius` needs 1 positive",
        ),
        (
            {"name": "crate", "shape": "box", "size": [1.0, 2.0]},
            r"obstacles\[1\] \(crate\).*`size` needs 3 positive",
        ),
        (
            {"shape": "box", "size": [1, 1, 1], "colour": "red"},
            r"obstacles\[1\] \(obstacle 1\): unknown keys \['colour'\]",
        ),
        (
            {"name": "blob", "shape": "torus"},
            r"obstacles\[1\] \(blob\): shape must be one of box, sphere, cylinder, mesh, got 'torus'",
        ),
        (
            {"name": "wall", "shape": "plane"},
            r"obstacles\[1\] \(wall\): shape must be one of box, sphere, cylinder, mesh",
        ),
        (
            {"name": "fixture", "shape": "mesh", "path": "/nonexistent/fixture.stl"},
            r"obstacles\[1\] \(fixture\): mesh file /nonexistent/fixture.stl",
        ),
    ],
)
def test_build_world_errors_name_the_entry_the_key_and_the_shape(entry, message) -> None:
    good = {"name": "ball", "shape": "sphere", "radius": 0.1}
    with pytest.raises(ValueError, match=message):
        build_world({"height": 0.0}, [good, entry])


def test_build_world_refuses_repeated_names_and_a_zero_normal() -> None:
    ball = {"name": "ball", "shape": "sphere", "radius": 0.1}
    with pytest.raises(ValueError, match=r"unique, repeated: \['ball'\]"):
        build_world(None, [ball, ball])
    with pytest.raises(ValueError, match="non-zero 3-vector"):
        build_world({"normal": [0, 0, 0]}, [])
    with pytest.raises(ValueError, match=r"mounting_surface: unknown keys \['tilt'\]"):
        build_world({"tilt": 1.0}, [])
    world = build_world({"height": -0.1}, [ball])
    assert [w.name for w in world] == ["mounting surface", "ball"]
    assert world[0].signed_distance(np.array([[3.0, -2.0, 0.4]]))[0][0] == pytest.approx(0.5)


def test_mesh_obstacle_is_scaled_posed_and_covered_by_its_spheres(tmp_path: Path) -> None:
    stl = tmp_path / "fixture.stl"
    write_tetrahedron_stl(stl, TETRAHEDRON)
    entry = {
        "name": "fixture",
        "shape": "mesh",
        "path": str(stl),
        "scale": [2.0, 1.0, 0.5],
        "xyz": [0.3, 0.0, 0.1],
        "rpy": [0.0, 0.0, np.pi / 2],
    }
    (obj,) = build_world(None, [entry])
    pose = np.eye(4)
    pose[:3, :3] = pin.rpy.rpyToMatrix(0.0, 0.0, np.pi / 2)
    pose[:3, 3] = [0.3, 0.0, 0.1]
    expected = (TETRAHEDRON * [2.0, 1.0, 0.5]) @ pose[:3, :3].T + pose[:3, 3]
    np.testing.assert_allclose(
        np.unique(obj.vertices.round(12), axis=0), np.unique(expected.round(12), axis=0), atol=1e-6
    )
    assert obj.spheres is not None
    points = sample_on_triangles(obj.vertices, obj.faces, 3000, np.random.default_rng(11))
    assert len(uncovered(points, *obj.spheres)) == 0
    with pytest.raises(ValueError, match="a mesh has no signed distance"):
        obj.signed_distance(points[:1])


# --- package:// resolution ------------------------------------------------------------------------

TETRAHEDRON = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.1]])


def write_tetrahedron_stl(path: Path, vertices: np.ndarray) -> None:
    """An ASCII STL of the tetrahedron on these 4 vertices (outward facets)."""
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    lines = ["solid tetrahedron"]
    for face in faces:
        a, b, c = vertices[list(face)]
        normal = np.cross(b - a, c - a)
        lines += [f"facet normal {' '.join(map(str, normal / np.linalg.norm(normal)))}", " outer loop"]
        lines += [f"  vertex {' '.join(map(str, v))}" for v in (a, b, c)]
        lines += [" endloop", "endfacet"]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join([*lines, "endsolid tetrahedron", ""]))


def write_robot_urdf(path: Path, second_mesh: str = "package://my_robot/meshes/x.stl") -> None:
    """A two-joint robot: a box on the base, the package mesh on link 1, a mesh and a cylinder on link 2."""
    inertial = (
        '<inertial><mass value="1"/>'
        '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
    )
    limit = '<limit lower="-3" upper="3" effort="10" velocity="1"/>'
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(
        f"""<?xml version="1.0"?>
<robot name="my_robot">
  <link name="base">
    <collision><origin xyz="0 0 0.05"/><geometry><box size="0.2 0.2 0.1"/></geometry></collision>
  </link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="link1"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 0 1"/>{limit}</joint>
  <link name="link1">{inertial}
    <collision><origin xyz="0 0 0.2" rpy="0.1 0.2 0.3"/><geometry><mesh filename="package://my_robot/meshes/x.stl"/></geometry></collision>
  </link>
  <joint name="j2" type="revolute"><parent link="link1"/><child link="link2"/><origin xyz="0 0 0.4"/>
    <axis xyz="0 1 0"/>{limit}</joint>
  <link name="link2">{inertial}
    <collision><geometry><mesh filename="{second_mesh}"/></geometry></collision>
    <collision><origin xyz="0 0 0.15"/><geometry><cylinder radius="0.05" length="0.3"/></geometry></collision>
  </link>
</robot>
"""
    )


@pytest.fixture
def package_tree(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """tmp/pkgs/my_robot/{meshes/x.stl, urdf/robot.urdf}; no ROS_PACKAGE_PATH."""
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    write_tetrahedron_stl(tmp_path / "pkgs" / "my_robot" / "meshes" / "x.stl", TETRAHEDRON)
    write_robot_urdf(tmp_path / "pkgs" / "my_robot" / "urdf" / "robot.urdf")
    return tmp_path / "pkgs"


def robot_model(urdf: Path) -> pin.Model:
    return pin.buildModelFromUrdf(str(urdf))


def assert_tetrahedron_on_link1(geometry) -> None:
    (shape,) = geometry.shapes_of("link1")
    assert shape.joint == 1
    expected_placement = np.eye(4)
    expected_placement[:3, :3] = pin.rpy.rpyToMatrix(0.1, 0.2, 0.3)
    expected_placement[:3, 3] = [0, 0, 0.2]
    np.testing.assert_allclose(shape.placement, expected_placement, atol=1e-12)
    np.testing.assert_allclose(
        np.unique(shape.vertices.round(12), axis=0), np.unique(TETRAHEDRON, axis=0), atol=1e-7
    )
    assert len(shape.faces) == 4


def test_package_meshes_resolve_through_package_dirs(package_tree: Path) -> None:
    urdf = package_tree / "my_robot" / "urdf" / "robot.urdf"
    geometry = load_robot_geometry(CollisionSource(urdf, package_dirs=(package_tree,)), robot_model(urdf))
    assert geometry.links == ("base", "link1", "link2")
    assert_tetrahedron_on_link1(geometry)
    assert [s.joint for s in geometry.shapes_of("link2")] == [2, 2]
    base = geometry.shapes_of("base")[0]
    assert base.joint == 0
    np.testing.assert_allclose(np.ptp(base.vertices, axis=0), [0.2, 0.2, 0.1])
    cylinder = geometry.shapes_of("link2")[1]
    assert (
        len(outside_hull(cylinder_surface(0.05, 0.15, 2000, np.random.default_rng(12)), cylinder.vertices))
        == 0
    )
    # the URDF itself by its package name
    by_name = CollisionSource("package://my_robot/urdf/robot.urdf", package_dirs=(package_tree,))
    assert load_robot_geometry(by_name, robot_model(urdf)).links == geometry.links


@pytest.mark.parametrize("entry", ["folder holding the package", "the package itself"])
def test_package_meshes_resolve_through_ros_package_path(
    package_tree: Path, monkeypatch: pytest.MonkeyPatch, tmp_path: Path, entry: str
) -> None:
    urdf = package_tree / "my_robot" / "urdf" / "robot.urdf"
    folder = package_tree if entry == "folder holding the package" else package_tree / "my_robot"
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{tmp_path / 'nowhere'}:{folder}")
    geometry = load_robot_geometry(CollisionSource(urdf), robot_model(urdf))
    assert_tetrahedron_on_link1(geometry)


def test_package_dirs_come_before_ros_package_path(
    package_tree: Path, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    shadow = tmp_path / "shadow"
    write_tetrahedron_stl(shadow / "my_robot" / "meshes" / "x.stl", 3 * TETRAHEDRON)
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(package_tree))
    folders = package_search_path([shadow])
    assert folders[:2] == [shadow, package_tree]
    found = resolve_mesh("package://my_robot/meshes/x.stl", tmp_path, folders)
    assert found == shadow / "my_robot" / "meshes" / "x.stl"
    urdf = package_tree / "my_robot" / "urdf" / "robot.urdf"
    geometry = load_robot_geometry(CollisionSource(urdf, package_dirs=(shadow,)), robot_model(urdf))
    assert np.ptp(geometry.shapes_of("link1")[0].vertices, axis=0).max() == pytest.approx(0.3)


def test_relative_absolute_and_file_uris_resolve(tmp_path: Path) -> None:
    mesh = tmp_path / "robot" / "meshes" / "x.stl"
    write_tetrahedron_stl(mesh, TETRAHEDRON)
    urdf_dir = tmp_path / "robot" / "urdf"
    urdf_dir.mkdir()
    assert resolve_mesh("../meshes/x.stl", urdf_dir, []) == urdf_dir / "../meshes/x.stl"
    assert resolve_mesh(str(mesh), urdf_dir, []) == mesh
    assert resolve_mesh(f"file://{mesh}", urdf_dir, []) == mesh
    assert resolve_mesh("package://robot/meshes/x.stl", urdf_dir, [tmp_path]) == mesh
    assert resolve_mesh("package://robot/meshes/y.stl", urdf_dir, [tmp_path]) is None
    assert resolve_mesh("package://other/meshes/x.stl", urdf_dir, [tmp_path]) is None
    write_robot_urdf(urdf_dir / "robot.urdf", second_mesh=f"file://{mesh}")
    urdf = urdf_dir / "robot.urdf"
    text = urdf.read_text().replace("package://my_robot/meshes/x.stl", "../meshes/x.stl")
    urdf.write_text(text)
    geometry = load_robot_geometry(CollisionSource(urdf), robot_model(urdf))
    assert_tetrahedron_on_link1(geometry)
    assert len(geometry.shapes_of("link2")) == 2


def test_a_missing_mesh_is_an_error_naming_the_uri_the_link_and_the_folders(package_tree: Path) -> None:
    urdf = package_tree / "my_robot" / "urdf" / "robot.urdf"
    write_robot_urdf(urdf, second_mesh="package://my_robot/meshes/missing.stl")
    with pytest.raises(CollisionGeometryError) as error:
        load_robot_geometry(CollisionSource(urdf, package_dirs=(package_tree,)), robot_model(urdf))
    message = str(error.value)
    assert "package://my_robot/meshes/missing.stl (link link2)" in message
    assert str(package_tree) in message
    assert "x.stl" not in message  # only what is missing
    assert "missing_meshes=drop" in message


def test_missing_meshes_drop_warns_and_loads_the_rest(
    package_tree: Path, caplog: pytest.LogCaptureFixture
) -> None:
    urdf = package_tree / "my_robot" / "urdf" / "robot.urdf"
    write_robot_urdf(urdf, second_mesh="package://my_robot/meshes/missing.stl")
    source = CollisionSource(urdf, package_dirs=(package_tree,), missing_meshes="drop")
    with caplog.at_level(logging.WARNING, logger="lwrlab.model.collision_geometry"):
        geometry = load_robot_geometry(source, robot_model(urdf))
    assert any("package://my_robot/meshes/missing.stl (link link2)" in r.getMessage() for r in caplog.records)
    assert_tetrahedron_on_link1(geometry)
    (cylinder,) = geometry.shapes_of("link2")
    assert type(cylinder.geometry).__name__ == "Cylinder"


def test_urdf_robot_build_carries_its_collision_source(package_tree: Path) -> None:
    urdf = package_tree / "my_robot" / "urdf" / "robot.urdf"
    robot = build("robot", "urdf", path=str(urdf), acceleration_limits=10, package_dirs=[str(package_tree)])
    assert robot.collision_source is not None
    assert robot.collision_source.package_dirs == (package_tree,)
    geometry = load_robot_geometry(robot.collision_source, robot.model)
    assert_tetrahedron_on_link1(geometry)


# --- SRDF and the pairs a scene checks ------------------------------------------------------------


def test_srdf_disabled_pairs_are_read_unordered(tmp_path: Path) -> None:
    srdf = tmp_path / "robot.srdf"
    srdf.write_text(
        """<?xml version="1.0"?>
<robot name="my_robot">
  <disable_collisions link1="base" link2="link2" reason="Never"/>
  <disable_collisions link1="link2" link2="link1" reason="Adjacent"/>
</robot>
"""
    )
    pairs = disabled_pairs_from_srdf(srdf)
    assert pairs == {frozenset({"base", "link2"}), frozenset({"link1", "link2"})}
    srdf.write_text("<robot><disable_collisions")
    with pytest.raises(CollisionGeometryError, match="cannot read the SRDF"):
        disabled_pairs_from_srdf(srdf)


@pytest.mark.parametrize(
    "relative",
    [False, True],
    ids=["absolute-paths", "paths-relative-to-the-working-directory"],
)
def test_srdf_given_with_the_urdf_is_read(
    package_tree: Path, monkeypatch: pytest.MonkeyPatch, relative: bool
) -> None:
    srdf = package_tree / "my_robot" / "srdf" / "robot.srdf"
    srdf.parent.mkdir()
    srdf.write_text(
        '<robot name="my_robot"><disable_collisions link1="base" link2="link2" reason="Never"/></robot>'
    )
    urdf = package_tree / "my_robot" / "urdf" / "robot.urdf"
    monkeypatch.chdir(package_tree.parent)
    if relative:
        urdf, srdf = urdf.relative_to(package_tree.parent), srdf.relative_to(package_tree.parent)
    robot = build(
        "robot",
        "urdf",
        path=str(urdf),
        acceleration_limits=10,
        package_dirs=[str(package_tree)],
        srdf=str(srdf),
    )
    geometry = load_robot_geometry(robot.collision_source, robot.model)
    assert geometry.disabled_pairs == {frozenset({"base", "link2"})}


def urdf_adjacency(urdf: Path, locked: set[str]) -> tuple[set[frozenset[str]], set[str]]:
    """Link pairs adjacent as MoveIt counts them, read from the URDF's joints (fixed and locked joints
    merge their links), and the links rigidly attached to the root."""
    root = ElementTree.parse(urdf).getroot()
    group = {link.get("name"): link.get("name") for link in root.findall("link")}

    def find(link: str) -> str:
        while group[link] != link:
            link = group[link]
        return link

    moving = []
    for joint in root.findall("joint"):
        parent, child = joint.find("parent").get("link"), joint.find("child").get("link")
        if joint.get("type") == "fixed" or joint.get("name") in locked:
            group[find(child)] = find(parent)
        else:
            moving.append((parent, child))
    members: dict[str, set[str]] = {}
    for link in group:
        members.setdefault(find(link), set()).add(link)
    adjacent = {frozenset(p) for g in members.values() for p in combinations(sorted(g), 2)}
    for parent, child in moving:
        adjacent |= {frozenset((a, b)) for a in members[find(parent)] for b in members[find(child)]}
    children = {child for _, child in moving} | {
        joint.find("child").get("link") for joint in root.findall("joint")
    }
    (root_link,) = set(group) - children
    fixed = members[find(root_link)]
    return adjacent, fixed


def scene_settings(**changes):
    return replace(build("trajectory", "optimal", from_file=None).constraints, **changes)


def assert_pairs_are_moveits(scene, urdf: Path, locked: set[str], disabled: set[frozenset[str]]) -> None:
    """The scene checks every pair of links with geometry that are not adjacent, not both fixed, not
    disabled, and not found always in contact (its notes say which)."""
    adjacent, fixed = urdf_adjacency(urdf, locked)
    checked = {frozenset((scene.bodies[a], scene.bodies[b])) for a, b in scene.checked_self_pairs}
    assert checked, "no pair checked"
    assert not checked & adjacent, f"adjacent pairs checked: {checked & adjacent}"
    assert not checked & disabled, f"disabled pairs checked: {checked & disabled}"
    noted = {frozenset(n.split(":")[0].split("–")) for n in scene.notes}
    expected = (
        {frozenset((a, b)) for a, b in combinations(scene.bodies, 2) if not (a in fixed and b in fixed)}
        - adjacent
        - disabled
        - noted
    )
    assert checked == expected
    assert set(scene.self_pairs) <= set(scene.checked_self_pairs)


@needs_robot_data
def test_ur10_scene_checks_every_pair_but_adjacent_ones() -> None:
    robot = build("robot", "urdf", path=str(ur10_urdf()), acceleration_limits=10)
    scene = scene_settings().scene(robot)
    assert scene.geometry is not None and scene.geometry.disabled_pairs == frozenset()
    assert_pairs_are_moveits(scene, ur10_urdf(), set(), set())
    # the base link stands on the mounting surface: never paired with it; every moving body is
    assert {scene.bodies[a] for a, _ in scene.checked_world_pairs} == set(scene.bodies) - {"base_link"}


@needs_robot_data
def test_panda_srdf_pairs_are_never_checked() -> None:
    robot = build(
        "robot",
        "urdf",
        path=str(panda_urdf()),
        acceleration_limits=10,
        srdf=str(panda_srdf()),
        locked_joints=PANDA_FINGERS,
    )
    assert robot.n_joints == 7
    scene = scene_settings().scene(robot)
    disabled = set(disabled_pairs_from_srdf(panda_srdf()))
    assert scene.geometry is not None and set(scene.geometry.disabled_pairs) == disabled
    assert len(disabled) > 20
    assert {"panda_hand", "panda_leftfinger", "panda_rightfinger"} <= set(scene.bodies)
    assert_pairs_are_moveits(scene, panda_urdf(), set(PANDA_FINGERS), disabled)
    # without the SRDF the same pairs (but adjacent ones) are checked
    plain = build(
        "robot", "urdf", path=str(panda_urdf()), acceleration_limits=10, locked_joints=PANDA_FINGERS
    )
    scene_plain = scene_settings().scene(plain)
    assert_pairs_are_moveits(scene_plain, panda_urdf(), set(PANDA_FINGERS), set())
    assert len(scene_plain.checked_self_pairs) > len(scene.checked_self_pairs)


@needs_robot_data
def test_shapes_sit_where_pinocchio_places_them_fingers_locked_open() -> None:
    """Every shape, posed by the batched kinematics, is where Pinocchio's full model (fingers free, set to
    the locked opening) places it."""
    opening = 0.03
    robot = build(
        "robot", "urdf", path=str(panda_urdf()), acceleration_limits=10,
        locked_joints={finger: opening for finger in PANDA_FINGERS},
    )  # fmt: skip
    geometry = load_robot_geometry(robot.collision_source, robot.model)
    model = pin.buildModelFromUrdf(str(panda_urdf()))
    full = pin.buildGeomFromUrdf(
        model, str(panda_urdf()), pin.GeometryType.COLLISION, package_dirs=[str(ROBOTS.parent.parent)]
    )
    data, full_data = model.createData(), full.createData()
    q = random_q(robot.model, 3, np.random.default_rng(13))
    poses = joint_poses(robot.model, q)
    fingers = [model.joints[model.getJointId(f)].idx_q for f in PANDA_FINGERS]
    for k in range(len(q)):
        q_full = np.zeros(model.nq)
        q_full[[i for i in range(model.nq) if i not in fingers]] = q[k]
        q_full[fingers] = opening
        pin.forwardKinematics(model, data, q_full)
        pin.updateGeometryPlacements(model, data, full, full_data)
        for shape in geometry.shapes:
            pose = (np.eye(4) if shape.joint == 0 else poses[shape.joint - 1, k]) @ shape.placement
            expected = full_data.oMg[full.getGeometryId(shape.name)].homogeneous
            np.testing.assert_allclose(pose, expected, atol=1e-12, err_msg=shape.name)
    left = [s for s in geometry.shapes if s.link == "panda_leftfinger"]
    right = [s for s in geometry.shapes if s.link == "panda_rightfinger"]
    gap = left[0].placement[:3, 3] - right[0].placement[:3, 3]
    assert np.linalg.norm(gap) > 2 * opening - 1e-9  # open, not at 0


@needs_kuka
def test_real_kuka_urdf_missing_wrist_mesh_is_named_or_dropped(caplog: pytest.LogCaptureFixture) -> None:
    urdf = KUKA_HW / "kuka_lwr4.urdf"
    robot = build("robot", "urdf", path=str(urdf), acceleration_limits=10, package_dirs=[str(KUKA_HW)])
    with pytest.raises(CollisionGeometryError) as error:
        load_robot_geometry(robot.collision_source, robot.model)
    message = str(error.value)
    assert "package://lwr_description/meshes/kuka/convex/arm_wrist_convex.stl (link lwr_6_link)" in message
    assert str(KUKA_HW) in message
    dropping = replace(robot.collision_source, missing_meshes="drop")
    with caplog.at_level(logging.WARNING, logger="lwrlab.model.collision_geometry"):
        geometry = load_robot_geometry(dropping, robot.model)
    assert any("arm_wrist_convex.stl" in r.getMessage() for r in caplog.records)
    assert "lwr_6_link" not in geometry.links
    assert {"box", "lwr_base_link", "lwr_1_link", "lwr_7_link"} <= set(geometry.links)
    # the fixed links' primitives become world objects of the scene, with the URDF's size and place
    scene = build_scene(
        replace(robot, collision_source=dropping),
        build_world({"height": 0.0}, []),
        ground_spheres=None, min_link_gap=2, clearance=0.01, self_collision=True, n_samples=100,
    )  # fmt: skip
    world = {w.name: w for w in scene.world}
    assert set(world) == {"mounting surface", "box", "lwr_base_link"}
    np.testing.assert_allclose(world["box"].size, [0.6, 0.37, 0.5])
    np.testing.assert_allclose(world["box"].pose[:3, 3], [0, 0, 0.5])
    np.testing.assert_allclose(world["lwr_base_link"].size, [0.07, 0.055])
    np.testing.assert_allclose(world["lwr_base_link"].pose[:3, 3], [-0.25, 0, 1.055])
    # the first moving link stands on them: never paired with them
    paired = {(scene.bodies[a], scene.world[w].name) for a, w in scene.checked_world_pairs}
    assert ("lwr_1_link", "box") not in paired and ("lwr_1_link", "lwr_base_link") not in paired
    assert ("lwr_3_link", "box") in paired and ("lwr_3_link", "lwr_base_link") in paired
    for shape in geometry.shapes:  # round primitives keep their radius for exact spheres
        if type(shape.geometry).__name__ == "Sphere":
            assert shape.sphere_radius == shape.geometry.radius == pytest.approx(0.07)


@needs_kuka
@pytest.mark.parametrize(
    "name",
    [
        "tray",
        "box",  # the name of the URDF's table link
    ],
)
def test_an_obstacle_named_like_a_fixed_urdf_link_is_still_checked(name: str) -> None:
    urdf = KUKA_HW / "kuka_lwr4.urdf"
    robot = build(
        "robot",
        "urdf",
        path=str(urdf),
        acceleration_limits=10,
        package_dirs=[str(KUKA_HW)],
        missing_meshes="drop",
    )
    # a small ball beside the first moving link (joint 1 turns about x = −0.25, y = 0; its body reaches
    # 0.1 m out): some configurations touch it, most do not
    obstacle = {"name": name, "shape": "sphere", "radius": 0.03, "xyz": [-0.25 + 0.13, 0.0, 1.2]}
    try:
        scene = build_scene(
            robot, build_world({"height": 0.0}, [obstacle]),
            ground_spheres=None, min_link_gap=2, clearance=0.01, self_collision=True, n_samples=100,
        )  # fmt: skip
    except ValueError as error:  # refusing the clash, naming it, would do too
        assert name in str(error)
        return
    configured = 1  # after the mounting surface
    assert scene.world[configured].shape == "sphere"
    first = scene.bodies.index("lwr_1_link")
    assert (first, configured) in scene.checked_world_pairs
    assert [w.name for w in scene.world].count(name) == 1, "two world objects under one name"
