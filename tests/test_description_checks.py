"""A robot's description files checked against each other, and names a link and a joint share.

An SRDF or a MoveIt ``joint_limits.yaml`` written for another robot used to be accepted silently (its
pairs or limits simply matched nothing): it is now one line naming what the URDF lacks and the files.
A ``joint_limits.yaml`` may name joints the robot locks (a gripper's fingers); a stray name in the
parts of an SRDF lwrlab does not read (MoveIt's groups) is a warning. Locking a joint whose
name is also a link's (the SO-100 arm's ``gripper``) used to end in a Pinocchio traceback ("Several
frames match the filter"): it now loads, and its geometry with it.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from composing import compose_config

from lwrlab.cli import _user_error, run
from lwrlab.errors import UnknownNameError
from lwrlab.model.collision_geometry import CollisionSource, load_robot_geometry, package_search_path
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from plugins.robots.example_robot import ROBOTS, example_robot_file

REPOSITORY = Path(__file__).resolve().parents[1]

SHARED_NAME_URDF = """<robot name="pincher">
  <link name="base"/>
  <link name="arm">
    <inertial><origin xyz="0 0 0.1"/><mass value="1"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <collision><origin xyz="0 0 0.1"/><geometry><box size="0.04 0.04 0.2"/></geometry></collision>
  </link>
  <link name="gripper">
    <inertial><origin xyz="0.01 0 0.03"/><mass value="0.3"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
    <collision><geometry><box size="0.04 0.04 0.04"/></geometry></collision>
  </link>
  <link name="jaw">
    <inertial><origin xyz="0 0.02 0.02"/><mass value="0.1"/>
      <inertia ixx="0.0002" ixy="0" ixz="0" iyy="0.0002" iyz="0" izz="0.0002"/></inertial>
    <collision><origin xyz="0 0.02 0.02"/><geometry><box size="0.01 0.04 0.04"/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="arm"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="2"/>
  </joint>
  <joint name="wrist" type="revolute">
    <parent link="arm"/><child link="gripper"/><origin xyz="0 0 0.2"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="5" velocity="3"/>
  </joint>
  <joint name="gripper" type="revolute">
    <parent link="gripper"/><child link="jaw"/><origin xyz="0 0.01 0.03"/><axis xyz="1 0 0"/>
    <limit lower="-0.2" upper="1.5" effort="2" velocity="1"/>
  </joint>
</robot>
"""
"""The SO-100's naming, at its smallest: the link ``gripper`` and the jaw joint ``gripper``."""


def example_robot_data(relative: str) -> Path:
    """A file of example-robot-data (a test extra: skip when it is missing)."""
    for folder in package_search_path():
        path = folder / "example-robot-data" / "robots" / relative
        if path.is_file():
            return path
    pytest.skip("example-robot-data is not installed (pip install 'lwrlab[robots]')")


def urdf_robot(path: Path, **changes: Any) -> RobotModel:
    """The robot of conf/robot/urdf.yaml read from ``path``, with ``changes`` of its settings."""
    return build("robot", "urdf", path=str(path), **changes)


def write_joint_limits(path: Path, names: list[str]) -> Path:
    lines = ["joint_limits:"]
    for name in names:
        lines += [f"  {name}:", "    has_acceleration_limits: true", "    max_acceleration: 4.0"]
    path.write_text("\n".join(lines) + "\n")
    return path


# --- the SRDF and the joint limits of another robot -------------------------------------------------


def test_an_srdf_of_another_robot_is_one_line_naming_what_the_urdf_lacks() -> None:
    ur5 = example_robot_data("ur_description/urdf/ur5_robot.urdf")
    panda_srdf = example_robot_data("panda_description/srdf/panda.srdf")
    with pytest.raises(UnknownNameError) as raised:
        urdf_robot(ur5, srdf=str(panda_srdf))
    message = str(raised.value)
    assert "\n" not in message.split("\nbuilding")[0]  # one line (Hydra's note on the target aside)
    assert str(panda_srdf) in message and str(ur5) in message
    assert "'panda_link0'" in message and "'panda_hand'" in message
    # not even checked against collision geometry: the check is the description's
    with pytest.raises(UnknownNameError, match="panda_link0"):
        urdf_robot(ur5, srdf=str(panda_srdf), collision_geometry=False)


@pytest.mark.parametrize("name", sorted(name for name, entry in ROBOTS.items() if entry.srdf))
def test_every_shipped_srdf_names_only_its_urdf(name: str) -> None:
    example_robot_data(ROBOTS[name].urdf)
    robot = build("robot", "example_robot", robot_name=name, acceleration_limits=1.0)
    assert robot.collision_source is not None and robot.collision_source.srdf == example_robot_file(
        str(ROBOTS[name].srdf)
    )


def test_an_srdf_is_refused_where_lwrlab_reads_it_and_warned_of_elsewhere(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """Its disabled pairs are what lwrlab reads: a link there the URDF lacks is an error. A stray name
    in a MoveIt group is a warning (shipped SRDFs have them: the Z1's chain starts at ``base``)."""
    urdf = tmp_path / "pincher.urdf"
    urdf.write_text(SHARED_NAME_URDF)
    srdf = tmp_path / "pincher.srdf"
    text = (
        '<robot name="pincher"><virtual_joint name="fixed_base" type="fixed" parent_frame="world" '
        'child_link="base"/><group name="arm"><joint name="shoulder"/><joint name="elbow"/></group>'
        '<disable_collisions link1="arm" link2="{link}" reason="Adjacent"/></robot>'
    )
    srdf.write_text(text.format(link="hand"))
    with pytest.raises(UnknownNameError, match=r"lacks \(links \['hand'\]; joints \['elbow'\]\)"):
        urdf_robot(urdf, srdf=str(srdf))
    srdf.write_text(text.format(link="gripper"))
    with caplog.at_level("WARNING"):
        assert urdf_robot(urdf, srdf=str(srdf)).n_joints == 3  # the virtual joint is the SRDF's own
    assert "joints ['elbow']" in caplog.text and "does not read" in caplog.text
    # an SRDF of which the URDF lacks most names is another robot's, pairs or not (Kinova's has none;
    # its chain starts at a link `base`, as the pincher's)
    with pytest.raises(UnknownNameError, match="j2s6s200_joint_1"):
        urdf_robot(urdf, srdf=str(example_robot_data("kinova_description/srdf/kinova.srdf")))


def test_the_collision_urdf_of_a_robot_description_is_checked_against_its_srdf() -> None:
    """A modified-DH robot may take its geometry from a URDF and an SRDF (``collision_urdf``): the same
    check, when the geometry is read."""
    ur5 = example_robot_data("ur_description/urdf/ur5_robot.urdf")
    robot = urdf_robot(ur5)
    source = CollisionSource(ur5, srdf=example_robot_data("panda_description/srdf/panda.srdf"))
    with pytest.raises(UnknownNameError, match=r"the collision SRDF .*panda_link0"):
        load_robot_geometry(source, robot.model)


def test_joint_limits_of_another_robot_are_refused_those_of_locked_joints_are_not(tmp_path: Path) -> None:
    panda = example_robot_data("panda_description/urdf/panda.urdf")
    fingers = {"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}
    arm = [f"panda_joint{j}" for j in range(1, 8)]
    limits = write_joint_limits(tmp_path / "joint_limits.yaml", [*arm, *fingers])
    robot = urdf_robot(panda, locked_joints=fingers, joint_limits=str(limits))
    np.testing.assert_array_equal(robot.limits.acceleration, np.full(7, 4.0))
    ur5_limits = write_joint_limits(tmp_path / "ur5_limits.yaml", ["shoulder_pan_joint", "panda_joint1"])
    with pytest.raises(UnknownNameError) as raised:
        urdf_robot(panda, locked_joints=fingers, joint_limits=str(ur5_limits))
    assert "['shoulder_pan_joint']" in str(raised.value) and str(ur5_limits) in str(raised.value)


def test_lwrlab_prints_the_mismatch_in_one_line(tmp_path: Path) -> None:
    """What the user sees from ``lwrlab``: the error through the entry point, no traceback."""
    ur5 = example_robot_data("ur_description/urdf/ur5_robot.urdf")
    panda_srdf = example_robot_data("panda_description/srdf/panda.srdf")
    cfg = compose_config(
        "task=identification", "tracking=none", "robot=urdf", f"robot.path={ur5}", f"robot.srdf={panda_srdf}"
    )
    with pytest.raises(Exception) as raised:
        run(cfg, tmp_path)
    error = _user_error(raised.value)
    assert isinstance(error, UnknownNameError), repr(raised.value)
    assert len(str(error).splitlines()) == 1 and "panda_link0" in str(error)


def test_lwrlab_exits_with_one_line_for_an_srdf_of_another_robot(tmp_path: Path) -> None:
    ur5 = example_robot_data("ur_description/urdf/ur5_robot.urdf")
    panda_srdf = example_robot_data("panda_description/srdf/panda.srdf")
    completed = subprocess.run(
        [
            sys.executable,
            "-m",
            "lwrlab.cli",
            f"hydra.run.dir={tmp_path}",
            "tracking=none",
            "task=identification",
            "robot=urdf",
            f"robot.path={ur5}",
            f"robot.srdf={panda_srdf}",
        ],
        cwd=REPOSITORY,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert completed.returncode == 1
    assert "panda_link0" in completed.stderr and "Traceback" not in completed.stderr


# --- a link and a joint of the same name ------------------------------------------------------------


def test_locking_a_joint_named_as_a_link_loads(tmp_path: Path) -> None:
    urdf = tmp_path / "pincher.urdf"
    urdf.write_text(SHARED_NAME_URDF)
    full = pin.buildModelFromUrdf(str(urdf))
    with pytest.raises(ValueError, match="Several frames match"):  # what Pinocchio does on its own
        pin.buildReducedModel(full, [full.getJointId("gripper")], pin.neutral(full))
    robot = urdf_robot(urdf, locked_joints=["gripper"], flange_frame="gripper")
    assert robot.joint_names == ("shoulder", "wrist")
    # the jaw merged into the gripper: the same torques as the full model with the jaw held at 0
    rng = np.random.default_rng(0)
    q, dq, ddq = rng.uniform(-1.0, 1.0, (3, 2))
    expected = pin.rnea(full, full.createData(), np.r_[q, 0.0], np.r_[dq, 0.0], np.r_[ddq, 0.0])[:2]
    np.testing.assert_allclose(
        robot.inverse_dynamics(q, dq, ddq, with_friction=False)[0], expected, atol=1e-12
    )
    # the flange is the link (not the locked joint's frame), and both frames keep their names
    model = robot.model
    flange = model.frames[model.getFrameId("flange")]
    link = model.frames[model.getFrameId("gripper", pin.FrameType.BODY)]
    assert flange.placement.isApprox(link.placement) and flange.parentJoint == link.parentJoint == 2
    assert model.existFrame("gripper", pin.FrameType.FIXED_JOINT)
    # and the collision geometry locks it the same way
    assert robot.collision_source is not None
    geometry = load_robot_geometry(robot.collision_source, robot.model)
    assert geometry.links == ("arm", "gripper", "jaw") and geometry.link_joint("jaw") == 2


def test_the_so100_arm_loads_with_its_jaw_locked() -> None:
    """``robot=urdf robot.path=…/so100.urdf robot.locked_joints=[gripper]``: the URDF of the issue (from
    example-robot-data), its meshes included."""
    urdf = example_robot_data("so_arm_description/urdf/so100.urdf")
    robot = urdf_robot(urdf, locked_joints=["gripper"], flange_frame="gripper")
    assert robot.n_joints == 5 and robot.model.existFrame("flange")
    assert robot.collision_source is not None
    geometry = load_robot_geometry(robot.collision_source, robot.model)
    assert "wrist" in geometry.links
