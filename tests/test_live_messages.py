"""ROS 2 on the wire (lwrlab/live): every message's CDR bytes equal ``rosbags``' serialiser (the bytes a
ROS 2 node sends and a bag holds), the fast codec of the sample path equals both, and the node
follows ROS 2's conventions (topic names, domain, loopback switch, QoS profiles).
"""

from __future__ import annotations

import dataclasses
import os
import socket
import sys
import time

import numpy as np
import pytest
import ros_domains
from ros_domains import ros_domain
from rosbags.typesys import Stores, get_typestore

from lwrlab.live import dds
from lwrlab.live.messages import (
    ROS_TYPES,
    Bool,
    DiagnosticArray,
    DiagnosticStatus,
    Float64MultiArray,
    Header,
    JointState,
    KeyValue,
    MultiArrayDimension,
    MultiArrayLayout,
    Time,
    Vector3,
    Wrench,
    WrenchStamped,
    ros_type_name,
)
from lwrlab.live.wire import BOOL_BYTES, JointStateEncoder, StampedEncoder, WireError, decode_joint_state

STORE = get_typestore(Stores.ROS2_HUMBLE)
ARRAY_TYPES = ("sensor_msgs/msg/JointState", "std_msgs/msg/Float64MultiArray")
"""Messages whose float64 sequences rosbags holds as numpy arrays."""


def _ours(rng: np.random.Generator) -> dict[str, object]:
    """One message of every type with random contents."""
    n = int(rng.integers(1, 9))
    stamp = Time(int(rng.integers(0, 2**31)), int(rng.integers(0, 10**9)))
    names = [f"joint_{i}_{'x' * int(rng.integers(0, 5))}" for i in range(n)]
    header = Header(stamp, "frame" * int(rng.integers(0, 3)))
    return {
        "builtin_interfaces/msg/Time": stamp,
        "std_msgs/msg/Header": header,
        "sensor_msgs/msg/JointState": JointState(
            header,
            names,
            rng.normal(size=n).tolist(),
            [] if rng.uniform() < 0.5 else rng.normal(size=n).tolist(),
            rng.normal(size=n).tolist(),
        ),
        "geometry_msgs/msg/Vector3": Vector3(*rng.normal(size=3).tolist()),
        "geometry_msgs/msg/Wrench": Wrench(Vector3(*rng.normal(size=3).tolist()), Vector3(1.0, 2.0, 3.0)),
        "geometry_msgs/msg/WrenchStamped": WrenchStamped(
            header, Wrench(Vector3(*rng.normal(size=3).tolist()), Vector3(*rng.normal(size=3).tolist()))
        ),
        "std_msgs/msg/Bool": Bool(bool(rng.uniform() < 0.5)),
        "std_msgs/msg/MultiArrayDimension": MultiArrayDimension("joints", n, n),
        "std_msgs/msg/MultiArrayLayout": MultiArrayLayout([MultiArrayDimension("joints", n, n)], 0),
        "std_msgs/msg/Float64MultiArray": Float64MultiArray(
            MultiArrayLayout([MultiArrayDimension("joints", n, n)], 0), rng.normal(size=n).tolist()
        ),
        "diagnostic_msgs/msg/KeyValue": KeyValue("samples", str(n)),
        "diagnostic_msgs/msg/DiagnosticStatus": DiagnosticStatus(
            2, "monitor", "contact", "arm", [KeyValue("a", "b")]
        ),
        "diagnostic_msgs/msg/DiagnosticArray": DiagnosticArray(
            header,
            [
                DiagnosticStatus(
                    int(rng.integers(0, 4)), "x", "y" * n, "", [KeyValue("k", "v"), KeyValue("n", "")]
                ),
                DiagnosticStatus(0, "z", "", "", []),
            ],
        ),
    }


def _theirs(message: object) -> object:
    """The same message as rosbags' class (built field by field from ours)."""
    name = ros_type_name(type(message))
    values = {}
    for field in (f.name for f in dataclasses.fields(message)):  # type: ignore[arg-type]
        value = getattr(message, field)
        if type(value) in ROS_TYPES.values():
            value = _theirs(value)
        elif isinstance(value, list) and value and type(value[0]) in ROS_TYPES.values():
            value = [_theirs(v) for v in value]
        elif isinstance(value, list) and field != "name" and name in ARRAY_TYPES:
            value = np.asarray(value, dtype=np.float64)
        values[field] = value
    return STORE.types[name](**values)


@pytest.mark.parametrize("seed", range(4))
def test_every_message_serialises_to_ros2s_bytes(seed: int) -> None:
    for name, message in _ours(np.random.default_rng(seed)).items():
        expected = bytes(STORE.serialize_cdr(_theirs(message), name))
        assert message.serialize() == expected, name  # type: ignore[attr-defined]


def test_every_message_has_ros2s_dds_type_name() -> None:
    for name, cls in ROS_TYPES.items():
        package, _, kind = name.split("/")
        assert cls.__idl_typename__ == f"{package}::msg::dds_::{kind}_"  # type: ignore[attr-defined]
    assert ros_type_name(JointState) == "sensor_msgs/msg/JointState"


@pytest.mark.parametrize("seed", range(6))
def test_the_sample_paths_codec_equals_the_serialisers(seed: int) -> None:
    rng = np.random.default_rng(seed)
    message = _ours(rng)["sensor_msgs/msg/JointState"]
    assert isinstance(message, JointState)
    decoded = decode_joint_state(message.serialize())
    assert decoded.header == message.header and list(decoded.name) == list(message.name)
    for field in ("position", "velocity", "effort"):
        np.testing.assert_array_equal(getattr(decoded, field), getattr(message, field))
    names = list(message.name)
    values = rng.normal(size=len(names))
    stamp_ns = int(rng.integers(0, 2**31 * 10**9))
    encoder = StampedEncoder(
        JointState(Header(Time(), "base"), names, [], [], [0.0] * len(names)), len(names)
    )
    stamp = Time(stamp_ns // 10**9, stamp_ns % 10**9)
    assert (
        encoder.encode(stamp_ns, values)
        == JointState(Header(stamp, "base"), names, [], [], values.tolist()).serialize()
    )
    wrench = StampedEncoder(WrenchStamped(Header(Time(), "flange")), 6)
    load = rng.normal(size=6)
    expected = WrenchStamped(Header(stamp, "flange"), Wrench(Vector3(*load[:3]), Vector3(*load[3:])))
    assert wrench.encode(stamp_ns, load) == expected.serialize()
    assert BOOL_BYTES[True] == Bool(True).serialize() and BOOL_BYTES[False] == Bool(False).serialize()
    q, dq, tau = rng.normal(size=(3, len(names)))
    for velocity in (True, False):
        states = JointStateEncoder(names, "base", velocity=velocity)
        full = JointState(
            Header(stamp, "base"), names, q.tolist(), dq.tolist() if velocity else [], tau.tolist()
        )
        assert states.encode(stamp_ns, q, dq, tau) == full.serialize()


def test_a_cut_message_is_a_wire_error() -> None:
    raw = JointState(Header(), ["a", "b"], [1.0, 2.0], [], [3.0, 4.0]).serialize()
    with pytest.raises(WireError):
        decode_joint_state(raw[:-9])
    with pytest.raises(WireError, match="little-endian"):
        decode_joint_state(b"\x00\x00\x00\x00" + raw[4:])


def test_the_node_follows_ros2s_conventions() -> None:
    assert dds.topic_name("/joint_states") == "rt/joint_states"
    assert dds.topic_name("lwrlab/collision") == "rt/lwrlab/collision"
    with pytest.raises(ValueError, match="not a ROS 2 topic"):
        dds.topic_name("/")
    assert dds.domain_id({}) == 0 and dds.domain_id({"ROS_DOMAIN_ID": "42"}) == 42
    with pytest.raises(ValueError, match="ROS_DOMAIN_ID"):
        dds.domain_id({"ROS_DOMAIN_ID": "300"})
    assert dds.localhost_only({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    assert dds.localhost_only({"ROS_LOCALHOST_ONLY": "1"})
    assert not dds.localhost_only({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"})
    with pytest.raises(ValueError, match="valid: \\['default', 'sensor_data'\\]"):
        dds.qos_profile("fast")
    reliable = str(dds.qos_profile("default"))
    assert "Reliable" in reliable and "KeepLast(depth=10)" in reliable and "Volatile" in reliable
    assert "BestEffort" in str(dds.qos_profile("sensor_data"))


def test_test_processes_side_by_side_get_domains_of_their_own() -> None:
    """The suite's ROS domains (tests/ros_domains.py): pytest-xdist workers of one run, and of two runs,
    never share a domain unless the runs' slots coincide; each in 1…100, this process on its first."""
    run = {"PYTEST_XDIST_WORKER_COUNT": "2", "PYTEST_XDIST_TESTRUNUID": "run-a"}
    blocks = [
        {ros_domain(k, {**run, "PYTEST_XDIST_WORKER": worker}) for k in range(ros_domains.BLOCK)}
        for worker in ("gw0", "gw1")
    ]
    assert len(blocks[0] | blocks[1]) == 2 * ros_domains.BLOCK
    assert all(ros_domains.FIRST <= d <= ros_domains.LAST for block in blocks for d in block)
    other = {"PYTEST_XDIST_WORKER_COUNT": "2", "PYTEST_XDIST_TESTRUNUID": "run-b"}
    assert ros_domain(0, {**other, "PYTEST_XDIST_WORKER": "gw0"}) != ros_domain(
        0, {**run, "PYTEST_XDIST_WORKER": "gw0"}
    )
    assert dds.domain_id() == ros_domain(0) and dds.localhost_only()  # what a Node without arguments takes
    with pytest.raises(RuntimeError, match="at most 25"):
        ros_domain(0, {"PYTEST_XDIST_WORKER": "gw0", "PYTEST_XDIST_WORKER_COUNT": "26"})


def test_a_subscription_counts_the_writers_of_its_topic() -> None:
    node = dds.Node(domain=ros_domain(1), localhost=True)  # a domain of this test's own
    try:
        states = node.subscribe("/joint_states", JointState, lambda received: None, "default")
        assert states.publishers == 0
        robots = [node.publisher("/joint_states", JointState, "default") for _ in range(2)]  # two robots
        deadline = time.monotonic() + 5.0
        while states.publishers < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert states.publishers == len(robots)
    finally:
        node.close()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="sockets read from Linux's /proc")
def test_a_loopback_node_receives_on_loopback_only() -> None:
    """Every UDP socket the node's participant opened is bound to 127.0.0.1 or to the loopback device
    (Cyclone binds its receiving sockets to every address; the node confines them)."""
    before = dds._socket_descriptors()
    node = dds.Node(domain=ros_domain(2), localhost=True)  # a domain of this test's own
    try:
        opened = sorted(dds._socket_descriptors() - before)
        listening = []
        for fd in opened:
            with socket.socket(fileno=os.dup(fd)) as sock:
                if sock.type != socket.SOCK_DGRAM:
                    continue
                device = sock.getsockopt(socket.SOL_SOCKET, socket.SO_BINDTODEVICE, 16).rstrip(b"\0")
                listening.append((sock.getsockname()[0], device))
        assert len(listening) >= 2  # discovery and data
        assert all(address == "127.0.0.1" or device == b"lo" for address, device in listening), listening
        assert len(node.confined) == sum(device == b"lo" for _, device in listening)
    finally:
        node.close()


def test_the_bag_holds_every_message_recorded_in_order(tmp_path) -> None:
    """The recorder's writer process: every message's bytes and time back from the bag (``rosbags``'
    reader), messages given as objects serialised, and an existing folder or a failing writer said."""
    from rosbags.rosbag2 import Reader

    from lwrlab.live.recorder import BagRecorder

    rng = np.random.default_rng(5)
    topics = {"/joint_states": JointState, "/lwrlab/force": WrenchStamped}
    bag = BagRecorder(tmp_path / "bag", topics)
    sent = []
    for k in range(2000):
        message = JointState(
            Header(Time.of(k * 1e-3), ""), ["a", "b"], list(rng.normal(size=2)), [], list(rng.normal(size=2))
        )
        topic, data = ("/joint_states", message.serialize()) if k % 3 else ("/lwrlab/force", None)
        if data is None:
            wrench = WrenchStamped(
                Header(Time.of(k * 1e-3), "tool"), Wrench(Vector3(k, 0, 0), Vector3(0, 0, 1))
            )
            bag.record(topic, 1_000_000 * k, wrench)  # an object: serialised on the way
            data = wrench.serialize()
        else:
            bag.record(topic, 1_000_000 * k, data)
        sent.append((topic, 1_000_000 * k, data))
        if k == 1000:
            time.sleep(0.05)  # two batches at least
    assert bag.close() == tmp_path / "bag" and bag.written == len(sent)
    with Reader(tmp_path / "bag") as reader:
        read = [(c.topic, t, bytes(raw)) for c, t, raw in reader.messages()]
    assert read == sent
    with pytest.raises(FileExistsError, match="exists already"):
        BagRecorder(tmp_path / "bag", topics)
    (tmp_path / "file").write_text("")
    broken = BagRecorder(tmp_path / "file" / "bag", topics)  # no folder can be made there
    broken.record("/joint_states", 0, sent[1][2])
    with pytest.raises(RuntimeError, match="the bag could not be written"):
        broken.close()
