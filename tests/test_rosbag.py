"""ROS 2 joint-state bags: written with the writer, read back exactly; every documented error."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import Reader, Writer

from lwrlab.io.logs import LogError
from lwrlab.io.rosbag import read_joint_states, write_joint_states

ROBOT = ("a1", "a2", "a3")
N = 300


def _states(seed: int = 0, n: int = N) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = 12.5 + 1e-3 * np.arange(n)
    return t, rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), rng.normal(size=(n, 3))


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_round_trip_is_exact(tmp_path: Path, storage: str) -> None:
    t, q, dq, tau = _states()
    bag = write_joint_states(tmp_path / "bag", t, q, tau, ROBOT, dq=dq, storage=storage)
    log = read_joint_states(bag, ROBOT)
    np.testing.assert_array_equal(log.q, q)
    np.testing.assert_array_equal(log.dq, dq)
    np.testing.assert_array_equal(log.tau, tau)
    np.testing.assert_allclose(log.t, t, rtol=0, atol=1e-9)  # ns stamps
    assert log.topic == "/joint_states" and log.joint_names == ROBOT
    assert log.skipped_messages == 0 and log.dropped_duplicates == 0
    # a storage file inside the folder reads the whole bag
    storage_file = next(p for p in bag.iterdir() if p.suffix in (".db3", ".mcap"))
    np.testing.assert_array_equal(read_joint_states(storage_file, ROBOT).q, q)


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_joints_matched_by_name_other_order_and_gripper(tmp_path: Path, storage: str) -> None:
    t, q, dq, tau = _states(1)
    gripper = np.full((N, 1), 0.04)
    # the message lists a gripper first and the arm joints in another order
    names = ["gripper", "a3", "a1", "a2"]
    order = [2, 0, 1]
    bag = write_joint_states(
        tmp_path / "bag",
        t,
        np.hstack([gripper, q[:, order]]),
        np.hstack([gripper, tau[:, order]]),
        names,
        dq=np.hstack([gripper, dq[:, order]]),
        storage=storage,
    )
    log = read_joint_states(bag, ROBOT)
    np.testing.assert_array_equal(log.q, q)
    np.testing.assert_array_equal(log.dq, dq)
    np.testing.assert_array_equal(log.tau, tau)


def test_rows_sorted_by_header_stamp_and_exact_repeats_dropped(tmp_path: Path) -> None:
    t, q, _, tau = _states(2)
    shuffled = np.random.default_rng(0).permutation(N)
    repeat = [*shuffled, shuffled[5]]  # one message recorded twice
    bag = write_joint_states(
        tmp_path / "bag", t[repeat], q[repeat], tau[repeat], ROBOT, receive_time=np.arange(N + 1) * 1e-3
    )
    log = read_joint_states(bag, ROBOT)
    np.testing.assert_array_equal(log.q, q)
    np.testing.assert_allclose(log.t, t, rtol=0, atol=1e-9)
    assert log.dropped_duplicates == 1


def test_same_stamp_different_values_is_an_error(tmp_path: Path) -> None:
    t, q, _, tau = _states(3)
    t[7] = t[6]
    bag = write_joint_states(tmp_path / "bag", t, q, tau, ROBOT)
    with pytest.raises(LogError, match=r"messages 6 and 7: same time stamp"):
        read_joint_states(bag, ROBOT)


def test_receive_time_when_messages_are_unstamped(tmp_path: Path) -> None:
    t, q, _, tau = _states(4)
    receive = 100.0 + 2e-3 * np.arange(N)
    stamped = write_joint_states(tmp_path / "stamped", t, q, tau, ROBOT, receive_time=receive)
    unstamped = write_joint_states(
        tmp_path / "unstamped", t, q, tau, ROBOT, receive_time=receive, stamp_header=False
    )
    np.testing.assert_allclose(read_joint_states(stamped, ROBOT).t, t, rtol=0, atol=1e-9)
    np.testing.assert_allclose(read_joint_states(unstamped, ROBOT).t, receive, rtol=0, atol=1e-9)


def test_simulation_clock_from_zero_is_stamped(tmp_path: Path) -> None:
    t, q, _, tau = _states(5)
    t = t - t[0]  # first stamp exactly 0
    bag = write_joint_states(tmp_path / "bag", t, q, tau, ROBOT, receive_time=t + 50.0)
    np.testing.assert_allclose(read_joint_states(bag, ROBOT).t, t, rtol=0, atol=1e-9)


def test_missing_robot_joint_names_it_and_the_bag_joints(tmp_path: Path) -> None:
    t, q, _, tau = _states(6)
    bag = write_joint_states(tmp_path / "bag", t, q, tau, ROBOT)
    with pytest.raises(
        LogError,
        match=r"message 0: joints \['a4'\] of the robot missing; the message has \['a1', 'a2', 'a3'\]",
    ) as error:
        read_joint_states(bag, (*ROBOT, "a4"))
    assert str(bag) in str(error.value) and "'/joint_states'" in str(error.value)
    with pytest.raises(
        LogError,
        match=r"no message carries the robot's joints; missing \['b1', 'b2'\]; the bag's joints are \['a1', 'a2', 'a3'\]",
    ):
        read_joint_states(bag, ("b1", "b2"))


def test_no_effort_is_an_error(tmp_path: Path) -> None:
    t, q, _, _ = _states(7)
    bag = write_joint_states(tmp_path / "bag", t, q, None, ROBOT)
    with pytest.raises(
        LogError,
        match=r"topic '/joint_states', message 0: 0 effort values for 3 joint names \(the log has no joint torques\)",
    ):
        read_joint_states(bag, ROBOT)


def test_velocity_absent_gives_none(tmp_path: Path) -> None:
    t, q, _, tau = _states(8)
    log = read_joint_states(write_joint_states(tmp_path / "bag", t, q, tau, ROBOT), ROBOT)
    assert log.dq is None
    np.testing.assert_array_equal(log.tau, tau)


def test_non_finite_effort_names_message_and_joint(tmp_path: Path) -> None:
    t, q, _, tau = _states(9)
    tau[41, 1] = np.nan
    bag = write_joint_states(tmp_path / "bag", t, q, tau, ROBOT)
    with pytest.raises(LogError, match=r"message 41: non-finite effort nan of joint 'a2'"):
        read_joint_states(bag, ROBOT)


def _merged(bags: list[Path], target: Path) -> Path:
    """One bag holding every message of ``bags``, one connection per topic, in receive order."""
    with Writer(target, version=Writer.VERSION_LATEST) as writer:
        connections = {}
        messages = []
        for source in bags:
            with Reader(source) as reader:
                for c in reader.connections:
                    if c.topic not in connections:
                        connections[c.topic] = writer.add_connection(
                            c.topic, c.msgtype, msgdef=c.msgdef.data, rihs01=c.digest
                        )
                messages += [(timestamp, c.topic, raw) for c, timestamp, raw in reader.messages()]
        for timestamp, topic, raw in sorted(messages, key=lambda m: m[0]):
            writer.write(connections[topic], timestamp, raw)
    return target


def test_several_joint_state_topics_need_a_choice(tmp_path: Path) -> None:
    t, q, _, tau = _states(10, n=50)
    arm = write_joint_states(tmp_path / "arm", t, q, tau, ROBOT, topic="/arm/joint_states")
    other = write_joint_states(tmp_path / "other", t, -q, -tau, ROBOT, topic="/joint_states")
    bag = _merged([arm, other], tmp_path / "both")
    with pytest.raises(
        LogError,
        match=r"several sensor_msgs/msg/JointState topics \['/arm/joint_states', '/joint_states'\]; set data.topic",
    ):
        read_joint_states(bag, ROBOT)
    np.testing.assert_array_equal(read_joint_states(bag, ROBOT, topic="/arm/joint_states").q, q)
    np.testing.assert_array_equal(read_joint_states(bag, ROBOT, topic="/joint_states").q, -q)
    with pytest.raises(LogError, match=r"no topic '/nope'"):
        read_joint_states(bag, ROBOT, topic="/nope")


def test_messages_without_robot_joints_are_skipped(tmp_path: Path) -> None:
    """A gripper driver publishing on the same topic: its messages carry none of the robot's joints."""
    t, q, _, tau = _states(11, n=60)
    arm = write_joint_states(tmp_path / "arm", t, q, tau, ROBOT)
    gripper = write_joint_states(tmp_path / "gripper", t + 5e-4, q[:, :1], tau[:, :1], ["finger"])
    bag = _merged([arm, gripper], tmp_path / "both")
    log = read_joint_states(bag, ROBOT)
    np.testing.assert_array_equal(log.q, q)
    assert log.skipped_messages == 60


def test_not_a_bag(tmp_path: Path) -> None:
    with pytest.raises(LogError, match="no metadata.yaml"):
        read_joint_states(tmp_path, ROBOT)
    with pytest.raises(LogError, match="no such ROS 2 bag"):
        read_joint_states(tmp_path / "missing", ROBOT)
