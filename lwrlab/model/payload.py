"""A rigid payload (a tool) fixed to a robot's flange: frame changes and attachment.

A tool's 10 standard parameters are naturally given in the flange frame F (origin on the mounting
face); the robot's last segment carries its parameters in its joint frame (frame 7 of the LWR4,
whose flange is 0.078 m along z7). For a constant placement ``F`` in frame j, rotation ``R`` and
origin ``p``, every body point ``r_j = R·r_F + p``, and the parameters change *linearly*::

    M'  = M
    MS' = R·MS + M·p
    I'  = R·I·Rᵀ + M·(|p|²·1 − p·pᵀ) + (2·(p·R·MS)·1 − p·(R·MS)ᵀ − (R·MS)·pᵀ)

(I about the frame origin): ``φ_j = T·φ_F`` with the 10×10 matrix of :func:`frame_change_matrix`.
So a regressor in frame-j columns ``W_j`` becomes ``W_j·T`` in flange-frame columns, and a
covariance ``Σ_F = T⁻¹·Σ_j·T⁻ᵀ``.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from lwrlab.errors import ConfigError
from lwrlab.model.inertia import inertia_matrix, packed_parameters
from lwrlab.model.robot import RobotModel

FLANGE_FRAME = "flange"
"""Name of the operational frame robots define at their tool-mounting face."""


def change_frame(phi: np.ndarray, rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """Standard parameters of a body given in frame F, expressed in frame j where F has pose (R, p).

    Parameters
    ----------
    phi : (10,) or (..., 10) parameters in frame F about its origin.
    rotation : (3, 3) orientation of F in j.
    translation : (3,) origin of F in j (m).
    """
    phi = np.asarray(phi, dtype=float)
    if phi.ndim > 1:
        return np.stack([change_frame(row, rotation, translation) for row in phi.reshape(-1, 10)]).reshape(
            phi.shape
        )
    r, p = np.asarray(rotation, dtype=float), np.asarray(translation, dtype=float)
    mass, first_moment = phi[0], r @ phi[1:4]
    inertia = (
        r @ inertia_matrix(phi) @ r.T
        + mass * (p @ p * np.eye(3) - np.outer(p, p))
        + 2.0 * (p @ first_moment) * np.eye(3)
        - np.outer(p, first_moment)
        - np.outer(first_moment, p)
    )
    return packed_parameters(mass, first_moment + mass * p, inertia)


def frame_change_matrix(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """The 10×10 matrix T with ``change_frame(φ, R, p) = T·φ`` (the change is linear in φ)."""
    return np.column_stack([change_frame(e, rotation, translation) for e in np.eye(10)])


def flange_placement(robot: RobotModel) -> tuple[int, pin.SE3]:
    """The joint that carries the flange and the flange's pose in that joint's frame.

    Raises a :class:`~lwrlab.errors.ConfigError` (a ``ValueError``, printed as one line) if the robot
    defines no ``flange`` frame (add ``flange:`` to its modified-DH config, or ``flange_frame:`` to a
    URDF robot).
    """
    model = robot.model
    if not model.existFrame(FLANGE_FRAME):
        raise ConfigError(
            f"robot {robot.name!r} has no {FLANGE_FRAME!r} frame to attach a tool to; give it one: "
            "robot.flange_frame=<the URDF link or fixed joint the tool is mounted on> for a URDF robot, "
            "`flange: [x, y, z]` in a modified-DH description"
        )
    frame = model.frames[model.getFrameId(FLANGE_FRAME)]
    return int(frame.parentJoint), frame.placement


def payload_in_joint_frame(robot: RobotModel, phi_flange: np.ndarray) -> tuple[int, np.ndarray]:
    """The joint carrying the flange (1-based) and the payload's parameters in that joint's frame."""
    joint, placement = flange_placement(robot)
    return joint, change_frame(phi_flange, placement.rotation, placement.translation)


def flange_to_joint_matrix(robot: RobotModel) -> np.ndarray:
    """T (10×10) mapping flange-frame payload parameters to the flange-carrying joint's frame."""
    _, placement = flange_placement(robot)
    return frame_change_matrix(placement.rotation, placement.translation)


def attach_payload(robot: RobotModel, phi_flange: np.ndarray | None) -> RobotModel:
    """A copy of ``robot`` whose flange-carrying segment also carries the payload ``phi_flange``.

    ``phi_flange``: (10,) standard parameters of the payload in the flange frame (None: unchanged).
    Masses, first moments and inertias add, so the segment stays physically consistent.
    """
    if phi_flange is None:
        return robot
    phi_flange = np.asarray(phi_flange, dtype=float)
    if phi_flange.shape != (10,):
        raise ValueError(f"a payload has 10 inertial parameters, got shape {phi_flange.shape}")
    joint, phi_joint = payload_in_joint_frame(robot, phi_flange)
    links = robot.link_parameters.copy()
    links[joint - 1] += phi_joint
    return robot.with_parameters(np.concatenate([links.ravel(), robot.friction.values(robot.friction_terms)]))
