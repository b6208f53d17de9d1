"""Arms as they are built: continuous joints (a revolute joint without position limits) and prismatic ones.

A URDF ``continuous`` joint is read as an ordinary revolute joint, one angle, with infinite position
limits (:mod:`lwrlab.model.urdf_description`). These tests hold it against Pinocchio's own reading, a
``RevoluteUnbounded`` joint configured by (cos, sin) of the angle, on a small turret written here
(an unaligned continuous axis and a prismatic joint) and on Kinova's Gen2 arm from example-robot-data;
then follow it through what reads position limits: the exciting motion's constraints and starting
points, the multisine motion, the log checks, the URDF export and, in the slow tests, ``lwrlab
task=excitation`` and ``task=identification``.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from composing import compose_config

from lwrlab.dynamics.base_parameters import random_states
from lwrlab.dynamics.regressor import regressor
from lwrlab.excitation.constraints import ConstraintSet, ConstraintSettings
from lwrlab.io.joint_signal_checks import position_findings
from lwrlab.io.plausibility import PlausibilityThresholds
from lwrlab.io.urdf_export import export_urdf, robot_urdf
from lwrlab.model.collision_geometry import package_search_path
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from lwrlab.trajectory.core import check_limits

TURRET = """<robot name="turret">
  <link name="base"/>
  <link name="turntable">
    <inertial><origin xyz="0.02 -0.01 0.05"/><mass value="3.0"/>
      <inertia ixx="0.03" ixy="0.001" ixz="-0.002" iyy="0.025" iyz="0.0015" izz="0.02"/></inertial>
    <collision><origin xyz="0 0 0.1"/><geometry><cylinder radius="0.08" length="0.2"/></geometry></collision>
  </link>
  <link name="slider">
    <inertial><origin xyz="0.0 0.03 0.1" rpy="0.1 0.2 0.3"/><mass value="1.5"/>
      <inertia ixx="0.01" ixy="0.0" ixz="0.0" iyy="0.012" iyz="0.0" izz="0.004"/></inertial>
    <collision><origin xyz="0 0 0.05"/><geometry><box size="0.05 0.05 0.1"/></geometry></collision>
  </link>
  <link name="wrist">
    <inertial><origin xyz="0.01 0.0 0.04"/><mass value="0.7"/>
      <inertia ixx="0.002" ixy="0.0001" ixz="0.0" iyy="0.0025" iyz="-0.0002" izz="0.0015"/></inertial>
    <collision><geometry><sphere radius="0.03"/></geometry></collision>
  </link>
  <joint name="turn" type="continuous">
    <parent link="base"/><child link="turntable"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit effort="20" velocity="3"/>
  </joint>
  <joint name="lift" type="prismatic">
    <parent link="turntable"/><child link="slider"/><origin xyz="0.1 0 0.2" rpy="0 0.3 0"/>
    <axis xyz="0 0 1"/><limit lower="0.0" upper="0.3" effort="100" velocity="0.5"/>
  </joint>
  <joint name="roll" type="continuous">
    <parent link="slider"/><child link="wrist"/><origin xyz="0 0.05 0.1" rpy="0.2 0 0"/>
    <axis xyz="0 0.6 0.8"/><limit effort="5" velocity="4"/>
  </joint>
  <transmission name="turn_transmission"><joint name="turn"/></transmission>
</robot>
"""
"""Two continuous joints (one about an unaligned axis) around a prismatic one, with collision
primitives; a transmission that names a joint, which is no joint."""


def example_robot_data_file(relative: str) -> Path:
    """A file of example-robot-data (a test extra: skip when it is missing)."""
    for folder in package_search_path():
        path = folder / "example-robot-data" / "robots" / relative
        if path.is_file():
            return path
    pytest.skip("example-robot-data is not installed (pip install 'lwrlab[robots]')")


@pytest.fixture
def turret_urdf(tmp_path: Path) -> Path:
    path = tmp_path / "turret.urdf"
    path.write_text(TURRET)
    return path


def urdf_robot(path: Path, **changes: Any) -> RobotModel:
    """The robot of conf/robot/urdf.yaml read from ``path``, with ``changes`` of its settings."""
    return build("robot", "urdf", path=str(path), **changes)


def pinocchio_configuration(model: pin.Model, angles: np.ndarray) -> np.ndarray:
    """Pinocchio's configuration for one angle (or position) per joint: (cos, sin) for an unbounded one."""
    q = np.empty(model.nq)
    for j in range(1, model.njoints):
        joint, value = model.joints[j], angles[model.joints[j].idx_v]
        if joint.nq == 2:
            q[joint.idx_q : joint.idx_q + 2] = np.cos(value), np.sin(value)
        else:
            q[joint.idx_q] = value
    return q


def states(robot: RobotModel, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random states; continuous joints over several turns (−10…10 rad)."""
    rng = np.random.default_rng(seed)
    lim = robot.limits
    free = ~np.isfinite(lim.position_lower)
    low, high = np.where(free, -10.0, lim.position_lower), np.where(free, 10.0, lim.position_upper)
    q = rng.uniform(low, high, (n, robot.n_joints))
    dq = rng.uniform(-lim.velocity, lim.velocity, (n, robot.n_joints))
    ddq = rng.uniform(-5.0, 5.0, (n, robot.n_joints))
    return q, dq, ddq


def assert_same_dynamics_as_pinocchios_unbounded_joints(robot: RobotModel, urdf: Path) -> None:
    reference = pin.buildModelFromUrdf(str(urdf))  # continuous: RevoluteUnbounded, nq = 2, nv = 1
    assert reference.nv == robot.n_joints and reference.nq > reference.nv
    data = reference.createData()
    q, dq, ddq = states(robot, 20)
    expected = np.stack(
        [
            pin.rnea(reference, data, pinocchio_configuration(reference, q[k]), dq[k], ddq[k])
            for k in range(20)
        ]
    )
    np.testing.assert_allclose(robot.inverse_dynamics(q, dq, ddq, with_friction=False), expected, atol=1e-10)
    # the regressor of the identification: W·φ is the same torque
    w = regressor(robot, q, dq, ddq)
    np.testing.assert_allclose(w @ robot.parameters, robot.inverse_dynamics(q, dq, ddq).ravel(), atol=1e-9)


def test_a_continuous_joint_is_one_angle_with_the_dynamics_of_pinocchios_unbounded_joint(
    turret_urdf: Path,
) -> None:
    robot = urdf_robot(turret_urdf, acceleration_limits=10.0)
    assert robot.n_joints == 3 and robot.model.nq == robot.model.nv == 3
    assert [j.shortname() for j in robot.model.joints[1:]] == [
        "JointModelRZ",
        "JointModelPZ",
        "JointModelRevoluteUnaligned",
    ]
    assert_same_dynamics_as_pinocchios_unbounded_joints(robot, turret_urdf)


def test_a_continuous_joint_has_no_position_limits_and_keeps_its_velocity_and_effort(
    turret_urdf: Path,
) -> None:
    robot = urdf_robot(turret_urdf)
    lim = robot.limits
    np.testing.assert_array_equal(lim.position_lower, [-np.inf, 0.0, -np.inf])
    np.testing.assert_array_equal(lim.position_upper, [np.inf, 0.3, np.inf])
    np.testing.assert_array_equal(lim.velocity, [3.0, 0.5, 4.0])
    np.testing.assert_array_equal(lim.torque, [20.0, 100.0, 5.0])
    np.testing.assert_array_equal(robot.model.lowerPositionLimit, lim.position_lower)  # the same model
    # identification's random states stay finite: one turn around 0
    q, _, _ = random_states(robot, 200, np.random.default_rng(0))
    assert np.all(np.abs(q[:, [0, 2]]) <= np.pi) and np.ptp(q[:, 0]) > 5.0


def test_kinova_gen2_loads_with_pinocchios_dynamics() -> None:
    urdf = example_robot_data_file("kinova_description/robots/kinova.urdf")
    robot = build("robot", "example_robot", robot_name="kinova")
    assert robot.n_joints == 6 and robot.model.existFrame("flange")
    free = ~np.isfinite(robot.limits.position_lower)
    assert np.flatnonzero(free).tolist() == [0, 3, 5]  # joints 1, 4, 6 are continuous
    assert_same_dynamics_as_pinocchios_unbounded_joints(robot, urdf)


def test_position_constraints_leave_continuous_joints_free_with_exact_derivatives(turret_urdf: Path) -> None:
    robot = urdf_robot(turret_urdf, acceleration_limits=10.0, collision_geometry=False)
    settings = ConstraintSettings(
        limit_margin=0.02,
        torque=True,
        ground_spheres=None,
        self_collision=False,
        clearance=0.01,
        distance_margin=0.005,
        min_link_gap=2,
        world={"mounting_surface": None},
    )
    constraints = ConstraintSet(robot, settings)
    assert constraints.column_labels("position") == ["joint 2 lower", "joint 2 upper"]
    np.testing.assert_allclose(constraints.scales("position"), [0.15, 0.15])
    q, dq, ddq = states(robot, 6)
    q[:, 0] = [-50.0, -7.0, 0.0, 3.0, 9.0, 100.0]  # any number of turns
    q[:, 1] = 0.15
    slacks = constraints.slacks(q, 0 * dq, 0 * ddq)
    assert slacks["position"].shape == (6, 2) and np.all(slacks["position"] > 0)
    # the derivative of every position column, against central differences
    samples, columns = np.repeat(np.arange(6), 2), np.tile(np.arange(2), 6)
    d_q, _, _ = constraints.slack_derivatives("position", q, dq, ddq, samples, columns)
    step = 1e-6
    for joint in range(3):
        shift = np.zeros_like(q)
        shift[:, joint] = step
        numerical = (
            constraints.slacks(q + shift, dq, ddq)["position"]
            - constraints.slacks(q - shift, dq, ddq)["position"]
        ) / (2 * step)
        np.testing.assert_allclose(d_q[:, joint], numerical[samples, columns], atol=1e-8)
    # a robot of continuous joints only has no position family at all
    only_free = ConstraintSet(
        urdf_robot(turret_urdf, acceleration_limits=10.0, locked_joints=["lift"], collision_geometry=False),
        settings,
    )
    assert "position" not in only_free.families()
    assert "position" not in only_free.slacks(q[:, [0, 2]], dq[:, [0, 2]], ddq[:, [0, 2]])


def test_an_exciting_motion_turns_continuous_joints_around_zero(turret_urdf: Path) -> None:
    robot = urdf_robot(turret_urdf, acceleration_limits=10.0)
    source = build("trajectory", "multisine", duration=4.0, harmonics=3, seed=0)
    motion = source.sample(robot, 200.0)
    check_limits(motion, robot)
    np.testing.assert_allclose(motion.q[0], [0.0, 0.15, 0.0], atol=1e-12)  # centred: 0 where unbounded
    # joint 1 bounded by its velocity or acceleration limit alone: one of them reached (the fraction)
    peaks = np.abs(motion.dq).max(axis=0)[0] / 3.0, np.abs(motion.ddq).max(axis=0)[0] / 10.0
    assert max(peaks) == pytest.approx(source.limit_fraction)
    # a starting point of the optimised motion: around 0 for a continuous joint, finite
    problem = build(
        "trajectory",
        "optimal",
        from_file=None,
        duration=2.0,
        constraints={"world": {"mounting_surface": None}},
    ).problem(robot)
    assert problem.middle_pose.tolist() == pytest.approx([0.0, 0.15, 0.0])
    assert np.all(np.isfinite(problem.safe_pose()))
    for fourier_or_bspline in ("fourier", "bspline"):
        parameterisation = build("trajectory", fourier_or_bspline, duration=2.0)
        start = parameterisation.initial_coefficients(robot, np.random.default_rng(0), 0.3)
        assert np.all(np.isfinite(start))


def test_an_arm_of_continuous_joints_only_gets_an_optimal_exciting_motion(turret_urdf: Path) -> None:
    """No position constraint at all: SLSQP's box bounds (B-spline via points) are open, the motion is
    checked at 1 kHz against the velocity, acceleration and torque limits and the collision primitives."""
    from lwrlab.excitation.solver import check_motion_at

    robot = urdf_robot(turret_urdf, acceleration_limits=10.0, locked_joints={"lift": 0.1})
    optimizer = build("optimizer", "slsqp", show_progress=False, max_iterations=30)
    source = build(
        "trajectory",
        "optimal",
        from_file=None,
        duration=2.0,
        optimizer=optimizer,
        constraints={"world": {"mounting_surface": None}},
    )
    motion, result, problem = source.optimise(robot)
    assert problem.bounds() == [(None, None)] * problem.n_variables
    assert [r.family for r in result.reports][:2] == ["velocity", "acceleration"]
    assert check_motion_at(robot, motion, source.constraints, 1000.0).passed
    assert np.all(np.ptp(motion.sample(robot, 100.0).q, axis=0) > 0.5)  # both joints turn


def test_a_continuous_joint_beyond_two_pi_is_no_sign_of_degrees(turret_urdf: Path) -> None:
    robot = urdf_robot(turret_urdf)
    t = np.linspace(0.0, 10.0, 1001)
    # joints 1, 3 turn ~3 times; joint 2 a little beyond its upper limit (0.3 m)
    q = np.column_stack([2.0 * t, 0.29 + 0.02 * np.sin(t), -1.5 * t])
    findings = position_findings(
        Path("log.csv"), q, ["q1", "q2", "q3"], robot.limits, "rad", PlausibilityThresholds(), set()
    )
    assert [(f.severity, f.check, f.column) for f in findings] == [("warning", "position_limit", "q2")]
    assert "degrees" not in findings[0].message


def test_continuous_and_prismatic_joints_are_exported_and_read_back(
    turret_urdf: Path, tmp_path: Path
) -> None:
    robot = urdf_robot(turret_urdf, acceleration_limits=10.0, friction={"coulomb": [0.5, 2.0, 0.1]})
    exported = export_urdf(robot, tmp_path / "exported.urdf")
    text = exported.read_text()
    assert text.count('type="continuous"') == 2 and text.count('type="prismatic"') == 1
    assert 'lower="0.0" upper="0.3"' in text and "inf" not in text
    again = urdf_robot(exported, acceleration_limits=10.0, friction={"coulomb": [0.5, 2.0, 0.1]})
    np.testing.assert_array_equal(again.limits.position_lower, robot.limits.position_lower)
    q, dq, ddq = states(robot, 10)
    np.testing.assert_allclose(
        again.inverse_dynamics(q, dq, ddq), robot.inverse_dynamics(q, dq, ddq), atol=1e-9
    )
    # and Pinocchio reads it as it reads the original: unbounded joints again
    reference = pin.buildModelFromUrdf(str(exported))
    assert [j.shortname() for j in reference.joints[1:]] == [
        "JointModelRUBZ",
        "JointModelPZ",
        "JointModelRevoluteUnboundedUnaligned",
    ]
    assert robot_urdf(robot) == text


def test_a_prismatic_and_continuous_arm_is_identified_and_exported(
    turret_urdf: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``task=identification`` (simulated plant, multisine motions: the optimal motion's derivatives
    need a revolute chain) writes its identified URDF with the prismatic and continuous joints; were a
    joint not exportable, the report would go without the URDF, with a warning, and keep its metrics."""
    from lwrlab.io.urdf_export import UnexportableJointError
    from lwrlab.pipeline.identification import report as identification_report
    from lwrlab.pipeline.config_nodes import resolved_mapping
    from lwrlab.pipeline.identification import identify_configured

    cfg = compose_config(
        "task=identification",
        "tracking=none",
        "robot=urdf",
        f"robot.path={turret_urdf}",
        "robot.acceleration_limits=10.0",
        "trajectory=multisine",
        "trajectory.duration=5.0",
        "validation.duration=5.0",
        "estimator=sdp",
    )
    report = identify_configured(cfg)
    assert (
        report.metrics["validation_rel_error"] < 0.1 and report.metrics["min_pseudo_inertia_eigenvalue"] >= 0
    )
    robot_config = resolved_mapping(cfg.robot, "robot")
    files = identification_report.write_report(report, tmp_path / "exported", robot_config)
    text = files["urdf"].read_text()
    assert text.count('type="continuous"') == 2 and text.count('type="prismatic"') == 1

    def refuse(*args: Any, **kwargs: Any) -> Path:
        raise UnexportableJointError("URDF export writes revolute, continuous and prismatic joints, not a X")

    monkeypatch.setattr(identification_report, "export_urdf", refuse)
    files = identification_report.write_report(report, tmp_path / "not_exported", robot_config)
    assert "urdf" not in files and files["metrics"].is_file()
    assert "WARNING: the identified model is not exported as URDF" in files["summary"].read_text()


def test_a_locked_mobile_base_is_no_longer_a_floating_base(tmp_path: Path) -> None:
    """Unsupported joints are checked after locking: a planar base the arm does not need is locked."""
    path = tmp_path / "mobile.urdf"
    path.write_text(
        TURRET.replace(
            '<link name="base"/>',
            '<link name="world"/><link name="base"><inertial><mass value="20"/>'
            '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>'
            '<joint name="drive" type="planar"><parent link="world"/><child link="base"/></joint>',
        )
    )
    with pytest.raises(ValueError, match=r"'drive' .*makes a floating base"):
        urdf_robot(path)
    robot = urdf_robot(path, locked_joints=["drive"])
    assert robot.joint_names == ("turn", "lift", "roll")
    with pytest.raises(ValueError, match=r"'drive' is a JointModelPlanar .* give it no position"):
        urdf_robot(path, locked_joints={"drive": 0.3})


def test_locked_joints_compose_from_the_command_line_as_a_list_or_positions() -> None:
    """What a user types, through Hydra's real composition, for TIAGo (a mobile manipulator whose
    wheels are continuous): its arm alone, the base, torso and head locked."""
    from hydra.utils import instantiate

    urdf = example_robot_data_file("tiago_description/robots/tiago_no_hand.urdf")
    others = "wheel_right_joint,wheel_left_joint,head_1_joint,head_2_joint"
    by_name = compose_config(
        "robot=urdf", f"robot.path={urdf}", f"robot.locked_joints=[torso_lift_joint,{others}]"
    )
    positions = compose_config(
        "robot=urdf",
        f"robot.path={urdf}",
        "robot.locked_joints={torso_lift_joint: 0.2, wheel_right_joint: 0.0, wheel_left_joint: 1.0, "
        "head_1_joint: 0.0, head_2_joint: 0.0}",
    )
    arm = [f"arm_{j}_joint" for j in range(1, 8)]
    raised = instantiate(positions.robot)
    assert instantiate(by_name.robot).joint_names == raised.joint_names == tuple(arm)
    assert np.all(np.isfinite(raised.limits.position_lower))  # the continuous wheels are locked
    # the torso raised by 0.2 m lifts the arm's first joint by as much
    lowered = instantiate(by_name.robot)
    placements = []
    for robot in (lowered, raised):
        data = robot.model.createData()
        pin.forwardKinematics(robot.model, data, np.zeros(robot.n_joints))
        placements.append(data.oMi[1].translation[2])
    assert placements[1] - placements[0] == pytest.approx(0.2)


# --- end to end: what a user types -----------------------------------------------------------------


@pytest.mark.slow
def test_kinova_gets_a_safe_exciting_motion_and_is_identified(tmp_path: Path) -> None:
    """``lwrlab task=excitation`` and ``task=identification`` (simulated plant) on Kinova's Gen2 arm,
    as shipped (10 s motion, one start: ~16 s each on a laptop core)."""
    from lwrlab.pipeline.excitation import run_excitation
    from lwrlab.pipeline.identification import run_identification

    robot = ("robot=example_robot", "robot.robot_name=kinova", "robot.acceleration_limits=5.0")
    quiet = ("optimizer.show_progress=false", "tracking=none")
    clock = time.perf_counter()
    metrics = run_excitation(compose_config("task=excitation", *robot, *quiet), tmp_path / "excitation")
    seconds = time.perf_counter() - clock
    assert metrics["violated_families"] == 0.0, metrics
    report = (tmp_path / "excitation" / "excitation_report.md").read_text()
    assert "| position |" in report  # joints 2, 3, 5 keep their limits
    assert seconds < 120.0
    identified = run_identification(
        compose_config("task=identification", *robot, *quiet, "estimator=sdp"), tmp_path / "identification"
    )
    assert identified["validation_rel_error"] < 0.1, identified
    urdf = (tmp_path / "identification" / "identified_model.urdf").read_text()
    assert urdf.count('type="continuous"') == 3
