"""Modified Denavit–Hartenberg tables (Khalil–Kleinfinger) and the Pinocchio models built from them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin


@dataclass(frozen=True)
class ModifiedDH:
    """A serial chain of revolute joints in Khalil–Kleinfinger modified DH convention.

    Frame ``j`` follows frame ``j-1`` by ``T = Rx(α_j)·Tx(d_j)·Rz(θ_j)·Tz(r_j)``, with ``θ_j = q_j +
    theta_offset_j``; joint ``j`` turns about ``z_j``. This is Table I of Katsumata et al. (columns
    α, d, θ, r); Craig's modified convention is the same with ``a_{j-1} → d_j`` and ``d_j → r_j``.
    """

    alpha: np.ndarray
    """Twist angles α_j (rad)."""
    d: np.ndarray
    """Distances d_j along x_{j-1} (m)."""
    r: np.ndarray
    """Offsets r_j along z_j (m)."""
    theta_offset: np.ndarray
    """Constant joint-angle offsets (rad)."""

    def __post_init__(self) -> None:
        lengths = {len(np.atleast_1d(v)) for v in (self.alpha, self.d, self.r, self.theta_offset)}
        if len(lengths) != 1:
            raise ValueError(
                f"modified DH columns alpha, d, r, theta_offset must have one length, got {lengths}"
            )

    @property
    def n_joints(self) -> int:
        return len(self.alpha)


def dh_transform(alpha: float, d: float, theta: float, r: float) -> np.ndarray:
    """4×4 homogeneous transform ``Rx(α)·Tx(d)·Rz(θ)·Tz(r)`` written out from the DH formulas."""
    ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
    return np.array(
        [
            [ct, -st, 0.0, d],
            [ca * st, ca * ct, -sa, -r * sa],
            [sa * st, sa * ct, ca, r * ca],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def build_dh_model(
    table: ModifiedDH,
    link_inertias: list[pin.Inertia],
    gravity: np.ndarray,
    joint_names: list[str] | None = None,
    flange: np.ndarray | None = None,
) -> pin.Model:
    """A Pinocchio model whose joint frames are the modified-DH frames of ``table``.

    The constant part of each DH transform becomes the joint placement (``Rz(θ_off)`` and ``Tz(r)``
    commute with the joint's own rotation about z), the joint is a revolute about its z axis, and the
    segment inertia (expressed in that frame) is appended to it. ``flange`` (4×4, in the last frame)
    adds an operational frame named ``flange``.
    """
    if len(link_inertias) != table.n_joints:
        raise ValueError(f"{table.n_joints} DH rows but {len(link_inertias)} segment inertias")
    names = joint_names or [f"joint{j}" for j in range(1, table.n_joints + 1)]
    model = pin.Model()
    model.gravity = pin.Motion(np.asarray(gravity, dtype=float), np.zeros(3))
    parent = 0
    for j in range(table.n_joints):
        placement = pin.SE3(dh_transform(table.alpha[j], table.d[j], table.theta_offset[j], table.r[j]))
        parent = model.addJoint(parent, pin.JointModelRZ(), placement, names[j])
        model.appendBodyToJoint(parent, link_inertias[j], pin.SE3.Identity())
        model.addFrame(pin.Frame(f"link{j + 1}", parent, pin.SE3.Identity(), pin.FrameType.BODY))
    if flange is not None:
        model.addFrame(
            pin.Frame("flange", parent, pin.SE3(np.asarray(flange, dtype=float)), pin.FrameType.OP_FRAME)
        )
    return model


def forward_kinematics(table: ModifiedDH, q: np.ndarray) -> list[np.ndarray]:
    """Pose of every DH frame in the base frame by chaining the DH transforms (no Pinocchio)."""
    poses, pose = [], np.eye(4)
    for j in range(table.n_joints):
        pose = pose @ dh_transform(table.alpha[j], table.d[j], q[j] + table.theta_offset[j], table.r[j])
        poses.append(pose)
    return poses
