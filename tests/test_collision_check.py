"""The exact collision check of a motion, the distances' lower bounds and their derivatives, against
brute force: coal queries on Pinocchio's own placement of the URDF's collision geometry at every sample.
"""

from __future__ import annotations

import itertools
import sys
from dataclasses import replace
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

from lwrlab.excitation.collision_check import check_collisions
from lwrlab.excitation.collision_scene import CollisionScene, posed_meshes
from lwrlab.excitation.constraints import ConstraintSet
from lwrlab.excitation.sphere_distances import SphereDistances
from lwrlab.excitation.sphere_layout import nearest_pairs
from lwrlab.model.collision_geometry import package_search_path
from lwrlab.pipeline.build import build


def _robot_data() -> Path | None:
    """example-robot-data's share folder (the test extra), wherever pip installed it."""
    shares = [*package_search_path(), *Path(sys.prefix).glob("lib/python*/site-packages/cmeel.prefix/share")]
    return next((s for s in shares if (s / "example-robot-data" / "robots").is_dir()), None)


SHARE = _robot_data()
pytestmark = pytest.mark.skipif(
    SHARE is None, reason="example-robot-data (test extra) is not installed: no real robot descriptions"
)

OBSTACLES = [
    {"name": "crate", "shape": "box", "size": [0.3, 0.4, 0.5], "xyz": [0.75, 0.3, 0.25], "rpy": [0, 0, 0.4]},
    {"name": "pillar", "shape": "cylinder", "radius": 0.08, "length": 1.2, "xyz": [-0.6, 0.6, 0.6]},
    {"name": "lamp", "shape": "sphere", "radius": 0.12, "xyz": [0.0, -0.7, 1.1]},
]
OCTAHEDRON = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)


def write_octahedron_stl(path: Path) -> None:
    """An ASCII STL of the unit octahedron (outward facets)."""
    lines = ["solid octahedron"]
    for x in (0, 1):
        for y in (2, 3):
            for z in (4, 5):
                a, b, c = OCTAHEDRON[[x, y, z]]
                if np.dot(np.cross(b - a, c - a), a + b + c) < 0:
                    b, c = c, b
                lines += [" facet normal 0 0 0", "  outer loop"]
                lines += [f"   vertex {v[0]} {v[1]} {v[2]}" for v in (a, b, c)]
                lines += ["  endloop", " endfacet"]
    path.write_text("\n".join([*lines, "endsolid octahedron", ""]))


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The mounting surface and four obstacles, one of them a mesh (an octahedron, scaled and turned)."""
    stl = tmp_path_factory.mktemp("world") / "wedge.stl"
    write_octahedron_stl(stl)
    wedge = {
        "name": "wedge", "shape": "mesh", "path": str(stl), "scale": [0.25, 0.15, 0.2],
        "xyz": [-0.5, -0.55, 0.35], "rpy": [0.3, 0.2, -0.4],
    }  # fmt: skip
    return {"mounting_surface": {"height": 0.0, "normal": [0.0, 0.0, 1.0]}, "obstacles": [*OBSTACLES, wedge]}


def urdf_of(robot: str) -> Path:
    assert SHARE is not None
    robots = SHARE / "example-robot-data" / "robots"
    return {
        "ur10": robots / "ur_description" / "urdf" / "ur10_robot.urdf",
        "panda": robots / "panda_description" / "urdf" / "panda.urdf",
    }[robot]


class BruteForce:
    """The URDF's collision geometry placed by Pinocchio, and the world built here from the config, queried
    pair by pair with coal (nothing of lwrlab's geometry, poses or pruning)."""

    def __init__(self, robot: str, locked: list[str], clearance: float, obstacles: list[dict]) -> None:
        urdf = urdf_of(robot)
        model = pin.buildModelFromUrdf(str(urdf))
        geometry = pin.buildGeomFromUrdf(
            model, str(urdf), pin.GeometryType.COLLISION, package_dirs=[str(SHARE)]
        )
        if locked:
            ids = [model.getJointId(name) for name in locked]
            model, geometry = pin.buildReducedModel(model, geometry, ids, pin.neutral(model))
        self.model, self.geometry = model, geometry
        self.data, self.geometry_data = model.createData(), geometry.createData()
        self.objects: dict[str, list[int]] = {}
        for i, obj in enumerate(geometry.geometryObjects):
            self.objects.setdefault(model.frames[obj.parentFrame].name, []).append(i)
        self.world: dict[str, tuple[object, object]] = {
            "mounting surface": (coal.Halfspace(np.array([0.0, 0, 1]), 0.0), coal.Transform3s())
        }
        self.world_balls: dict[str, tuple[np.ndarray, float]] = {}
        for entry in obstacles:
            rotation = pin.rpy.rpyToMatrix(*np.asarray(entry.get("rpy", [0, 0, 0]), dtype=float))
            position = np.asarray(entry["xyz"], dtype=float)
            if entry["shape"] == "mesh":
                shape = coal.MeshLoader().load(entry["path"], np.asarray(entry["scale"], dtype=float))
                vertices = np.asarray(shape.vertices(), dtype=float)
                centre = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
                radius = float(np.linalg.norm(vertices - centre, axis=1).max())
            else:
                shape = {
                    "box": lambda e: coal.Box(*e["size"]),
                    "cylinder": lambda e: coal.Cylinder(e["radius"], e["length"]),
                    "sphere": lambda e: coal.Sphere(e["radius"]),
                }[entry["shape"]](entry)
                centre = np.zeros(3)
                radius = {
                    "box": lambda e: 0.5 * float(np.linalg.norm(e["size"])),
                    "cylinder": lambda e: float(np.hypot(e["radius"], e["length"] / 2)),
                    "sphere": lambda e: float(e["radius"]),
                }[entry["shape"]](entry)
            self.world[entry["name"]] = (shape, coal.Transform3s(rotation, position))
            self.world_balls[entry["name"]] = (rotation @ centre + position, radius)
        # a ball around each geometry (own frame): cheap lower bounds to skip far samples
        self.balls = []
        for i in range(len(geometry.geometryObjects)):
            vertices = self._vertices(i)
            centre = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
            self.balls.append((centre, float(np.linalg.norm(vertices - centre, axis=1).max())))
        self.collide_request = coal.CollisionRequest()
        self.collide_request.security_margin = clearance
        self.distance_request = coal.DistanceRequest()
        self.distance_request.enable_signed_distance = True

    def place(self, q: np.ndarray) -> list[object]:
        pin.forwardKinematics(self.model, self.data, q)
        pin.updateGeometryPlacements(self.model, self.data, self.geometry, self.geometry_data)
        return [coal.Transform3s(m.rotation, m.translation) for m in self.geometry_data.oMg]

    def _vertices(self, i: int) -> np.ndarray:
        """Vertices (V, 3) of geometry object i in its own frame: a mesh's, or a box's corners."""
        geometry = self.geometry.geometryObjects[i].geometry
        if isinstance(geometry, coal.Box):
            signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
            return signs * np.asarray(geometry.halfSide)
        return np.asarray(geometry.vertices(), dtype=float).reshape(-1, 3)

    def height(self, link: str, placed: list[object]) -> float:
        """Signed height above the floor z = 0 of a link's lowest point (coal's mesh–halfspace distance
        is not the penetration depth once below)."""
        lowest = np.inf
        for i in self.objects[link]:
            rotation, translation = placed[i].getRotation(), placed[i].getTranslation()
            lowest = min(lowest, float((self._vertices(i) @ rotation.T + translation)[:, 2].min()))
        return lowest

    def lower_bound(self, kind: str, link: str, other: str, placed: list[object]) -> float:
        """A lower bound of the pair's distance from the balls around its geometries."""
        if other == "mounting surface":
            return self.height(link, placed)

        def balls(link: str) -> list[tuple[np.ndarray, float]]:
            return [(placed[i].transform(self.balls[i][0]), self.balls[i][1]) for i in self.objects[link]]

        second = balls(other) if kind == "self" else [self.world_balls[other]]
        return min(float(np.linalg.norm(ca - cb)) - ra - rb for ca, ra in balls(link) for cb, rb in second)

    def _sides(self, kind: str, link: str, other: str, placed: list[object]) -> tuple[list, list]:
        objects = self.geometry.geometryObjects
        first = [(objects[i].geometry, placed[i]) for i in self.objects[link]]
        if kind == "self":
            second = [(objects[i].geometry, placed[i]) for i in self.objects[other]]
        else:
            second = [self.world[other]]
        return first, second

    def in_contact(self, kind: str, link: str, other: str, placed: list[object]) -> bool:
        first, second = self._sides(kind, link, other, placed)
        return any(
            coal.collide(a, pa, b, pb, self.collide_request, coal.CollisionResult())
            for a, pa in first
            for b, pb in second
        )

    def distance(self, kind: str, link: str, other: str, placed: list[object]) -> float:
        first, second = self._sides(kind, link, other, placed)
        if other == "mounting surface":
            height = self.height(link, placed)
            if height > 0:  # apart: coal agrees
                (floor, placement) = second[0]
                by_coal = min(
                    coal.distance(a, pa, floor, placement, self.distance_request, coal.DistanceResult())
                    for a, pa in first
                )
                assert by_coal == pytest.approx(height, abs=1e-9)
            return height
        return min(
            coal.distance(a, pa, b, pb, self.distance_request, coal.DistanceResult())
            for a, pa in first
            for b, pb in second
        )


def checked_pairs(scene) -> list[tuple[str, str, str]]:
    """(kind, body, other) of every pair the scene's exact check checks."""
    return [("self", scene.bodies[a], scene.bodies[b]) for a, b in scene.checked_self_pairs] + [
        ("world", scene.bodies[a], scene.world[w].name) for a, w in scene.checked_world_pairs
    ]


@pytest.fixture(scope="module")
def ur10(world):
    robot = build("robot", "urdf", path=str(urdf_of("ur10")), acceleration_limits=10)
    settings = replace(build("trajectory", "optimal", from_file=None).constraints, world=world)
    scene = settings.scene(robot)
    brute = BruteForce("ur10", [], settings.clearance, world["obstacles"])
    assert list(brute.model.names) == list(robot.model.names)
    return robot, settings, scene, brute


@pytest.fixture(scope="module")
def panda(world):
    fingers = ["panda_finger_joint1", "panda_finger_joint2"]
    robot = build("robot", "urdf", path=str(urdf_of("panda")), acceleration_limits=10, locked_joints=fingers)
    settings = replace(build("trajectory", "optimal", from_file=None).constraints, world=world)
    scene = settings.scene(robot)
    brute = BruteForce("panda", fingers, settings.clearance, world["obstacles"])
    assert list(brute.model.names) == list(robot.model.names)
    return robot, settings, scene, brute


def folding_motion(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A 2 s UR10 motion through random configurations, the arm folded onto itself and dipping below
    the mounting surface, smoothly blended (t (n,) s, q (n, 6) rad)."""
    home = np.array([0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0])
    waypoints = [
        home,
        home + rng.uniform(-0.8, 0.8, 6),
        np.array([0.3, -1.4, 2.9, -1.0, 1.2, 0.0]),  # forearm folded back: the wrist on the upper arm
        home + rng.uniform(-0.8, 0.8, 6),
        np.array([1.0, 0.1, 0.3, 0.0, 0.5, 0.0]),  # upper arm below the horizontal: into the floor
        home + rng.uniform(-1.5, 1.5, 6),
        np.array([0.6, -0.5, 1.0, -0.6, 0.0, 0.0]),  # reaching over the crate
        home,
    ]
    t = np.linspace(0.0, 2.0, n)
    s = np.linspace(0.0, len(waypoints) - 1, n)
    segment = np.minimum(s.astype(int), len(waypoints) - 2)
    blend = 0.5 - 0.5 * np.cos(np.pi * (s - segment))[:, None]
    start, end = np.array(waypoints)[segment], np.array(waypoints)[segment + 1]
    return t, start + blend * (end - start)


class BruteMotion:
    """Brute force over a motion: contacts at every sample (coal.collide, security margin = clearance) and
    exact distances (coal.distance), computed where asked; the true minimum of a pair over the motion by
    branch and bound on the balls' lower bounds (exact: only samples whose bound is below it are skipped)."""

    def __init__(self, brute: BruteForce, pairs: list[tuple[str, str, str]], q: np.ndarray) -> None:
        self.brute, self.pairs = brute, pairs
        self.placed = [brute.place(q_k) for q_k in q]
        self.bounds = np.array(
            [[brute.lower_bound(*pair, placed) for pair in pairs] for placed in self.placed]
        )
        self.contacts: dict[tuple[str, str, str], list[int]] = {}
        clearance = brute.collide_request.security_margin
        for k, placed in enumerate(self.placed):
            for c, pair in enumerate(pairs):
                if self.bounds[k, c] < clearance and brute.in_contact(*pair, placed):
                    self.contacts.setdefault(pair, []).append(k)
        self._distances: dict[tuple[int, int], float] = {}

    def distance(self, k: int, c: int) -> float:
        if (k, c) not in self._distances:
            self._distances[(k, c)] = self.brute.distance(*self.pairs[c], self.placed[k])
        return self._distances[(k, c)]

    def minimum(self, c: int) -> float:
        best = np.inf
        for k in np.argsort(self.bounds[:, c]):
            if self.bounds[k, c] >= best:
                break
            best = min(best, self.distance(int(k), c))
        return best


@pytest.fixture(scope="module")
def folding(ur10):
    robot, settings, scene, brute = ur10
    t, q = folding_motion(200, np.random.default_rng(0))
    assert np.all(q >= robot.limits.position_lower) and np.all(q <= robot.limits.position_upper)
    pairs = checked_pairs(scene)
    motion = BruteMotion(brute, pairs, q)
    check = check_collisions(scene, t, q, settings.clearance)
    return t, pairs, motion, check


def test_the_folding_motion_collides_with_itself_the_floor_and_an_obstacle(folding) -> None:
    t, pairs, motion, check = folding
    contacts = motion.contacts
    kinds = {(kind, other if kind == "world" else "robot") for kind, _, other in contacts}
    assert ("self", "robot") in kinds and ("world", "mounting surface") in kinds
    assert any(kind == "world" and other in ("crate", "pillar", "lamp", "wedge") for kind, other in kinds)
    in_contact = {k for samples in contacts.values() for k in samples}
    assert 0.1 < len(in_contact) / len(t) < 0.9, "the motion must be partly free"
    assert len(contacts) < len(pairs), "some pairs must stay apart"
    assert check.exact and not check.free
    assert check.pairs_checked == len(pairs)


def test_contacts_equal_brute_force_at_every_sample(folding) -> None:
    t, pairs, motion, check = folding
    contacts = motion.contacts
    found = {(c.kind, c.bodies): c for c in check.contacts}
    expected = {(kind, f"{a}–{b}"): samples for (kind, a, b), samples in contacts.items()}
    assert set(found) == set(expected)
    for key, samples in expected.items():
        contact = found[key]
        assert contact.samples == len(samples), key
        assert (contact.first_s, contact.last_s) == (t[samples[0]], t[samples[-1]]), key
    # the deepest reported is the exact distance at a sample in contact or at the closest approach
    columns = {f"{a}–{b}": c for c, (_, a, b) in enumerate(pairs)}
    approaches = {f"{a.body_a}–{a.body_b}": a for a in check.approaches}
    for contact in check.contacts:
        c = columns[contact.bodies]
        samples = contacts[pairs[c]]
        exact = [motion.distance(k, c) for k in samples] + [approaches[contact.bodies].distance]
        assert contact.deepest < 0.01
        assert contact.deepest >= motion.minimum(c) - 1e-9
        assert np.abs(np.array(exact) - contact.deepest).min() < 1e-6, contact.bodies
    assert len(check.describe().splitlines()) == len(check.contacts)


def test_closest_approaches_are_exact_distances_no_nearer_than_the_true_minimum(folding) -> None:
    t, pairs, motion, check = folding
    assert len(check.approaches) == len(pairs)
    columns = {(kind, a, b): c for c, (kind, a, b) in enumerate(pairs)}
    assert [a.distance for a in check.approaches] == sorted(a.distance for a in check.approaches)
    for approach in check.approaches:
        c = columns[(approach.kind, approach.body_a, approach.body_b)]
        k = int(np.argmin(np.abs(t - approach.t)))
        assert t[k] == approach.t
        assert approach.distance == pytest.approx(motion.distance(k, c), abs=1e-6), approach.label
        minimum = motion.minimum(c)
        assert approach.distance >= minimum - 1e-9
        assert approach.violated == (pairs[c] in motion.contacts)
        if approach.distance > 1e-6:  # apart: its points are on the two bodies, that far apart
            assert np.linalg.norm(approach.point_a - approach.point_b) == pytest.approx(
                approach.distance, abs=1e-6
            )
        if approach.body_b == "mounting surface":  # heights are exact at every sample
            assert approach.distance == pytest.approx(minimum, abs=1e-9)
            assert approach.point_b[2] == pytest.approx(0.0, abs=1e-9)


def test_a_motion_clear_of_everything_is_free_by_both(ur10) -> None:
    _, settings, scene, brute = ur10
    t = np.linspace(0.0, 1.0, 60)
    home = np.array([0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0])
    q = home + 0.3 * np.sin(2 * np.pi * t[:, None] * np.arange(1, 7) / 3)
    pairs = checked_pairs(scene)
    motion = BruteMotion(brute, pairs, q)
    assert not motion.contacts
    check = check_collisions(scene, t, q, settings.clearance)
    assert check.free and check.contacts == () and check.describe() == ""
    assert len(check.approaches) == len(pairs)
    assert not any(a.violated for a in check.approaches)
    nearest = check.approaches[0]  # and it is as near as the brute force finds
    c = pairs.index((nearest.kind, nearest.body_a, nearest.body_b))
    assert nearest.distance == pytest.approx(motion.minimum(c), abs=2e-3)


def test_posed_meshes_are_the_geometry_where_pinocchio_places_it(ur10) -> None:
    robot, _, scene, brute = ur10
    q = random_configurations(robot, 1, seed=3)[0]
    placed = brute.place(q)
    meshes = {name: (vertices, faces, fixed) for name, vertices, faces, fixed in posed_meshes(scene, q)}
    assert set(meshes) == set(scene.bodies) | {w.name for w in scene.world if w.shape != "plane"}
    for body in scene.bodies:
        vertices, faces, fixed = meshes[body]
        expected = np.vstack(
            [
                brute._vertices(i) @ placed[i].getRotation().T + placed[i].getTranslation()
                for i in brute.objects[body]
            ]
        )
        np.testing.assert_allclose(vertices, expected, atol=1e-12, err_msg=body)
        assert faces.max() < len(vertices) and fixed == (body == "base_link")
    wedge_shape, wedge_placement = brute.world["wedge"]
    wedge = (
        np.asarray(wedge_shape.vertices()) @ wedge_placement.getRotation().T
        + wedge_placement.getTranslation()
    )
    np.testing.assert_allclose(meshes["wedge"][0], wedge, atol=1e-12)


# --- lower bounds ---------------------------------------------------------------------------------


def random_configurations(robot, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    low, high = (
        np.maximum(robot.limits.position_lower, -np.pi),
        np.minimum(robot.limits.position_upper, np.pi),
    )
    return rng.uniform(low, high, size=(n, robot.n_joints))


@pytest.mark.parametrize("robot_fixture", ["ur10", "panda"])
def test_sphere_and_hull_distances_are_lower_bounds_of_the_exact_distance(robot_fixture, request) -> None:
    robot, _, scene, brute = request.getfixturevalue(robot_fixture)
    q = random_configurations(robot, 25, seed=1)
    pairs = checked_pairs(scene)
    motion = BruteMotion(brute, pairs, q)
    signed = np.array([[motion.distance(k, c) for c in range(len(pairs))] for k in range(len(q))])
    exact = np.maximum(signed, 0.0)  # meshes in contact: 0 (their depth is not defined)
    poses = scene.poses(q)
    spheres = SphereDistances(scene)
    n_self = len(scene.checked_self_pairs)
    bounds = np.hstack(
        [
            spheres.self_distances(scene.checked_self_pairs, poses)[0],
            spheres.world_distances(scene.checked_world_pairs, poses)[0],
        ]
    )
    slack = exact - bounds
    assert slack.min() >= -1e-9, f"spheres above the exact distance: {pairs[np.argmin(slack.min(axis=0))]}"
    assert np.median(slack[exact > 0]) < 0.05  # and not absurdly loose
    # the convex hulls (every checked pair that is not against a plane) and the exact plane heights
    hulls = SphereDistances(scene)
    hulls.use_hulls = True
    keys = frozenset(
        [("self", pair) for pair in scene.checked_self_pairs]
        + [("world", pair) for pair in scene.checked_world_pairs if scene.world[pair[1]].shape != "plane"]
    )
    hull = hulls.hull_distances(q, keys=keys)
    assert len(hull) == len(keys)
    hull_slack: list[np.ndarray] = []
    sphere_slack: list[np.ndarray] = []
    for key, (values, _, _) in hull.items():
        family, (a, b) = key
        c = (
            scene.checked_self_pairs.index((a, b))
            if family == "self"
            else n_self + scene.checked_world_pairs.index((a, b))
        )
        assert np.all(values <= exact[:, c] + 1e-7), pairs[c]
        hull_slack.append(exact[:, c] - values)
        sphere_slack.append(exact[:, c] - bounds[:, c])
    # the hulls hug the bodies closer than the spheres do, on the whole
    assert np.median(hull_slack) < np.median(sphere_slack)
    refined = np.hstack(
        [
            hulls.pair_distances("self", scene.checked_self_pairs, poses, q)[0],
            hulls.pair_distances("world", scene.checked_world_pairs, poses, q)[0],
        ]
    )
    assert np.all(refined <= exact + 1e-7)
    planes = [c for c, (kind, _, other) in enumerate(pairs) if other == "mounting surface"]
    np.testing.assert_allclose(refined[:, planes], signed[:, planes], atol=1e-9)  # exact, below the floor too
    assert any(scene.hull_pairs), "the scene measures some pairs between hulls"


@pytest.mark.parametrize("robot_fixture", ["ur10", "panda"])
def test_distances_past_a_horizon_are_the_full_ones_within_it_lower_bounds_past_it(
    robot_fixture, request
) -> None:
    """Past a horizon, the exact check bounds a pair by its bodies' bounding spheres (a body against a
    fixed box, cylinder or sphere: by its bounding sphere), no sphere pair computed: the same values
    as every sphere pair within the horizon, lower bounds past it (and past it only)."""
    robot, _, scene, _ = request.getfixturevalue(robot_fixture)
    q = random_configurations(robot, 150, seed=3)
    poses = scene.poses(q)
    spheres = SphereDistances(scene)
    for family, pairs in (("self", scene.checked_self_pairs), ("world", scene.checked_world_pairs)):
        full = spheres.pair_distances(family, pairs, poses)[0]
        for horizon in (0.02, 0.1, 0.3):
            near = full < horizon
            assert near.any() and (~near).any(), "entries on both sides of the horizon"
            bounded = spheres.pair_distances(family, pairs, poses, horizon=horizon)[0]
            np.testing.assert_allclose(bounded[near], full[near], rtol=0, atol=1e-12)
            assert np.all(bounded <= full + 1e-12) and np.all(bounded[~near] >= horizon - 1e-12)
            # the bodies' bounding spheres stand in past the horizon, against a box or cylinder too
            kinds = [scene.world[p[1]].shape if family == "world" else "body" for p in pairs]
            for kind in set(kinds) & {"body", "box", "cylinder"}:
                of_kind = np.array(kinds) == kind
                past = ~near & of_kind
                assert np.any(bounded[past] < full[past] - 1e-9), f"{kind}: bounded past {horizon} m"


def test_a_body_s_fixed_objects_are_one_column_whose_window_minima_are_exact(ur10) -> None:
    """A moving body's pairs with two or more fixed boxes, cylinders or spheres are one column, the
    smallest of their distances; measured only where it may be its window's smallest, its windows'
    minima and where they are reached are those of every pair at every sample (to the last bit)."""
    robot, settings, scene, _ = ur10
    constraints = ConstraintSet(robot, settings, scene=scene)
    columns = constraints.distance_columns["world"]
    merged = [c for c, members in enumerate(columns.columns) if len(members) > 1]
    assert merged and all(
        len(members) == 1 for members in constraints.distance_columns["self_collision"].columns
    )
    assert sorted(p for members in columns.columns for p in members) == sorted(scene.world_pairs)
    labels = constraints.column_labels("world")
    assert all(labels[c].endswith(f"{len(columns.columns[c])} fixed objects") for c in merged)
    q = random_configurations(robot, 120, seed=5)
    assert_each_column_is_its_pairs_smallest(constraints, scene, "world", q)
    assert_window_minima_exact(constraints, q)
    # no object beside the surface: one column per pair, as for an arm on a table
    bare = replace(settings, world={"mounting_surface": {"height": 0.0}})
    alone = ConstraintSet(robot, bare)
    assert all(len(m) == 1 for m in alone.distance_columns["world"].columns)


def assert_each_column_is_its_pairs_smallest(
    constraints: ConstraintSet, scene: CollisionScene, family: str, q: np.ndarray
) -> None:
    """Every distance column of ``family`` ("world" or "self"), measured at every sample, is the
    smallest of its member pairs' distances measured one by one, to the last bit."""
    pairs = scene.world_pairs if family == "world" else scene.self_pairs
    each = SphereDistances(scene)
    each.use_hulls = True
    distances = each.pair_distances(family, pairs, scene.poses(q), q)[0]
    zeros = np.zeros_like(q)
    key = "world" if family == "world" else "self_collision"
    dense = constraints.slacks(q, zeros, zeros)[key]
    offset = constraints.settings.clearance + constraints.settings.distance_margin
    for c, members in enumerate(constraints.distance_columns[key].columns):
        picked = [pairs.index(p) for p in members]
        np.testing.assert_array_equal(dense[:, c], distances[:, picked].min(axis=1) - offset)


def assert_window_minima_exact(constraints: ConstraintSet, q: np.ndarray) -> None:
    """Measured only where a window's smallest can be, every distance column's window minima and
    where they are reached are those of every pair at every sample, to the last bit; elsewhere its
    values are lower bounds."""
    zeros = np.zeros_like(q)
    dense = constraints.slacks(q, zeros, zeros)
    for windows in (np.arange(0, len(q) - 1, 10), np.arange(0, len(q) - 1, 40), np.array([0])):
        pruned = constraints.slacks(q, zeros, zeros, windows=windows)
        for family in ("world", "self_collision"):
            assert np.all(pruned[family] <= dense[family])
            for w, start in enumerate(windows):
                stop = windows[w + 1] if w + 1 < len(windows) else len(q)
                whole, measured = dense[family][start:stop], pruned[family][start:stop]
                np.testing.assert_array_equal(measured.min(axis=0), whole.min(axis=0))
                np.testing.assert_array_equal(measured.argmin(axis=0), whole.argmin(axis=0))


def test_the_bodies_one_joint_moves_are_one_side_of_a_bigger_robot_s_columns(panda) -> None:
    """For the arm of a bigger robot (here the Panda as if it hung from a torso), the bodies one joint
    moves (its last link, hand and fingers) are one side of a column: each column the smallest of its
    pairs' distances, every pair in one column, fewer columns; an arm alone keeps a column per body
    pair. Windows' minima exact; a column's derivative is its nearest pair's (central differences)."""
    robot, settings, scene, _ = panda
    alone = ConstraintSet(robot, settings, scene=scene)
    assert all(len(m) == 1 for m in alone.distance_columns["self_collision"].columns)
    hanging = replace(robot, mounted_on="panda_link0")
    constraints = ConstraintSet(hanging, settings, scene=replace(scene, robot=hanging))
    columns = constraints.distance_columns["self_collision"]
    assert sorted(p for members in columns.columns for p in members) == sorted(scene.self_pairs)
    assert len(columns.columns) < len(scene.self_pairs)
    joints = scene.body_joints
    for members, label in zip(columns.columns, columns.labels, strict=True):
        sides = {frozenset(int(joints[b]) for b in pair) for pair in members}
        assert len(sides) == 1, f"{label}: pairs between other joints {sides}"
        assert (len(members) > 1) == (" more" in label)
    q = random_configurations(robot, 120, seed=6)
    zeros = np.zeros_like(q)
    assert_each_column_is_its_pairs_smallest(constraints, scene, "self", q)
    assert_window_minima_exact(constraints, q)
    merged = np.array([c for c, members in enumerate(columns.columns) if len(members) > 1])
    samples = np.repeat(np.arange(8), len(merged))
    d_q = constraints.slack_derivatives("self_collision", q, zeros, zeros, samples, np.tile(merged, 8))[0]
    h = 1e-5
    for j in range(robot.n_joints):
        step = np.zeros_like(q[:8])
        step[:, j] = h
        numeric = (
            constraints.slacks(q[:8] + step, zeros[:8], zeros[:8])["self_collision"][:, merged]
            - constraints.slacks(q[:8] - step, zeros[:8], zeros[:8])["self_collision"][:, merged]
        ) / (2 * h)
        assert np.abs(d_q[:, j] - numeric.ravel()).max() < 3e-4


def test_a_column_s_derivative_at_its_window_minimum_takes_the_pair_its_distances_found(panda) -> None:
    """After the windowed distances, the derivatives at each window's smallest take the nearest member
    pair those distances found (not measured again): the same derivatives as a constraint set that
    measures them afresh, to the last bit; at other configurations, measured again."""
    robot, settings, scene, _ = panda
    hanging = replace(robot, mounted_on="panda_link0")
    constraints = ConstraintSet(hanging, settings, scene=replace(scene, robot=hanging))
    fresh = ConstraintSet(hanging, settings, scene=replace(scene, robot=hanging))
    merged = [c for c, m in enumerate(constraints.distance_columns["self_collision"].columns) if len(m) > 1]
    q = random_configurations(robot, 120, seed=11)
    zeros = np.zeros_like(q)
    windows = np.arange(0, len(q) - 1, 10)
    values = constraints.slacks(q, zeros, zeros, windows=windows)["self_collision"]
    starts = np.append(windows, len(q))
    samples = np.concatenate(
        [start + np.argmin(values[start:stop], axis=0) for start, stop in itertools.pairwise(starts)]
    )
    columns = np.tile(np.arange(values.shape[1]), len(windows))
    nearest = constraints._nearest["self_collision"]
    assert nearest.known[samples, columns].all()
    assert merged
    cached = constraints.slack_derivatives("self_collision", q, zeros, zeros, samples, columns)[0]
    measured = fresh.slack_derivatives("self_collision", q, zeros, zeros, samples, columns)[0]
    np.testing.assert_array_equal(cached, measured)
    other = q + 0.01
    np.testing.assert_array_equal(
        constraints.slack_derivatives("self_collision", other, zeros, zeros, samples, columns)[0],
        fresh.slack_derivatives("self_collision", other, zeros, zeros, samples, columns)[0],
    )


def test_a_hull_distance_does_not_depend_on_the_calls_before_it(ur10) -> None:
    """GJK starts where the last configuration's ended: each call starts it afresh, so the same
    configurations give the same distances whatever was measured before."""
    robot, _, scene, _ = ur10
    hulls = SphereDistances(scene)
    q = random_configurations(robot, 30, seed=8)
    first = hulls.hull_distances(q)
    hulls.hull_distances(random_configurations(robot, 7, seed=9))
    again = hulls.hull_distances(q)
    assert first and all(np.array_equal(first[key][0], again[key][0]) for key in first)


def test_the_nearest_sphere_pairs_of_many_columns_at_once_are_each_column_s_argmin(ur10) -> None:
    """The derivatives take every sphere column's nearest sphere pair in one batch: the same pair,
    the first of equals, as the argmin over that column's pairs alone."""
    robot, _, scene, _ = ur10
    spheres = SphereDistances(scene)
    centres = spheres._centres(scene.poses(random_configurations(robot, 40, seed=7)))
    pairs = scene.checked_self_pairs
    layout = spheres._flat_layout("self", pairs)
    rng = np.random.default_rng(0)
    run, sample = rng.integers(0, len(pairs), 200), rng.integers(0, 40, 200)
    first, second = nearest_pairs(layout, centres, spheres.all_radii, run, sample)
    for r, k, a, b in zip(run, sample, first, second, strict=True):
        own = spheres._flat_layout("self", (pairs[r],))
        at = np.argmin(spheres._sphere_gaps(own.first, own.second, centres[:, [k]])[:, 0])
        assert (a, b) == (own.first[at], own.second[at])


# --- derivatives ----------------------------------------------------------------------------------


def test_world_and_self_collision_derivatives_equal_central_differences(ur10) -> None:
    robot, settings, scene, _ = ur10
    constraints = ConstraintSet(robot, settings, scene=scene)
    assert {"world", "self_collision"} <= set(constraints.families())
    assert any(scene.world[w].shape == "plane" for _, w in scene.world_pairs)
    assert len({scene.world[w].shape for _, w in scene.world_pairs}) >= 3
    q = random_configurations(robot, 16, seed=2)
    zeros = np.zeros_like(q)
    h = 1e-5
    for family in ("world", "self_collision"):
        values = constraints.slacks(q, zeros, zeros)[family]
        n, columns = values.shape
        samples, cols = np.repeat(np.arange(n), columns), np.tile(np.arange(columns), n)
        d_q, d_v, d_a = constraints.slack_derivatives(family, q, zeros, zeros, samples, cols)
        assert np.abs(d_v).max() == 0 and np.abs(d_a).max() == 0
        analytic = d_q.reshape(n, columns, -1)
        numeric = np.empty_like(analytic)
        for j in range(robot.n_joints):
            step = np.zeros_like(q)
            step[:, j] = h
            numeric[:, :, j] = (
                constraints.slacks(q + step, zeros, zeros)[family]
                - constraints.slacks(q - step, zeros, zeros)[family]
            ) / (2 * h)
        # hull distances come from GJK to 1e-9 m: differences over 2h = 2e-5 rad are good to 1e-4
        error = np.abs(analytic - numeric)
        assert np.abs(numeric).max() > 0.1
        assert error.max() < 3e-4, (
            f"{family}: worst {error.max():.2e} at {np.unravel_index(error.argmax(), error.shape)}"
        )
