"""Forward kinematics and the analytic inverse geometric model with swivel angle (§II.B)."""

from lwrlab.kinematics.displaced_path import DisplacedPathIK
from lwrlab.kinematics.forward import frame_pose, joint_frame_poses
from lwrlab.kinematics.swivel_ik import (
    BRANCHES,
    Branch,
    IKSolution,
    JointLimitViolation,
    SwivelIK,
    UnreachablePose,
)

__all__ = [
    "BRANCHES",
    "Branch",
    "DisplacedPathIK",
    "IKSolution",
    "JointLimitViolation",
    "SwivelIK",
    "UnreachablePose",
    "frame_pose",
    "joint_frame_poses",
]
