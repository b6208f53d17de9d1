"""The Cartesian wrench or force behind external joint torques (eq. (14): F = (Jᵀ)⁺·τ_ext).

At a frame of the robot (the flange by default) or a point fixed to one, with Jacobians in
base-frame axes (Pinocchio's ``LOCAL_WORLD_ALIGNED``): the 6-D wrench ``[f; m]`` from the frame's full
Jacobian, or a pure force ``f`` (a contact point transmits no moment) from the linear part alone,
which is what a contact on a link needs (3 unknowns, determined from the joints before the link when
there are at least three). Each sample's least-squares solution ``(Jᵀ)⁺·τ`` is the pseudo-inverse's
(SVD; singular directions below ``rcond`` of the largest are left out, as near a singularity no
torque measures them).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from lwrlab.model.robot import RobotModel

_BASE_AXES = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


def frame_id(robot: RobotModel, frame: str) -> int:
    """Pinocchio id of a frame of the robot by name; a ValueError naming the frames otherwise."""
    if not robot.model.existFrame(frame):
        names = [f.name for f in robot.model.frames]
        raise ValueError(f"robot {robot.name!r} has no frame {frame!r}; its frames: {names}")
    return int(robot.model.getFrameId(frame))


def default_frame(robot: RobotModel) -> str:
    """The frame loads are mapped at by default: ``flange`` if the robot has one, else the last frame
    carried by its last joint (the URDF's last link)."""
    model = robot.model
    if model.existFrame("flange"):
        return "flange"
    last_joint = model.njoints - 1
    carried = [frame.name for frame in model.frames if frame.parentJoint == last_joint]
    return carried[-1]


def point_jacobians(
    robot: RobotModel, q: np.ndarray, frame: str, point: np.ndarray | None = None
) -> np.ndarray:
    """(N, 6, N_J) Jacobians of a point fixed to ``frame`` (``point`` in the frame's axes, m; None:
    its origin), base-frame axes, rows ``[linear; angular]``."""
    model = robot.model
    data = model.createData()
    fid = frame_id(robot, frame)
    q = np.atleast_2d(np.asarray(q, dtype=float))
    offset = np.zeros(3) if point is None else np.asarray(point, dtype=float)
    jacobians = np.empty((q.shape[0], 6, robot.n_joints))
    for k in range(q.shape[0]):
        jacobians[k] = pin.computeFrameJacobian(model, data, q[k], fid, _BASE_AXES)
        if point is not None:
            # v_point = v_origin + ω × r = v_origin − [r]×·ω, r the offset in base axes
            r = data.oMf[fid].rotation @ offset
            jacobians[k, :3] -= np.cross(r[:, None], jacobians[k, 3:], axis=0)
    return jacobians


def wrench_from_torques(
    jacobians: np.ndarray, external_torque: np.ndarray, rcond: float = 1e-3
) -> np.ndarray:
    """(N, 6) wrenches ``[f (N); m (N·m)]`` with ``Jᵀ·w = τ_ext`` in least squares (eq. (14))."""
    return _solve_transposed(jacobians, external_torque, rcond)


def force_from_torques(jacobians: np.ndarray, external_torque: np.ndarray, rcond: float = 1e-3) -> np.ndarray:
    """(N, 3) pure forces (N) at the Jacobians' point with ``J_vᵀ·f = τ_ext`` in least squares."""
    return _solve_transposed(jacobians[:, :3], external_torque, rcond)


def _solve_transposed(jacobians: np.ndarray, torque: np.ndarray, rcond: float) -> np.ndarray:
    """``pinv(Jᵀ)·τ`` per sample: (N, m, N_J) Jacobians, (N, N_J) torques → (N, m)."""
    pseudo_inverse = np.linalg.pinv(np.swapaxes(jacobians, 1, 2), rcond=rcond)  # (N, m, N_J)
    return np.einsum("kmj,kj->km", pseudo_inverse, torque)


class FrameLoad:
    """The wrench (or pure force at a point) at one frame, one sample at a time: the same numbers as
    :func:`point_jacobians` with :func:`wrench_from_torques` (or :func:`force_from_torques`), with
    the Pinocchio scratch made once (a live loop's per-sample call).

    Parameters
    ----------
    robot : the model.
    frame : the frame's name.
    point : (3,) a point of the frame taking a pure force (m, frame axes); None: the frame's wrench.
    rcond : the pseudo-inverse's cut-off.
    """

    def __init__(
        self, robot: RobotModel, frame: str, point: np.ndarray | None = None, rcond: float = 1e-3
    ) -> None:
        self.model = robot.model
        self.data = robot.model.createData()
        self.frame = frame_id(robot, frame)
        self.point = None if point is None else np.asarray(point, dtype=float)
        self.rcond = rcond

    def __call__(self, q: np.ndarray, external_torque: np.ndarray) -> np.ndarray:
        """(6,) wrench ``[f; m]`` or (3,) force (N, N·m) behind ``external_torque`` (N_J,) at ``q``."""
        jacobian = pin.computeFrameJacobian(self.model, self.data, q, self.frame, _BASE_AXES)
        if self.point is not None:
            r = self.data.oMf[self.frame].rotation @ self.point
            jacobian = jacobian[:3] - np.cross(r[:, None], jacobian[3:], axis=0)
        # (J·Jᵀ)⁻¹·J·τ is the pseudo-inverse's solution where no singular value falls below rcond of
        # the largest (a fifth of its cost); near a singularity the pseudo-inverse itself
        gram = jacobian @ jacobian.T
        eigenvalues = np.linalg.eigvalsh(gram)
        if eigenvalues[0] > (self.rcond**2) * eigenvalues[-1]:
            return np.linalg.solve(gram, jacobian @ external_torque)
        return np.linalg.pinv(jacobian.T, rcond=self.rcond) @ external_torque
