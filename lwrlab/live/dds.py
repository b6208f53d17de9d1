"""A ROS 2 node over Cyclone DDS: a participant on ROS 2's domain, publishers and subscriptions.

ROS 2's conventions, as ``rmw_cyclonedds`` applies them:

- a topic ``/joint_states`` is the DDS topic ``rt/joint_states``;
- the domain is ``ROS_DOMAIN_ID`` (0 when unset);
- ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` (or the older ``ROS_LOCALHOST_ONLY=1``) keeps every
  packet on the loopback interface: the participant binds 127.0.0.1, multicast off, its peer
  127.0.0.1 (:data:`LOCALHOST_CONFIG`); ``localhost_only=True`` asks for it whatever the environment;
- QoS profiles (:data:`QOS_PROFILES`): ``default`` (reliable, keep last 10, volatile: ROS 2's
  default) and ``sensor_data`` (best effort, keep last 5: ``rclcpp::SensorDataQoS``).

A subscription runs its callback on a thread of its own, as soon as DDS hands over a sample, with
its CDR bytes, its decoded message and its publication time (the writer's clock, ns): nothing
queues between the wire and the callback. Publishers take a message, or its CDR bytes already made
(:mod:`lwrlab.live.wire`): the bytes a bag records are then the bytes sent. Both go through
Cyclone's C layer as its Python ``DataReader.take`` and ``DataWriter.write`` do, less their generic
(de)serialisation.
"""

from __future__ import annotations

import os
import socket
import sys
import threading
import time
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from cyclonedds._clayer import ddspy_take, ddspy_write
from cyclonedds.core import InstanceState, Policy, Qos, ReadCondition, SampleState, ViewState, WaitSet
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

LOCALHOST_CONFIG = """<CycloneDDS><Domain Id="any">
<General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>
<AllowMulticast>false</AllowMulticast></General>
<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>64</MaxAutoParticipantIndex>
<Peers><Peer address="127.0.0.1"/></Peers></Discovery>
</Domain></CycloneDDS>"""
"""Cyclone's configuration for loopback only: the interface 127.0.0.1, no multicast, unicast
discovery of the participants on 127.0.0.1 (what ROS 2's ``LOCALHOST`` range does)."""

QOS_PROFILES: dict[str, Qos] = {
    "default": Qos(
        Policy.Reliability.Reliable(duration(milliseconds=100)),
        Policy.History.KeepLast(10),
        Policy.Durability.Volatile,
    ),
    "sensor_data": Qos(
        Policy.Reliability.BestEffort,
        Policy.History.KeepLast(5),
        Policy.Durability.Volatile,
    ),
}
"""ROS 2's QoS profiles by name."""

READER_DEPTH = 1000
"""History a subscription keeps (samples): ROS 2's profiles keep 10 (or 5), which a 1 kHz stream
overwrites in 10 ms, so a reader held up that long loses samples; depth is not part of QoS matching,
so a deeper reader stays compatible with every publisher."""

MAX_DOMAIN_ID = 232
"""The largest domain ROS 2 allows (the port arithmetic of DDS)."""


def topic_name(name: str) -> str:
    """The DDS topic of a ROS 2 topic: ``/joint_states`` → ``rt/joint_states``."""
    name = name.strip()
    if not name or name == "/":
        raise ValueError(f"not a ROS 2 topic name: {name!r}")
    return "rt/" + name.lstrip("/")


def domain_id(environ: Mapping[str, str] | None = None) -> int:
    """``ROS_DOMAIN_ID`` (0 when unset); an error for a value ROS 2 refuses."""
    value = (os.environ if environ is None else environ).get("ROS_DOMAIN_ID", "").strip()
    if not value:
        return 0
    if not value.isdigit() or int(value) > MAX_DOMAIN_ID:
        raise ValueError(f"ROS_DOMAIN_ID={value!r}: give an integer in 0…{MAX_DOMAIN_ID}")
    return int(value)


def localhost_only(environ: Mapping[str, str] | None = None) -> bool:
    """Whether ROS 2's environment asks for loopback only (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``,
    or ``ROS_LOCALHOST_ONLY=1``)."""
    environ = os.environ if environ is None else environ
    scope = environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").strip().upper()
    return scope == "LOCALHOST" or environ.get("ROS_LOCALHOST_ONLY", "").strip() == "1"


def qos_profile(name: str) -> Qos:
    """The QoS profile ``name`` (:data:`QOS_PROFILES`); an error listing the valid ones."""
    try:
        return QOS_PROFILES[name]
    except KeyError:
        raise ValueError(f"unknown QoS profile {name!r}; valid: {sorted(QOS_PROFILES)}") from None


@dataclass(frozen=True)
class Received:
    """A sample as a subscription hands it over."""

    message: Any
    """The message (a class of :mod:`lwrlab.live.messages`)."""
    raw: bytes
    """Its CDR bytes, encapsulation header included."""
    published_ns: int
    """When the writer wrote it (its clock, ns since the epoch)."""
    received_ns: int
    """When it was taken here (ns since the epoch)."""
    newer: int = 0
    """Samples of the topic taken with it that are newer (a reader that fell behind catches up)."""


class Subscription:
    """A topic's samples handed to ``callback`` on a thread of the subscription's (see :class:`Node`)."""

    def __init__(
        self,
        participant: DomainParticipant,
        topic: Topic[Any],
        qos: Qos,
        callback: Callable[[Received], None],
        decode: Callable[[bytes], Any] | None = None,
        batch: int = 64,
    ) -> None:
        self.reader: DataReader[Any] = DataReader(participant, topic, qos=qos)
        self._callback = callback
        self._decode = decode or topic.data_type.deserialize
        self._batch = batch
        self._waitset = WaitSet(participant)
        self._condition = ReadCondition(self.reader, SampleState.Any | ViewState.Any | InstanceState.Any)
        self._waitset.attach(self._condition)
        self._running = True
        self.error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name=f"dds:{topic.name}", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        timeout = duration(milliseconds=50)
        mask = SampleState.Any | ViewState.Any | InstanceState.Any
        try:
            while self._running:
                self._waitset.wait(timeout)
                while self._running:
                    taken = ddspy_take(self.reader._ref, mask, self._batch)
                    if isinstance(taken, int):
                        raise RuntimeError(f"DDS take failed ({taken}) on {self.reader.topic.name}")
                    if not taken:
                        break
                    now = time.time_ns()
                    for index, (data, info) in enumerate(taken):
                        if info.valid_data:
                            self._callback(
                                Received(
                                    self._decode(data),
                                    data,
                                    int(info.source_timestamp),
                                    now,
                                    len(taken) - 1 - index,
                                )
                            )
        except BaseException as error:  # handed to the owner, who stops on it
            self.error = error

    @property
    def publishers(self) -> int:
        """Writers matched with this reader now: more than one robot may be publishing the topic."""
        return len(self.reader.get_matched_publications())

    @property
    def lost(self) -> int:
        """Samples DDS reports lost before they reached this reader (best effort)."""
        return int(self.reader.get_sample_lost_status().total_count)

    def close(self) -> None:
        """Stop handing samples over; returns once the thread has ended."""
        self._running = False
        self._thread.join(timeout=2.0)


class Publisher:
    """Publishes on one topic: a message (``publisher(message)``) or its CDR bytes (:meth:`raw`)."""

    def __init__(self, writer: DataWriter[Any]) -> None:
        self.writer = writer

    def __call__(self, message: Any) -> None:
        """Publish ``message``."""
        self.writer.write(message)

    def raw(self, data: bytes) -> None:
        """Publish a message's CDR bytes (encapsulation header included)."""
        padded = data if len(data) % 4 == 0 else data.ljust((len(data) + 3) & ~3, b"\0")
        code = ddspy_write(self.writer._ref, padded)
        if code < 0:
            raise RuntimeError(f"DDS write failed ({code}) on {self.writer.topic.name}")

    @property
    def matched(self) -> int:
        """Readers matched with it (0 until discovery found them)."""
        return len(self.writer.get_matched_subscriptions())


def _socket_descriptors() -> set[int]:
    """This process's file descriptors that are sockets (Linux's ``/proc``; empty elsewhere)."""
    try:
        names = os.listdir("/proc/self/fd")
    except OSError:
        return set()
    found = set()
    for name in names:
        try:
            if os.readlink(f"/proc/self/fd/{name}").startswith("socket:"):
                found.add(int(name))
        except OSError:  # closed since the listing
            continue
    return found


def _confine_to_loopback(descriptors: set[int]) -> list[tuple[str, int]]:
    """Bind to the loopback device the UDP sockets among ``descriptors`` that listen on every address.

    Cyclone binds its receiving sockets to the wildcard address whatever its interface setting; the
    device binding (``SO_BINDTODEVICE``, Linux) makes the kernel hand them only what arrives on
    loopback. Returns the (address, port) of each socket confined.
    """
    if not sys.platform.startswith("linux"):
        return []
    confined = []
    for fd in sorted(descriptors):
        try:
            sock = socket.socket(fileno=os.dup(fd))
        except OSError:
            continue
        with sock:
            if sock.type != socket.SOCK_DGRAM or sock.family not in (socket.AF_INET, socket.AF_INET6):
                continue
            address, port = sock.getsockname()[:2]
            if address not in ("0.0.0.0", "::"):
                continue
            try:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_BINDTODEVICE, b"lo")
            except OSError as error:  # a kernel before 5.7 asks for CAP_NET_RAW
                warnings.warn(
                    f"the DDS socket on port {port} also listens beyond loopback ({error}): "
                    "sending and discovery stay on 127.0.0.1; a firewall keeps other hosts out",
                    stacklevel=3,
                )
                continue
            confined.append((address, port))
    return confined


class Node:
    """A ROS 2 node's DDS side: one participant, its publishers and subscriptions.

    Parameters
    ----------
    domain : the ROS 2 domain; None: ``ROS_DOMAIN_ID``.
    localhost : loopback only; None: as ROS 2's environment says (:func:`localhost_only`).

    Examples
    --------
    >>> from lwrlab.live.messages import Bool  # doctest: +SKIP
    >>> node = Node(localhost=True)  # doctest: +SKIP
    >>> publish = node.publisher("/lwrlab/collision", Bool)  # doctest: +SKIP
    >>> publish(Bool(True))  # doctest: +SKIP
    """

    def __init__(self, domain: int | None = None, localhost: bool | None = None) -> None:
        self.domain_id = domain_id() if domain is None else int(domain)
        self.localhost = localhost_only() if localhost is None else bool(localhost)
        before = _socket_descriptors() if self.localhost else set()
        # a Domain made before the participant sets its configuration; kept alive with the node
        self._domain = Domain(self.domain_id, LOCALHOST_CONFIG) if self.localhost else None
        self.participant = DomainParticipant(self.domain_id)
        self.confined: list[tuple[str, int]] = []
        """The receiving sockets the participant opened on every address, confined to loopback."""
        if self.localhost:
            self.confined = _confine_to_loopback(_socket_descriptors() - before)
        self._topics: dict[str, Topic[Any]] = {}
        self._subscriptions: list[Subscription] = []

    def _topic(self, name: str, message_type: type) -> Topic[Any]:
        dds_name = topic_name(name)
        if dds_name not in self._topics:
            self._topics[dds_name] = Topic(self.participant, dds_name, message_type)
        return self._topics[dds_name]

    def publisher(self, name: str, message_type: type, qos: str = "default") -> Publisher:
        """A publisher of ``message_type`` messages on the ROS 2 topic ``name``."""
        return Publisher(DataWriter(self.participant, self._topic(name, message_type), qos=qos_profile(qos)))

    def subscribe(
        self,
        name: str,
        message_type: type,
        callback: Callable[[Received], None],
        qos: str = "default",
        decode: Callable[[bytes], Any] | None = None,
    ) -> Subscription:
        """Hand every message of the ROS 2 topic ``name`` to ``callback`` (on the subscription's
        thread), decoded by ``decode`` (None: Cyclone's deserialiser); the profile's history deepened
        to :data:`READER_DEPTH`."""
        kept = [p for p in qos_profile(qos) if "History" not in type(p).__qualname__]
        profile = Qos(*kept, Policy.History.KeepLast(READER_DEPTH))
        subscription = Subscription(
            self.participant, self._topic(name, message_type), profile, callback, decode
        )
        self._subscriptions.append(subscription)
        return subscription

    def close(self) -> None:
        """Stop the subscriptions' threads (the participant goes with the node)."""
        for subscription in self._subscriptions:
            subscription.close()


__all__ = [
    "LOCALHOST_CONFIG",
    "QOS_PROFILES",
    "READER_DEPTH",
    "Node",
    "Publisher",
    "Received",
    "Subscription",
    "domain_id",
    "localhost_only",
    "qos_profile",
    "topic_name",
]
