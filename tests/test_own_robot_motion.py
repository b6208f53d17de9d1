"""A user's own robot: limits that must be given, a motion rejected when its 1 kHz check fails, the
accepted motion exported for ROS 2 with its preview, and, on a URDF nobody here wrote (meshes found
through ROS_PACKAGE_PATH), a motion an independent exact-mesh check finds free of contact."""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pinocchio as pin
import pytest
from composing import compose_config
from test_end_to_end import only_run, run_lwrlab

from lwrlab.errors import ConfigError
from lwrlab.excitation.solver import RejectedMotionError
from lwrlab.io.ros2_trajectory import read_follow_joint_trajectory_goal, read_joint_trajectory_bag
from lwrlab.model.collision_geometry import package_search_path
from lwrlab.pipeline.excitation import run_excitation

QUICK = ["optimizer.max_iterations=30", "optimizer.show_progress=false", "trajectory.duration=2.0"]


def example_robots() -> Path:
    """The robots folder of the installed example-robot-data (skip when it is not installed)."""
    for folder in package_search_path():
        if (folder / "example-robot-data" / "robots").is_dir():
            return folder / "example-robot-data" / "robots"
    pytest.skip("example-robot-data is not installed (pip install 'lwrlab[robots]')")


def test_a_urdf_without_acceleration_limits_stops_naming_the_setting(tmp_path: Path) -> None:
    urdf = example_robots() / "ur_description" / "urdf" / "ur5_robot.urdf"
    cfg = compose_config("task=excitation", "robot=urdf", f"robot.path={urdf}", *QUICK)
    with pytest.raises(
        ConfigError, match=r"no acceleration limit .* robot\.acceleration_limits=.*joint_limits"
    ):
        run_excitation(cfg, tmp_path)
    assert not list(tmp_path.iterdir())  # stopped before any work


def test_moveit_joint_limits_give_the_acceleration_limits(tmp_path: Path) -> None:
    from lwrlab.pipeline.build import build

    urdf = example_robots() / "ur_description" / "urdf" / "ur5_robot.urdf"
    names = [
        f"{j}_joint" for j in ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")
    ]
    lines = ["joint_limits:"]
    for i, name in enumerate(names):
        lines += [
            f"  {name}:",
            "    has_velocity_limits: true",
            "    max_velocity: 1.5",
            f"    has_acceleration_limits: {'true' if i else 'false'}",
            f"    max_acceleration: {5.0 + i}",
        ]
    limits = tmp_path / "joint_limits.yaml"
    limits.write_text("\n".join(lines) + "\n")
    robot = build("robot", "urdf", path=str(urdf), joint_limits=str(limits))
    assert np.isinf(robot.limits.acceleration[0])  # has_acceleration_limits: false
    np.testing.assert_allclose(robot.limits.acceleration[1:], [6.0, 7.0, 8.0, 9.0, 10.0])
    np.testing.assert_allclose(robot.limits.velocity, 1.5)  # lower than the URDF's


def test_a_motion_failing_its_1khz_check_is_rejected_and_kept_under_another_name(tmp_path: Path) -> None:
    """Optimised on a 10 Hz grid without margins, the motion breaks its limits between the samples."""
    cfg = compose_config(
        "task=excitation",
        *QUICK,
        "trajectory.rate_hz=10",
        "trajectory.window_s=0.1",
        "trajectory.constraints.limit_margin=0.0",
        "trajectory.constraints.distance_margin=0.0",
    )
    with pytest.raises(RejectedMotionError, match=r"not written as a motion to run.*violated by .* at t = "):
        run_excitation(cfg, tmp_path)
    assert (tmp_path / "rejected_exciting_motion.yaml").is_file()
    assert (tmp_path / "rejected_exciting_motion.csv").is_file()
    assert (tmp_path / "rejected_exciting_motion_preview.png").is_file()
    assert (
        not (tmp_path / "exciting_motion.yaml").exists() and not (tmp_path / "exciting_motion_bag").exists()
    )
    report = (tmp_path / "excitation_report.md").read_text()
    assert "**Rejected**" in report
    assert json.loads((tmp_path / "metrics.json").read_text())["accepted"] == 0.0


def test_an_accepted_motion_is_exported_for_ros2_with_its_preview(tmp_path: Path) -> None:
    cfg = compose_config("task=excitation", *QUICK, "trajectory.from_file=null")
    metrics = run_excitation(cfg, tmp_path)
    assert metrics["accepted"] == 1.0 and metrics["closest_self_m"] >= 0.01
    motion = pd.read_csv(tmp_path / "exciting_motion.csv")
    q = motion.filter(regex=r"^q\d").to_numpy()
    bag = read_joint_trajectory_bag(tmp_path / "exciting_motion_bag")
    np.testing.assert_allclose(bag.q, q, atol=1e-12)
    assert bag.joint_names == tuple(f"joint{j}" for j in range(1, 8))
    goal = read_follow_joint_trajectory_goal(tmp_path / "exciting_motion_goal.yaml")
    np.testing.assert_allclose(goal.q[0], q[0], atol=1e-12)  # it starts at the start pose
    assert goal.t[-1] == pytest.approx(2.0)
    assert (tmp_path / "exciting_motion_preview.png").stat().st_size > 20_000
    assert "Start pose" in (tmp_path / "excitation_report.md").read_text()


def _vertices(geometry: object) -> np.ndarray:
    """Points whose lowest is the lowest of a mesh, a box, a cylinder or a sphere (shape frame; round
    shapes by 256 points on their rims, within 0.01 % of their radius)."""
    if hasattr(geometry, "vertices"):
        return np.asarray(geometry.vertices())
    if hasattr(geometry, "halfSide"):  # a box
        half = np.asarray(geometry.halfSide)
        return np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
    angle = np.linspace(0.0, 2 * np.pi, 256, endpoint=False)
    if hasattr(geometry, "halfLength"):  # a cylinder along z
        ring = geometry.radius * np.column_stack([np.cos(angle), np.sin(angle)])
        return np.vstack(
            [np.column_stack([ring, np.full(256, z)]) for z in (-geometry.halfLength, geometry.halfLength)]
        )
    circles = [
        np.column_stack([np.cos(angle), np.sin(angle), np.zeros(256)])[:, order]
        for order in ([0, 1, 2], [0, 2, 1], [2, 0, 1])
    ]
    return geometry.radius * np.vstack(circles)  # a sphere: its great circles


def _independent_contacts(urdf: Path, share: Path, q: np.ndarray, clearance: float) -> tuple[int, float]:
    """Poses of q in self-contact (URDF collision meshes, neighbours and always-touching pairs left
    out, padding = clearance) and the lowest point of the moving links beyond the first, by Pinocchio
    and coal alone."""
    model = pin.buildModelFromUrdf(str(urdf))
    geometry = pin.buildGeomFromUrdf(model, str(urdf), pin.GeometryType.COLLISION, package_dirs=[str(share)])
    geometry.addAllCollisionPairs()
    for k in reversed(range(len(geometry.collisionPairs))):
        pair = geometry.collisionPairs[k]
        a = geometry.geometryObjects[pair.first].parentJoint
        b = geometry.geometryObjects[pair.second].parentJoint
        if a == b or model.parents[a] == b or model.parents[b] == a:
            geometry.removeCollisionPair(pair)
    data, geometry_data = model.createData(), geometry.createData()
    rng = np.random.default_rng(3)
    always = np.zeros(len(geometry.collisionPairs))
    for _ in range(100):
        pin.computeCollisions(
            model,
            data,
            geometry,
            geometry_data,
            rng.uniform(model.lowerPositionLimit, model.upperPositionLimit),
        )
        always += [r.isCollision() for r in geometry_data.collisionResults]
    for k in reversed(np.flatnonzero(always >= 95)):
        geometry.removeCollisionPair(geometry.collisionPairs[int(k)])
    geometry_data = geometry.createData()
    for request in geometry_data.collisionRequests:
        request.security_margin = clearance
    in_contact, lowest = 0, np.inf
    for k in range(q.shape[0]):
        pin.computeCollisions(model, data, geometry, geometry_data, q[k], False)
        in_contact += any(r.isCollision() for r in geometry_data.collisionResults)
        pin.updateGeometryPlacements(model, data, geometry, geometry_data)
        for i, obj in enumerate(geometry.geometryObjects):
            if obj.parentJoint > 1:
                placement = geometry_data.oMg[i]
                points = _vertices(obj.geometry) @ placement.rotation.T + placement.translation
                lowest = min(lowest, float(points[:, 2].min()))
    return in_contact, lowest


@pytest.mark.slow
def test_an_unseen_industrial_arm_gets_a_motion_clear_of_its_meshes_and_the_table(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A UR10 URDF copied elsewhere, its meshes named package://ur_description/… and found through
    ROS_PACKAGE_PATH: the command a user types gives a motion an independent mesh check clears."""
    robots = example_robots()
    urdf = tmp_path / "ur10.urdf"
    text = (robots / "ur_description" / "urdf" / "ur10_robot.urdf").read_text()
    urdf.write_text(
        text.replace("package://example-robot-data/robots/ur_description/", "package://ur_description/")
    )
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(robots))
    completed = run_lwrlab(
        tmp_path / "run",
        "task=excitation",
        "robot=urdf",
        f"robot.path={urdf}",
        "robot.acceleration_limits=10",
        "optimizer.show_progress=false",
    )
    assert completed.returncode == 0, completed.stderr[-3000:]
    folder = tmp_path / "run" / "run"
    q = pd.read_csv(folder / "exciting_motion.csv").filter(regex=r"^q\d").to_numpy()
    assert q.shape == (10001, 6)
    in_contact, lowest = _independent_contacts(urdf, robots, q, clearance=0.01)
    assert in_contact == 0
    assert lowest > 0.01  # above the mounting surface, with the clearance
    assert only_run(tmp_path / "run", "excitation").info.status == "FINISHED"


@pytest.mark.slow
def test_the_shipped_panda_motion_clears_the_panda_meshes_hand_and_srdf(tmp_path: Path) -> None:
    """The library's Panda motion, checked with the Panda's own URDF (hand, open fingers), its SRDF
    and coal, independently of lwrlab's check."""
    from lwrlab.pipeline.build import build

    robots = example_robots()
    motion = build(
        "trajectory", "bspline", from_file="pkg://lwrlab/data/exciting_motions/panda_logdet_10s.yaml"
    )
    robot = build("robot", "panda")
    q = motion.sample(robot, 1000.0).q
    urdf = robots / "panda_description" / "urdf" / "panda.urdf"
    model = pin.buildModelFromUrdf(str(urdf))
    share = robots.parents[1]
    geometry = pin.buildGeomFromUrdf(model, str(urdf), pin.GeometryType.COLLISION, package_dirs=[str(share)])
    fingers = [model.getJointId(n) for n in ("panda_finger_joint1", "panda_finger_joint2")]
    reference = pin.neutral(model)
    reference[[model.joints[j].idx_q for j in fingers]] = 0.04
    model, geometry = pin.buildReducedModel(model, geometry, fingers, reference)
    geometry.addAllCollisionPairs()
    pin.removeCollisionPairs(model, geometry, str(robots / "panda_description" / "srdf" / "panda.srdf"))
    data, geometry_data = model.createData(), geometry.createData()
    contacts, lowest = 0, np.inf
    for k in range(0, q.shape[0]):
        contacts += pin.computeCollisions(model, data, geometry, geometry_data, q[k], True)
        pin.updateGeometryPlacements(model, data, geometry, geometry_data)
        for i, obj in enumerate(geometry.geometryObjects):
            if obj.parentJoint > 1:
                placement = geometry_data.oMg[i]
                points = _vertices(obj.geometry) @ placement.rotation.T + placement.translation
                lowest = min(lowest, float(points[:, 2].min()))
    assert contacts == 0
    assert lowest > 0.0  # the hand and fingers above the mounting surface


@pytest.mark.slow
@pytest.mark.parametrize("name", ["panda", "ur3", "ur5", "ur10", "xarm7", "z1"])
def test_every_example_robot_gets_a_motion_its_own_meshes_clear(name: str) -> None:
    """Each arm robot=example_robot loads: the default 10 s motion passes lwrlab's check, and an
    independent Pinocchio/coal check of its URDF meshes finds no self-contact (SRDF pairs aside) and
    nothing below the mounting surface."""
    from lwrlab.excitation.solver import check_motion_at
    from lwrlab.pipeline.build import build
    from plugins.robots.example_robot import ROBOTS, example_robot_file

    robots = example_robots()
    entry = ROBOTS[name]
    robot = build(
        "robot",
        "example_robot",
        robot_name=name,
        acceleration_limits=None if entry.acceleration_limits else 10.0,
    )
    optimizer = build("optimizer", "slsqp", show_progress=False)
    source = build("trajectory", "optimal", from_file=None, optimizer=optimizer)
    motion, _, _ = source.optimise(robot)
    assert check_motion_at(robot, motion, source.constraints, 1000.0).passed
    q = motion.sample(robot, 1000.0).q
    urdf = Path(example_robot_file(entry.urdf))
    model = pin.buildModelFromUrdf(str(urdf))
    geometry = pin.buildGeomFromUrdf(
        model, str(urdf), pin.GeometryType.COLLISION, package_dirs=[str(robots.parents[1])]
    )
    if entry.locked_joints:
        reference = pin.neutral(model)
        ids = [model.getJointId(j) for j in entry.locked_joints]
        for joint, value in entry.locked_joints.items():
            reference[model.joints[model.getJointId(joint)].idx_q] = value
        model, geometry = pin.buildReducedModel(model, geometry, ids, reference)
    geometry.addAllCollisionPairs()
    if entry.srdf is not None:
        pin.removeCollisionPairs(model, geometry, example_robot_file(entry.srdf))
    for k in reversed(range(len(geometry.collisionPairs))):  # neighbours touch at their joint
        pair = geometry.collisionPairs[k]
        a = geometry.geometryObjects[pair.first].parentJoint
        b = geometry.geometryObjects[pair.second].parentJoint
        if a == b or model.parents[a] == b or model.parents[b] == a:
            geometry.removeCollisionPair(pair)
    data, geometry_data = model.createData(), geometry.createData()
    rng = np.random.default_rng(3)
    always = np.zeros(len(geometry.collisionPairs))
    for _ in range(100):  # pairs touching in every pose are the robot's own structure
        pin.computeCollisions(
            model,
            data,
            geometry,
            geometry_data,
            rng.uniform(model.lowerPositionLimit, model.upperPositionLimit),
        )
        always += [r.isCollision() for r in geometry_data.collisionResults]
    for k in reversed(np.flatnonzero(always >= 95)):
        geometry.removeCollisionPair(geometry.collisionPairs[int(k)])
    geometry_data = geometry.createData()
    contacts, lowest = 0, np.inf
    for k in range(q.shape[0]):
        contacts += pin.computeCollisions(model, data, geometry, geometry_data, q[k], True)
        pin.updateGeometryPlacements(model, data, geometry, geometry_data)
        for i, obj in enumerate(geometry.geometryObjects):
            if model.parents[obj.parentJoint] > 0:  # the links beyond the first (it stands on the surface)
                placement = geometry_data.oMg[i]
                points = _vertices(obj.geometry) @ placement.rotation.T + placement.translation
                lowest = min(lowest, float(points[:, 2].min()))
    assert contacts == 0
    assert lowest > 0.0


def test_a_urdf_robot_without_a_flange_frame_is_one_line_naming_the_setting(tmp_path: Path) -> None:
    """task=payload needs the flange: the error is a user error (one line) naming robot.flange_frame."""
    from lwrlab.model.payload import flange_placement
    from lwrlab.pipeline.build import build

    urdf = example_robots() / "ur_description" / "urdf" / "ur5_robot.urdf"
    robot = build("robot", "urdf", path=str(urdf))
    with pytest.raises(ConfigError, match=r"robot\.flange_frame=<the URDF link"):
        flange_placement(robot)
