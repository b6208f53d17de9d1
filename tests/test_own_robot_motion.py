"""A user's own robot: limits that must be given, a motion rejected when its 1 kHz check fails, the
accepted motion exported for ROS 2 with its preview, and, on a URDF nobody here wrote (meshes found
through ROS_PACKAGE_PATH), a motion an independent exact-mesh check finds free of contact."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from composing import compose_config
from test_end_to_end import only_run, run_lwrlab

from lwrlab.errors import ConfigError
from lwrlab.excitation.solver import RejectedMotionError
from lwrlab.io.ros2_trajectory import read_follow_joint_trajectory_goal, read_joint_trajectory_bag
from lwrlab.model.collision_geometry import package_search_path
from lwrlab.pipeline.excitation import run_excitation

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
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


def independent_check(*args: object) -> tuple[int, int, float]:
    """``benchmarks/independent_mesh_check.py``'s check (Pinocchio and coal only, no lwrlab code)."""
    spec = importlib.util.spec_from_file_location(
        "independent_mesh_check", BENCHMARKS / "independent_mesh_check.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.independent_check(*args)


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
    in_contact, below, lowest = independent_check(urdf, robots, q, 0.01)
    assert in_contact == 0 and below == 0
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
    srdf = robots / "panda_description" / "srdf" / "panda.srdf"
    fingers = {"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}
    contacts, _, lowest = independent_check(urdf, robots.parents[1], q, 0.0, srdf, fingers)
    assert contacts == 0
    assert lowest > 0.0  # the hand and fingers above the mounting surface


@pytest.mark.slow
@pytest.mark.parametrize("name", ["panda", "ur3", "ur5", "ur10", "xarm7", "z1", "kinova"])
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
    srdf = None if entry.srdf is None else example_robot_file(entry.srdf)
    contacts, _, lowest = independent_check(
        example_robot_file(entry.urdf), robots.parents[1], q, 0.0, srdf, dict(entry.locked_joints)
    )
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


def test_the_panda_motion_is_exported_with_the_joint_names_its_controller_knows(tmp_path: Path) -> None:
    """The shipped Panda is a modified-DH table (joints joint1…7); its collision URDF names them as
    franka_ros does, and the ROS 2 export uses those."""
    example_robots()
    cfg = compose_config("task=excitation", "robot=panda", *QUICK, "trajectory.from_file=null")
    run_excitation(cfg, tmp_path)
    bag = read_joint_trajectory_bag(tmp_path / "exciting_motion_bag")
    assert bag.joint_names == tuple(f"panda_joint{j}" for j in range(1, 8))
    assert "panda_joint1" in (tmp_path / "exciting_motion_goal.yaml").read_text()


@pytest.mark.slow
def test_a_rejected_motion_fails_the_command_in_one_line_and_the_run_in_mlflow(tmp_path: Path) -> None:
    """What a user sees: exit status 1, one line saying why, the run FAILED with its error, the
    rejected motion on disk under its own name."""
    completed = run_lwrlab(
        tmp_path,
        "task=excitation",
        *QUICK,
        "trajectory.rate_hz=10",
        "trajectory.window_s=0.1",
        "trajectory.constraints.limit_margin=0.0",
        "trajectory.constraints.distance_margin=0.0",
    )
    assert completed.returncode == 1
    errors = [line for line in completed.stderr.splitlines() if line.startswith("lwrlab: ")]
    assert len(errors) == 1 and "not written as a motion to run" in errors[0], completed.stderr[-2000:]
    assert "Traceback" not in completed.stderr
    run = only_run(tmp_path, "excitation")
    assert run.info.status == "FAILED"
    folder = tmp_path / "run"
    assert (folder / "rejected_exciting_motion.yaml").is_file()
    assert not (folder / "exciting_motion.yaml").exists()


def test_pairs_the_optimiser_sees_within_the_clearance_everywhere_are_left_to_the_exact_check() -> None:
    """A UR5 without an SRDF: wrist 1 and wrist 3 sit 1.4 cm apart in every configuration, inside the
    1 cm clearance plus the 0.5 cm the optimiser keeps free; no motion can keep them further apart, so
    the optimiser does not try (it found no feasible start), the note says so, and the exact check
    still checks the pair. Every pair the optimiser keeps apart can be kept apart somewhere."""
    from lwrlab.dynamics.base_parameters import random_states
    from lwrlab.excitation.sphere_distances import SphereDistances
    from lwrlab.pipeline.build import build

    urdf = example_robots() / "ur_description" / "urdf" / "ur5_robot.urdf"
    robot = build("robot", "urdf", path=str(urdf), acceleration_limits=10.0)
    settings = build("trajectory", "optimal", from_file=None).constraints
    scene = settings.scene(robot)
    optimised = {scene.pair_label("self", pair) for pair in scene.self_pairs}
    checked = {scene.pair_label("self", pair) for pair in scene.checked_self_pairs}
    assert "wrist_1_link–wrist_3_link" not in optimised and "wrist_1_link–wrist_3_link" in checked
    (note,) = [n for n in scene.notes if n.startswith("wrist_1_link–wrist_3_link")]
    assert "1.5 cm" in note and "exact check" in note

    distances = SphereDistances(scene)
    distances.use_hulls = True  # as the optimiser measures
    q, _, _ = random_states(robot, 200, np.random.default_rng(11))
    padding = settings.clearance + settings.distance_margin
    for family, pairs in (("self", scene.self_pairs), ("world", scene.world_pairs)):
        values, _ = distances.pair_distances(family, pairs, scene.poses(q), q)
        kept_apart_somewhere = (values >= padding).mean(axis=0) > 0.05
        assert kept_apart_somewhere.all(), [
            scene.pair_label(family, p) for p, ok in zip(pairs, kept_apart_somewhere, strict=True) if not ok
        ]


def test_a_motion_no_start_can_find_says_what_to_change() -> None:
    """The infeasible motion's message ends with the settings that may help: the SRDF pair to disable
    (MoveIt's syntax), the world, the duration."""
    from lwrlab.excitation.solver_report import FamilyReport, violation_hint

    reports = [
        FamilyReport("velocity", -5.6, "rad/s", "joint 1 lower", 2.76),
        FamilyReport("self_collision", -0.059, "m", "forearm_link–wrist_3_link", 0.99),
        FamilyReport("world", 0.02, "m", "wrist_2_link–mounting surface", 1.0),
    ]
    hint = violation_hint(reports)
    assert '<disable_collisions link1="forearm_link" link2="wrist_3_link"/>' in hint
    assert "robot.srdf" in hint and "trajectory.duration" in hint and "world" not in hint
    assert violation_hint(reports[2:]) == ""
