"""Motions exported for ROS 2: bag and FollowJointTrajectory goal round trips, quintic interpolation."""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import yaml
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from lwrlab.io.logs import LogError
from lwrlab.io.ros2_trajectory import (
    JOINT_TRAJECTORY_TYPE,
    JointTrajectoryData,
    quintic_interpolation,
    read_follow_joint_trajectory_goal,
    read_joint_trajectory_bag,
    write_follow_joint_trajectory_goal,
    write_joint_trajectory_bag,
)
from lwrlab.io.rosbag import write_joint_states

JOINTS = ("lbr_a1", "lbr_a2", "lbr_a3")
OMEGA = np.array([1.3, 2.1, 0.7])  # rad/s
PHASE = np.array([0.4, -1.0, 2.5])  # rad


def _motion(n: int = 1234, period: float = 1e-3) -> tuple[np.ndarray, ...]:
    """Sines on a uniform grid from t = 0 (s, rad, rad/s, rad/s²): exact derivatives, a start away from 0."""
    t = np.arange(n) * period
    angle = np.outer(t, OMEGA) + PHASE
    return t, np.sin(angle), OMEGA * np.cos(angle), -(OMEGA**2) * np.sin(angle)


def _comments(path: Path) -> list[str]:
    return [line for line in path.read_text().splitlines() if line.startswith("#")]


# --- bag ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_bag_round_trip_is_exact(tmp_path: Path, storage: str) -> None:
    t, q, dq, ddq = _motion()
    bag = write_joint_trajectory_bag(tmp_path / "bag", list(JOINTS), t, q, dq, ddq, storage=storage)
    assert bag == tmp_path / "bag" and (bag / "metadata.yaml").is_file()

    data = read_joint_trajectory_bag(bag)
    assert isinstance(data, JointTrajectoryData) and data.joint_names == JOINTS
    np.testing.assert_array_equal(data.q, q)
    np.testing.assert_array_equal(data.dq, dq)
    np.testing.assert_array_equal(data.ddq, ddq)
    np.testing.assert_allclose(data.t, t, rtol=0, atol=1e-9)
    with pytest.raises(dataclasses.FrozenInstanceError):
        data.t = t  # type: ignore[misc]
    # a storage file inside the folder reads the whole bag
    storage_file = next(p for p in bag.iterdir() if p.suffix in (".db3", ".mcap"))
    np.testing.assert_array_equal(read_joint_trajectory_bag(storage_file, topic="/joint_trajectory").q, q)


def test_bag_read_independently_with_rosbags(tmp_path: Path) -> None:
    """What a ROS 2 user gets: one JointTrajectory, every point, header stamp 0, time_from_start in ns."""
    t, q, dq, ddq = _motion(300)
    topic = "/joint_trajectory_controller/joint_trajectory"
    bag = write_joint_trajectory_bag(tmp_path / "bag", JOINTS, t, q, dq, ddq, topic=topic)
    typestore = get_typestore(Stores.ROS2_HUMBLE)
    with Reader(bag) as reader:
        assert [(c.topic, c.msgtype) for c in reader.connections] == [(topic, JOINT_TRAJECTORY_TYPE)]
        messages = [typestore.deserialize_cdr(raw, c.msgtype) for c, _, raw in reader.messages()]
    assert len(messages) == 1
    msg = messages[0]
    assert msg.header.stamp.sec == 0 and msg.header.stamp.nanosec == 0 and msg.header.frame_id == ""
    assert list(msg.joint_names) == list(JOINTS) and len(msg.points) == len(t)
    np.testing.assert_array_equal([p.positions for p in msg.points], q)
    np.testing.assert_array_equal([p.velocities for p in msg.points], dq)
    np.testing.assert_array_equal([p.accelerations for p in msg.points], ddq)
    assert all(len(p.effort) == 0 for p in msg.points)
    ns = [p.time_from_start.sec * 1_000_000_000 + p.time_from_start.nanosec for p in msg.points]
    np.testing.assert_array_equal(ns, np.round(t * 1e9).astype(np.int64))
    seconds = np.array([p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in msg.points])
    np.testing.assert_allclose(seconds, t, rtol=0, atol=1e-9)


def test_bag_times_exact_to_the_nanosecond_past_one_second(tmp_path: Path) -> None:
    t = np.array([0.0, 0.999999999, 1.0, 2.000000001, 7.5])
    q = np.arange(10.0).reshape(5, 2)
    bag = write_joint_trajectory_bag(tmp_path / "bag", ["a", "b"], t, q, -q, 2 * q)
    data = read_joint_trajectory_bag(bag)
    np.testing.assert_array_equal(
        np.round(data.t * 1e9).astype(np.int64), [0, 999999999, 10**9, 2000000001, 75 * 10**8]
    )
    np.testing.assert_allclose(data.t, t, rtol=0, atol=1e-12)


# --- goal YAML ----------------------------------------------------------------------------------------


def test_goal_round_trip_at_the_decimated_samples(tmp_path: Path) -> None:
    t, q, dq, ddq = _motion()  # 1 kHz, last sample at 1.233 s: not on the 100 Hz grid
    goal = write_follow_joint_trajectory_goal(tmp_path / "goal.yaml", JOINTS, t, q, dq, ddq, rate_hz=100.0)
    index = np.r_[np.arange(0, len(t), 10), len(t) - 1]  # every 10th sample, the last one included
    data = read_follow_joint_trajectory_goal(goal)
    assert data.joint_names == JOINTS
    np.testing.assert_array_equal(data.q, q[index])
    np.testing.assert_array_equal(data.dq, dq[index])
    np.testing.assert_array_equal(data.ddq, ddq[index])
    np.testing.assert_allclose(data.t, t[index], rtol=0, atol=1e-9)
    # the file is the goal mapping of control_msgs/action/FollowJointTrajectory
    document = yaml.safe_load(goal.read_text())
    assert set(document) == {"trajectory", "goal_time_tolerance"}
    assert document["goal_time_tolerance"] == {"sec": 0, "nanosec": 0}
    assert document["trajectory"]["joint_names"] == list(JOINTS)
    points = document["trajectory"]["points"]
    assert set(points[0]) == {"positions", "velocities", "accelerations", "time_from_start"}
    assert points[-1]["time_from_start"] == {"sec": 1, "nanosec": 233_000_000}
    assert points[50]["time_from_start"] == {"sec": 0, "nanosec": 500_000_000}


def test_goal_starts_at_the_start_pose_and_says_how_to_send_it(tmp_path: Path) -> None:
    t, q, dq, ddq = _motion(501)
    goal = write_follow_joint_trajectory_goal(
        tmp_path / "excite.yaml", JOINTS, t, q, dq, ddq, rate_hz=50.0, controller="arm_controller"
    )
    data = read_follow_joint_trajectory_goal(goal)
    np.testing.assert_array_equal(data.q[0], q[0])
    assert data.t[0] == 0.0 and data.t[-1] == pytest.approx(0.5, abs=1e-9)

    comments = _comments(goal)
    assert goal.read_text().startswith("# ") and all(
        not line.startswith("#") for line in goal.read_text().splitlines()[len(comments) :]
    )
    text = "\n".join(comments)
    assert (
        "ros2 action send_goal /arm_controller/follow_joint_trajectory "
        'control_msgs/action/FollowJointTrajectory "$(cat excite.yaml)"'
    ) in text
    assert "START POSE" in text and "at rest" in text and "quintic" in text
    start = comments.index(next(line for line in comments if "START POSE" in line))
    for k, name in enumerate(JOINTS):  # the start pose, full precision, in joint order
        assert comments[start + 1 + k].split() == ["#", f"{name}:", repr(float(q[0, k]))]
    # the ready-made goal to the start pose is valid YAML bringing the arm there at rest
    to_start = next(line for line in comments if "send_goal" in line and "$(cat" not in line)
    flow = yaml.safe_load(to_start.split('FollowJointTrajectory "', 1)[1].rsplit('"', 1)[0])
    (point,) = flow["trajectory"]["points"]
    assert flow["trajectory"]["joint_names"] == list(JOINTS) and point["positions"] == [
        float(v) for v in q[0]
    ]
    assert point["velocities"] == [0.0] * 3 and point["accelerations"] == [0.0] * 3
    # this motion starts and ends moving: both are said
    assert "does not start at rest" in text and "allow_nonzero_velocity_at_trajectory_end" in text


def test_goal_states_the_deviation_of_the_quintic_interpolation(tmp_path: Path) -> None:
    t, q, dq, ddq = _motion(1001)
    goal = write_follow_joint_trajectory_goal(tmp_path / "goal.yaml", JOINTS, t, q, dq, ddq, rate_hz=20.0)
    data = read_follow_joint_trajectory_goal(goal)
    deviation = np.abs(quintic_interpolation(data.t, data.q, data.dq, data.ddq, t) - q)
    line = next(line for line in _comments(goal) if "Largest deviation" in line)
    stated = float(line.split(": ")[1].split(" rad")[0])
    assert stated == pytest.approx(deviation.max(), rel=1e-3)
    assert 0 < stated < 1e-6  # 50 ms between points, slow sines
    column = int(np.argmax(deviation.max(axis=0)))
    assert f"joint {JOINTS[column]!r}" in line


def test_goal_at_rest_has_no_warnings_and_a_large_goal_warns_of_the_shell_limit(tmp_path: Path) -> None:
    t = np.linspace(0.0, 1.0, 401)
    s = t**3 * (10 - 15 * t + 6 * t**2)  # rest to rest
    ds = 30 * t**2 * (1 - t) ** 2
    dds = 60 * t * (1 - t) * (1 - 2 * t)
    q, dq, ddq = (np.outer(x, [0.3, -0.2, 0.1, 0.5, -0.4, 0.25, 0.15]) for x in (s, ds, dds))
    names = [f"j{k}" for k in range(7)]
    small = write_follow_joint_trajectory_goal(tmp_path / "small.yaml", names, t, q, dq, ddq, rate_hz=20.0)
    text = "\n".join(_comments(small))
    assert "rest:" not in text and "not at rest" not in text and "WARNING" not in text
    large = write_follow_joint_trajectory_goal(tmp_path / "large.yaml", names, t, q, dq, ddq, rate_hz=400.0)
    assert len(large.read_bytes()) > 131_072
    assert "Argument list too long" in "\n".join(_comments(large))
    assert len(read_follow_joint_trajectory_goal(large).t) == 401


# --- quintic interpolation ----------------------------------------------------------------------------


def test_quintic_interpolation_reproduces_a_quintic_polynomial() -> None:
    rng = np.random.default_rng(3)
    coefficients = rng.normal(size=(6, 2))  # q_j(t) = Σ c_kj t^k, two joints
    powers = np.arange(6)

    def derivative(times: np.ndarray, order: int) -> np.ndarray:
        factor = np.ones(6)
        for m in range(order):
            factor *= np.clip(powers - m, 0, None)
        return (factor * times[:, None] ** np.clip(powers - order, 0, None)) @ coefficients

    knots = np.array([0.0, 0.13, 0.5, 0.51, 1.2, 2.0])  # uneven segments
    query = np.sort(np.r_[rng.uniform(0.0, 2.0, 500), knots])
    got = quintic_interpolation(
        knots, derivative(knots, 0), derivative(knots, 1), derivative(knots, 2), query
    )
    assert got.shape == (len(query), 2)
    np.testing.assert_allclose(got, derivative(query, 0), rtol=0, atol=1e-12)
    # one joint as a 1-D array; the knots themselves come back exactly
    single = quintic_interpolation(knots, *(derivative(knots, k)[:, 0] for k in range(3)), knots)
    np.testing.assert_array_equal(single, derivative(knots, 0)[:, 0])


def test_quintic_interpolation_is_not_a_lower_order_fit() -> None:
    """End accelerations matter: the same positions and velocities with other accelerations differ."""
    knots = np.array([0.0, 1.0])
    middle = quintic_interpolation(knots, np.zeros(2), np.zeros(2), np.array([1.0, 0.0]), np.array([0.5]))
    assert middle[0] == pytest.approx(0.5 * (0.25 - 3 / 8 + 3 / 16 - 1 / 32))


def test_quintic_interpolation_of_sines_converges_with_rate() -> None:
    t, q, dq, ddq = _motion(2001)
    errors = []
    for step in (40, 20, 10):  # 25, 50, 100 Hz points
        index = np.r_[np.arange(0, len(t), step)]
        errors.append(np.abs(quintic_interpolation(t[index], q[index], dq[index], ddq[index], t) - q).max())
    assert errors[0] < 1e-7
    assert errors[0] > 30 * errors[1] > 900 * errors[2]  # sixth order: 64× per halving


def test_quintic_interpolation_rejects_bad_input() -> None:
    knots = np.array([0.0, 1.0])
    zeros = np.zeros(2)
    with pytest.raises(ValueError, match="outside"):
        quintic_interpolation(knots, zeros, zeros, zeros, np.array([1.5]))
    with pytest.raises(ValueError, match="increase strictly"):
        quintic_interpolation(np.array([1.0, 1.0]), zeros, zeros, zeros, np.array([1.0]))
    with pytest.raises(ValueError, match="shape"):
        quintic_interpolation(knots, zeros, np.zeros(3), zeros, np.array([0.5]))


# --- errors -------------------------------------------------------------------------------------------


@pytest.mark.parametrize("write", [write_joint_trajectory_bag, write_follow_joint_trajectory_goal])
def test_writers_refuse_bad_motions(tmp_path: Path, write: Callable[..., Path]) -> None:
    t, q, dq, ddq = _motion(50)
    path = tmp_path / "out"
    with pytest.raises(LogError, match=r"q has shape \(50, 3\), expected \(50, 2\)"):
        write(path, JOINTS[:2], t, q, dq, ddq)
    bad = dq.copy()
    bad[7, 1] = np.nan
    with pytest.raises(LogError, match="non-finite dq nan of joint 'lbr_a2' at sample 7"):
        write(path, JOINTS, t, q, bad, ddq)
    with pytest.raises(LogError, match="shape"):
        write(path, JOINTS, t, q, dq, ddq[:-1])
    backwards = t.copy()
    backwards[10] = backwards[9]
    with pytest.raises(LogError, match=r"increase strictly.*sample 10"):
        write(path, JOINTS, backwards, q, dq, ddq)
    with pytest.raises(LogError, match="distinct"):
        write(path, ["a", "a", "b"], t, q, dq, ddq)
    assert not path.exists()
    with pytest.raises(LogError, match=re.escape(str(path))):
        write(path, JOINTS, t - 1.0, q, dq, ddq)


def test_bag_writer_refuses_an_existing_path(tmp_path: Path) -> None:
    t, q, dq, ddq = _motion(20)
    bag = write_joint_trajectory_bag(tmp_path / "bag", JOINTS, t, q, dq, ddq)
    with pytest.raises(LogError, match="exists already"):
        write_joint_trajectory_bag(bag, JOINTS, t, q, dq, ddq)
    np.testing.assert_array_equal(read_joint_trajectory_bag(bag).q, q)  # untouched


def test_goal_writer_refuses_a_rate_above_the_motion(tmp_path: Path) -> None:
    t, q, dq, ddq = _motion(50)
    with pytest.raises(LogError, match="exceeds the motion's sample rate"):
        write_follow_joint_trajectory_goal(tmp_path / "g.yaml", JOINTS, t, q, dq, ddq, rate_hz=2000.0)
    with pytest.raises(LogError, match="rate_hz must be positive"):
        write_follow_joint_trajectory_goal(tmp_path / "g.yaml", JOINTS, t, q, dq, ddq, rate_hz=0.0)


def test_bag_reader_names_the_bag_and_topic(tmp_path: Path) -> None:
    t, q, dq, ddq = _motion(20)
    states = write_joint_states(tmp_path / "states", t, q, None, JOINTS)
    with pytest.raises(LogError, match=re.escape(f"{tmp_path / 'states'}: 0 {JOINT_TRAJECTORY_TYPE} topics")):
        read_joint_trajectory_bag(states)
    with pytest.raises(
        LogError, match=r"topic '/joint_states' is not a .*it carries sensor_msgs/msg/JointState"
    ):
        read_joint_trajectory_bag(states, topic="/joint_states")
    bag = write_joint_trajectory_bag(tmp_path / "bag", JOINTS, t, q, dq, ddq)
    with pytest.raises(LogError, match=r"topic '/other' is not a .*no such topic"):
        read_joint_trajectory_bag(bag, topic="/other")
    with pytest.raises(LogError, match="no such ROS 2 bag"):
        read_joint_trajectory_bag(tmp_path / "missing")


def test_goal_reader_names_the_file_and_the_point(tmp_path: Path) -> None:
    t, q, dq, ddq = _motion(20)
    goal = write_follow_joint_trajectory_goal(tmp_path / "goal.yaml", JOINTS, t, q, dq, ddq, rate_hz=1000.0)
    document = yaml.safe_load(goal.read_text())
    del document["trajectory"]["points"][4]["velocities"][2]
    edited = tmp_path / "edited.yaml"
    edited.write_text(yaml.safe_dump(document))
    with pytest.raises(LogError, match=re.escape(f"{edited}: point 4: 2 velocities for 3 joints")):
        read_follow_joint_trajectory_goal(edited)
    document = yaml.safe_load(goal.read_text())
    document["trajectory"]["points"][3]["time_from_start"] = {"sec": 0, "nanosec": 1_000_000}
    edited.write_text(yaml.safe_dump(document))
    with pytest.raises(LogError, match="point 3 does not exceed that of point 2"):
        read_follow_joint_trajectory_goal(edited)
    edited.write_text("- just a list\n")
    with pytest.raises(LogError, match=re.escape(f"{edited}: the goal must be a mapping")):
        read_follow_joint_trajectory_goal(edited)
