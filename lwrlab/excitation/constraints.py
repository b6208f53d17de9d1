"""The constraints of the excitation problem, eq. (10)–(11), vectorised over the samples.

Each *family* (position, velocity, acceleration, torque, ground, self_collision) gives, for every
sample at once, a matrix of slacks ``s[k, c] ≥ 0`` when satisfied, in physical units (rad, rad/s,
rad/s², N·m, m), and the derivative of the slack of chosen (sample, column) pairs with respect to
q, q̇, q̈ at that sample. The problem (:mod:`lwrlab.excitation.problem`) divides slacks by a scale per
column, aggregates each column over time windows (the window's smallest slack) and chains the
derivatives to the trajectory parameters. Boundary conditions (rest at both ends) hold by
construction of the parameterisations and are not constraints here.

* position, velocity, acceleration: ``x⁺_j·(1 − margin) ∓ x_j``, two columns per joint;
* torque: ``Γ⁺_j·(1 − margin) ∓ Γ_j`` with Γ the CAD model's inverse dynamics with friction;
* ground: ``z_c − r − z_ground − margin`` for the centre c and radius r of each sphere named in
  ``ground_spheres`` (the elbow and the wrist);
* self_collision: ``‖c_a − c_b‖ − r_a − r_b − clearance − margin`` for every relevant pair of spheres.

The margins keep the 100 Hz optimum feasible between its samples; the final check of a motion
(:func:`lwrlab.excitation.solver.verify_motion`) sets them to zero.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from itertools import combinations
from typing import ClassVar

import numpy as np
import pinocchio as pin

from lwrlab.dynamics.base_parameters import random_states
from lwrlab.kinematics.forward import joint_frame_poses
from lwrlab.model.collision import CollisionSphere
from lwrlab.model.robot import RobotModel

log = logging.getLogger(__name__)

FAMILIES = ("position", "velocity", "acceleration", "torque", "ground", "self_collision")


@dataclass(frozen=True)
class ConstraintSettings:
    """What the exciting motion must respect besides its parameterisation's boundary conditions.

    Every field is required: the ``constraints`` node of conf/trajectory/optimal.yaml gives their values.

    Parameters
    ----------
    limit_margin : fraction of every joint limit (position range, velocity, acceleration, torque)
        kept free: the optimisation samples at 100 Hz, the robot plays 1 kHz.
    torque : constrain the CAD model's joint torques (with friction) to the torque limits.
    z_ground : height (m, base frame) of the virtual floor the ground spheres stay above.
    ground_spheres : names of the robot's collision spheres kept above the floor (elbow, wrist).
    self_collision : keep relevant pairs of collision spheres apart.
    clearance : extra distance (m) between sphere surfaces.
    distance_margin : distance (m) kept free on top of the ground and self-collision constraints
        during the optimisation (what ``limit_margin`` is to the limits).
    min_link_gap : spheres on segments fewer joints apart than this are never checked (neighbours
        touch at their joint).
    """

    limit_margin: float
    torque: bool
    z_ground: float | None
    ground_spheres: tuple[str, ...]
    self_collision: bool
    clearance: float
    distance_margin: float
    min_link_gap: int

    def __post_init__(self) -> None:
        if not 0.0 <= self.limit_margin < 1.0:
            raise ValueError(f"limit_margin must be in [0, 1), got {self.limit_margin}")
        object.__setattr__(self, "ground_spheres", tuple(self.ground_spheres))


def relevant_pairs(
    robot: RobotModel, min_link_gap: int, n_samples: int = 200, seed: int = 0
) -> list[tuple[int, int]]:
    """Sphere pairs worth checking: segments ≥ ``min_link_gap`` joints apart, distance not constant.

    A pair whose distance never changes (both centres on the axis chain between them, e.g. the
    shoulder and the elbow) is rigid: no motion can bring it closer, so it is not a constraint.
    """
    spheres = robot.collision_spheres
    q, _, _ = random_states(robot, n_samples, np.random.default_rng(seed))
    centres = sphere_centres(robot, q, spheres)
    pairs = []
    for a, b in combinations(range(len(spheres)), 2):
        if abs(spheres[a].link - spheres[b].link) < min_link_gap:
            continue
        distance = np.linalg.norm(centres[a] - centres[b], axis=1)
        if np.ptp(distance) > 1e-9:
            pairs.append((a, b))
    return pairs


def sphere_centres(
    robot: RobotModel, q: np.ndarray, spheres: tuple[CollisionSphere, ...], poses: np.ndarray | None = None
) -> np.ndarray:
    """(n_spheres, N, 3) centres in the base frame (m) at joint positions q (N, N_J)."""
    poses = joint_frame_poses(robot, q) if poses is None else poses
    out = np.empty((len(spheres), q.shape[0], 3))
    for s, sphere in enumerate(spheres):
        if sphere.link == 0:
            out[s] = sphere.center
        else:
            pose = poses[sphere.link - 1]
            out[s] = pose[:, :3, :3] @ sphere.center + pose[:, :3, 3]
    return out


def _point_jacobian(poses: np.ndarray, link: int, point: np.ndarray, n_joints: int) -> np.ndarray:
    """(N, 3, N_J) ∂point/∂q for points (N, 3) fixed to segment ``link``: ``z_l × (p − o_l)``, l ≤ link."""
    jac = np.zeros((point.shape[0], 3, n_joints))
    if link:
        frames = np.asarray(poses[:link])  # (link, N, 4, 4)
        axis, lever = frames[..., :3, 2], point - frames[..., :3, 3]  # (link, N, 3): one cross for all joints
        jac[:, :, :link] = np.cross(axis, lever).transpose(1, 2, 0)
    return jac


class ConstraintSet:
    """The constraint families of one robot and settings: slacks on samples, and their derivatives."""

    def __init__(
        self, robot: RobotModel, settings: ConstraintSettings, coulomb_smoothing: float | None = None
    ) -> None:
        self.robot = robot
        self.settings = settings
        self.coulomb_smoothing = coulomb_smoothing
        """ε (rad/s) of the ``tanh(q̇/ε)`` that stands for ``sign(q̇)`` in the torques whose derivatives are
        asked (None: the exact sign, whose derivative is zero)."""
        spheres = robot.collision_spheres
        names = [s.name for s in spheres]
        self.ground_indices: list[int] = []
        if settings.z_ground is not None and settings.ground_spheres and not names:
            # a robot described without collision geometry (a plain URDF): nothing to keep off the floor
            log.warning(
                "%s has no collision spheres: "
                "the exciting motion is not kept above the floor or free of self-collision",
                robot.name,
            )
        elif settings.z_ground is not None and settings.ground_spheres:
            unknown = [name for name in settings.ground_spheres if name not in names]
            if unknown:
                raise ValueError(
                    f"ground_spheres {unknown} are not collision spheres of {robot.name}; "
                    f"its spheres: {names} "
                    "(add a collision_spheres block to the robot config, or set z_ground: null)"
                )
            self.ground_indices = [names.index(name) for name in settings.ground_spheres]
        self.pairs = (
            relevant_pairs(robot, settings.min_link_gap) if settings.self_collision and spheres else []
        )
        lim = robot.limits
        keep = 1.0 - settings.limit_margin
        middle = 0.5 * (lim.position_lower + lim.position_upper)
        half = 0.5 * (lim.position_upper - lim.position_lower)
        self.position_bounds = (middle - keep * half, middle + keep * half)
        self._friction_viscous = (
            robot.friction.viscous if "viscous" in robot.friction_terms else np.zeros(robot.n_joints)
        )
        self._data = robot.model.createData()

    # --- layout ---------------------------------------------------------------------------------

    def families(self) -> list[str]:
        """The active families, in order."""
        active = ["position", "velocity", "acceleration"]
        if self.settings.torque:
            active.append("torque")
        if self.ground_indices:
            active.append("ground")
        if self.pairs:
            active.append("self_collision")
        return active

    def column_labels(self, family: str) -> list[str]:
        """What each slack column of a family is, e.g. ``joint 3 upper`` or ``elbow–flange``."""
        n = self.robot.n_joints
        if family in ("position", "velocity", "acceleration", "torque"):
            return [f"joint {j + 1} {side}" for side in ("lower", "upper") for j in range(n)]
        spheres = self.robot.collision_spheres
        if family == "ground":
            return [spheres[i].name for i in self.ground_indices]
        return [f"{spheres[a].name}–{spheres[b].name}" for a, b in self.pairs]

    def scales(self, family: str) -> np.ndarray:
        """Per-column scale dividing the slacks (the limit, or 1 m for distances), so all are O(1)."""
        lim = self.robot.limits
        per_joint = {
            "position": 0.5 * (lim.position_upper - lim.position_lower),
            "velocity": lim.velocity,
            "acceleration": lim.acceleration,
            "torque": lim.torque,
        }
        if family in per_joint:
            return np.tile(per_joint[family], 2)
        return np.ones(len(self.column_labels(family)))

    UNITS: ClassVar[dict[str, str]] = {
        "position": "rad",
        "velocity": "rad/s",
        "acceleration": "rad/s²",
        "torque": "N·m",
        "ground": "m",
        "self_collision": "m",
    }

    # --- values ---------------------------------------------------------------------------------

    def slacks(
        self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, torque: np.ndarray | None = None
    ) -> dict[str, np.ndarray]:
        """Slack of every family at every sample, (N, columns) each, in physical units (≥ 0: satisfied).

        ``torque`` (N, N_J) may be passed when already known (e.g. ``W·φ``); otherwise it is computed.
        """
        lim, keep = self.robot.limits, 1.0 - self.settings.limit_margin
        low, high = self.position_bounds
        out = {
            "position": np.hstack([q - low, high - q]),
            "velocity": np.hstack([keep * lim.velocity + dq, keep * lim.velocity - dq]),
            "acceleration": np.hstack([keep * lim.acceleration + ddq, keep * lim.acceleration - ddq]),
        }
        if self.settings.torque:
            torque = self.robot.inverse_dynamics(q, dq, ddq) if torque is None else torque
            out["torque"] = np.hstack([keep * lim.torque + torque, keep * lim.torque - torque])
        if self.ground_indices or self.pairs:
            centres = sphere_centres(self.robot, q, self.robot.collision_spheres)
            radii = np.array([s.radius for s in self.robot.collision_spheres])
            if self.ground_indices:
                g = self.ground_indices
                out["ground"] = (
                    (centres[g, :, 2] - radii[g, None]).T
                    - self.settings.z_ground
                    - self.settings.distance_margin
                )
            if self.pairs:
                a, b = np.array(self.pairs).T
                distance = np.linalg.norm(centres[a] - centres[b], axis=2)
                out["self_collision"] = (
                    (distance - radii[a, None] - radii[b, None]).T
                    - self.settings.clearance
                    - self.settings.distance_margin
                )
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
            joint, sign = columns % n, np.where(columns < n, 1.0, -1.0)
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
        unique, inverse = np.unique(samples, return_inverse=True)
        poses = joint_frame_poses(self.robot, q[unique])
        spheres = self.robot.collision_spheres
        centres = sphere_centres(self.robot, q[unique], spheres, poses)
        rows = np.arange(m)
        if family == "ground":
            dz = zeros.copy()
            for c, index in enumerate(self.ground_indices):
                jac = _point_jacobian(poses, spheres[index].link, centres[index], n)  # (U, 3, N_J)
                chosen = columns == c
                dz[chosen] = jac[inverse[chosen], 2]
            return dz, zeros, zeros
        dd = zeros.copy()
        for c, (a, b) in enumerate(self.pairs):
            chosen = rows[columns == c]
            if not chosen.size:
                continue
            at = inverse[chosen]
            ja = _point_jacobian(poses[:, at], spheres[a].link, centres[a][at], n)
            jb = _point_jacobian(poses[:, at], spheres[b].link, centres[b][at], n)
            gap = centres[a][at] - centres[b][at]
            normal = gap / np.linalg.norm(gap, axis=1, keepdims=True)
            dd[chosen] = np.einsum("mi,mij->mj", normal, ja - jb)
        return dd, zeros, zeros

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
