"""A motion as a rosbag2 bag of one ``trajectory_msgs/msg/JointTrajectory`` message, and its reader.

Every sample is a point (``time_from_start`` exact to the ns, header stamp zero: "start now"), to
replay with ``ros2 bag play`` onto the controller's ``~/joint_trajectory`` topic. Part of
:mod:`lwrlab.io.ros2_trajectory`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np
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

from lwrlab.io.joint_trajectory import (
    _NS,
    JointTrajectoryData,
    _checked_motion,
    _nanoseconds,
    _trajectory_data,
)
from lwrlab.io.log_schema import LogError
from lwrlab.io.rosbag import STORAGES, _bag_folder

JOINT_TRAJECTORY_TYPE = "trajectory_msgs/msg/JointTrajectory"
"""The ROS 2 message type of the bag."""


# JointTrajectory is the same message in every ROS 2 distribution; Humble is a long-term release.
_TYPESTORE = get_typestore(Stores.ROS2_HUMBLE)


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
