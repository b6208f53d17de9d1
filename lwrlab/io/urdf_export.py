"""Export a robot model (typically the identified, physically consistent one) as URDF.

Each moving segment becomes a link whose ``<inertial>`` carries its mass, centre of mass and
inertia about the centre of mass (from the standard parameters about the joint frame); each joint
keeps its placement (``<origin xyz rpy>``), axis and limits, and its friction goes into
``<dynamics damping="FV" friction="FC"/>`` (viscous N·m·s/rad, Coulomb N·m; N·s/m and N for a
prismatic joint). A revolute joint without position limits is written back as ``continuous`` (no
``lower``/``upper``), a prismatic one as ``prismatic``; a joint of any other kind cannot be written
(:class:`UnexportableJointError`, and the identification report then goes without its URDF). Constant torque
offsets (FO) and drive rotor inertia have no URDF field and are left out (a warning says so when
they are non-zero). Numbers are written with 17 significant digits, so Pinocchio and MuJoCo read
back the same model to round-off. Gravity is not part of URDF: both engines default to
−9.81 m/s² along z, as the models of this lab.
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin

from lwrlab.model.inertia import from_pin_inertia, mass_com_inertia
from lwrlab.model.robot import RobotModel

log = logging.getLogger(__name__)

_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}
_ALIGNED = {
    **{f"JointModelR{axis}": ("revolute", direction) for axis, direction in _AXES.items()},
    **{f"JointModelRUB{axis}": ("continuous", direction) for axis, direction in _AXES.items()},
    **{f"JointModelP{axis}": ("prismatic", direction) for axis, direction in _AXES.items()},
}
"""Pinocchio's joints along an axis of their frame: (URDF type, axis)."""
_UNALIGNED = {
    "JointModelRevoluteUnaligned": "revolute",
    "JointModelRevoluteUnboundedUnaligned": "continuous",
    "JointModelPrismaticUnaligned": "prismatic",
}
"""Pinocchio's joints along any axis (read from the joint): their URDF type."""


class UnexportableJointError(ValueError):
    """A joint URDF has no type for (planar, spherical, floating, …); the message names it."""


def _number(value: float) -> str:
    return repr(float(value))  # shortest string that reads back to the same double


def _text(values: np.ndarray | tuple[float, ...]) -> str:
    return " ".join(_number(v) for v in values)


def inertial_element(phi: np.ndarray) -> ET.Element:
    """URDF ``<inertial>`` of the standard parameters ``phi`` (10,): origin at the centre of mass,
    axes of the link frame, inertia about the centre of mass (kg·m²)."""
    mass, com, inertia = mass_com_inertia(phi)
    inertial = ET.Element("inertial")
    ET.SubElement(inertial, "origin", xyz=_text(com), rpy="0 0 0")
    ET.SubElement(inertial, "mass", value=_number(mass))
    ET.SubElement(
        inertial,
        "inertia",
        ixx=_number(inertia[0, 0]),
        ixy=_number(inertia[0, 1]),
        ixz=_number(inertia[0, 2]),
        iyy=_number(inertia[1, 1]),
        iyz=_number(inertia[1, 2]),
        izz=_number(inertia[2, 2]),
    )
    return inertial


def joint_type_and_axis(joint: pin.JointModel) -> tuple[str, tuple[float, ...]]:
    """The URDF type (``revolute``, ``continuous``, ``prismatic``) and axis of a Pinocchio joint;
    :class:`UnexportableJointError` for any other joint."""
    name = joint.shortname()
    if name in _ALIGNED:
        return _ALIGNED[name]
    if name in _UNALIGNED:
        return _UNALIGNED[name], tuple(float(x) for x in np.asarray(joint.extract().axis, dtype=float))
    raise UnexportableJointError(
        f"URDF export writes revolute, continuous and prismatic joints, not a {name}"
    )


def robot_urdf(robot: RobotModel, name: str | None = None) -> str:
    """The URDF document (a string) of ``robot``: links, inertials, joints, limits, friction.

    Raises
    ------
    UnexportableJointError
        For a joint URDF cannot describe (neither revolute, continuous nor prismatic with limits).
    """
    model = robot.model
    root = ET.Element("robot", name=name or robot.name)
    ET.SubElement(root, "link", name="base_link")
    links = ["base_link"] + [f"link_{label}" for label in robot.link_labels]
    if np.any(robot.friction.offset != 0.0) and "offset" in robot.friction_terms:
        log.warning("%s: torque offsets FO have no URDF field and are not exported", robot.name)
    for j in range(1, model.njoints):
        link = ET.SubElement(root, "link", name=links[j])
        link.append(inertial_element(from_pin_inertia(model.inertias[j])))
        k = j - 1
        lim = robot.limits
        kind, axis = joint_type_and_axis(model.joints[j])
        free = not (np.isfinite(lim.position_lower[k]) and np.isfinite(lim.position_upper[k]))
        if kind == "revolute" and free:
            kind = "continuous"  # a continuous joint of the URDF, read as a revolute one
        elif kind == "prismatic" and free:
            raise UnexportableJointError(
                f"{robot.name}: prismatic joint {model.names[j]!r} has no position limits (URDF needs them)"
            )
        joint = ET.SubElement(root, "joint", name=model.names[j], type=kind)
        placement = model.jointPlacements[j]
        ET.SubElement(
            joint,
            "origin",
            xyz=_text(placement.translation),
            rpy=_text(pin.rpy.matrixToRpy(placement.rotation)),
        )
        ET.SubElement(joint, "parent", link=links[model.parents[j]])
        ET.SubElement(joint, "child", link=links[j])
        ET.SubElement(joint, "axis", xyz=_text(axis))
        limit = ET.SubElement(joint, "limit")
        if kind != "continuous":  # a continuous joint has no position limits
            limit.set("lower", _number(lim.position_lower[k]))
            limit.set("upper", _number(lim.position_upper[k]))
        limit.set("effort", _number(lim.torque[k]))
        limit.set("velocity", _number(lim.velocity[k]))
        damping = robot.friction.viscous[k] if "viscous" in robot.friction_terms else 0.0
        coulomb = robot.friction.coulomb[k] if "coulomb" in robot.friction_terms else 0.0
        ET.SubElement(joint, "dynamics", damping=_number(damping), friction=_number(coulomb))
    ET.indent(root)
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def export_urdf(robot: RobotModel, path: str | Path, name: str | None = None) -> Path:
    """Write :func:`robot_urdf` of ``robot`` to ``path`` (nothing is written if it raises)."""
    path = Path(path)
    path.write_text(robot_urdf(robot, name))
    return path
