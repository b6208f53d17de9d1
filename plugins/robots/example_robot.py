"""Real arms described by others, by name, from the ``example-robot-data`` package (``robot=example_robot``).

``example-robot-data`` (pip; ``pip install lwrlab[robots]``) ships the URDFs, collision meshes and
MoveIt SRDFs of real fixed-base arms. Each entry below names the files, the joints to lock (a
gripper's fingers, open as wide as they go: the motion must clear them whatever they do) and the flange
frame; the robot is then loaded as any URDF (:func:`plugins.robots.urdf.load_urdf_robot`). Acceleration
limits are not in these descriptions: a robot's entry gives the manufacturer's where they are published
(Panda: libfranka), else ``acceleration_limits`` must be set.

Kinova's Gen2 arm (``kinova``, the six-joint JACO² j2s6s200) has continuous joints 1, 4 and 6: they are
read as revolute joints without position limits (:mod:`lwrlab.model.urdf_robot`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from lwrlab.errors import ConfigError
from lwrlab.model.collision_geometry import package_search_path
from lwrlab.model.robot import RobotModel
from lwrlab.model.urdf_robot import load_urdf_robot

PACKAGE = "example-robot-data"


@dataclass(frozen=True)
class ExampleRobot:
    """Where one arm's description lies inside ``example-robot-data/robots/``."""

    urdf: str
    srdf: str | None
    flange_frame: str | None
    locked_joints: Mapping[str, float] = field(default_factory=dict)
    acceleration_limits: Sequence[float] | None = None
    """rad/s², published by the manufacturer; None: unknown (the user must give them)."""


ROBOTS: dict[str, ExampleRobot] = {
    "panda": ExampleRobot(
        "panda_description/urdf/panda.urdf",
        "panda_description/srdf/panda.srdf",
        "panda_link8",
        {"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04},
        (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0),  # libfranka kMaxJointAcceleration
    ),
    "ur3": ExampleRobot("ur_description/urdf/ur3_robot.urdf", None, "ee_link"),
    "ur5": ExampleRobot("ur_description/urdf/ur5_robot.urdf", "ur_description/srdf/ur5.srdf", "ee_link"),
    "ur10": ExampleRobot("ur_description/urdf/ur10_robot.urdf", None, "ee_link"),
    "xarm7": ExampleRobot("xarm_description/urdf/xarm7.urdf", "xarm_description/srdf/xarm7.srdf", "link7"),
    "z1": ExampleRobot(
        "z1_description/urdf/z1.urdf", "z1_description/srdf/z1.srdf", "link06", {"jointGripper": 0.0}
    ),
    "kinova": ExampleRobot(
        "kinova_description/robots/kinova.urdf",
        "kinova_description/srdf/kinova.srdf",
        "j2s6s200_end_effector",
    ),
}
"""The arms this plugin loads by name."""


def example_robot_file(relative: str) -> str:
    """The path of ``robots/<relative>`` inside the installed ``example-robot-data``."""
    for folder in package_search_path():
        candidate = folder / PACKAGE / "robots" / relative
        if candidate.is_file():
            return str(candidate)
    raise ConfigError(
        f"robot=example_robot needs the `{PACKAGE}` package (pip install 'lwrlab[robots]'): "
        f"robots/{relative} not found"
    )


def load_example_robot(
    robot_name: str,
    *,
    acceleration_limits: Sequence[float] | float | None,
    friction: Mapping[str, Sequence[float]] | None,
    friction_terms: Sequence[str],
    gravity: Sequence[float],
    drive: Mapping[str, Any] | None,
    friction_law: Mapping[str, Any] | None,
) -> RobotModel:
    """The arm ``robot_name`` (a key of :data:`ROBOTS`) from ``example-robot-data``, with its collision
    meshes and SRDF.

    Every argument is required: conf/robot/example_robot.yaml gives their values.

    Parameters
    ----------
    robot_name : panda, ur3, ur5, ur10, xarm7, z1 or kinova.
    acceleration_limits : rad/s², one per joint or a scalar; None: the manufacturer's, where known.
    friction, friction_terms, gravity, drive, friction_law : as for
        :func:`plugins.robots.urdf.load_urdf_robot`.
    """
    if robot_name not in ROBOTS:
        raise ConfigError(f"robot.robot_name={robot_name!r} is not one of {sorted(ROBOTS)}")
    entry = ROBOTS[robot_name]
    return load_urdf_robot(
        example_robot_file(entry.urdf),
        name=robot_name,
        acceleration_limits=acceleration_limits
        if acceleration_limits is not None
        else entry.acceleration_limits,
        friction=friction,
        friction_terms=friction_terms,
        gravity=gravity,
        flange_frame=entry.flange_frame,
        locked_joints=dict(entry.locked_joints),
        chain=None,
        group=None,
        package_dirs=[],
        srdf=None if entry.srdf is None else example_robot_file(entry.srdf),
        joint_limits=None,
        collision_geometry=True,
        missing_meshes="error",
        drive=drive,
        friction_law=friction_law,
    )
