"""The live monitor (lwrlab/live, task=live_monitor, task=sim_robot) on real DDS over loopback.

Fast: joint states read by name (reordered, extra, missing, another robot's, non-finite, motor side);
the sample path fed a recorded stream equals the offline monitor (estimates, thresholds, contacts);
every kind of bad stream gets its diagnostic and never a crash. Slow: the two processes over DDS
(the simulated robot and the monitor), every push detected with no false alarm, and the same alarms
and estimates offline on the run's bag; the run FINISHED in MLflow with its figures.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from pushed_logs import SETTINGS, pushed_log
from ros_domains import ros_domain

from lwrlab.live.dds import Node, Received
from lwrlab.live.joint_states import JointSample, JointStateReader, Refusal
from lwrlab.live.messages import Bool, DiagnosticArray, Header, JointState, Time, WrenchStamped
from lwrlab.live.monitor_loop import LiveMonitorLoop
from lwrlab.live.wire import decode_joint_state
from lwrlab.model.drive_train import DriveTrain
from lwrlab.model.robot import RobotModel
from lwrlab.monitoring.contact_force import FrameLoad
from lwrlab.monitoring.estimates import calibrate, detect, estimate_external_torques
from lwrlab.monitoring.stream import MonitorStream
from lwrlab.plants.pushed_arm import ExternalForce

LOOPBACK = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
TOPICS = {
    "joint_states": "/test/joint_states",
    "external_torque": "/test/external_torque",
    "contact_wrench": "/test/contact_wrench",
    "collision": "/test/collision",
    "diagnostics": "/test/diagnostics",
}


def test_joint_states_are_read_by_name(lwr4: RobotModel) -> None:
    reader = JointStateReader(lwr4)
    names = list(lwr4.joint_names)
    q, tau = np.arange(7) * 0.1, np.arange(7) * 1.0
    order = [3, 0, 6, 2, 5, 1, 4]
    shuffled = reader.read(1.0, [names[i] for i in order] + ["gripper"], [*q[order], 9.0], [*tau[order], 9.0])
    assert isinstance(shuffled, JointSample)
    np.testing.assert_array_equal(shuffled.q, q)
    np.testing.assert_array_equal(shuffled.tau, tau)
    other = reader.read(1.0, ["finger_1", "finger_2"], [0.0, 0.0], [0.0, 0.0])
    assert isinstance(other, Refusal) and other.other_robot
    missing = reader.read(1.0, names[:6], q[:6].tolist(), tau[:6].tolist())
    assert isinstance(missing, Refusal) and names[6] in missing.reason and not missing.other_robot
    short = reader.read(1.0, names, q.tolist(), [])
    assert isinstance(short, Refusal) and "efforts" in short.reason
    bad = reader.read(1.0, names, [*q[:6], np.nan], tau.tolist())
    assert isinstance(bad, Refusal) and names[6] in bad.reason
    with pytest.raises(ValueError, match=r"task\.joint_names"):
        JointStateReader(lwr4, ["a", "b"])
    renamed = JointStateReader(lwr4, [f"arm_{i}" for i in range(7)])
    assert isinstance(
        renamed.read(0.0, [f"arm_{i}" for i in range(7)], q.tolist(), tau.tolist()), JointSample
    )


def test_motor_side_joint_states_reach_the_joint_side(lwr4: RobotModel) -> None:
    gears = np.full(7, 100.0)
    drive = DriveTrain(
        gear_ratios=gears,
        coupling=np.eye(7),
        torque_constants=np.full(7, 0.2),
        position_side="motor",
        torque_side="motor",
    )
    robot = replace(lwr4, drive=drive)
    reader = JointStateReader(robot)
    q = np.linspace(-0.5, 0.5, 7)
    tau = np.linspace(-10.0, 10.0, 7)
    theta = drive.measured_positions(q)
    current = drive.motor_torques(tau) / 0.2
    wrapped = np.angle(np.exp(1j * theta))  # encoders that wrap every turn
    first = reader.read(0.0, robot.joint_names, wrapped.tolist(), current.tolist())
    assert isinstance(first, JointSample)
    np.testing.assert_allclose(first.tau, tau, atol=1e-9)
    # the motors turn on by a third of a turn a sample: the wraps are counted
    for k in range(1, 8):
        step = theta + k * 2.0
        sample = reader.read(
            k * 1e-3, robot.joint_names, np.angle(np.exp(1j * step)).tolist(), current.tolist()
        )
        assert isinstance(sample, JointSample)
    np.testing.assert_allclose(sample.q - first.q, 7 * 2.0 / gears, atol=1e-9)


@pytest.fixture(scope="module")
def recorded(lwr4: RobotModel):
    """A pushed log (two pushes) and thresholds calibrated on a contact-free one, 3 s each."""
    pushes = [
        ExternalForce(1.0, 0.3, 4, np.array([0.0, 0.05, 0.1]), np.array([0.0, 30.0, 0.0])),
        ExternalForce(2.0, 0.2, 6, np.array([0.0, 0.0, 0.05]), np.array([20.0, 0.0, 0.0])),
    ]
    free = pushed_log(lwr4, 5, [], "free")
    calibrations = calibrate([estimate_external_torques(lwr4, free, SETTINGS)], SETTINGS)
    return pushed_log(lwr4, 6, pushes, "pushed"), calibrations


def _loop(robot: RobotModel, calibrations, node: Node, rate_hz: float | None = 1000.0) -> LiveMonitorLoop:
    kinds = (JointState, WrenchStamped, Bool, DiagnosticArray)
    keys = ("external_torque", "contact_wrench", "collision", "diagnostics")
    publish = {key: node.publisher(TOPICS[key], kind) for key, kind in zip(keys, kinds, strict=True)}
    return LiveMonitorLoop(
        lambda period: MonitorStream.of(robot, SETTINGS, calibrations["observer"], period),
        JointStateReader(robot),
        FrameLoad(robot, "flange"),
        "flange",
        list(robot.joint_names),
        publish,
        None,
        TOPICS,
        rate_hz=rate_hz,
        max_gap_s=0.05,
        diagnostics_hz=10.0,
    )


def _message(names, t: float, q, tau) -> Received:
    message = JointState(Header(Time.of(t), ""), list(names), list(q), [], list(tau))
    raw = message.serialize()
    now = time.time_ns()
    return Received(decode_joint_state(raw), raw, now, now)


@pytest.fixture(scope="module")
def node() -> Node:
    return Node(localhost=True)


def test_the_sample_path_equals_the_offline_monitor(lwr4: RobotModel, recorded, node: Node) -> None:
    pushed, calibrations = recorded
    loop = _loop(lwr4, calibrations, node, rate_hz=None)  # the rate measured on the first samples
    names = list(lwr4.joint_names)
    order = [6, 5, 4, 3, 2, 1, 0]  # the publisher lists the joints in its own order
    for k in range(len(pushed.t)):
        loop.on_joint_state(
            _message([names[i] for i in order], pushed.t[k], pushed.q[k][order], pushed.tau[k][order])
        )
    loop.finish()
    offline = estimate_external_torques(lwr4, pushed, SETTINGS)
    found = detect(offline, calibrations, SETTINGS)["observer"]
    rows = loop.estimates.table()
    assert loop.counts.samples == len(pushed.t) and loop.counts.dropped == 0
    expected = np.where(offline.watched("observer")[:, None], offline.observer, 0.0)
    np.testing.assert_allclose(rows["external_torque"], expected, rtol=0, atol=1e-7 * np.abs(expected).max())
    assert [(d.start_index, d.end_index, d.joint) for d in loop.detections] == [
        (d.start_index, d.end_index, d.joint) for d in found
    ]
    assert len(found) == 2
    assert np.all(np.isfinite(rows["latency"][1:]))


def test_bad_streams_are_said_and_survived(lwr4: RobotModel, recorded, node: Node) -> None:
    pushed, calibrations = recorded
    loop = _loop(lwr4, calibrations, node)
    names = list(lwr4.joint_names)
    feed = [(k, pushed.t[k]) for k in range(600)]
    feed += [(k, pushed.t[k]) for k in range(605, 900)]  # 5 samples lost: filled in
    feed += [(k, pushed.t[k]) for k in range(1000, 1400)]  # 0.1 s lost: the observer starts anew
    for k, t in feed:
        loop.on_joint_state(_message(names, t, pushed.q[k], pushed.tau[k]))
        if k == 300:
            loop.on_joint_state(_message(names, t, pushed.q[k], pushed.tau[k]))  # again: out of order
            loop.on_joint_state(_message(["finger"], t + 1e-4, [0.0], [0.0]))  # another robot's
            loop.on_joint_state(_message(names[:5], t + 2e-4, pushed.q[k][:5], pushed.tau[k][:5]))
            loop.on_joint_state(_message(names, t + 3e-4, [np.nan] * 7, pushed.tau[k]))
    for k in range(200):  # the publisher restarts: its stamps start again from 0
        loop.on_joint_state(_message(names, k * 1e-3, pushed.q[k], pushed.tau[k]))
    loop.finish()
    counts = loop.counts
    assert counts.out_of_order == 1 and counts.other_robot == 1 and counts.refused == 2
    assert counts.dropped == 1 + 5 + 100 and counts.restarts == 2
    said = " | ".join(counts.notes)
    for words in (
        "another robot",
        "joints missing",
        "non-finite",
        "at or before",
        "filled in",
        "stall",
        "went back",
    ):
        assert words in said, words
    rows = loop.estimates.table()
    assert len(rows["t"]) == counts.samples + 5  # the filled-in samples are kept, not published
    assert not rows["monitored"][-199:-99].any() and rows["monitored"][-1]  # a new start-up after a restart


def test_unstamped_joint_states_use_their_publication_times(lwr4: RobotModel, recorded, node: Node) -> None:
    pushed, calibrations = recorded
    loop = _loop(lwr4, calibrations, node)
    names = list(lwr4.joint_names)
    for k in range(300):
        message = JointState(Header(), names, pushed.q[k].tolist(), [], pushed.tau[k].tolist())
        raw = message.serialize()
        published = 10**18 + k * 1_000_000
        loop.on_joint_state(Received(decode_joint_state(raw), raw, published, published))
    assert any("unstamped" in note for note in loop.counts.notes)
    assert loop.counts.samples >= 298


# --- two processes over DDS on loopback (slow) ------------------------------------------------------


def _lwrlab(*args: str, env: dict[str, str]) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "lwrlab.cli", *args],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )


def _sockets(pids: list[int]) -> list[str]:
    """The listening sockets (TCP) and bound UDP sockets of ``pids``, as ``ss`` lists them."""
    lines = []
    for flags in ("-tlnp", "-ulnp"):
        out = subprocess.run(["ss", flags], capture_output=True, text=True, check=False).stdout.splitlines()
        lines += [f"{flags} {line}" for line in out if any(f"pid={pid}," in line for pid in pids)]
    return lines


@pytest.fixture(scope="module")
def identified(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The simulated LWR4 identified on the defaults (the robot task=sim_robot simulates)."""
    folder = tmp_path_factory.mktemp("identified")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "lwrlab.cli",
            "task=identification",
            f"hydra.run.dir={folder}",
            "tracking=none",
        ],
        check=True,
        capture_output=True,
    )
    return folder


@pytest.mark.slow
def test_the_simulated_robot_and_the_live_monitor_over_dds(tmp_path: Path, identified: Path) -> None:
    env = {**os.environ, **LOOPBACK, "ROS_DOMAIN_ID": str(ros_domain(2))}
    store = f"sqlite:///{tmp_path / 'mlflow.db'}"
    monitor_dir, robot_dir = tmp_path / "monitor", tmp_path / "robot"
    monitor = _lwrlab(
        "task=live_monitor",
        f"task.model={identified}",
        "task.idle_stop_s=1.5",
        f"hydra.run.dir={monitor_dir}",
        f"tracking.uri={store}",
        env=env,
    )
    robot = _lwrlab(
        "task=sim_robot",
        "task.random_pushes=6",
        "task.stamps=sim",
        "task.hold_after_s=3",
        f"hydra.run.dir={robot_dir}",
        "tracking=none",
        env=env,
    )
    sockets: list[str] = []
    deadline = time.monotonic() + 240
    while robot.poll() is None and time.monotonic() < deadline:
        time.sleep(2.0)
        sockets = sockets or _sockets([monitor.pid, robot.pid])
    robot_out = robot.communicate(timeout=60)[0]
    monitor_out = monitor.communicate(timeout=60)[0]
    assert robot.returncode == 0, robot_out[-3000:]
    assert monitor.returncode == 0, monitor_out[-3000:]
    # loopback only: nothing listens on TCP; the packets leave from 127.0.0.1
    assert sockets and not any(line.startswith("-tlnp") for line in sockets), sockets
    assert any("127.0.0.1:" in line for line in sockets), sockets

    metrics = json.loads((monitor_dir / "metrics.json").read_text())
    assert metrics["dropped_samples"] == 0 and metrics["refused_messages"] == 0
    contacts = pd.read_csv(robot_dir / "contacts.csv")
    detections = pd.read_csv(monitor_dir / "detections.csv")
    assert len(contacts) == 6 and len(detections) == 6  # every push, no false alarm
    for (_, push), (_, found) in zip(contacts.iterrows(), detections.iterrows(), strict=True):
        assert push.start <= found.start and found.raised - push.start <= 0.03
    # the same alarms and estimates offline, on the run's bag read as a log
    offline_dir = tmp_path / "offline"
    subprocess.run(
        [
            sys.executable,
            "-m",
            "lwrlab.cli",
            "task=monitor",
            "plant=log",
            f"task.model={identified}",
            f"data.paths=[{monitor_dir / 'live_bag'}]",
            f"hydra.run.dir={offline_dir}",
            "tracking=none",
        ],
        env=env,
        check=True,
        capture_output=True,
    )
    offline = pd.read_csv(offline_dir / "detections.csv")
    offline = offline[offline.estimator == "observer"]
    np.testing.assert_allclose(
        offline[["start", "raised", "end"]], detections[["start", "raised", "end"]], atol=1e-9
    )
    assert offline.joint.tolist() == detections.joint.tolist()
    live = pd.read_parquet(monitor_dir / "external_torque.parquet")
    again = pd.read_parquet(offline_dir / "external_torque.parquet")
    columns = [f"observer{j}" for j in range(1, 8)]
    watched = live["monitored"].to_numpy()
    np.testing.assert_allclose(live.loc[watched, columns], again.loc[watched, columns], rtol=0, atol=1e-6)
    # the MLflow run: FINISHED with the live figures
    import mlflow

    client = mlflow.MlflowClient(store)
    (run,) = client.search_runs([e.experiment_id for e in client.search_experiments()])
    assert run.info.status == "FINISHED"
    assert {"samples", "dropped_samples", "latency_median_ms", "latency_p99_ms", "detections"} <= set(
        run.data.metrics
    )


@pytest.mark.slow
def test_a_live_monitor_without_joint_states_fails_in_mlflow(tmp_path: Path, identified: Path) -> None:
    env = {**os.environ, **LOOPBACK, "ROS_DOMAIN_ID": str(ros_domain(3))}
    store = f"sqlite:///{tmp_path / 'mlflow.db'}"
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "lwrlab.cli",
            "task=live_monitor",
            "task.wait_s=2",
            f"task.model={identified}",
            f"hydra.run.dir={tmp_path / 'run'}",
            f"tracking.uri={store}",
        ],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode != 0
    import mlflow

    client = mlflow.MlflowClient(store)
    runs = client.search_runs([e.experiment_id for e in client.search_experiments()])
    assert runs and runs[0].info.status == "FAILED"
    assert "no joint states on /joint_states within 2 s" in done.stderr + done.stdout


def test_thresholds_are_calibrated_once_per_logs_model_and_settings(
    lwr4: RobotModel, recorded, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from lwrlab.pipeline.live import calibration_cache
    from lwrlab.plants.core import Measurement
    from lwrlab.tracking.store.schema_template import CACHE_ENVIRONMENT_VARIABLE

    monkeypatch.setenv(CACHE_ENVIRONMENT_VARIABLE, str(tmp_path))
    pushed, _ = recorded
    log = Measurement(t=pushed.t[:1500], q=pushed.q[:1500], tau=pushed.tau[:1500])
    monkeypatch.setattr(calibration_cache, "calibration_measurements", lambda *args: ([log], "a log"))
    calls = []
    real = calibration_cache.calibrate
    monkeypatch.setattr(calibration_cache, "calibrate", lambda *a: calls.append(1) or real(*a))
    first, source = calibration_cache.cached_calibration(None, lwr4, None, None, SETTINGS)
    again, _ = calibration_cache.cached_calibration(None, lwr4, None, None, SETTINGS)
    assert source == "a log" and len(calls) == 1
    np.testing.assert_array_equal(again["observer"].floor, first["observer"].floor)  # type: ignore[union-attr]
    calibration_cache.cached_calibration(None, lwr4, None, None, replace(SETTINGS, margin=1.4))
    assert len(calls) == 2 and len(list((tmp_path / "calibrations").glob("*.pickle"))) == 2
