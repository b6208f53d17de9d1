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

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import yaml
from rosbags.interfaces import TopicInfo
from rosbags.rosbag2 import Reader, Writer
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.stores.ros2_humble import builtin_interfaces__msg__Duration as Duration
from rosbags.typesys.stores.ros2_humble import builtin_interfaces__msg__Time as Time
from rosbags.typesys.stores.ros2_humble import std_msgs__msg__Header as Header
from rosbags.typesys.stores.ros2_humble import trajectory_msgs__msg__JointTrajectory as JointTrajectory
from rosbags.typesys.stores.ros2_humble import (
    trajectory_msgs__msg__JointTrajectoryPoint as JointTrajectoryPoint,
)

from lwrlab.io.log_schema import LogError
from lwrlab.io.rosbag import STORAGES, _bag_folder

JOINT_TRAJECTORY_TYPE = "trajectory_msgs/msg/JointTrajectory"
"""The ROS 2 message type of the bag."""
FOLLOW_JOINT_TRAJECTORY_ACTION = "control_msgs/action/FollowJointTrajectory"
"""The ROS 2 action whose goal the YAML file holds."""
MAX_SHELL_ARGUMENT_BYTES = 131_072
"""Linux's limit on one command-line argument (``MAX_ARG_STRLEN``): ``"$(cat goal.yaml)"`` must fit."""
JTC_VELOCITY_EPSILON = float(np.finfo(np.float32).eps)
"""Largest final speed (rad/s) taken as rest, unless ``allow_nonzero_velocity_at_trajectory_end``."""
_NS = 1_000_000_000

# JointTrajectory is the same message in every ROS 2 distribution; Humble is a long-term release.
_TYPESTORE = get_typestore(Stores.ROS2_HUMBLE)


@dataclass(frozen=True)
class JointTrajectoryData:
    """A joint trajectory read back from a bag or a goal file (SI units)."""

    joint_names: tuple[str, ...]
    """The joints, the column order of ``q``, ``dq``, ``ddq``."""
    t: np.ndarray
    """(N,) times from the start of the trajectory (s), strictly increasing."""
    q: np.ndarray
    """(N, N_J) joint positions (rad)."""
    dq: np.ndarray
    """(N, N_J) joint velocities (rad/s)."""
    ddq: np.ndarray
    """(N, N_J) joint accelerations (rad/s²)."""


# --- checks shared by the writers -------------------------------------------------------------------


def _checked_motion(
    where: str,
    joint_names: Sequence[str],
    t: np.ndarray,
    q: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
) -> tuple[tuple[str, ...], np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The motion as float arrays and its times in ns; LogError naming ``where`` on any bad input."""
    names = tuple(str(name) for name in joint_names)
    if not names or len(set(names)) != len(names):
        raise LogError(f"{where}: joint names must be non-empty and distinct, got {list(names)}")
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or len(t) < 2:
        raise LogError(f"{where}: t must be a 1-D array of at least 2 times, got shape {t.shape}")
    arrays = {"q": np.asarray(q, dtype=float), "dq": np.asarray(dq, dtype=float)}
    arrays["ddq"] = np.asarray(ddq, dtype=float)
    for name, array in arrays.items():
        if array.shape != (len(t), len(names)):
            raise LogError(
                f"{where}: {name} has shape {array.shape}, expected ({len(t)}, {len(names)}) "
                f"for {len(t)} times and the joints {list(names)}"
            )
        bad = ~np.isfinite(array)
        if bad.any():
            row, column = np.argwhere(bad)[0]
            raise LogError(
                f"{where}: non-finite {name} {array[row, column]} of joint {names[column]!r} at sample {row}"
            )
    return names, t, arrays["q"], arrays["dq"], arrays["ddq"]


def _nanoseconds(t: np.ndarray, where: str) -> np.ndarray:
    """Times (s) as int64 ns; LogError unless finite, non-negative and strictly increasing at 1 ns."""
    if not np.isfinite(t).all() or t[0] < 0:
        raise LogError(f"{where}: times must be finite and start at or after 0 s (time from start)")
    ns = np.round(t * _NS).astype(np.int64)
    steps = np.diff(ns)
    if (steps <= 0).any():
        k = int(np.argmax(steps <= 0))
        raise LogError(
            f"{where}: times must increase strictly (by at least 1 ns); "
            f"sample {k + 1} at {t[k + 1]!r} s follows {t[k]!r} s"
        )
    return ns


def _seconds(ns: np.ndarray) -> np.ndarray:
    """int64 ns as float s (correctly rounded)."""
    return (ns // _NS).astype(float) + (ns % _NS).astype(float) / _NS


# --- quintic interpolation --------------------------------------------------------------------------


def quintic_interpolation(
    t_points: np.ndarray, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, t_query: np.ndarray
) -> np.ndarray:
    """Piecewise quintic Hermite interpolation from positions, velocities and accelerations.

    Each segment ``[t_i, t_{i+1}]`` is the quintic polynomial that matches position, velocity and
    acceleration at both ends: what ``joint_trajectory_controller`` does between trajectory points
    that carry all three (its ``splines`` interpolation).

    Parameters
    ----------
    t_points : (M,) times of the points (s), strictly increasing, M ≥ 2.
    q : (M,) or (M, N_J) positions at the points (rad).
    dq : velocities at the points (rad/s), shaped like ``q``.
    ddq : accelerations at the points (rad/s²), shaped like ``q``.
    t_query : (K,) times to evaluate (s), within ``[t_points[0], t_points[-1]]``.

    Returns
    -------
    np.ndarray
        (K,) or (K, N_J) interpolated positions (rad).

    Raises
    ------
    ValueError
        Mismatched shapes, fewer than 2 points, times not increasing, a query outside the points.

    Examples
    --------
    >>> quintic_interpolation(np.array([0.0, 2.0]), np.array([0.0, 32.0]), np.array([0.0, 80.0]),
    ...                       np.array([0.0, 160.0]), np.array([1.0, 1.5]))  # q = t⁵
    array([1.     , 7.59375])
    """
    t_points = np.asarray(t_points, dtype=float)
    t_query = np.asarray(t_query, dtype=float)
    q, dq, ddq = (np.asarray(a, dtype=float) for a in (q, dq, ddq))
    if t_points.ndim != 1 or len(t_points) < 2:
        raise ValueError(f"t_points must be a 1-D array of at least 2 times, got shape {t_points.shape}")
    if not (q.shape == dq.shape == ddq.shape) or q.shape[:1] != t_points.shape:
        raise ValueError(
            f"q, dq, ddq must share the shape (M, ...) with M = {len(t_points)} points; "
            f"got {q.shape}, {dq.shape}, {ddq.shape}"
        )
    if not (np.diff(t_points) > 0).all():
        raise ValueError("t_points must increase strictly")
    if t_query.ndim != 1:
        raise ValueError(f"t_query must be a 1-D array, got shape {t_query.shape}")
    if t_query.size and (t_query.min() < t_points[0] or t_query.max() > t_points[-1]):
        raise ValueError(
            f"t_query spans [{t_query.min()!r}, {t_query.max()!r}] s, "
            f"outside the points' [{t_points[0]!r}, {t_points[-1]!r}] s"
        )
    segment = np.clip(np.searchsorted(t_points, t_query, side="right") - 1, 0, len(t_points) - 2)
    h = t_points[segment + 1] - t_points[segment]
    s = (t_query - t_points[segment]) / h
    # Quintic Hermite basis on s ∈ [0, 1]: value, slope·h and curvature·h² at each end.
    s2 = s * s
    s3 = s2 * s
    s4 = s3 * s
    s5 = s4 * s
    basis = (
        (1 - 10 * s3 + 15 * s4 - 6 * s5, q[segment]),
        ((s - 6 * s3 + 8 * s4 - 3 * s5) * h, dq[segment]),
        (0.5 * (s2 - 3 * s3 + 3 * s4 - s5) * h * h, ddq[segment]),
        (10 * s3 - 15 * s4 + 6 * s5, q[segment + 1]),
        ((-4 * s3 + 7 * s4 - 3 * s5) * h, dq[segment + 1]),
        (0.5 * (s3 - 2 * s4 + s5) * h * h, ddq[segment + 1]),
    )
    extra_axes = (slice(None),) + (None,) * (q.ndim - 1)  # broadcast the (K,) weights over the joints
    result = np.zeros((len(t_query), *q.shape[1:]))
    for weight, values in basis:
        result += weight[extra_axes] * values
    return result


# --- rosbag2 ----------------------------------------------------------------------------------------


def _duration(ns: int) -> Duration:
    return Duration(sec=ns // _NS, nanosec=ns % _NS)


def write_joint_trajectory_bag(
    path: str | Path,
    joint_names: Sequence[str],
    t: np.ndarray,
    q: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
    *,
    topic: str = "/joint_trajectory",
    storage: Literal["sqlite3", "mcap"] = "sqlite3",
) -> Path:
    """Write a motion as one ``trajectory_msgs/msg/JointTrajectory`` message into a new rosbag2 folder.

    Every sample is a point (positions, velocities, accelerations, ``time_from_start`` = ``t`` to the
    ns); the header stamp is zero (the controller starts the trajectory on receipt) and ``frame_id``
    empty. The message is recorded at bag time 0.

    Parameters
    ----------
    path : the bag folder to create (must not exist).
    joint_names : the joints (URDF names), the column order of the arrays.
    t : (N,) times from the start (s), non-negative, strictly increasing (at 1 ns resolution).
    q : (N, N_J) positions (rad).
    dq : (N, N_J) velocities (rad/s).
    ddq : (N, N_J) accelerations (rad/s²).
    topic : the topic, e.g. ``/joint_trajectory_controller/joint_trajectory`` to replay it straight
        onto the controller.
    storage : ``"sqlite3"`` (``.db3``) or ``"mcap"``.

    Returns
    -------
    Path
        The bag folder.

    Raises
    ------
    LogError
        Naming the bag: an existing path, an unknown storage, mismatched shapes or names,
        non-finite values, times negative or not increasing.
    """
    bag = Path(path)
    names, t, q, dq, ddq = _checked_motion(str(bag), joint_names, t, q, dq, ddq)
    times_ns = _nanoseconds(t, str(bag))
    if storage not in STORAGES:
        raise LogError(f"{bag}: unknown storage {storage!r}; use one of {sorted(STORAGES)}")
    if bag.exists():
        raise LogError(f"{bag}: exists already; a bag is written into a new folder")
    points = [
        JointTrajectoryPoint(
            positions=q[k],
            velocities=dq[k],
            accelerations=ddq[k],
            effort=np.zeros(0),
            time_from_start=_duration(int(ns)),
        )
        for k, ns in enumerate(times_ns)
    ]
    msg = JointTrajectory(
        header=Header(stamp=Time(sec=0, nanosec=0), frame_id=""), joint_names=list(names), points=points
    )
    with Writer(bag, version=Writer.VERSION_LATEST, storage_plugin=STORAGES[storage]) as writer:
        connection = writer.add_connection(topic, JOINT_TRAJECTORY_TYPE, typestore=_TYPESTORE)
        writer.write(connection, 0, _TYPESTORE.serialize_cdr(msg, JOINT_TRAJECTORY_TYPE))
    return bag


def _trajectory_topic(bag: Path, topics: dict[str, TopicInfo], topic: str | None) -> str:
    trajectory_topics = sorted(name for name, info in topics.items() if info.msgtype == JOINT_TRAJECTORY_TYPE)
    if topic is not None:
        if topic not in trajectory_topics:
            found = f"it carries {topics[topic].msgtype}" if topic in topics else "no such topic"
            raise LogError(
                f"{bag}: topic {topic!r} is not a {JOINT_TRAJECTORY_TYPE} topic ({found}); "
                f"its JointTrajectory topics are {trajectory_topics}"
            )
        return topic
    if len(trajectory_topics) != 1:
        raise LogError(
            f"{bag}: {len(trajectory_topics)} {JOINT_TRAJECTORY_TYPE} topics {trajectory_topics} "
            f"(all topics {sorted(topics)}); give topic= to pick one"
        )
    return trajectory_topics[0]


def _point_arrays(where: str, n_joints: int, points: Sequence[Any]) -> tuple[np.ndarray, ...]:
    """Positions, velocities, accelerations (N, N_J) of message points; LogError naming the point."""
    fields = ("positions", "velocities", "accelerations")
    for k, point in enumerate(points):
        for field in fields:
            if len(getattr(point, field)) != n_joints:
                raise LogError(
                    f"{where}: point {k} has {len(getattr(point, field))} {field} for {n_joints} joints"
                )
    arrays = tuple(np.array([getattr(point, field) for point in points], dtype=float) for field in fields)
    return tuple(array.reshape(len(points), n_joints) for array in arrays)


def _trajectory_data(
    where: str, names: Sequence[str], times_ns: np.ndarray, arrays: tuple[np.ndarray, ...]
) -> JointTrajectoryData:
    """Check a trajectory read from a file (finite, times increasing) and wrap it."""
    if len(times_ns) == 0:
        raise LogError(f"{where}: the trajectory has no points")
    steps = np.diff(times_ns)
    if (steps <= 0).any():
        k = int(np.argmax(steps <= 0))
        raise LogError(f"{where}: time_from_start of point {k + 1} does not exceed that of point {k}")
    for field, array in zip(("positions", "velocities", "accelerations"), arrays, strict=True):
        bad = ~np.isfinite(array)
        if bad.any():
            row, column = np.argwhere(bad)[0]
            raise LogError(f"{where}: point {row}: non-finite {field} of joint {names[column]!r}")
    q, dq, ddq = arrays
    return JointTrajectoryData(joint_names=tuple(names), t=_seconds(times_ns), q=q, dq=dq, ddq=ddq)


def read_joint_trajectory_bag(path: str | Path, *, topic: str | None = None) -> JointTrajectoryData:
    """Read the one ``trajectory_msgs/msg/JointTrajectory`` message of a ROS 2 bag.

    Parameters
    ----------
    path : the bag folder (with ``metadata.yaml``), or one of its ``.db3``/``.mcap`` files.
    topic : the JointTrajectory topic; None = the bag's only one.

    Returns
    -------
    JointTrajectoryData
        The message's joint names and points: ``t`` (N,) s (``time_from_start``), ``q``, ``dq``,
        ``ddq`` (N, N_J) rad, rad/s, rad/s².

    Raises
    ------
    LogError
        Naming the bag and the topic: not a bag, no or several JointTrajectory topics, not exactly
        one message, a point without all positions, velocities and accelerations, non-finite
        values, times not increasing.
    """
    bag = _bag_folder(Path(path))
    try:
        with Reader(bag) as reader:
            topic = _trajectory_topic(bag, reader.topics, topic)
            where = f"{bag}: topic {topic!r}"
            connections = [c for c in reader.connections if c.topic == topic]
            raw_messages = [(c.msgtype, raw) for c, _, raw in reader.messages(connections=connections)]
    except LogError:
        raise
    except Exception as error:  # rosbags' own errors (bad metadata, unreadable storage)
        raise LogError(f"{bag}: cannot read the ROS 2 bag ({type(error).__name__}: {error})") from error
    if len(raw_messages) != 1:
        raise LogError(f"{where}: {len(raw_messages)} messages; a trajectory bag holds exactly one")
    msgtype, raw = raw_messages[0]
    try:
        msg = _TYPESTORE.deserialize_cdr(raw, msgtype)
    except Exception as error:  # a corrupt message: name it rather than fail deep in rosbags
        raise LogError(f"{where}: cannot decode the message ({error})") from error
    if not isinstance(msg, JointTrajectory):  # the topic's type was checked; a connection may still lie
        raise LogError(f"{where}: a {type(msg).__name__}, not a {JOINT_TRAJECTORY_TYPE}")
    names = [str(name) for name in msg.joint_names]
    times_ns = np.array(
        [int(p.time_from_start.sec) * _NS + int(p.time_from_start.nanosec) for p in msg.points],
        dtype=np.int64,
    )
    return _trajectory_data(where, names, times_ns, _point_arrays(where, len(names), msg.points))


# --- FollowJointTrajectory goal (YAML) --------------------------------------------------------------


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
