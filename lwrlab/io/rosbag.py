"""ROS 2 bags of joint states, read and written in pure Python (``rosbags``; no ROS install).

A rosbag2 bag is a folder with a ``metadata.yaml`` and one or more storage files (sqlite3 ``.db3``
or MCAP ``.mcap``). This module reads the ``sensor_msgs/msg/JointState`` messages of one topic into
arrays in the robot's joint order, and writes such bags (to convert a log, or for tests).

Reading rules
-------------

- **Topic**: ``topic``, or else the single JointState topic of the bag that is not lwrlab's own
  (``/lwrlab/…``: a live monitor's bag holds its estimates beside the robot's states); several: an
  error listing them, to be chosen with ``data.topic``.
- **Joints by name**: every message is mapped through its own ``name`` list, so messages may list
  the joints in another order or carry more joints (a gripper). Messages that carry none of the
  robot's joints (another publisher on the same topic, e.g. a gripper driver) are skipped and
  counted in :attr:`JointStateLog.skipped_messages`; a message that carries only some of them is an
  error naming the message and the missing joints.
- **Arrays**: ``position`` and ``effort`` must have one value per name in every message (a bag
  without efforts is an error: it has no joint torques); ``velocity`` is returned only when every
  message has a full, finite velocity array, else ``dq`` is None. Non-finite positions or efforts
  are an error naming the message and the joint.
- **Time**: the header stamp (``sec + nanosec·1e-9``) when the publisher stamps its messages, else
  (every stamp zero) the bag's receive time. Zero stamps are accepted only before the first
  non-zero one (a simulation clock starting at 0); a zero stamp after it means an unstamped
  publisher mixed with a stamped one, an error. Times are absolute seconds (float64).
- **Order and duplicates**: rows are sorted by time. Two messages with the same time stamp and
  the same values (a message recorded twice) are kept once and counted in
  :attr:`JointStateLog.dropped_duplicates`; same stamp with different values is an error naming
  both messages.

Every error is a :class:`~lwrlab.io.log_schema.LogError` naming the bag, the topic and, where relevant,
the message (0-based index among the topic's messages in the bag's order).

Example
-------
>>> import numpy as np, tempfile, pathlib
>>> t = np.arange(5) * 1e-3
>>> q = np.zeros((5, 2)); tau = np.ones((5, 2))
>>> bag = write_joint_states(pathlib.Path(tempfile.mkdtemp()) / "bag", t, q, tau, ["a1", "a2"])
>>> read_joint_states(bag, ["a2", "a1"]).tau.shape
(5, 2)
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path
from typing import Literal

import numpy as np
from rosbags.interfaces import TopicInfo
from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.stores.ros2_humble import builtin_interfaces__msg__Time as Time
from rosbags.typesys.stores.ros2_humble import sensor_msgs__msg__JointState as JointState
from rosbags.typesys.stores.ros2_humble import std_msgs__msg__Header as Header

from lwrlab.io.log_schema import LogError

JOINT_STATE_TYPE = "sensor_msgs/msg/JointState"
"""The ROS 2 message type read and written."""
OWN_TOPICS = "/lwrlab/"
"""Where lwrlab publishes (its estimates are JointStates too): never a robot's states."""
STORAGES: dict[str, StoragePlugin] = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}
"""Storage plugins the writer offers (the reader recognises both from the bag)."""
_NS = 1_000_000_000

# JointState is the same message in every ROS 2 distribution; Humble is a long-term release.
_TYPESTORE = get_typestore(Stores.ROS2_HUMBLE)


@dataclass(frozen=True)
class JointStateLog:
    """Joint states of one topic, in the robot's joint order, sorted by time (SI units)."""

    t: np.ndarray
    """(N,) absolute times (s)."""
    q: np.ndarray
    """(N, N_J) joint positions (rad)."""
    dq: np.ndarray | None
    """(N, N_J) joint velocities (rad/s), or None if some message lacks them."""
    tau: np.ndarray
    """(N, N_J) joint efforts (N·m)."""
    topic: str
    """The topic read."""
    joint_names: tuple[str, ...]
    """The robot's joints, the column order of ``q``, ``dq``, ``tau``."""
    skipped_messages: int = 0
    """Messages skipped because they carry none of the robot's joints."""
    dropped_duplicates: int = 0
    """Messages dropped as exact repeats (same stamp, same values) of another."""


@dataclass
class _Sample:
    index: int
    stamp_ns: int
    receive_ns: int
    q: np.ndarray
    dq: np.ndarray | None
    tau: np.ndarray


def _bag_folder(path: Path) -> Path:
    """The folder to open: the bag folder itself, or the folder of one of its storage files."""
    if path.is_dir():
        if not (path / "metadata.yaml").is_file():
            raise LogError(f"{path}: not a rosbag2 folder (no metadata.yaml)")
        return path
    if path.is_file() and path.suffix.lower() in (".db3", ".mcap"):
        if not (path.parent / "metadata.yaml").is_file():
            raise LogError(f"{path}: a storage file outside a rosbag2 folder (no metadata.yaml beside it)")
        return path.parent
    if not path.exists():
        raise LogError(f"{path}: no such ROS 2 bag")
    raise LogError(f"{path}: not a ROS 2 bag; give the bag folder or its .db3/.mcap file")


def _joint_state_topic(bag: Path, topics: dict[str, TopicInfo], topic: str | None) -> str:
    joint_state_topics = sorted(name for name, info in topics.items() if info.msgtype == JOINT_STATE_TYPE)
    if topic is not None:
        if topic not in topics:
            raise LogError(
                f"{bag}: no topic {topic!r}; its {JOINT_STATE_TYPE} topics are {joint_state_topics}, "
                f"all topics {sorted(topics)}"
            )
        if topic not in joint_state_topics:
            raise LogError(
                f"{bag}: topic {topic!r} carries {topics[topic].msgtype}, not {JOINT_STATE_TYPE}; "
                f"its JointState topics are {joint_state_topics}"
            )
        return topic
    if not joint_state_topics:
        raise LogError(f"{bag}: no {JOINT_STATE_TYPE} topic; the bag has {sorted(topics)}")
    robots = [name for name in joint_state_topics if not name.startswith(OWN_TOPICS)]
    if len(joint_state_topics) > 1 and len(robots) == 1:
        return robots[0]  # a robot's states beside lwrlab's estimates (a live monitor's bag)
    if len(joint_state_topics) > 1:
        raise LogError(
            f"{bag}: several {JOINT_STATE_TYPE} topics {joint_state_topics}; set data.topic to one of them"
        )
    return joint_state_topics[0]


def _sample(
    msg: JointState, index: int, receive_ns: int, columns: np.ndarray, where: str, joint_names: Sequence[str]
) -> _Sample:
    n_names = len(msg.name)
    for field in ("position", "effort"):
        values = getattr(msg, field)
        if len(values) != n_names:
            what = "the log has no joint torques" if field == "effort" else "positions missing"
            raise LogError(
                f"{where}, message {index}: {len(values)} {field} values for {n_names} joint names ({what})"
            )
    q = np.asarray(msg.position, dtype=float)[columns]
    tau = np.asarray(msg.effort, dtype=float)[columns]
    for field, values in (("position", q), ("effort", tau)):
        bad = ~np.isfinite(values)
        if bad.any():
            column = int(np.argmax(bad))
            raise LogError(
                f"{where}, message {index}: non-finite {field} {float(values[column])} "
                f"of joint {joint_names[column]!r}"
            )
    dq = np.asarray(msg.velocity, dtype=float)[columns] if len(msg.velocity) == n_names else None
    if dq is not None and not np.isfinite(dq).all():
        dq = None
    stamp_ns = int(msg.header.stamp.sec) * _NS + int(msg.header.stamp.nanosec)
    return _Sample(index, stamp_ns, receive_ns, q, dq, tau)


def _samples(
    reader: Reader, topic: str, where: str, joint_names: Sequence[str]
) -> tuple[list[_Sample], int, set[str]]:
    """Every message of ``topic`` that carries the robot's joints, mapped to the robot's order."""
    connections = [c for c in reader.connections if c.topic == topic]
    for connection in connections:
        serialization = getattr(connection.ext, "serialization_format", "cdr")
        if serialization != "cdr":
            raise LogError(f"{where}: serialization {serialization!r}; only cdr is read")
    columns_by_names: dict[tuple[str, ...], np.ndarray | None] = {}
    samples: list[_Sample] = []
    bag_joints: set[str] = set()
    skipped = 0
    for index, (connection, receive_ns, raw) in enumerate(reader.messages(connections=connections)):
        try:
            msg = _TYPESTORE.deserialize_cdr(raw, connection.msgtype)
        except Exception as error:  # a corrupt message: name it rather than fail deep in rosbags
            raise LogError(f"{where}, message {index}: cannot decode ({error})") from error
        if not isinstance(msg, JointState):  # the topic's type was checked; a connection may still lie
            raise LogError(f"{where}, message {index}: a {type(msg).__name__}, not a {JOINT_STATE_TYPE}")
        names = tuple(msg.name)
        if names not in columns_by_names:
            bag_joints.update(names)
            position = {name: i for i, name in enumerate(names)}
            present = [name for name in joint_names if name in position]
            if len(set(names)) != len(names):
                raise LogError(f"{where}, message {index}: repeated joint names {list(names)}")
            if present and len(present) < len(joint_names):
                missing = [name for name in joint_names if name not in position]
                raise LogError(
                    f"{where}, message {index}: joints {missing} of the robot missing; "
                    f"the message has {list(names)}"
                )
            columns_by_names[names] = np.array([position[name] for name in joint_names]) if present else None
        columns = columns_by_names[names]
        if columns is None:
            skipped += 1
            continue
        samples.append(_sample(msg, index, receive_ns, columns, where, joint_names))
    return samples, skipped, bag_joints


def _times_ns(samples: list[_Sample], where: str) -> np.ndarray:
    """Header stamps if the publisher stamps its messages, else the receive times (ns)."""
    stamps = np.array([s.stamp_ns for s in samples], dtype=np.int64)
    stamped = np.flatnonzero(stamps != 0)
    if stamped.size == 0:
        return np.array([s.receive_ns for s in samples], dtype=np.int64)
    late_zero = np.flatnonzero(stamps[stamped[0] :] == 0)
    if late_zero.size:
        sample = samples[stamped[0] + late_zero[0]]
        raise LogError(
            f"{where}, message {sample.index}: zero header stamp after stamped messages "
            "(an unstamped publisher mixed with a stamped one?)"
        )
    return stamps


def _same_values(a: _Sample, b: _Sample) -> bool:
    if not (np.array_equal(a.q, b.q) and np.array_equal(a.tau, b.tau)):
        return False
    if a.dq is None or b.dq is None:
        return a.dq is None and b.dq is None
    return np.array_equal(a.dq, b.dq)


def read_joint_states(
    path: str | Path, joint_names: Sequence[str], topic: str | None = None
) -> JointStateLog:
    """Read the joint states of a ROS 2 bag in the robot's joint order (rules: module docstring).

    Parameters
    ----------
    path : the bag folder (with ``metadata.yaml``), or one of its ``.db3``/``.mcap`` files.
    joint_names : the robot's joints, in robot order; matched by name to each message's ``name``.
    topic : the JointState topic; None = the bag's only one.

    Returns
    -------
    JointStateLog
        ``t`` (N,) s, ``q`` (N, N_J) rad, ``dq`` (N, N_J) rad/s or None, ``tau`` (N, N_J) N·m,
        rows sorted by time.

    Raises
    ------
    LogError
        Naming the bag, the topic and the message: no or several JointState topics, a robot joint
        absent from the bag, no efforts, non-finite values, conflicting time stamps.
    """
    given = Path(path)
    bag = _bag_folder(given)
    joint_names = tuple(joint_names)
    try:
        with Reader(bag) as reader:
            topic = _joint_state_topic(bag, reader.topics, topic)
            where = f"{bag}: topic {topic!r}"
            samples, skipped, bag_joints = _samples(reader, topic, where, joint_names)
    except LogError:
        raise
    except Exception as error:  # rosbags' own errors (bad metadata, unreadable storage)
        raise LogError(f"{bag}: cannot read the ROS 2 bag ({type(error).__name__}: {error})") from error
    if not samples:
        missing = [name for name in joint_names if name not in bag_joints]
        if not bag_joints:
            raise LogError(f"{where}: no messages" if not skipped else f"{where}: no message names any joint")
        raise LogError(
            f"{where}: no message carries the robot's joints; missing {missing}; "
            f"the bag's joints are {sorted(bag_joints)}"
        )

    times_ns = _times_ns(samples, where)
    order = np.argsort(times_ns, kind="stable")
    kept = [order[0]]
    for previous, current in pairwise(order):
        if times_ns[current] != times_ns[previous]:
            kept.append(current)
        elif not _same_values(samples[previous], samples[current]):
            raise LogError(
                f"{where}, messages {samples[previous].index} and {samples[current].index}: "
                f"same time stamp {times_ns[current] / _NS:.9f} s, different values"
            )
    rows = [samples[i] for i in kept]
    seconds = times_ns[kept] // _NS
    t = seconds.astype(float) + (times_ns[kept] - seconds * _NS).astype(float) * 1e-9
    velocities = [s.dq for s in rows]
    dq = None if any(v is None for v in velocities) else np.array(velocities)
    return JointStateLog(
        t=t,
        q=np.array([s.q for s in rows]),
        dq=dq,
        tau=np.array([s.tau for s in rows]),
        topic=topic,
        joint_names=joint_names,
        skipped_messages=skipped,
        dropped_duplicates=len(samples) - len(kept),
    )


def _nanoseconds(seconds: np.ndarray, what: str) -> np.ndarray:
    if not np.isfinite(seconds).all() or (seconds < 0).any():
        raise LogError(f"{what}: times must be finite and non-negative (ROS time)")
    return np.round(seconds * _NS).astype(np.int64)


def _contiguous(array: np.ndarray | None) -> np.ndarray | None:
    """A C-contiguous float copy (what the CDR serialiser writes), or None."""
    return None if array is None else np.ascontiguousarray(array, dtype=float)


def _messages(
    stamps_ns: np.ndarray, names: list[str], q: np.ndarray, dq: np.ndarray | None, tau: np.ndarray | None
) -> Iterator[JointState]:
    empty = np.zeros(0)
    for k, stamp in enumerate(stamps_ns):
        yield JointState(
            header=Header(stamp=Time(sec=int(stamp // _NS), nanosec=int(stamp % _NS)), frame_id=""),
            name=names,
            position=q[k],
            velocity=empty if dq is None else dq[k],
            effort=empty if tau is None else tau[k],
        )


def write_joint_states(
    path: str | Path,
    t: np.ndarray,
    q: np.ndarray,
    tau: np.ndarray | None,
    joint_names: Sequence[str],
    dq: np.ndarray | None = None,
    topic: str = "/joint_states",
    storage: Literal["sqlite3", "mcap"] = "sqlite3",
    *,
    receive_time: np.ndarray | None = None,
    stamp_header: bool = True,
) -> Path:
    """Write joint states as ``sensor_msgs/msg/JointState`` messages into a new rosbag2 folder.

    Parameters
    ----------
    path : the bag folder to create (must not exist).
    t : (N,) times (s, non-negative): the header stamps, and the receive times unless given.
    q : (N, N_J) positions (rad), columns in ``joint_names`` order.
    tau : (N, N_J) efforts (N·m), or None for messages without efforts.
    joint_names : the ``name`` list of every message (any order, extra joints allowed).
    dq : (N, N_J) velocities (rad/s), or None for messages without velocities.
    topic : the topic.
    storage : ``"sqlite3"`` (``.db3``) or ``"mcap"``.
    receive_time : (N,) bag receive times (s); None = ``t``.
    stamp_header : False writes zero header stamps (an unstamped publisher).

    Returns
    -------
    Path
        The bag folder.
    """
    bag = Path(path)
    names = [str(name) for name in joint_names]
    t = np.asarray(t, dtype=float)
    q = np.asarray(q, dtype=float)
    n = len(t)
    arrays = {"q": q, "dq": dq, "tau": tau}
    for name, array in arrays.items():
        if array is not None and np.shape(array) != (n, len(names)):
            raise LogError(f"{bag}: {name} has shape {np.shape(array)}, expected ({n}, {len(names)})")
    if storage not in STORAGES:
        raise LogError(f"{bag}: unknown storage {storage!r}; use one of {sorted(STORAGES)}")
    if bag.exists():
        raise LogError(f"{bag}: exists already; a bag is written into a new folder")
    stamps_ns = _nanoseconds(t, str(bag)) if stamp_header else np.zeros(n, dtype=np.int64)
    receive_ns = _nanoseconds(t if receive_time is None else np.asarray(receive_time, dtype=float), str(bag))
    if receive_ns.shape != (n,):
        raise LogError(f"{bag}: receive_time has shape {receive_ns.shape}, expected ({n},)")
    with Writer(bag, version=Writer.VERSION_LATEST, storage_plugin=STORAGES[storage]) as writer:
        connection = writer.add_connection(topic, JOINT_STATE_TYPE, typestore=_TYPESTORE)
        messages = _messages(stamps_ns, names, np.ascontiguousarray(q), _contiguous(dq), _contiguous(tau))
        for received, msg in zip(receive_ns, messages, strict=True):
            writer.write(connection, int(received), _TYPESTORE.serialize_cdr(msg, JOINT_STATE_TYPE))
    return bag
