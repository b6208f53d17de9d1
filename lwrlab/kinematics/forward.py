"""Batched forward kinematics of serial chains of revolute-z joints (every modified-DH robot).

Pinocchio computes one configuration per call; a painting path has tens of thousands of samples,
so the joint transforms are chained here as batched 4×4 products over all samples at once.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from lwrlab.model.robot import RobotModel


def _check_revolute_z_chain(model: pin.Model) -> None:
    for j in range(1, model.njoints):
        if model.joints[j].shortname() != "JointModelRZ" or model.parents[j] != j - 1:
            raise ValueError(
                f"batched forward kinematics needs a serial chain of revolute-z joints; joint {j} "
                f"({model.names[j]}) is a {model.joints[j].shortname()} with parent {model.parents[j]}"
            )


def rotation_z(angles: np.ndarray) -> np.ndarray:
    """(N, 4, 4) homogeneous rotations about z by ``angles`` (rad)."""
    angles = np.asarray(angles, dtype=float)
    out = np.zeros((*angles.shape, 4, 4))
    c, s = np.cos(angles), np.sin(angles)
    out[..., 0, 0], out[..., 0, 1], out[..., 1, 0], out[..., 1, 1] = c, -s, s, c
    out[..., 2, 2] = out[..., 3, 3] = 1.0
    return out


def joint_frame_poses(robot: RobotModel, q: np.ndarray) -> np.ndarray:
    """Pose of every joint frame in the base frame.

    Parameters
    ----------
    robot : a serial chain of revolute-z joints (any robot built from a modified-DH table).
    q : (N, N_J) joint positions (rad).

    Returns
    -------
    (N_J, N, 4, 4) homogeneous transforms (m), frame j after joint j has turned by q_j.
    """
    model = robot.model
    _check_revolute_z_chain(model)
    q = np.atleast_2d(np.asarray(q, dtype=float))
    poses = np.empty((robot.n_joints, q.shape[0], 4, 4))
    pose = np.broadcast_to(np.eye(4), (q.shape[0], 4, 4))
    for j in range(robot.n_joints):
        placement = model.jointPlacements[j + 1].homogeneous
        pose = pose @ placement @ rotation_z(q[:, j])
        poses[j] = pose
    return poses


def frame_pose(
    robot: RobotModel, q: np.ndarray, frame: str = "flange", offset: np.ndarray | None = None
) -> np.ndarray:
    """(N, 4, 4) pose (m) of an operational frame of ``robot`` (default the flange), then ``offset``.

    ``offset`` (4×4) is a further constant transform expressed in that frame, e.g. a tool's
    centre point in the flange frame.
    """
    model = robot.model
    if not model.existFrame(frame):
        raise ValueError(
            f"robot {robot.name!r} has no frame {frame!r}; frames: {[f.name for f in model.frames]}"
        )
    definition = model.frames[model.getFrameId(frame)]
    last = joint_frame_poses(robot, q)[definition.parentJoint - 1]
    pose = last @ definition.placement.homogeneous
    return pose if offset is None else pose @ np.asarray(offset, dtype=float)
