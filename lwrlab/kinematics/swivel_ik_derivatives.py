"""Derivatives of the closed-form swivel-angle IK (§II.B) along the flange position and the swivel angle.

Forward-mode differentiation of :meth:`SwivelIK.solve_branch`, step by step through its closed form,
for a flange whose orientation is held (the painting tool keeps its orientation): four directions,
the flange position's x, y, z and the swivel angle φ. Each derivative array carries the directions
on its last axis. For a point that moves along no singularity (|sin q2|, |sin q4|, |sin q6| > 0,
the elbow circle not degenerate) the result is exact; tests compare it with finite differences.

Notation: ``arctan2(y, x)`` has the derivative ``(x·dy − y·dx)/(x² + y²)``; ``dRz(q)/dq = Rz(q)·S``
with ``S`` the generator of rotations about z.
"""

from __future__ import annotations

import numpy as np

from lwrlab.kinematics.swivel_ik import DEFAULT_BRANCH, HALF_PI, Branch, IKSolution, SwivelIK, _rx, _rz

_GENERATOR_Z = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
"""S: dRz(q)/dq = Rz(q)·S."""

DIRECTIONS = 4
"""Flange position x, y, z (m), then the swivel angle φ (rad)."""


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b over axis 1 of (N, 3, ...) arrays that broadcast."""
    return np.stack(
        [
            a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
            a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
            a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0],
        ],
        axis=1,
    )


def _atan2_derivative(y: np.ndarray, x: np.ndarray, dy: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """d arctan2(y, x) for values (N,) and derivatives (N, D)."""
    return (x[:, None] * dy - y[:, None] * dx) / (x**2 + y**2)[:, None]


def _scaled(matrix: np.ndarray, rate: np.ndarray) -> np.ndarray:
    """(N, D, 3, 3): a matrix (N, 3, 3) times a derivative (N, D) (rotation derivatives keep D second)."""
    return matrix[:, None] * rate[:, :, None, None]


def solve_branch_derivatives(
    ik: SwivelIK, flange_pose: np.ndarray, swivel: np.ndarray | float, branch: Branch = DEFAULT_BRANCH
) -> tuple[IKSolution, np.ndarray, np.ndarray]:
    """The IK solution of N flange poses (N, 4, 4) and its derivatives at fixed flange orientation.

    Returns
    -------
    solution : as :meth:`SwivelIK.solve_branch`.
    dq_dposition : (N, 7, 3) ∂q/∂p of the flange position p (rad/m), base axes.
    dq_dswivel : (N, 7) ∂q/∂φ (rad/rad).
    """
    solution = ik.solve_branch(flange_pose, swivel, branch)
    q = solution.q
    n = q.shape[0]
    frame7 = ik.wrist_pose(flange_pose)
    wrist, rotation7 = frame7[:, :3, 3], frame7[:, :3, :3]
    phi = np.broadcast_to(np.asarray(swivel, dtype=float), (n,))
    shoulder = np.array([0.0, 0.0, ik.shoulder_height])
    upper, fore = ik.upper_arm, ik.forearm
    # seeds: the wrist moves with the flange position (fixed orientation); φ is the fourth direction
    d_wrist = np.zeros((n, 3, DIRECTIONS))
    d_wrist[:, [0, 1, 2], [0, 1, 2]] = 1.0
    d_phi = np.zeros((n, DIRECTIONS))
    d_phi[:, 3] = 1.0

    # elbow circle (eq. 1): centre, radius, frame û, v̂ of the shoulder–wrist axis n̂
    centre, radius, u, v, axis = ik.elbow_circle(wrist)
    offset = wrist - shoulder
    distance = np.linalg.norm(offset, axis=1)
    d_distance = np.einsum("ni,nid->nd", axis, d_wrist)
    d_axis = (d_wrist - axis[:, :, None] * d_distance[:, None, :]) / distance[:, None, None]
    b = ik.reference
    along = axis @ b
    d_along = np.einsum("nid,i->nd", d_axis, b)
    projected = b - along[:, None] * axis
    d_projected = -(d_along[:, None, :] * axis[:, :, None] + along[:, None, None] * d_axis)
    norm = np.linalg.norm(projected, axis=1)
    d_u = (d_projected - u[:, :, None] * np.einsum("ni,nid->nd", u, d_projected)[:, None, :]) / norm[
        :, None, None
    ]
    d_v = _cross(d_axis, u[:, :, None]) + _cross(axis[:, :, None], d_u)
    cos_alpha = (upper**2 + distance**2 - fore**2) / (2 * upper * distance)
    d_cos = ((fore**2 - upper**2) / (2 * upper * distance**2) + 1.0 / (2 * upper))[:, None] * d_distance
    d_centre = upper * (d_cos[:, None, :] * axis[:, :, None] + cos_alpha[:, None, None] * d_axis)
    d_radius = -upper * (cos_alpha / np.sqrt(1.0 - cos_alpha**2))[:, None] * d_cos
    ring = np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v
    d_ring = np.cos(phi)[:, None, None] * d_u + np.sin(phi)[:, None, None] * d_v
    d_ring += (-np.sin(phi)[:, None] * u + np.cos(phi)[:, None] * v)[:, :, None] * d_phi[:, None, :]
    elbow = centre + radius[:, None] * ring
    d_elbow = d_centre + d_radius[:, None, :] * ring[:, :, None] + radius[:, None, None] * d_ring

    # q1, q2 from the upper arm's direction
    e, d_e = (elbow - shoulder) / upper, d_elbow / upper
    rho = np.hypot(e[:, 0], e[:, 1])
    d_rho = (e[:, 0, None] * d_e[:, 0] + e[:, 1, None] * d_e[:, 1]) / rho[:, None]
    d_q1 = _atan2_derivative(e[:, 1], e[:, 0], d_e[:, 1], d_e[:, 0])  # the branch sign cancels
    d_q2 = branch.shoulder * _atan2_derivative(rho, e[:, 2], d_rho, d_e[:, 2])
    rz1, rz2 = _rz(q[:, 0]), _rz(q[:, 1])
    r2 = rz1 @ _rx(HALF_PI) @ rz2
    d_r2 = _scaled(rz1 @ _GENERATOR_Z @ _rx(HALF_PI) @ rz2, d_q1) + _scaled(r2 @ _GENERATOR_Z, d_q2)

    # q3, q4 from the wrist seen from the elbow, in frame 3
    forearm = wrist - elbow
    d_forearm = d_wrist - d_elbow
    a = (np.matmul(r2.transpose(0, 2, 1), forearm[:, :, None])[:, :, 0]) @ _rx(HALF_PI).T
    d_frame3 = np.matmul(r2.transpose(0, 2, 1), d_forearm) + (
        d_r2.transpose(0, 1, 3, 2) @ forearm[:, None, :, None]
    )[..., 0].transpose(0, 2, 1)
    d_a = _rx(HALF_PI) @ d_frame3
    rho = np.hypot(a[:, 0], a[:, 1])
    d_rho = (a[:, 0, None] * d_a[:, 0] + a[:, 1, None] * d_a[:, 1]) / rho[:, None]
    d_q3 = _atan2_derivative(a[:, 1], a[:, 0], d_a[:, 1], d_a[:, 0])
    d_q4 = branch.elbow * _atan2_derivative(rho, a[:, 2], d_rho, d_a[:, 2])
    rz3, rz4 = _rz(q[:, 2]), _rz(q[:, 3])
    tail = _rx(-HALF_PI) @ rz3 @ _rx(-HALF_PI) @ rz4
    r4 = r2 @ tail
    d_r4 = d_r2 @ tail[:, None]
    d_r4 += _scaled(r2 @ _rx(-HALF_PI) @ rz3 @ _GENERATOR_Z @ _rx(-HALF_PI) @ rz4, d_q3) + _scaled(
        r4 @ _GENERATOR_Z, d_q4
    )

    # q5, q6, q7 from the remaining wrist rotation m = Rx(π/2)ᵀ·R4ᵀ·R7 (R7 fixed)
    m = _rx(HALF_PI).T @ r4.transpose(0, 2, 1) @ rotation7
    d_m = (_rx(HALF_PI).T @ d_r4.transpose(0, 1, 3, 2) @ rotation7[:, None]).transpose(
        0, 2, 3, 1
    )  # (N, 3, 3, D)
    s = branch.wrist
    sin6 = s * np.hypot(m[:, 0, 2], m[:, 1, 2])
    d_sin6 = (
        s
        * (m[:, 0, 2, None] * d_m[:, 0, 2] + m[:, 1, 2, None] * d_m[:, 1, 2])
        / np.hypot(m[:, 0, 2], m[:, 1, 2])[:, None]
    )
    d_q5 = _atan2_derivative(m[:, 1, 2], m[:, 0, 2], d_m[:, 1, 2], d_m[:, 0, 2])
    d_q6 = _atan2_derivative(sin6, m[:, 2, 2], d_sin6, d_m[:, 2, 2])
    d_q7 = _atan2_derivative(-m[:, 2, 1], m[:, 2, 0], -d_m[:, 2, 1], d_m[:, 2, 0])
    d_q = np.stack([d_q1, d_q2, d_q3, d_q4, d_q5, d_q6, d_q7], axis=1)  # (N, 7, D)
    return solution, d_q[:, :, :3], d_q[:, :, 3]
