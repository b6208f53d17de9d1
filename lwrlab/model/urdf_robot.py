"""Robots described by a URDF file (the loader of ``robot=urdf``, :mod:`plugins.robots.urdf`).

The kinematics, the inertials and the position, velocity and torque limits come from the URDF through
Pinocchio's parser; what a URDF does not hold (acceleration limits, the friction of our model, which
joints to lock) is given as arguments. The base is fixed to the URDF's root link.

Pinocchio merges every ``fixed`` joint into its parent body (the child's inertia is added to the
parent segment, its frames are kept as operational frames). A ``mimic`` joint is loaded as an
independent joint (Pinocchio's default); lock it, or lock the whole gripper, with ``locked_joints``:
the locked subtrees are merged into their parent segment at the given positions
(``pin.buildReducedModel``, also where a link and a joint share a name, as the SO-100's ``gripper``).

Supported: fixed-base trees of one-degree-of-freedom joints, revolute, prismatic (aligned with an axis
of their frame or not) and continuous. A ``continuous`` joint (a revolute joint without position limits:
a wheel, a Kinova wrist) is read as a revolute joint, one angle in rad, with infinite position limits
(:mod:`lwrlab.model.urdf_description`; Pinocchio's own ``RevoluteUnbounded`` joint would carry cos and
sin of the angle); motions and checks treat it as a joint that may turn freely
(:mod:`lwrlab.model.position_ranges`). Floating and planar joints are refused, unless locked (a mobile
manipulator's base). Joints are checked after locking, so whatever ``locked_joints`` removes may be of
any kind.

A MoveIt ``joint_limits.yaml`` naming joints the URDF lacks (a file of another robot) is refused in one
line naming them (it may name joints the robot locks); so is an SRDF whose disabled collision pairs
name links the URDF lacks, or which the URDF lacks most names of (a stray name in its MoveIt groups is a
warning: :func:`lwrlab.model.urdf_description.check_srdf_names`).

The URDF's ``<collision>`` geometry (meshes found through ``package_dirs`` and ``ROS_PACKAGE_PATH``)
and an SRDF's disabled pairs are what exciting motions are kept clear of
(:mod:`lwrlab.model.collision_geometry`); they are read when a motion is optimised or checked, so
identifying from logs needs neither. Acceleration limits, which a URDF lacks, come from
``acceleration_limits`` or a MoveIt ``joint_limits.yaml``.
"""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ElementTree
from collections.abc import Collection, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from lwrlab.errors import ConfigError, MissingFileError, UnknownNameError
from lwrlab.model.collision_geometry import CollisionSource, package_search_path, resolve_mesh
from lwrlab.model.description import build_friction, friction_law_of, gravity_vector
from lwrlab.model.drive_train import DriveTrain, build_drive_train
from lwrlab.model.friction_laws import FrictionLaw
from lwrlab.model.kinematic_chain import arm_joints, locked_outside, mounted_on
from lwrlab.model.robot import JointLimits, RobotModel
from lwrlab.model.urdf_description import (
    check_joint_limit_names,
    check_srdf_names,
    description_names,
    frame_id,
    read_urdf_document,
    reduced_model,
    revolute_for_continuous,
    transmission_reductions,
)
from lwrlab.yaml_files import read_yaml_mapping

_FLOATING_JOINTS = ("JointModelFreeFlyer", "JointModelPlanar")


class URDFNotFoundError(MissingFileError):
    """A URDF path that is not a file: a ``FileNotFoundError`` that a ``ValueError`` handler also catches."""


def _check_joints(model: pin.Model, path: Path) -> None:
    """Refuse a floating base and any joint that is not a 1-DoF joint with nq == nv (after locking:
    a locked joint may be of any kind)."""
    for j in range(1, model.njoints):
        joint = model.joints[j]
        kind = joint.shortname()
        if kind in _FLOATING_JOINTS and model.parents[j] == 0:
            raise ConfigError(
                f"{path}: joint {model.names[j]!r} ({kind}) makes a floating base; "
                "only fixed-base robots are supported "
                "(fix the root link to the world in the URDF)"
            )
        if joint.nq != 1 or joint.nv != 1:
            raise ConfigError(
                f"{path}: joint {model.names[j]!r} is a {kind} (nq={joint.nq}, nv={joint.nv}); "
                "only one-degree-of-freedom joints with nq == nv are supported "
                "(revolute, continuous, prismatic), not planar, spherical or floating joints "
                "(lock it with robot.locked_joints if the arm does not need it)"
            )


def _locked_configuration(
    model: pin.Model, locked_joints: Sequence[str] | Mapping[str, float], path: Path
) -> tuple[list[int], np.ndarray]:
    """Ids of the joints to lock, and the configuration they are locked at (zero but for the given
    positions)."""
    positions = (
        dict(locked_joints) if isinstance(locked_joints, Mapping) else {name: 0.0 for name in locked_joints}
    )
    unknown = [name for name in positions if not model.existJointName(name)]
    if unknown:
        raise UnknownNameError(
            f"{path}: robot.locked_joints {unknown} are not joints of the model; "
            f"joints: {list(model.names)[1:]}"
        )
    q_reference = pin.neutral(model)
    ids = []
    for name, position in positions.items():
        joint_id = model.getJointId(name)
        joint = model.joints[joint_id]
        if joint.nq == 1:
            q_reference[joint.idx_q] = float(position)
        elif float(position) != 0.0:
            raise ConfigError(
                f"{path}: robot.locked_joints: {name!r} is a {joint.shortname()} with {joint.nq} "
                "coordinates, locked at its neutral configuration: give it no position"
            )
        ids.append(joint_id)
    return sorted(ids), q_reference


def _check_limits(model: pin.Model, path: Path, unbounded: Collection[str]) -> None:
    """URDF joints without limits come out of Pinocchio as zero (or infinite) limits: refuse them.
    The ``unbounded`` (continuous) joints have no position limits by definition."""
    names = list(model.names)[1:]
    problems = []
    for i, name in enumerate(names):
        lower, upper = model.lowerPositionLimit[i], model.upperPositionLimit[i]
        velocity, effort = model.velocityLimit[i], model.effortLimit[i]
        if name not in unbounded and not (np.isfinite(lower) and np.isfinite(upper) and lower < upper):
            problems.append(f"{name}: position limits [{lower}, {upper}]")
        if not (np.isfinite(velocity) and velocity > 0):
            problems.append(f"{name}: velocity limit {velocity}")
        if not (np.isfinite(effort) and effort > 0):
            problems.append(f"{name}: effort limit {effort}")
    if problems:
        raise ConfigError(
            f"{path}: missing joint limits (every joint needs <limit lower upper velocity effort> "
            f"with lower < upper and positive velocity and effort, a continuous joint <limit velocity "
            f"effort>): {'; '.join(problems)}"
        )


def _acceleration_limits(
    acceleration_limits: Sequence[float] | float | None, n: int, path: Path
) -> np.ndarray:
    if acceleration_limits is None:  # unknown: fine for identifying from logs; motion stages refuse it
        return np.full(n, np.inf)
    values = np.asarray(acceleration_limits, dtype=float).ravel()
    if values.size == 1:
        values = np.full(n, values[0])  # one value for every joint
    if values.shape != (n,):
        raise ConfigError(
            f"{path}: robot.acceleration_limits: expected {n} values or a scalar, got {values.size}"
        )
    if not np.all(values > 0):
        raise ConfigError(f"{path}: robot.acceleration_limits must be positive, got {values.tolist()}")
    return values


def _moveit_limits(
    path: Path, names: Sequence[str], urdf: Path, urdf_joints: Collection[str]
) -> dict[str, np.ndarray]:
    """Velocity and acceleration limits of a MoveIt ``joint_limits.yaml`` (``has_*_limits: true`` only),
    NaN where a joint has none. Every joint it names must be one of the URDF's ``urdf_joints``
    (locked ones included)."""
    if not path.is_file():
        raise MissingFileError(f"{urdf}: robot.joint_limits file {path} does not exist")
    joints = read_yaml_mapping(path, "joint limits").get("joint_limits")
    if not isinstance(joints, dict):
        raise ConfigError(f"{path}: no `joint_limits:` mapping (MoveIt's joint_limits.yaml format)")
    check_joint_limit_names(path, [str(name) for name in joints], urdf, urdf_joints)
    out = {key: np.full(len(names), np.nan) for key in ("velocity", "acceleration")}
    for i, name in enumerate(names):
        entry = joints.get(name) or {}
        for key in out:
            if entry.get(f"has_{key}_limits") and entry.get(f"max_{key}") is not None:
                out[key][i] = float(entry[f"max_{key}"])
    return out


def _add_flange(model: pin.Model, flange_frame: str, path: Path) -> None:
    """Add an operational frame named ``flange`` at the URDF frame ``flange_frame``."""
    if not model.existFrame(flange_frame):
        raise UnknownNameError(
            f"{path}: robot.flange_frame {flange_frame!r} is not a frame of the model; "
            f"frames: {[f.name for f in model.frames]}"
        )
    if flange_frame == "flange":
        return  # the URDF already names its flange
    if model.existFrame("flange"):
        raise ConfigError(
            f"{path}: the URDF already has a frame named 'flange'; "
            "drop robot.flange_frame or set it to 'flange'"
        )
    frame = model.frames[frame_id(model, flange_frame)]
    model.addFrame(pin.Frame("flange", frame.parentJoint, frame.placement, pin.FrameType.OP_FRAME))


def load_urdf_robot(
    path: str | Path,
    *,
    name: str | None,
    acceleration_limits: Sequence[float] | float | None,
    friction: Mapping[str, Sequence[float]] | None,
    friction_terms: Sequence[str],
    gravity: Sequence[float],
    flange_frame: str | None,
    locked_joints: Sequence[str] | Mapping[str, float] | None,
    chain: Sequence[str] | None,
    group: str | None,
    package_dirs: Sequence[str],
    srdf: str | None,
    joint_limits: str | None,
    collision_geometry: bool,
    missing_meshes: str,
    drive: Mapping[str, Any] | None,
    friction_law: FrictionLaw | Mapping[str, Any] | None,
) -> RobotModel:
    """Build a fixed-base :class:`RobotModel` from a URDF file.

    Every argument is required: conf/robot/urdf.yaml gives their values (in Python,
    ``lwrlab.pipeline.build.build("robot", "urdf", path=…, **changes)``).

    Parameters
    ----------
    path : URDF file. Meshes it references need not exist (only kinematics and inertials are read).
    name : robot name; None: the URDF's ``<robot name>``, else the file name.
    acceleration_limits : largest absolute joint acceleration (rad/s²), one per joint after locking,
        or one scalar for every joint. A URDF has none: without them the limits are infinite, which
        identifying from logs does not need and sampling or optimising a motion refuses.
    friction : nominal friction ``{"coulomb": [...], "viscous": [...], "offset": [...]}`` (N·m,
        N·m·s/rad, N·m); a missing term is zero.
    friction_terms : friction columns of the regressor (subset of coulomb, viscous, offset).
    gravity : gravity acceleration in the base frame (m/s²).
    flange_frame : name of a URDF frame (a link or a fixed joint, e.g. ``panda_link8``) where an
        operational frame named ``flange`` is added, or None.
    locked_joints : joints removed from the model and merged into their parent segment, a list of
        names (locked at 0) or a mapping name → position (rad or m), e.g. the fingers of a gripper
        or a mobile base's wheels; None or empty: none.
    chain : ``[root link, tip link]``: the arm of a bigger description, every moving joint off the
        path between them locked (at 0 or the position ``locked_joints`` gives; what hangs from the
        arm, a gripper, merged into its last segment), or None (:mod:`lwrlab.model.kinematic_chain`).
    group : an SRDF planning group (of ``srdf``) naming the arm, the same way; None: none.
    package_dirs : folders holding the ROS packages that ``package://NAME/…`` mesh names refer to
        (``DIR/NAME/``), searched before ``ROS_PACKAGE_PATH``.
    srdf : a MoveIt SRDF whose ``disable_collisions`` pairs are never checked, or None. The links of
        its pairs, and most names it gives, must be the URDF's.
    joint_limits : a MoveIt ``joint_limits.yaml``: its ``max_acceleration`` (where
        ``has_acceleration_limits``) gives the acceleration limits ``acceleration_limits`` leaves
        unset, its ``max_velocity`` lowers the URDF's velocity limits. The joints it names must be
        the URDF's (locked ones included).
    collision_geometry : keep exciting motions clear of the URDF's ``<collision>`` geometry (read
        when a motion is optimised or checked); False: no collision model.
    missing_meshes : ``error`` or ``drop`` (leave out, with a warning) collision meshes not found.
    drive : the drive train (:func:`lwrlab.model.drive_train.build_drive_train`'s ``drive`` block:
        gear ratios, coupling, torque constants, measured sides); its gear ratios default to the
        URDF's ros_control ``<transmission>`` ``mechanicalReduction`` (1 where a joint has none).
    friction_law : the description's friction law (a law or its mapping); None: the paper's.

    Returns
    -------
    RobotModel
        Joints in URDF tree order, link labels "1" … "n", position/velocity/torque limits from the
        URDF ``<limit>`` tags (position limits ±inf for a continuous joint).

    Raises
    ------
    URDFNotFoundError
        If ``path`` is not a file (a subclass of both ``FileNotFoundError`` and ``ValueError``).
    ConfigError
        (a ``ValueError``) For an unreadable URDF, a URDF without moving joints, a floating base,
        an unsupported joint, missing limits, unknown locked or flange frames, an SRDF or
        ``joint_limits.yaml`` naming what the URDF lacks, or wrongly sized acceleration limits; the
        message names the file and the key.
    """
    path = Path(path)
    if not path.is_file():
        raise URDFNotFoundError(f"robot.path={path}: the URDF file does not exist")
    document = read_urdf_document(path)
    continuous = revolute_for_continuous(document)
    urdf_links, urdf_joints = description_names(document)
    hangs_from = None
    if chain is not None or group is not None:  # the arm of a bigger robot: every other joint locked
        found = (
            None if srdf is None else resolve_mesh(str(srdf), Path.cwd(), package_search_path(package_dirs))
        )
        if srdf is not None and found is None:
            raise MissingFileError(f"{path}: robot.srdf file {srdf} does not exist")
        arm = arm_joints(document, chain=chain, group=group, srdf=found)
        given = (
            dict(locked_joints)
            if isinstance(locked_joints, Mapping)
            else dict.fromkeys(locked_joints or (), 0.0)
        )
        locked_joints = locked_outside(document, arm, given)
        hangs_from = mounted_on(document, arm)
    try:  # fixed base: no root joint
        model = pin.buildModelFromXML(ElementTree.tostring(document, encoding="unicode"))
    except (ValueError, RuntimeError) as error:
        raise ConfigError(f"{path}: Pinocchio could not parse the URDF ({error})") from error
    if locked_joints:
        ids, q_reference = _locked_configuration(model, locked_joints, path)
        model, _ = reduced_model(model, ids, q_reference)
    _check_joints(model, path)
    if model.nv == 0:
        raise ConfigError(f"{path}: the URDF has no joint that moves (a robot needs at least one)")
    _check_limits(model, path, continuous)
    for joint_name in continuous:  # no position limits (the parser was given placeholders)
        if model.existJointName(joint_name):
            index = model.joints[model.getJointId(joint_name)].idx_q
            model.lowerPositionLimit[index], model.upperPositionLimit[index] = -np.inf, np.inf
    model.gravity = pin.Motion(gravity_vector(gravity), np.zeros(3))
    if flange_frame is not None:
        _add_flange(model, flange_frame, path)
    n = model.nv
    robot_name = name or model.name or path.stem
    velocity = np.array(model.velocityLimit, dtype=float)
    acceleration = _acceleration_limits(acceleration_limits, n, path)
    if joint_limits is not None:
        moveit = _moveit_limits(Path(joint_limits), list(model.names)[1:], path, urdf_joints)
        velocity = np.fmin(velocity, moveit["velocity"])  # NaN (no MoveIt limit) keeps the URDF's
        if acceleration_limits is None:
            acceleration = np.where(np.isnan(moveit["acceleration"]), np.inf, moveit["acceleration"])
    limits = JointLimits(
        position_lower=np.array(model.lowerPositionLimit, dtype=float),
        position_upper=np.array(model.upperPositionLimit, dtype=float),
        velocity=velocity,
        acceleration=acceleration,
        torque=np.array(model.effortLimit, dtype=float),
    )
    if missing_meshes not in ("error", "drop"):
        raise ConfigError(f"{path}: robot.missing_meshes must be error or drop, got {missing_meshes!r}")
    if srdf is not None:
        srdf_file = resolve_mesh(str(srdf), Path.cwd(), package_search_path(package_dirs))
        if srdf_file is not None:
            check_srdf_names(srdf_file, path, urdf_links, urdf_joints)
    source = None
    if collision_geometry:
        locked = (
            dict(locked_joints)
            if isinstance(locked_joints, Mapping)
            else {j: 0.0 for j in locked_joints or ()}
        )
        if srdf is not None and not str(srdf).startswith("package://") and not Path(srdf).is_file():
            raise MissingFileError(f"{path}: robot.srdf file {srdf} does not exist")
        source = CollisionSource(
            urdf=path,
            package_dirs=tuple(Path(d) for d in package_dirs),
            # a file name is the user's, from the working directory (package:// names resolve later)
            srdf=None
            if srdf is None
            else str(srdf)
            if str(srdf).startswith("package://")
            else str(Path(srdf).resolve()),
            missing_meshes="drop" if missing_meshes == "drop" else "error",
            locked_joints=tuple((k, float(v)) for k, v in locked.items()),
        )
    reductions, unusable = transmission_reductions(document)
    unusable = {joint: text for joint, text in unusable.items() if joint in list(model.names)[1:]}
    gears = [reductions.get(joint, 1.0) for joint in list(model.names)[1:]] if reductions else None
    drive_train = build_drive_train(drive, n, robot_name, gear_ratios=gears)
    if unusable and (drive or {}).get("gear_ratios") is None:
        _unusable_transmissions(path, unusable, drive_train)
    return RobotModel(
        name=robot_name,
        model=model,
        limits=limits,
        friction=build_friction(friction, n, robot_name),
        friction_terms=tuple(friction_terms),
        collision_source=source,
        drive=drive_train,
        friction_law=friction_law_of(friction_law),
        mounted_on=hangs_from,
    )


def _unusable_transmissions(path: Path, unusable: Mapping[str, str], drive: DriveTrain) -> None:
    """Transmissions whose ``mechanicalReduction`` is no number: an error where a log measured at the
    motors needs the gear ratios, else a warning (their gear ratio is taken as 1, which motions and
    logs measured at the joints do not use)."""
    named = ", ".join(
        f"joint {joint!r}: mechanicalReduction {text!r} is not a number" for joint, text in unusable.items()
    )
    what = f"{path}: transmission of {named} (a xacro argument left in the URDF?)"
    if drive.motor_side or drive.torque_constants is not None:
        raise ConfigError(
            f"{what}; the logs are measured at the motors, which needs the gear ratios: give them as "
            "robot.drive.gear_ratios=[…] (or fix the URDF)"
        )
    warnings.warn(
        f"{what}: gear ratio 1 taken, unused by motions and logs measured at the joints",
        UserWarning,
        stacklevel=3,
    )
