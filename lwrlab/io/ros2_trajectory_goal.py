"""A motion as a ``control_msgs/action/FollowJointTrajectory`` goal (YAML), and its reader.

The motion is resampled at ``rate_hz`` for ``ros2 action send_goal``; the file's leading comments say
how to send it, the start pose, and how far the controller's quintic interpolation between the points
strays from the full-rate motion. Part of :mod:`lwrlab.io.ros2_trajectory`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from lwrlab.io.joint_trajectory import (
    _NS,
    JointTrajectoryData,
    _checked_motion,
    _nanoseconds,
    _trajectory_data,
    quintic_interpolation,
)
from lwrlab.io.log_schema import LogError

FOLLOW_JOINT_TRAJECTORY_ACTION = "control_msgs/action/FollowJointTrajectory"
"""The ROS 2 action whose goal the YAML file holds."""
MAX_SHELL_ARGUMENT_BYTES = 131_072
"""Linux's limit on one command-line argument (``MAX_ARG_STRLEN``): ``"$(cat goal.yaml)"`` must fit."""
JTC_VELOCITY_EPSILON = float(np.finfo(np.float32).eps)
"""Largest final speed (rad/s) taken as rest, unless ``allow_nonzero_velocity_at_trajectory_end``."""


def _decimation(t: np.ndarray, rate_hz: float, where: str) -> np.ndarray:
    """Indices of the samples nearest to ``t[0] + k / rate_hz``, the last sample always included."""
    if not np.isfinite(rate_hz) or rate_hz <= 0:
        raise LogError(f"{where}: rate_hz must be positive, got {rate_hz!r}")
    sample_rate = 1.0 / float(np.median(np.diff(t)))
    if rate_hz > sample_rate * (1 + 1e-6):
        raise LogError(f"{where}: rate_hz {rate_hz!r} exceeds the motion's sample rate {sample_rate:.6g} Hz")
    targets = t[0] + np.arange(int(np.floor((t[-1] - t[0]) * rate_hz + 1e-9)) + 1) / rate_hz
    after = np.clip(np.searchsorted(t, targets), 1, len(t) - 1)
    nearest = np.where(targets - t[after - 1] <= t[after] - targets, after - 1, after)
    return np.unique(np.append(nearest, len(t) - 1))


def _floats(row: np.ndarray) -> list[float]:
    return [float(value) for value in row]


def _flow(document: Any) -> str:
    """One-line YAML flow text (full-precision floats)."""
    return yaml.safe_dump(document, default_flow_style=True, sort_keys=False, width=float("inf")).strip()


def _goal_comments(
    path: Path,
    controller: str,
    names: tuple[str, ...],
    t: np.ndarray,
    q: np.ndarray,
    dq: np.ndarray,
    index: np.ndarray,
) -> list[str]:
    """The leading comment lines: how to send the goal, the start pose, what the interpolation costs."""
    action = f"/{controller}/follow_joint_trajectory"
    rate = (len(index) - 1) / (t[-1] - t[0]) if len(index) > 1 else 0.0
    to_start = {
        "trajectory": {
            "joint_names": list(names),
            "points": [
                {
                    "positions": _floats(q[0]),
                    "velocities": [0.0] * len(names),
                    "accelerations": [0.0] * len(names),
                    "time_from_start": {"sec": 10, "nanosec": 0},
                }
            ],
        }
    }
    start_speed = float(np.abs(dq[0]).max())
    end_speed = float(np.abs(dq[-1]).max())
    lines = [
        f"{FOLLOW_JOINT_TRAJECTORY_ACTION} goal for ros2_control's joint_trajectory_controller:",
        f"an exciting motion of {t[-1] - t[0]:.6g} s, {len(index)} points (about {rate:.6g} Hz) "
        f"of the {len(t)}-sample motion, joints {list(names)}.",
        "",
        "1. First bring the arm to the START POSE, at rest (rad):",
        *(f"     {name}: {float(value)!r}" for name, value in zip(names, q[0], strict=True)),
        "   e.g. with a separate short goal (choose a duration slow enough for your robot and workspace):",
        f'     ros2 action send_goal {action} {FOLLOW_JOINT_TRAJECTORY_ACTION} "{_flow(to_start)}"',
        "   or with the robot's own jog.",
        "2. Then send this goal:",
        f'     ros2 action send_goal {action} {FOLLOW_JOINT_TRAJECTORY_ACTION} "$(cat {path.name})"',
        "",
        "The controller interpolates between the points with quintic splines from their positions,",
        "velocities and accelerations (interpolation_method: splines, its default).",
        f"The motion starts at max |dq| = {start_speed:.3g} rad/s, ends at max |dq| = {end_speed:.3g} rad/s.",
    ]
    if start_speed > JTC_VELOCITY_EPSILON:
        lines.append(
            "The motion does not start at rest: from the start pose at rest it begins with a jump in speed."
        )
    if end_speed > JTC_VELOCITY_EPSILON:
        lines += [
            "The last point is not at rest: the controller rejects the goal unless its parameter",
            "allow_nonzero_velocity_at_trajectory_end is true.",
        ]
    return lines


def _deviation_comment(names: tuple[str, ...], t: np.ndarray, q: np.ndarray, interpolated: np.ndarray) -> str:
    error = np.abs(interpolated - q)
    row, column = np.unravel_index(int(np.argmax(error)), error.shape)
    return (
        "Largest deviation of that quintic interpolation from the full-rate motion: "
        f"{error[row, column]:.3e} rad (joint {names[column]!r} at t = {t[row]:.6g} s)."
    )


def write_follow_joint_trajectory_goal(
    path: str | Path,
    joint_names: Sequence[str],
    t: np.ndarray,
    q: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
    *,
    rate_hz: float = 100.0,
    controller: str = "joint_trajectory_controller",
    goal_time_tolerance: float = 0.0,
) -> Path:
    """Write a motion as a ``control_msgs/action/FollowJointTrajectory`` goal (YAML) for ``ros2 action``.

    The goal's points are the samples of the motion nearest to ``t[0] + k / rate_hz``, the last
    sample always included, each with positions, velocities, accelerations and ``time_from_start``
    (``t`` to the ns). The file's leading comments give the command that sends it to
    ``/<controller>/follow_joint_trajectory``, the START POSE q(0) the arm must first be brought to,
    at rest (with a ready-made short goal to get there), and the largest deviation (rad) of the
    controller's quintic interpolation between the points from the full-rate motion.
    ``"$(cat file)"`` passes at most 128 KiB on Linux: a larger file says so in a comment (use a lower
    ``rate_hz``, or send the goal from a script). An existing file is overwritten.

    Parameters
    ----------
    path : the YAML file to write.
    joint_names : the joints (URDF names, as the controller's ``joints`` parameter names them).
    t : (N,) times from the start (s), non-negative, strictly increasing (a uniform grid).
    q : (N, N_J) positions (rad).
    dq : (N, N_J) velocities (rad/s).
    ddq : (N, N_J) accelerations (rad/s²).
    rate_hz : rate of the goal's points (Hz), at most the motion's sample rate.
    controller : the controller's name, for the action name in the comments.
    goal_time_tolerance : the goal's ``goal_time_tolerance`` (s); 0 = the controller's
        ``constraints.goal_time``.

    Returns
    -------
    Path
        The YAML file.

    Raises
    ------
    LogError
        Naming the file: mismatched shapes or names, non-finite values, times negative or not
        increasing, a rate above the motion's.
    """
    goal = Path(path)
    names, t, q, dq, ddq = _checked_motion(str(goal), joint_names, t, q, dq, ddq)
    times_ns = _nanoseconds(t, str(goal))
    index = _decimation(t, float(rate_hz), str(goal))
    if not np.isfinite(goal_time_tolerance) or goal_time_tolerance < 0:
        raise LogError(
            f"{goal}: goal_time_tolerance must be a non-negative time (s), got {goal_time_tolerance!r}"
        )
    tolerance_ns = round(goal_time_tolerance * _NS)
    points = [
        {
            "positions": _floats(q[k]),
            "velocities": _floats(dq[k]),
            "accelerations": _floats(ddq[k]),
            "time_from_start": {"sec": int(times_ns[k] // _NS), "nanosec": int(times_ns[k] % _NS)},
        }
        for k in index
    ]
    document = {
        "trajectory": {"joint_names": list(names), "points": points},
        "goal_time_tolerance": {"sec": tolerance_ns // _NS, "nanosec": tolerance_ns % _NS},
    }
    body = yaml.safe_dump(document, default_flow_style=None, sort_keys=False, width=float("inf"))
    interpolated = quintic_interpolation(t[index], q[index], dq[index], ddq[index], t)
    lines = [
        *_goal_comments(goal, controller, names, t, q, dq, index),
        _deviation_comment(names, t, q, interpolated),
    ]
    header = "".join(f"# {line}".rstrip() + "\n" for line in lines)
    size = len((header + body).encode())
    if size >= MAX_SHELL_ARGUMENT_BYTES:
        header += (
            f"# WARNING: this file is {size / 1024:.0f} KiB; a shell passes at most 128 KiB in one\n"
            '# argument, so "$(cat ...)" fails (Argument list too long): write it at a lower rate_hz,\n'
            "# or send it from a script (rclpy ActionClient, rosidl_runtime_py.set_message_fields).\n"
        )
    goal.write_text(header + body)
    return goal


def _mapping(value: Any, where: str, what: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise LogError(f"{where}: {what} must be a mapping, got {type(value).__name__}")
    return value


def _goal_point(point: Any, where: str, n_joints: int) -> tuple[int, list[list[float]]]:
    """A goal point's time (ns) and its positions, velocities, accelerations; LogError naming it."""
    point = _mapping(point, where, "a point")
    values = []
    for field in ("positions", "velocities", "accelerations"):
        row = point.get(field)
        if not isinstance(row, list) or len(row) != n_joints:
            count = len(row) if isinstance(row, list) else "no"
            raise LogError(f"{where}: {count} {field} for {n_joints} joints")
        if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in row):
            raise LogError(f"{where}: {field} must be numbers, got {row}")
        values.append([float(v) for v in row])
    stamp = _mapping(point.get("time_from_start"), where, "time_from_start")
    sec, nanosec = stamp.get("sec", 0), stamp.get("nanosec", 0)
    if not (isinstance(sec, int) and isinstance(nanosec, int) and 0 <= nanosec < _NS):
        raise LogError(f"{where}: time_from_start must be integer sec and nanosec < 1e9, got {stamp}")
    return sec * _NS + nanosec, values


def read_follow_joint_trajectory_goal(path: str | Path) -> JointTrajectoryData:
    """Read the trajectory of a ``control_msgs/action/FollowJointTrajectory`` goal (YAML).

    Parameters
    ----------
    path : the YAML file (as written by :func:`write_follow_joint_trajectory_goal`).

    Returns
    -------
    JointTrajectoryData
        The goal's joint names and points: ``t`` (N,) s (``time_from_start``), ``q``, ``dq``, ``ddq``
        (N, N_J) rad, rad/s, rad/s².

    Raises
    ------
    LogError
        Naming the file and the point: not YAML, no ``trajectory.joint_names`` or ``points``, a point
        without all positions, velocities and accelerations, non-finite values, times not increasing.
    """
    goal = Path(path)
    try:
        document = yaml.safe_load(goal.read_text())
    except OSError as error:
        raise LogError(f"{goal}: cannot read the goal file ({error})") from error
    except yaml.YAMLError as error:
        raise LogError(f"{goal}: not YAML ({error})") from error
    trajectory = _mapping(
        _mapping(document, str(goal), "the goal").get("trajectory"), str(goal), "trajectory"
    )
    names = trajectory.get("joint_names")
    points = trajectory.get("points")
    if not isinstance(names, list) or not names or not all(isinstance(name, str) for name in names):
        raise LogError(f"{goal}: trajectory.joint_names must be a list of joint names, got {names!r}")
    if not isinstance(points, list):
        raise LogError(f"{goal}: trajectory.points must be a list, got {type(points).__name__}")
    read = [_goal_point(point, f"{goal}: point {k}", len(names)) for k, point in enumerate(points)]
    times_ns = np.array([time for time, _ in read], dtype=np.int64)
    arrays = tuple(
        np.array([values[i] for _, values in read], dtype=float).reshape(-1, len(names)) for i in range(3)
    )
    return _trajectory_data(str(goal), names, times_ns, arrays)
