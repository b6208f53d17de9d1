"""Analytic inverse geometric model of the KUKA LWR4 with the swivel angle (§II.B, eq. (1)).

The LWR4 is a spherical-shoulder / revolute-elbow / spherical-wrist arm: in its modified-DH table
(the paper's Table I) joints 1–2 meet at the shoulder ``P_s`` (height L1), joints 3–4 at the elbow
``P_e`` (L2 further along z_3), joints 5–7 at the wrist ``P_w`` (L3 further along z_5). For a flange
pose the wrist is fixed, and the elbow is free on a circle about the shoulder–wrist axis (Tolani,
Goswami and Badler 2000): with ``n̂`` the unit shoulder→wrist vector, ``û`` the projection of a
reference vector ``b`` onto the plane normal to ``n̂`` and ``v̂ = n̂ × û``,

    cos α = (L2² + D_sw² − L3²) / (2 L2 D_sw),  c = cos α · L2 · n̂,  R = sin α · L2,
    P_e(φ) = P_s + c + R (cos φ û + sin φ v̂)                                       (eq. 1)

The joint angles then follow in closed form, joint after joint (Paul's method): q1, q2 from the
direction of the upper arm (two signs of q2), q3, q4 from the wrist seen from the elbow (two signs of
q4), q5–q7 from the remaining wrist rotation (ZYZ, two signs of q6): eight branches, each a
``Branch(shoulder, elbow, wrist)`` of signs ±1 of sin q2, sin q4, sin q6. A branch is continuous
along a path as long as none of these sines reaches zero (the three singularities), which the path
optimisation keeps away from.

Everything is vectorised over N poses. Reference vector default: ``b = (0, 0, 1)`` (φ = 0 puts the
elbow in the vertical plane through the shoulder–wrist axis, above it).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from lwrlab.model.robot import RobotModel

HALF_PI = np.pi / 2


class Branch(NamedTuple):
    """Signs (+1 or −1) of sin q2 (shoulder), sin q4 (elbow) and sin q6 (wrist)."""

    shoulder: int = 1
    elbow: int = 1
    wrist: int = 1


DEFAULT_BRANCH = Branch()
"""All three signs +1 (the branch a call gets unless it names one)."""


BRANCHES: tuple[Branch, ...] = tuple(Branch(s, e, w) for s in (1, -1) for e in (1, -1) for w in (1, -1))
"""The eight solution branches of the LWR4's inverse geometric model for a given swivel angle."""


class UnreachablePose(ValueError):
    """A pose is out of the arm's reach, or on a singularity where the swivel angle is undefined."""


class JointLimitViolation(ValueError):
    """An inverse-geometric solution leaves the joint position limits."""


def _rx(alpha: float) -> np.ndarray:
    c, s = np.cos(alpha), np.sin(alpha)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rz(angles: np.ndarray) -> np.ndarray:
    c, s = np.cos(angles), np.sin(angles)
    out = np.zeros((*np.shape(angles), 3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 1, 0], out[..., 1, 1], out[..., 2, 2] = c, -s, s, c, 1.0
    return out


# Twist angles of the LWR4 (Table I) that the closed-form solution relies on.
_ALPHAS = (0.0, HALF_PI, -HALF_PI, -HALF_PI, HALF_PI, HALF_PI, -HALF_PI)


@dataclass(frozen=True)
class IKSolution:
    """Joint positions solving one branch for N poses."""

    q: np.ndarray
    """(N, 7) joint positions (rad), each in (−π, π]."""
    branch: Branch
    within_limits: np.ndarray
    """(N,) True where every joint is inside the robot's position limits."""
    singularity_margin: np.ndarray
    """(N, 3) |sin q2|, |sin q4|, |sin q6|: distance to the shoulder, elbow and wrist singularities."""


class SwivelIK:
    """Closed-form inverse geometric model of an LWR4-like arm (the paper's Table I structure).

    Parameters
    ----------
    robot : the arm; its Pinocchio joint placements must follow Table I (twists 0, π/2, −π/2, −π/2,
        π/2, π/2, −π/2; offsets L1, 0, L2, 0, L3, 0, 0; no d), any lengths.
    reference : the vector ``b`` whose projection defines φ = 0 (base frame).

    Examples
    --------
    >>> ik = SwivelIK(robot)                                  # doctest: +SKIP
    >>> q = ik.solve(flange_pose, swivel=0.3).q               # doctest: +SKIP
    """

    def __init__(self, robot: RobotModel, reference: tuple[float, float, float] = (0.0, 0.0, 1.0)) -> None:
        model = robot.model
        if robot.n_joints != 7:
            raise ValueError(
                f"the swivel-angle IK is for 7-joint LWR4-like arms; {robot.name} has {robot.n_joints} joints"
            )
        offsets = []
        for j, alpha in enumerate(_ALPHAS, start=1):
            placement = model.jointPlacements[j]
            if model.joints[j].shortname() != "JointModelRZ" or not np.allclose(
                placement.rotation, _rx(alpha), atol=1e-12
            ):
                raise ValueError(
                    f"{robot.name}: joint {j} is not a revolute-z joint with twist {alpha:.4f} rad "
                    "as in the LWR4's Table I"
                )
            # the placement is Rx(α)·Tz(r): its translation is r·(Rx(α) e_z)
            offsets.append(float(placement.translation @ placement.rotation[:, 2]))
            if not np.allclose(placement.translation, offsets[-1] * placement.rotation[:, 2], atol=1e-12):
                raise ValueError(
                    f"{robot.name}: joint {j} has a non-zero DH distance d; the LWR4 structure has none"
                )
        if any(abs(offsets[j]) > 1e-12 for j in (1, 3, 5, 6)):
            raise ValueError(
                f"{robot.name}: offsets r2, r4, r6, r7 must be zero for concurrent shoulder and wrist axes, "
                f"got {offsets}"
            )
        self.robot = robot
        self.shoulder_height, self.upper_arm, self.forearm = offsets[0], offsets[2], offsets[4]
        self.position_lower = robot.limits.position_lower
        self.position_upper = robot.limits.position_upper
        flange = (
            model.frames[model.getFrameId("flange")].placement.homogeneous
            if model.existFrame("flange")
            else np.eye(4)
        )
        self.flange_in_frame7 = flange
        self.frame7_in_flange = np.linalg.inv(flange)  # constant: inverted once, not per pose
        self.reference = np.asarray(reference, dtype=float) / np.linalg.norm(reference)

    # --- geometry ----------------------------------------------------------------------------
    @property
    def reach(self) -> tuple[float, float]:
        """Smallest and largest shoulder–wrist distance (m)."""
        return abs(self.upper_arm - self.forearm), self.upper_arm + self.forearm

    def wrist_pose(self, flange_pose: np.ndarray) -> np.ndarray:
        """(N, 4, 4) pose of frame 7 (origin at the wrist centre) from the flange pose (N, 4, 4)."""
        return np.atleast_3d(flange_pose).reshape(-1, 4, 4) @ self.frame7_in_flange

    def elbow_circle(
        self, wrist: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Centre ``P_s + c`` (N, 3), radius R (N,) and frame û, v̂, n̂ (N, 3 each) of the elbow circle."""
        shoulder = np.array([0.0, 0.0, self.shoulder_height])
        d = wrist - shoulder
        distance = np.linalg.norm(d, axis=1)
        low, high = self.reach
        bad = np.flatnonzero((distance >= high) | (distance <= low))
        if bad.size:
            k = bad[0]
            raise UnreachablePose(
                f"{bad.size} pose(s) out of reach, first #{k}: shoulder–wrist distance {distance[k]:.4f} m "
                f"outside ({low:.4f}, {high:.4f}) m (at the boundary the elbow circle degenerates)"
            )
        n = d / distance[:, None]
        u = self.reference - (n @ self.reference)[:, None] * n
        norm_u = np.linalg.norm(u, axis=1)
        bad = np.flatnonzero(norm_u < 1e-9)
        if bad.size:
            raise UnreachablePose(
                f"pose #{bad[0]}: shoulder–wrist axis parallel to the swivel reference {self.reference}; "
                "φ is undefined"
            )
        u /= norm_u[:, None]
        v = np.stack(
            [
                n[:, 1] * u[:, 2] - n[:, 2] * u[:, 1],
                n[:, 2] * u[:, 0] - n[:, 0] * u[:, 2],
                n[:, 0] * u[:, 1] - n[:, 1] * u[:, 0],
            ],
            axis=1,
        )  # n̂ × û
        cos_alpha = (self.upper_arm**2 + distance**2 - self.forearm**2) / (2 * self.upper_arm * distance)
        centre = shoulder + (cos_alpha * self.upper_arm)[:, None] * n
        radius = np.sqrt(1.0 - cos_alpha**2) * self.upper_arm
        return centre, radius, u, v, n

    def elbow_position(self, wrist: np.ndarray, swivel: np.ndarray | float) -> np.ndarray:
        """(N, 3) elbow position P_e(φ) (m), eq. (1), for wrist positions (N, 3) and swivel angles (rad)."""
        centre, radius, u, v, _ = self.elbow_circle(wrist)
        phi = np.broadcast_to(np.asarray(swivel, dtype=float), (wrist.shape[0],))
        return centre + radius[:, None] * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v)

    def swivel_angle(self, q: np.ndarray) -> np.ndarray:
        """(N,) swivel angle φ (rad) of configurations q (N, 7): inverse of eq. (1)."""
        from lwrlab.kinematics.forward import joint_frame_poses

        poses = joint_frame_poses(self.robot, np.atleast_2d(q))
        elbow, wrist = poses[2][:, :3, 3], poses[4][:, :3, 3]
        centre, _, u, v, _ = self.elbow_circle(wrist)
        r = elbow - centre
        return np.arctan2(np.einsum("ij,ij->i", r, v), np.einsum("ij,ij->i", r, u))

    # --- joint angles ------------------------------------------------------------------------
    def solve_branch(
        self, flange_pose: np.ndarray, swivel: np.ndarray | float, branch: Branch = DEFAULT_BRANCH
    ) -> IKSolution:
        """Joint positions of one branch for N flange poses (N, 4, 4) and swivel angles (rad).

        Raises
        ------
        UnreachablePose : a pose is out of reach or on a singularity of this branch.
        """
        frame7 = self.wrist_pose(flange_pose)
        wrist, rotation7 = frame7[:, :3, 3], frame7[:, :3, :3]
        shoulder = np.array([0.0, 0.0, self.shoulder_height])
        elbow = self.elbow_position(wrist, swivel)
        # q1, q2: the upper arm points along z_3 = (−c1 s2, −s1 s2, c2)
        e = (elbow - shoulder) / self.upper_arm
        rho = np.hypot(e[:, 0], e[:, 1])
        q2 = branch.shoulder * np.arctan2(rho, e[:, 2])
        q1 = np.where(rho > 1e-12, np.arctan2(-branch.shoulder * e[:, 1], -branch.shoulder * e[:, 0]), 0.0)
        r2 = _rz(q1) @ _rx(HALF_PI) @ _rz(q2)
        # q3, q4: in frame 3 the forearm points along z_5 = (s4, 0, c4); Rx(−π/2)ᵀ = Rx(π/2)
        a = (np.matmul(r2.transpose(0, 2, 1), (wrist - elbow)[:, :, None])[:, :, 0]) @ _rx(HALF_PI).T
        rho = np.hypot(a[:, 0], a[:, 1])
        q3 = np.arctan2(branch.elbow * a[:, 1], branch.elbow * a[:, 0])
        q4 = np.arctan2(branch.elbow * rho, a[:, 2])
        r4 = r2 @ _rx(-HALF_PI) @ _rz(q3) @ _rx(-HALF_PI) @ _rz(q4)
        # q5, q6, q7: Rx(π/2)ᵀ·R4ᵀ·R7 = Rz(q5)·Ry(−q6)·Rz(q7)
        m = _rx(HALF_PI).T @ r4.transpose(0, 2, 1) @ rotation7
        sin6 = branch.wrist * np.hypot(m[:, 0, 2], m[:, 1, 2])
        q6 = np.arctan2(sin6, m[:, 2, 2])
        s = branch.wrist
        q5 = np.arctan2(-s * m[:, 1, 2], -s * m[:, 0, 2])
        q7 = np.arctan2(-s * m[:, 2, 1], s * m[:, 2, 0])
        q = np.stack([q1, q2, q3, q4, q5, q6, q7], axis=1)
        margin = np.abs(np.sin(q[:, [1, 3, 5]]))
        within = np.all((q >= self.position_lower) & (q <= self.position_upper), axis=1)
        return IKSolution(q=q, branch=branch, within_limits=within, singularity_margin=margin)

    def all_branches(self, flange_pose: np.ndarray, swivel: np.ndarray | float) -> list[IKSolution]:
        """The eight branches (:data:`BRANCHES` order) for N flange poses and swivel angles."""
        return [self.solve_branch(flange_pose, swivel, branch) for branch in BRANCHES]

    def solve(
        self,
        flange_pose: np.ndarray,
        swivel: np.ndarray | float,
        branch: Branch = DEFAULT_BRANCH,
        min_singularity_margin: float = 1e-6,
    ) -> IKSolution:
        """One branch, checked: every pose reachable, away from singularities, inside the joint limits.

        Raises
        ------
        UnreachablePose : out of reach, or |sin q2|, |sin q4| or |sin q6| below ``min_singularity_margin``.
        JointLimitViolation : a joint leaves its position limits (the message names joint, value, pose).
        """
        solution = self.solve_branch(flange_pose, swivel, branch)
        names = ("shoulder (q2)", "elbow (q4)", "wrist (q6)")
        low = solution.singularity_margin < min_singularity_margin
        if low.any():
            k, which = np.argwhere(low)[0]
            raise UnreachablePose(
                f"pose #{k}: {names[which]} singularity, "
                f"|sin| = {solution.singularity_margin[k, which]:.2e} (branch {branch})"
            )
        if not solution.within_limits.all():
            k = int(np.flatnonzero(~solution.within_limits)[0])
            q = solution.q[k]
            j = int(np.flatnonzero((q < self.position_lower) | (q > self.position_upper))[0])
            raise JointLimitViolation(
                f"pose #{k} (of {solution.q.shape[0]}), branch {branch}: "
                f"joint {j + 1} at {q[j]:.4f} rad outside "
                f"[{self.position_lower[j]:.4f}, {self.position_upper[j]:.4f}] rad"
            )
        return solution
