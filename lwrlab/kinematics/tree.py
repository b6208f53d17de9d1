"""Batched forward kinematics and point Jacobians of any fixed-base tree of one-axis joints.

:mod:`lwrlab.kinematics.forward` chains revolute-z joints (every modified-DH robot); a URDF's joints
turn about x, y, z or any unit axis, or slide along one, and form a tree. Here each joint's motion is
a rotation (Rodrigues) or a translation along its axis, chained over all samples at once, so the poses
of the collision spheres along a whole motion cost a few batched 4×4 products per joint.

Examples
--------
>>> import pinocchio as pin, numpy as np
>>> model = pin.buildSampleModelManipulator()
>>> q = np.zeros((1, model.nq))
>>> poses = joint_poses(model, q)
>>> data = model.createData(); pin.forwardKinematics(model, data, q[0])
>>> bool(np.allclose(poses[-1, 0], data.oMi[model.njoints - 1].homogeneous))
True
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin


@dataclass(frozen=True)
class JointAxis:
    """The motion of one joint in its own frame."""

    revolute: bool
    """True: rotation about ``axis``; False: translation along it."""
    axis: np.ndarray
    """(3,) unit axis in the joint frame."""


_AXES = {"X": np.array([1.0, 0.0, 0.0]), "Y": np.array([0.0, 1.0, 0.0]), "Z": np.array([0.0, 0.0, 1.0])}


def joint_axes(model: pin.Model) -> tuple[JointAxis, ...]:
    """The axis of every joint 1 … njoints−1 (revolute or prismatic, aligned or not).

    Raises ``ValueError`` for any other joint type, naming it.
    """
    axes = []
    for j in range(1, model.njoints):
        joint = model.joints[j]
        kind = joint.shortname()  # e.g. JointModelRZ, JointModelRevoluteUnaligned, JointModelPY
        if kind in ("JointModelRevoluteUnaligned", "JointModelRevoluteUnboundedUnaligned"):
            axes.append(JointAxis(True, np.asarray(joint.extract().axis, dtype=float)))
        elif kind == "JointModelPrismaticUnaligned":
            axes.append(JointAxis(False, np.asarray(joint.extract().axis, dtype=float)))
        elif kind[:-1] in ("JointModelR", "JointModelP") and kind[-1] in _AXES:
            axes.append(JointAxis(kind[-2] == "R", _AXES[kind[-1]]))
        else:
            raise ValueError(
                f"joint {model.names[j]!r} is a {kind}: batched kinematics handles revolute and "
                "prismatic joints only"
            )
    return tuple(axes)


def _joint_motion(axis: JointAxis, q: np.ndarray) -> np.ndarray:
    """(N, 4, 4) motion of one joint by q (N,): Rodrigues rotation or translation."""
    out = np.zeros((q.shape[0], 4, 4))
    out[:, 3, 3] = 1.0
    if not axis.revolute:
        out[:, :3, :3] = np.eye(3)
        out[:, :3, 3] = q[:, None] * axis.axis
        return out
    k = axis.axis
    skew = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    s, c = np.sin(q)[:, None, None], np.cos(q)[:, None, None]
    out[:, :3, :3] = np.eye(3) + s * skew + (1.0 - c) * (skew @ skew)
    return out


def joint_poses(model: pin.Model, q: np.ndarray, axes: tuple[JointAxis, ...] | None = None) -> np.ndarray:
    """Pose of every joint frame in the base frame, for N configurations at once.

    Parameters
    ----------
    model : a fixed-base tree of revolute and prismatic joints (nq == nv == njoints − 1).
    q : (N, N_J) joint positions (rad or m).
    axes : :func:`joint_axes` of the model, when the caller has them.

    Returns
    -------
    (N_J, N, 4, 4) homogeneous transforms (m): index j−1 is joint j's frame after its motion.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    axes = joint_axes(model) if axes is None else axes
    poses = np.empty((model.njoints - 1, q.shape[0], 4, 4))
    for j in range(1, model.njoints):
        parent = model.parents[j]
        placement = model.jointPlacements[j].homogeneous
        before = placement if parent == 0 else poses[parent - 1] @ placement
        poses[j - 1] = before @ _joint_motion(axes[j - 1], q[:, model.joints[j].idx_q])
    return poses


def supports(model: pin.Model) -> tuple[tuple[int, ...], ...]:
    """For joint index 0 … njoints−1, the joints (1-based) that move it: itself and its ancestors."""
    chains: list[tuple[int, ...]] = [()]
    for j in range(1, model.njoints):
        chains.append((*chains[model.parents[j]], j))
    return tuple(chains)


def point_jacobian(
    model: pin.Model,
    poses: np.ndarray,
    joint: int,
    points: np.ndarray,
    axes: tuple[JointAxis, ...] | None = None,
) -> np.ndarray:
    """∂p/∂q (N, 3, N_J) of points p (N, 3) (base frame, m) fixed to the body of ``joint`` (0: the base).

    Revolute joint i moving the body: ``a_i × (p − o_i)``; prismatic: ``a_i``, with ``a_i`` and ``o_i``
    joint i's axis and origin in the base frame from ``poses`` (:func:`joint_poses`).
    """
    return point_jacobians(model, poses, np.full(points.shape[0], joint), points, axes)


def support_matrix(model: pin.Model) -> np.ndarray:
    """(njoints, N_J) booleans: entry [b, i] says joint i+1 moves the body of joint b (0: the base)."""
    matrix = np.zeros((model.njoints, model.nv), dtype=bool)
    for body, chain in enumerate(supports(model)):
        for i in chain:
            matrix[body, model.joints[i].idx_v] = True
    return matrix


def point_jacobians(
    model: pin.Model,
    poses: np.ndarray,
    joints: np.ndarray,
    points: np.ndarray,
    axes: tuple[JointAxis, ...] | None = None,
) -> np.ndarray:
    """∂p/∂q (m, 3, N_J) of m points, each fixed to its own body.

    ``poses`` (N_J, m, 4, 4): the joint poses at each point's own configuration; ``joints`` (m,): the
    joint moving each point's body (0: the base); ``points`` (m, 3): base frame (m).
    """
    axes = joint_axes(model) if axes is None else axes
    moves = _support_matrix(model)[np.asarray(joints, dtype=int)]  # (m, N_J)
    jac = np.zeros((points.shape[0], 3, model.nv))
    for i in range(1, model.njoints):
        v = model.joints[i].idx_v
        if not moves[:, v].any():
            continue
        frame = poses[i - 1]
        axis = frame[:, :3, :3] @ axes[i - 1].axis
        if axes[i - 1].revolute:
            lever = points - frame[:, :3, 3]
            column = np.stack(  # axis × lever, written out (np.cross costs more than the product here)
                [
                    axis[:, 1] * lever[:, 2] - axis[:, 2] * lever[:, 1],
                    axis[:, 2] * lever[:, 0] - axis[:, 0] * lever[:, 2],
                    axis[:, 0] * lever[:, 1] - axis[:, 1] * lever[:, 0],
                ],
                axis=1,
            )
        else:
            column = axis
        jac[:, :, v] = column * moves[:, v, None]
    return jac


_SUPPORTS: dict[int, tuple[pin.Model, np.ndarray]] = {}


def _support_matrix(model: pin.Model) -> np.ndarray:
    """:func:`support_matrix`, computed once per model object."""
    cached = _SUPPORTS.get(id(model))
    if cached is None or cached[0] is not model:
        cached = (model, support_matrix(model))
        _SUPPORTS[id(model)] = cached
    return cached[1]


def posed_points(points: np.ndarray, joints: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """(P, N, 3) points (P, 3), each given in the frame of its joint (P,) (0: the base), in the base
    frame at joint poses (N_J, N, 4, 4)."""
    out = np.empty((len(points), poses.shape[1], 3))
    for joint in np.unique(joints):  # one product per joint for all its points
        chosen = joints == joint
        if joint == 0:
            out[chosen] = points[chosen][:, None, :]
        else:
            pose = poses[joint - 1]
            rotated = np.matmul(pose[:, :3, :3], points[chosen].T)  # (N, 3, p)
            out[chosen] = rotated.transpose(2, 0, 1) + pose[:, :3, 3]
    return out
