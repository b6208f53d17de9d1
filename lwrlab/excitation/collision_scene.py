"""What the exciting motion must not touch: the robot's bodies, their sphere stand-ins, and the world.

A :class:`CollisionScene` gathers, for one robot and one set of settings:

* **bodies**: the robot's URDF links with ``<collision>`` geometry (when the robot has a
  :class:`~lwrlab.model.collision_geometry.CollisionSource`), each covered by enclosing spheres
  (:mod:`lwrlab.model.enclosing_spheres`); or, for a robot described by hand-written
  ``collision_spheres`` only, each sphere a body of its own;
* **world**: the mounting surface and the configured obstacles
  (:mod:`lwrlab.model.world`), plus the URDF's own fixed links (joint 0: a table, a stand, the base)
  — primitives as world objects, meshes as bodies fixed to the base;
* **pairs**: the body pairs and (body, world object) pairs that are checked. Never checked: bodies
  on the same joint (rigidly attached), bodies on neighbouring joints (adjacent, as MoveIt counts
  them: a fixed link is adjacent to whatever its parent is adjacent to), pairs an SRDF disables, and
  pairs found in contact in (almost) every random configuration (MoveIt's "always"). The optimiser
  also leaves out pairs never near each other in random configurations (MoveIt's "never"), and
  pairs that its own bounds put within the clearance plus its margin in (almost) every random
  configuration (parts built that close: no motion keeps them further apart, so no start would be
  feasible); the exact check of the final motion still checks both.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from lwrlab.dynamics.base_parameters import random_states
from lwrlab.excitation.scene_bodies import fitted_spheres, world_from_shapes
from lwrlab.kinematics.tree import JointAxis, joint_axes, joint_poses, posed_points
from lwrlab.model.collision import CollisionSphere
from lwrlab.model.collision_geometry import (
    CollisionGeometryError,
    RobotGeometry,
    load_robot_geometry,
)
from lwrlab.model.robot import RobotModel
from lwrlab.model.world import WorldObject

log = logging.getLogger(__name__)

ALWAYS_IN_CONTACT = 0.95
"""A pair in contact in at least this fraction of random configurations is never checked (MoveIt)."""
NEVER_NEAR = 0.05
"""The optimiser leaves out pairs whose spheres stay this far (m) beyond the clearance in every sample."""
HULL_FRACTION = 0.2
"""Pairs whose spheres come that near in at least this fraction of the samples are measured between
convex hulls by the optimiser (the spheres' overshoot would make them look in contact)."""


@dataclass(frozen=True)
class CollisionScene:
    """Bodies, their spheres, the world and the pairs to check (module docstring)."""

    robot: RobotModel
    bodies: tuple[str, ...]
    """Body names: URDF links, or hand-written sphere names."""
    body_joints: np.ndarray
    """(B,) the joint moving each body (0: fixed to the base)."""
    spheres: tuple[CollisionSphere, ...]
    """Enclosing spheres; ``link`` is the joint moving them, ``body`` their body."""
    sphere_bodies: np.ndarray
    """(S,) body index of each sphere."""
    world: tuple[WorldObject, ...]
    self_pairs: tuple[tuple[int, int], ...]
    """Body pairs the optimiser keeps apart."""
    world_pairs: tuple[tuple[int, int], ...]
    """(body, world object) pairs the optimiser keeps apart."""
    checked_self_pairs: tuple[tuple[int, int], ...]
    """Body pairs the exact check checks (a superset of ``self_pairs``)."""
    checked_world_pairs: tuple[tuple[int, int], ...]
    geometry: RobotGeometry | None = None
    """The exact geometry (None: the hand-written spheres are the robot's collision model)."""
    notes: tuple[str, ...] = field(default_factory=tuple)
    """What was left out and why, for the report."""
    axes: tuple[JointAxis, ...] = field(default_factory=tuple)
    hull_pairs: frozenset[tuple[str, tuple[int, int]]] = frozenset()
    """(family, pair) whose spheres come within the clearance in many random configurations: the
    optimiser measures them between convex hulls (:mod:`lwrlab.excitation.sphere_distances`)."""

    @property
    def radii(self) -> np.ndarray:
        return np.array([s.radius for s in self.spheres])

    def sphere_centres(self, poses: np.ndarray) -> np.ndarray:
        """(S, N, 3) sphere centres (m, base frame) from joint poses (N_J, N, 4, 4)."""
        links = np.array([s.link for s in self.spheres], dtype=int)
        centers = np.array([s.center for s in self.spheres]).reshape(-1, 3)
        return posed_points(centers, links, poses)

    def poses(self, q: np.ndarray) -> np.ndarray:
        """(N_J, N, 4, 4) joint poses at q (N, N_J)."""
        return joint_poses(self.robot.model, q, self.axes)

    def pair_label(self, family: str, pair: tuple[int, int]) -> str:
        a, b = pair
        return f"{self.bodies[a]}–{self.world[b].name if family == 'world' else self.bodies[b]}"


def _adjacent(robot: RobotModel, a: int, b: int) -> bool:
    """Bodies on the same joint or on a joint and its parent (MoveIt's adjacency, fixed links merged)."""
    parents = robot.model.parents
    return a == b or parents[b] == a or parents[a] == b


_CACHE: dict[tuple[int, str], CollisionScene] = {}
"""Scenes already built, by robot and settings: loading and fitting the geometry and sampling the
pairs costs a second; the optimiser, the grid check and the 1 kHz check share one scene."""


def build_scene(
    robot: RobotModel,
    world: tuple[WorldObject, ...],
    **settings: Any,
) -> CollisionScene:
    """The collision scene of ``robot`` in ``world`` (module docstring), once per robot object and
    settings: :func:`sampled_scene`'s settings, and ``distance_margin`` (m), what the optimiser keeps
    free beyond the clearance (:func:`separable_scene`). The pairs are sampled once for every
    ``distance_margin`` (the optimiser's scene and the exact check's differ only by it)."""
    scene = _cached(robot, world, settings)
    if scene is None:
        sampling = {k: v for k, v in settings.items() if k != "distance_margin"}
        stage = {**sampling, "stage": "sampled"}  # a key of its own, whatever the settings
        sampled = _cached(robot, world, stage)
        if sampled is None:
            sampled = _store(robot, world, stage, sampled_scene(robot, world, **sampling))
        scene = _store(
            robot,
            world,
            settings,
            separable_scene(sampled, settings.get("distance_margin", 0.0), len(world), **sampling),
        )
    return scene


def _key(robot: RobotModel, world: tuple[WorldObject, ...], settings: dict[str, Any]) -> tuple[int, str]:
    described = [(w.name, w.shape, w.pose.tobytes(), w.size.tobytes()) for w in world]
    return id(robot), repr((sorted(settings.items()), described))


def _cached(
    robot: RobotModel, world: tuple[WorldObject, ...], settings: dict[str, Any]
) -> CollisionScene | None:
    scene = _CACHE.get(_key(robot, world, settings))
    return scene if scene is not None and scene.robot is robot else None


def _store(
    robot: RobotModel, world: tuple[WorldObject, ...], settings: dict[str, Any], scene: CollisionScene
) -> CollisionScene:
    if len(_CACHE) >= 8:
        _CACHE.pop(next(iter(_CACHE)))
    _CACHE[_key(robot, world, settings)] = scene
    return scene


def separable_scene(
    sampled: CollisionScene,
    distance_margin: float,
    n_configured: int,
    *,
    clearance: float,
    n_samples: int = 500,
    seed: int = 0,
    **_sampling: Any,
) -> CollisionScene:
    """:func:`sampled_scene`'s pairs less those the optimiser cannot keep ``clearance + distance_margin``
    apart (:func:`_unseparable_left_to_the_check`); the first ``n_configured`` world objects are the
    configuration's (kept). Takes :func:`sampled_scene`'s settings (those it does not read ignored)."""
    if not sampled.spheres or (not sampled.checked_self_pairs and not sampled.checked_world_pairs):
        return sampled
    return _unseparable_left_to_the_check(sampled, clearance + distance_margin, n_samples, seed, n_configured)


def sampled_scene(
    robot: RobotModel,
    world: tuple[WorldObject, ...],
    *,
    ground_spheres: tuple[str, ...] | None,
    min_link_gap: int,
    clearance: float,
    self_collision: bool,
    n_samples: int = 500,
    seed: int = 0,
) -> CollisionScene:
    """The scene's bodies, world and pairs, pruned by sampling (:func:`_prune_by_sampling`).

    ``ground_spheres`` and ``min_link_gap`` serve robots described by hand-written spheres only:
    the spheres kept off the world (None: all but those on the base and joint 1) and the least joint
    gap between spheres kept apart.
    """
    geometry: RobotGeometry | None = None
    world_objects = list(world)
    notes: list[str] = []
    axes = joint_axes(robot.model)
    if robot.collision_source is not None and robot.collision_spheres:
        try:  # a described robot may fall back on its spheres (e.g. without the optional robot data)
            geometry = load_robot_geometry(robot.collision_source, robot.model)
        except CollisionGeometryError as error:
            log.warning("%s: %s; its collision spheres stand for its geometry instead", robot.name, error)
    elif robot.collision_source is not None:
        geometry = load_robot_geometry(robot.collision_source, robot.model)
    if geometry is not None:
        fixed_primitives = tuple(
            s
            for s in geometry.shapes
            if s.joint == 0 and type(s.geometry).__name__ in ("Box", "Sphere", "Cylinder")
        )
        taken = {w.name for w in world}
        world_objects += [  # a configured obstacle may share a URDF link's name: keep the names apart
            replace(o, name=f"{o.name} (URDF)") if o.name in taken else o
            for o in world_from_shapes(fixed_primitives)
        ]
        links = [
            link
            for link in geometry.links
            if any(s not in fixed_primitives for s in geometry.shapes_of(link))
        ]
        spheres = fitted_spheres(geometry, links)
        bodies = tuple(dict.fromkeys(s.body for s in spheres))
        body_joints = np.array([geometry.link_joint(b) for b in bodies])
    else:
        spheres = list(robot.collision_spheres)
        unknown = [n for n in ground_spheres or () if n not in {s.name for s in spheres}]
        if spheres and unknown:
            raise ValueError(
                f"ground_spheres {unknown} are not collision spheres of {robot.name}; its spheres: "
                f"{[s.name for s in spheres]} (set trajectory.constraints.ground_spheres to some of them, "
                "or null for all)"
            )
        bodies = tuple(s.body for s in spheres)
        body_joints = np.array([s.link for s in spheres], dtype=int)
    sphere_bodies = np.array([bodies.index(s.body) for s in spheres], dtype=int)

    # candidate pairs
    candidates_self: list[tuple[int, int]] = []
    for a in range(len(bodies)):
        for b in range(a + 1, len(bodies)):
            ja, jb = int(body_joints[a]), int(body_joints[b])
            if ja == 0 and jb == 0:
                continue
            if geometry is not None:
                if _adjacent(robot, ja, jb):
                    continue
                if frozenset((bodies[a], bodies[b])) in geometry.disabled_pairs:
                    continue
            elif abs(ja - jb) < min_link_gap:
                continue
            candidates_self.append((a, b))
    if not self_collision:
        candidates_self = []
    fixed_world = set(range(len(world), len(world_objects)))  # the URDF's fixed links, after the config's
    candidates_world: list[tuple[int, int]] = []
    for a in range(len(bodies)):
        ja = int(body_joints[a])
        if ja == 0:
            continue
        if geometry is None and ground_spheres is not None and bodies[a] not in ground_spheres:
            continue
        for w in range(len(world_objects)):
            if w in fixed_world and robot.model.parents[ja] == 0:
                continue  # the URDF's fixed links are adjacent to the first moving link
            candidates_world.append((a, w))

    scene = CollisionScene(
        robot, bodies, body_joints, tuple(spheres), sphere_bodies, tuple(world_objects),
        tuple(candidates_self), tuple(candidates_world), tuple(candidates_self), tuple(candidates_world),
        geometry, (), axes,
    )  # fmt: skip
    if not spheres or (not candidates_self and not candidates_world):
        return scene
    return _prune_by_sampling(scene, clearance, n_samples, seed, notes, set(range(len(world))))


def _prune_by_sampling(
    scene: CollisionScene,
    clearance: float,
    n_samples: int,
    seed: int,
    notes: list[str],
    configured_world: set[int],
) -> CollisionScene:
    """Drop pairs (almost) always in contact, and, for the optimiser, pairs never near.

    A configured world object (the mounting surface, an obstacle) always in contact with a body is
    dropped only when no motion changes their distance (a base link standing on the surface); else
    the user's world leaves no room and the optimiser must say so."""
    from lwrlab.excitation.sphere_distances import SphereDistances

    q, _, _ = random_states(scene.robot, n_samples, np.random.default_rng(seed))
    distances = SphereDistances(scene)
    poses = scene.poses(q)
    self_d = distances.self_distances(scene.checked_self_pairs, poses)[0]  # (N, pairs)
    world_d = distances.world_distances(scene.checked_world_pairs, poses)[0]
    kept: dict[str, list[tuple[int, int]]] = {"self": [], "world": [], "self_opt": [], "world_opt": []}
    hulls: set[tuple[str, tuple[int, int]]] = set()
    for family, pairs, values in (
        ("self", scene.checked_self_pairs, self_d),
        ("world", scene.checked_world_pairs, world_d),
    ):
        for c, pair in enumerate(pairs):
            column = values[:, c]
            rigid = np.ptp(column) < 1e-9  # no motion changes it (e.g. a link turning about the vertical)
            if rigid and scene.geometry is None:
                continue
            contact = (
                distances.exact_contact_fraction(family, pair, poses, column, clearance)
                if scene.geometry is not None
                else float(np.mean(column < clearance))
            )
            label = scene.pair_label(family, pair)
            configured = family == "world" and pair[1] in configured_world
            if contact >= ALWAYS_IN_CONTACT and (not configured or rigid):
                # the robot's own structure (or a link standing on the mounting surface): not a motion's doing
                notes.append(
                    f"{label}: in contact in {100 * contact:.0f} % of random configurations, not checked"
                )
                continue
            kept[family].append(pair)
            if scene.geometry is None or (not rigid and column.min() < clearance + NEVER_NEAR):
                kept[f"{family}_opt"].append(pair)
                if scene.geometry is not None and np.mean(column < clearance + NEVER_NEAR) >= HULL_FRACTION:
                    hulls.add((family, pair))
    return CollisionScene(
        scene.robot, scene.bodies, scene.body_joints, scene.spheres, scene.sphere_bodies, scene.world,
        tuple(kept["self_opt"]), tuple(kept["world_opt"]), tuple(kept["self"]), tuple(kept["world"]),
        scene.geometry, tuple(notes), scene.axes, frozenset(hulls),
    )  # fmt: skip


def _unseparable_left_to_the_check(
    scene: CollisionScene, padding: float, n_samples: int, seed: int, n_configured: int
) -> CollisionScene:
    """Leave to the exact check the optimiser's pairs that its own bounds (spheres, hulls) put within
    ``padding`` (the clearance and the optimiser's margin) in almost every random configuration:
    parts built that close, which no motion keeps further apart (the optimiser would find no feasible
    start). The configured world (the mounting surface, obstacles) is the user's and stays."""
    if scene.geometry is None or not (scene.self_pairs or scene.world_pairs):
        return scene
    from lwrlab.excitation.sphere_distances import SphereDistances

    q, _, _ = random_states(scene.robot, n_samples, np.random.default_rng(seed))
    distances = SphereDistances(scene)
    distances.use_hulls = True  # as the optimiser measures
    poses = scene.poses(q)
    notes = list(scene.notes)
    kept: dict[str, tuple[tuple[int, int], ...]] = {}
    for family, pairs in (("self", scene.self_pairs), ("world", scene.world_pairs)):
        values = distances.pair_distances(family, pairs, poses, q)[0]
        within = (values < padding).mean(axis=0)
        kept[family] = tuple(
            pair
            for pair, share in zip(pairs, within, strict=True)
            if share < ALWAYS_IN_CONTACT or (family == "world" and pair[1] < n_configured)
        )
        for c, pair in enumerate(pairs):
            if pair not in kept[family]:
                notes.append(
                    f"{scene.pair_label(family, pair)}: within {100 * padding:.2g} cm (the clearance and "
                    f"the optimiser's margin) in {100 * within[c]:.0f} % of random configurations as the "
                    f"optimiser bounds it (closest {100 * values[:, c].min():.2g} cm): built that close, "
                    "not kept apart by the optimiser; the exact check still keeps it at the clearance"
                )
    if len(notes) == len(scene.notes):
        return scene
    return replace(scene, self_pairs=kept["self"], world_pairs=kept["world"], notes=tuple(notes))


def posed_meshes(scene: CollisionScene, q: np.ndarray) -> list[tuple[str, np.ndarray, np.ndarray, bool]]:
    """(name, vertices (V, 3) in the base frame, faces (F, 3), is_world) of every body and world object at
    one configuration q (N_J,): the robot's meshes (or its spheres), for pictures."""
    from lwrlab.model.collision_geometry import sphere_mesh

    poses = scene.poses(np.atleast_2d(q))[:, 0]
    out = []
    for b, name in enumerate(scene.bodies):
        joint = int(scene.body_joints[b])
        pose = np.eye(4) if joint == 0 else poses[joint - 1]
        if scene.geometry is not None:
            shapes = scene.geometry.shapes_of(name)
            vertices = np.vstack([s.vertices_in_joint_frame() for s in shapes])
            offsets = np.cumsum([0] + [len(s.vertices) for s in shapes[:-1]])
            faces = np.vstack([s.faces + o for s, o in zip(shapes, offsets, strict=True)])
        else:
            sphere = scene.spheres[int(np.flatnonzero(scene.sphere_bodies == b)[0])]
            vertices, faces = sphere_mesh(sphere.radius, 12)
            vertices = vertices + sphere.center
        out.append((name, vertices @ pose[:3, :3].T + pose[:3, 3], faces, joint == 0))
    out += [(w.name, w.vertices, w.faces, True) for w in scene.world if w.shape != "plane"]
    return out
