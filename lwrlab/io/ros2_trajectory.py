"""An exciting motion exported for ROS 2's ``joint_trajectory_controller`` (``rosbags``; no ROS install).

A motion is a joint trajectory sampled on a time grid: times ``t`` (N,) s from 0, positions ``q``
(N, N_J) rad, velocities ``dq`` (N, N_J) rad/s and accelerations ``ddq`` (N, N_J) rad/s², columns in
the order of ``joint_names`` (the URDF's joints). Two exports, each with its reader:

- **A rosbag2 bag** (:func:`write_joint_trajectory_bag`) holding one
  ``trajectory_msgs/msg/JointTrajectory`` message with every sample as a point (``time_from_start``
  exact to the ns, header stamp zero: "start now"), to replay with ``ros2 bag play`` onto the
  controller's ``~/joint_trajectory`` topic.
- **A FollowJointTrajectory goal** (:func:`write_follow_joint_trajectory_goal`): a YAML file holding
  a ``control_msgs/action/FollowJointTrajectory`` goal with the motion resampled at ``rate_hz``, for
  ``ros2 action send_goal``. Its leading comments say how to send it, the start pose the arm must
  first be brought to, at rest, and how far the controller's quintic-spline interpolation between
  the points strays from the full-rate motion (:func:`quintic_interpolation`).

The parts: :mod:`lwrlab.io.joint_trajectory` (the motion read back, its checks, the interpolation),
:mod:`lwrlab.io.ros2_trajectory_bag` and :mod:`lwrlab.io.ros2_trajectory_goal` (one export each).

Numbers are written at full precision (``repr``), so both round trips return the positions,
velocities and accelerations exactly; times come back to the ns. Every error is a
:class:`~lwrlab.io.log_schema.LogError` naming the file (and for a bag, the topic).

Example
-------
>>> import numpy as np, tempfile, pathlib
>>> t = np.arange(101) * 1e-2
>>> q = np.c_[np.sin(t), np.cos(t)]; dq = np.c_[np.cos(t), -np.sin(t)]; ddq = -q
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> bag = write_joint_trajectory_bag(folder / "bag", ["a1", "a2"], t, q, dq, ddq)
>>> read_joint_trajectory_bag(bag).q.shape
(101, 2)
>>> goal = write_follow_joint_trajectory_goal(folder / "goal.yaml", ["a1", "a2"], t, q, dq, ddq, rate_hz=10)
>>> read_follow_joint_trajectory_goal(goal).t
array([0. , 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1. ])
"""

from __future__ import annotations

from lwrlab.io.joint_trajectory import JointTrajectoryData, quintic_interpolation
from lwrlab.io.ros2_trajectory_bag import (
    JOINT_TRAJECTORY_TYPE,
    read_joint_trajectory_bag,
    write_joint_trajectory_bag,
)
from lwrlab.io.ros2_trajectory_goal import (
    FOLLOW_JOINT_TRAJECTORY_ACTION,
    JTC_VELOCITY_EPSILON,
    MAX_SHELL_ARGUMENT_BYTES,
    read_follow_joint_trajectory_goal,
    write_follow_joint_trajectory_goal,
)

__all__ = [
    "FOLLOW_JOINT_TRAJECTORY_ACTION",
    "JOINT_TRAJECTORY_TYPE",
    "JTC_VELOCITY_EPSILON",
    "MAX_SHELL_ARGUMENT_BYTES",
    "JointTrajectoryData",
    "quintic_interpolation",
    "read_follow_joint_trajectory_goal",
    "read_joint_trajectory_bag",
    "write_follow_joint_trajectory_goal",
    "write_joint_trajectory_bag",
]
