"""Export a robot model (typically the identified, physically consistent one) as URDF.

Each moving segment becomes a link whose ``<inertial>`` carries its mass, centre of mass and
inertia about the centre of mass (from the standard parameters about the joint frame); each joint
keeps its placement (``<origin xyz rpy>``), axis and limits, and its friction goes into
``<dynamics damping="FV" friction="FC"/>`` (viscous N·m·s/rad, Coulomb N·m). Constant torque
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

_AXES = {"JointModelRX": (1.0, 0.0, 0.0), "JointModelRY": (0.0, 1.0, 0.0), "JointModelRZ": (0.0, 0.0, 1.0)}


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


def _joint_axis(joint: pin.JointModel) -> tuple[float, ...]:
    name = joint.shortname()
    if name in _AXES:
        return _AXES[name]
    if name == "JointModelRevoluteUnaligned":
        return tuple(np.asarray(joint.extract().axis, dtype=float))
    raise ValueError(f"URDF export supports revolute joints only, got {name}")


def robot_urdf(robot: RobotModel, name: str | None = None) -> str:
    """The URDF document (a string) of ``robot``: links, inertials, joints, limits, friction."""
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
        joint = ET.SubElement(root, "joint", name=model.names[j], type="revolute")
        placement = model.jointPlacements[j]
        ET.SubElement(
            joint,
            "origin",
            xyz=_text(placement.translation),
            rpy=_text(pin.rpy.matrixToRpy(placement.rotation)),
        )
        ET.SubElement(joint, "parent", link=links[model.parents[j]])
        ET.SubElement(joint, "child", link=links[j])
        ET.SubElement(joint, "axis", xyz=_text(_joint_axis(model.joints[j])))
        lim = robot.limits
        ET.SubElement(
            joint,
            "limit",
            lower=_number(lim.position_lower[k]),
            upper=_number(lim.position_upper[k]),
            effort=_number(lim.torque[k]),
            velocity=_number(lim.velocity[k]),
        )
        damping = robot.friction.viscous[k] if "viscous" in robot.friction_terms else 0.0
        coulomb = robot.friction.coulomb[k] if "coulomb" in robot.friction_terms else 0.0
        ET.SubElement(joint, "dynamics", damping=_number(damping), friction=_number(coulomb))
    ET.indent(root)
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def export_urdf(robot: RobotModel, path: str | Path, name: str | None = None) -> Path:
    """Write :func:`robot_urdf` of ``robot`` to ``path``."""
    path = Path(path)
    path.write_text(robot_urdf(robot, name))
    return path
