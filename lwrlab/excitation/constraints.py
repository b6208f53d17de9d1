"""The constraints of the excitation problem, eq. (10)–(11), vectorised over the samples.

Each *family* (position, velocity, acceleration, torque, world, self_collision) gives, for every
sample at once, a matrix of slacks ``s[k, c] ≥ 0`` when satisfied, in physical units (rad, rad/s,
rad/s², N·m, m), and the derivative of the slack of chosen (sample, column) pairs with respect to
q, q̇, q̈ at that sample. The problem (:mod:`lwrlab.excitation.problem`) divides slacks by a scale per
column, aggregates each column over time windows (the window's smallest slack) and chains the
derivatives to the trajectory parameters. Boundary conditions (rest at both ends) hold by
construction of the parameterisations and are not constraints here.

* position, velocity, acceleration: ``x⁺_j·(1 − margin) ∓ x_j``, two columns per joint (position:
  per joint with position limits; a continuous joint turns freely and has none);
* torque: ``Γ⁺_j·(1 − margin) ∓ Γ_j`` with Γ the CAD model's inverse dynamics with friction;
* world: ``d − clearance − margin`` for each (body, world object) pair of the collision scene (the
  mounting surface, obstacles, the URDF's fixed links), d the distance of the body's enclosing
  spheres to the object;
* self_collision: ``d − clearance − margin`` for each body pair of the scene, d the smallest gap
  between their spheres (:mod:`lwrlab.excitation.collision_scene`).

The margins keep the 100 Hz optimum feasible between its samples; the final check of a motion
(:func:`lwrlab.excitation.solver.verify_motion`) sets them to zero, and
:mod:`lwrlab.excitation.collision_check` checks the exact geometry at every sample.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
import pinocchio as pin

from lwrlab.excitation.collision_scene import CollisionScene, build_scene
from lwrlab.excitation.distance_columns import (
    NearestMembers,
    column_derivatives,
    column_distances,
    distance_columns,
)
from lwrlab.excitation.mounting import describe_surface, resolve_surface
from lwrlab.excitation.sphere_distances import SphereDistances
from lwrlab.model.position_ranges import range_center, range_span, unbounded
from lwrlab.model.robot import RobotModel
from lwrlab.model.world import WorldObject, build_world

log = logging.getLogger(__name__)

FAMILIES = ("position", "velocity", "acceleration", "torque", "world", "self_collision")


@dataclass(frozen=True)
class ConstraintSettings:
    """What the exciting motion must respect besides its parameterisation's boundary conditions.

    Every field but ``world`` is required: the ``constraints`` node of conf/trajectory/optimal.yaml
    gives their values.

    Parameters
    ----------
    limit_margin : fraction of every joint limit (position range, velocity, acceleration, torque)
        kept free: the optimisation samples at 100 Hz, the robot plays 1 kHz.
    torque : constrain the CAD model's joint torques (with friction) to the torque limits.
    world : ``{mounting_surface: {height, normal} | null | auto, obstacles: [...]}``
        (:mod:`lwrlab.model.world`; ``auto``: :mod:`lwrlab.excitation.mounting`); the robot's bodies
        stay ``clearance`` away from them.
    ground_spheres : for a robot described by hand-written collision spheres only: the spheres kept
        off the world (null: all).
    self_collision : keep the robot's bodies apart.
    clearance : distance (m) kept between bodies, and between bodies and the world, by the
        optimiser and by the exact check (a padding of the geometry).
    distance_margin : distance (m) kept free on top of the clearance during the optimisation (what
        ``limit_margin`` is to the limits).
    min_link_gap : for hand-written spheres: spheres on segments fewer joints apart are never checked.
    pair_samples : random configurations that choose the pairs to check (always in contact: never
        checked; never near: left to the exact check).
    """

    limit_margin: float
    torque: bool
    ground_spheres: tuple[str, ...] | None
    self_collision: bool
    clearance: float
    distance_margin: float
    min_link_gap: int
    world: Mapping[str, Any] = field(default_factory=lambda: {"mounting_surface": {"height": 0.0}})
    pair_samples: int = 300

    def __post_init__(self) -> None:
        if not 0.0 <= self.limit_margin < 1.0:
            raise ValueError(f"limit_margin must be in [0, 1), got {self.limit_margin}")
        if self.clearance < 0 or self.distance_margin < 0:
            raise ValueError("clearance and distance_margin must be ≥ 0")
        if self.ground_spheres is not None:
            object.__setattr__(self, "ground_spheres", tuple(self.ground_spheres))
        unknown = set(self.world or {}) - {"mounting_surface", "obstacles"}
        if unknown:
            raise ValueError(
                f"trajectory.constraints.world: unknown keys {sorted(unknown)} (mounting_surface, obstacles)"
            )

    def scene(self, robot: RobotModel) -> CollisionScene:
        """The collision scene of ``robot`` with these settings (built once per robot and settings)."""
        return build_scene(
            robot,
            self.world_objects(robot),
            ground_spheres=self.ground_spheres,
            min_link_gap=self.min_link_gap,
            clearance=self.clearance,
            self_collision=self.self_collision,
            n_samples=self.pair_samples,
            distance_margin=self.distance_margin,
        )

    def world_objects(self, robot: RobotModel | None = None) -> tuple[WorldObject, ...]:
        """The mounting surface (:meth:`mounting_surface`) and obstacles of ``world``."""
        world = dict(self.world or {})
        obstacles: Sequence[Mapping[str, Any]] = world.get("obstacles") or ()
        return build_world(self.mounting_surface(robot), obstacles)

    def mounting_surface(self, robot: RobotModel | None = None) -> dict[str, Any] | None:
        """``{height, normal}`` of the surface ``robot`` stands on, or None
        (:func:`~lwrlab.excitation.mounting.resolve_surface`)."""
        return resolve_surface((self.world or {}).get("mounting_surface"), robot)

    def describe_world(self, robot: RobotModel) -> str:
        """One line for the run's log and report: the surface the motion keeps clear of, and how many
        obstacles."""
        mounting = (self.world or {}).get("mounting_surface")
        line = describe_surface(mounting, self.mounting_surface(robot), robot.mounted_on)
        obstacles = len((self.world or {}).get("obstacles") or ())
        return line + (f"; {obstacles} obstacle(s)" if obstacles else "")


class ConstraintSet:
    """The constraint families of one robot and settings: slacks on samples, and their derivatives."""

    def __init__(
        self,
        robot: RobotModel,
        settings: ConstraintSettings,
        coulomb_smoothing: float | None = None,
        scene: CollisionScene | None = None,
    ) -> None:
        self.robot = robot
        self.settings = settings
        self.coulomb_smoothing = coulomb_smoothing
        """ε (rad/s) of the ``tanh(q̇/ε)`` that stands for ``sign(q̇)`` in the torques whose derivatives are
        asked (None: the exact sign, whose derivative is zero)."""
        self.scene: CollisionScene = scene if scene is not None else settings.scene(robot)
        if not self.scene.spheres:
            log.warning(
                "%s has no collision model (no <collision> geometry, no collision spheres): the exciting "
                "motion is not kept clear of itself or of the world",
                robot.name,
            )
        self.distances = SphereDistances(self.scene)
        self.distances.use_hulls = True
        self.distance_columns = {
            "world": distance_columns(self.scene, "world"),
            "self_collision": distance_columns(self.scene, "self"),
        }
        """The columns of the distance families (:mod:`lwrlab.excitation.distance_columns`)."""
        lim = robot.limits
        keep = 1.0 - settings.limit_margin
        free = unbounded(lim.position_lower, lim.position_upper)
        self.bounded_joints = np.flatnonzero(~free)
        """Indices of the joints with position limits: the columns of the position family."""
        middle = range_center(lim.position_lower, lim.position_upper)
        half = 0.5 * range_span(lim.position_lower, lim.position_upper)
        self.position_bounds = (
            np.where(free, -np.inf, middle - keep * half),
            np.where(free, np.inf, middle + keep * half),
        )
        """(low, high) rad: the positions the motion keeps within, ±inf for a continuous joint."""
        self._position_half_range = half
        self._friction_viscous = (
            robot.friction.viscous if "viscous" in robot.friction_terms else np.zeros(robot.n_joints)
        )
        self._data = robot.model.createData()
        self._nearest: dict[str, NearestMembers] = {}
        """Each distance family's nearest member pairs as its last slacks found them: the derivatives at
        the same configurations need not measure them again."""

    # --- layout ---------------------------------------------------------------------------------

    def families(self) -> list[str]:
        """The active families, in order."""
        active = ["position"] if self.bounded_joints.size else []
        active += ["velocity", "acceleration"]
        if self.settings.torque:
            active.append("torque")
        if self.scene.world_pairs:
            active.append("world")
        if self.scene.self_pairs:
            active.append("self_collision")
        return active

    def column_labels(self, family: str) -> list[str]:
        """What each slack column of a family is, e.g. ``joint 3 upper`` or ``elbow–flange``."""
        n = self.robot.n_joints
        if family == "position":
            return [f"joint {j + 1} {side}" for side in ("lower", "upper") for j in self.bounded_joints]
        if family in ("velocity", "acceleration", "torque"):
            return [f"joint {j + 1} {side}" for side in ("lower", "upper") for j in range(n)]
        return list(self.distance_columns[family].labels)

    def scales(self, family: str) -> np.ndarray:
        """Per-column scale dividing the slacks (the limit, or 1 m for distances), so all are O(1)."""
        lim = self.robot.limits
        per_joint = {
            "position": self._position_half_range[self.bounded_joints],
            "velocity": lim.velocity,
            "acceleration": lim.acceleration,
            "torque": lim.torque,
        }
        if family in per_joint:
            return np.tile(per_joint[family], 2)
        return np.ones(len(self.column_labels(family)))

    def margin(self, family: str) -> float:
        """The margin of a family's scaled slacks: a scaled slack above minus it keeps the true limit
        (a fraction of it) or the clearance itself (m)."""
        if family in ("world", "self_collision"):
            return self.settings.distance_margin
        return self.settings.limit_margin

    UNITS: ClassVar[dict[str, str]] = {
        "position": "rad",
        "velocity": "rad/s",
        "acceleration": "rad/s²",
        "torque": "N·m",
        "world": "m",
        "self_collision": "m",
    }

    # --- values ---------------------------------------------------------------------------------

    def slacks(
        self,
        q: np.ndarray,
        dq: np.ndarray,
        ddq: np.ndarray,
        torque: np.ndarray | None = None,
        collisions: bool = True,
        windows: np.ndarray | None = None,
    ) -> dict[str, np.ndarray]:
        """Slack of every family at every sample, (N, columns) each, in physical units (≥ 0: satisfied).

        ``torque`` (N, N_J) may be passed when already known (e.g. ``W·φ``); otherwise it is computed.
        With ``windows`` (the first sample of each), a distance column that merges pairs is exact only
        where it may be its window's smallest, and a lower bound above that elsewhere: its windows'
        minima and where they are reached are exact (:mod:`lwrlab.excitation.distance_columns`).
        """
        lim, keep = self.robot.limits, 1.0 - self.settings.limit_margin
        low, high = (bound[self.bounded_joints] for bound in self.position_bounds)
        bounded = q[:, self.bounded_joints]
        out = {"position": np.hstack([bounded - low, high - bounded])} if self.bounded_joints.size else {}
        out |= {
            "velocity": np.hstack([keep * lim.velocity + dq, keep * lim.velocity - dq]),
            "acceleration": np.hstack([keep * lim.acceleration + ddq, keep * lim.acceleration - ddq]),
        }
        if self.settings.torque:
            torque = self.robot.inverse_dynamics(q, dq, ddq) if torque is None else torque
            out["torque"] = np.hstack([keep * lim.torque + torque, keep * lim.torque - torque])
        if collisions and (self.scene.world_pairs or self.scene.self_pairs):
            poses = self.scene.poses(q)
            centres = self.distances._centres(poses) if windows is not None else None  # both families'
            offset = self.settings.clearance + self.settings.distance_margin
            for family, columns in self.distance_columns.items():
                if columns.columns:
                    distances, self._nearest[family] = column_distances(
                        self.distances, columns, poses, q, windows, centres
                    )
                    out[family] = distances - offset
        return out

    # --- derivatives ----------------------------------------------------------------------------

    def slack_derivatives(
        self,
        family: str,
        q: np.ndarray,
        dq: np.ndarray,
        ddq: np.ndarray,
        samples: np.ndarray,
        columns: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """∂slack/∂(q, q̇, q̈) at (sample, column) pairs: three (m, N_J) arrays (per rad, rad/s, rad/s²)."""
        n = self.robot.n_joints
        m = len(samples)
        zeros = np.zeros((m, n))
        if family in ("position", "velocity", "acceleration"):
            joints = self.bounded_joints if family == "position" else np.arange(n)
            joint, sign = joints[columns % joints.size], np.where(columns < joints.size, 1.0, -1.0)
            d = zeros.copy()
            d[np.arange(m), joint] = sign
            return (
                (d, zeros, zeros)
                if family == "position"
                else (zeros, d, zeros)
                if family == "velocity"
                else (zeros, zeros, d)
            )
        if family == "torque":
            return self._torque_derivatives(q, dq, ddq, samples, columns)
        d_q = column_derivatives(
            self.distances, self.distance_columns[family], q, samples, columns, self._nearest.get(family)
        )
        return d_q, zeros, zeros

    def _torque_derivatives(
        self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, samples: np.ndarray, columns: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``∓∂Γ_j/∂(q, q̇, q̈)`` by Pinocchio's RNEA derivatives, once per distinct sample, plus viscous
        friction."""
        n = self.robot.n_joints
        model, data = self.robot.model, self._data
        unique, inverse = np.unique(samples, return_inverse=True)
        d_q, d_v, d_a = (np.empty((len(unique), n, n)) for _ in range(3))
        for u, k in enumerate(unique):
            pin.computeRNEADerivatives(model, data, q[k], dq[k], ddq[k])
            d_q[u], d_v[u], d_a[u] = data.dtau_dq, data.dtau_dv, data.M
        d_a = np.triu(d_a) + np.triu(d_a, 1).transpose(0, 2, 1)  # Pinocchio fills the upper triangle
        d_v += np.diag(self._friction_viscous)
        if self.coulomb_smoothing and "coulomb" in self.robot.friction_terms:
            slope = (1.0 - np.tanh(dq[unique] / self.coulomb_smoothing) ** 2) / self.coulomb_smoothing
            d_v += np.einsum("uj,jl->ujl", slope * self.robot.friction.coulomb, np.eye(n))
        joint, sign = columns % n, np.where(columns < n, 1.0, -1.0)[:, None]
        return sign * d_q[inverse, joint], sign * d_v[inverse, joint], sign * d_a[inverse, joint]
