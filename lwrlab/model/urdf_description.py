"""A URDF as a document, before and around Pinocchio's parser: what the robot and collision loaders share.

* :func:`revolute_for_continuous` rewrites every ``continuous`` joint (a revolute joint without
  position limits) as a ``revolute`` one with the same axis and effort and velocity limits. Pinocchio
  would load it as a ``RevoluteUnbounded`` joint (two configuration coordinates, cos and sin, for one
  velocity); identification needs only the angle, so the joint becomes an ordinary revolute joint,
  one angle in rad, and the loaders give it infinite position limits
  (:mod:`lwrlab.model.position_ranges`).
* :func:`description_names` lists the links and joints a URDF holds, which an SRDF
  (:func:`check_srdf_names`) or a MoveIt ``joint_limits.yaml`` (:func:`check_joint_limit_names`) must
  not name otherwise: a file written for another robot is refused in one line rather than silently
  ignored.
* :func:`reduced_model` locks joints as ``pin.buildReducedModel`` does, also when a link and a joint
  share a name (the SO-100 arm's ``gripper``): Pinocchio finds the frames of the locked joints by name
  and stops where two frames answer it.

Examples
--------
>>> import xml.etree.ElementTree as ET
>>> root = ET.fromstring(
...     '<robot name="r"><link name="a"/><link name="b"/>'
...     '<joint name="wrist" type="continuous"><parent link="a"/><child link="b"/>'
...     '<limit effort="5" velocity="2"/></joint></robot>'
... )
>>> revolute_for_continuous(root)
('wrist',)
>>> root.find("joint").get("type"), root.find("joint/limit").get("effort")
('revolute', '5')
>>> description_names(root)
(('a', 'b'), ('wrist',))
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ElementTree
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from lwrlab.errors import ConfigError, UnknownNameError

log = logging.getLogger(__name__)

_PLACEHOLDER_LIMIT = np.pi
"""rad: the position limits written into a rewritten continuous joint for the parser's sake; the
loaders replace them by ±inf."""

_RENAMED = "\x1f"
"""Marks a frame renamed for the time of :func:`reduced_model` (a character no URDF name holds)."""


def revolute_for_continuous(robot: ElementTree.Element) -> tuple[str, ...]:
    """Rewrite, in place, the ``continuous`` joints of a URDF ``<robot>`` element as ``revolute`` ones.

    The axis, origin, dynamics and the ``<limit>``'s effort and velocity are kept (a missing one is
    written as 0, which the loaders refuse naming the joint, as for any joint); ``lower`` and
    ``upper`` get placeholders the loaders replace by infinite limits. Only the ``<joint>`` children
    of ``<robot>`` are joints (a ``<transmission>`` names joints too).

    Returns
    -------
    tuple of str
        The names of the rewritten joints, in document order.
    """
    names = []
    for joint in robot.findall("joint"):
        if joint.get("type") != "continuous":
            continue
        joint.set("type", "revolute")
        limit = joint.find("limit")
        if limit is None:
            limit = ElementTree.SubElement(joint, "limit")
        for key in ("effort", "velocity"):
            limit.set(key, limit.get(key, "0"))
        limit.set("lower", repr(-_PLACEHOLDER_LIMIT))
        limit.set("upper", repr(_PLACEHOLDER_LIMIT))
        names.append(joint.get("name", ""))
    return tuple(names)


def description_names(robot: ElementTree.Element) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(links, joints): the names of a URDF ``<robot>``'s links and joints (fixed ones too)."""
    links = tuple(link.get("name", "") for link in robot.findall("link"))
    joints = tuple(joint.get("name", "") for joint in robot.findall("joint"))
    return links, joints


def read_urdf_document(path: Path) -> ElementTree.Element:
    """The ``<robot>`` element of a URDF file, its default XML namespace (if any) dropped from the tags;
    a one-line :class:`ConfigError` if it cannot be read."""
    try:
        root = ElementTree.parse(path).getroot()
    except (ElementTree.ParseError, OSError) as error:
        raise ConfigError(f"{path}: could not parse the URDF ({error})") from error
    if root.tag.startswith("{"):  # <robot xmlns="…">: the parser reads the names without it
        namespace = root.tag[: root.tag.index("}") + 1]
        for element in root.iter():
            if isinstance(element.tag, str) and element.tag.startswith(namespace):
                element.tag = element.tag[len(namespace) :]
    if root.tag != "robot":
        raise ConfigError(f"{path}: could not parse the URDF (its root element is <{root.tag}>, not <robot>)")
    return root


@dataclass(frozen=True)
class SrdfNames:
    """The links and joints an SRDF names, by what lwrlab does with them."""

    disabled_links: frozenset[str]
    """Links of its ``disable_collisions`` pairs: what lwrlab reads (pairs never checked)."""
    other_links: frozenset[str]
    """Links of its groups, chains, end effectors and virtual joints (MoveIt's; not read here)."""
    joints: frozenset[str]
    """Joints of its groups, group states and passive joints (not read here); a virtual joint's own
    name lies outside the URDF by design and is left out."""

    @property
    def all(self) -> frozenset[str]:
        return self.disabled_links | self.other_links | self.joints


def srdf_names(srdf: Path) -> SrdfNames:
    """The names an SRDF gives (:class:`SrdfNames`); a :class:`ConfigError` if it cannot be read."""
    try:
        root = ElementTree.parse(srdf).getroot()
    except (ElementTree.ParseError, OSError) as error:
        raise ConfigError(f"{srdf}: cannot read the SRDF ({error})") from error
    disabled = {
        element.get(key, "") for element in root.iter("disable_collisions") for key in ("link1", "link2")
    }
    links: set[str] = set()
    joints: set[str] = set()
    for group in root.iter("group"):
        links.update(link.get("name", "") for link in group.findall("link"))
        joints.update(joint.get("name", "") for joint in group.findall("joint"))
        for chain in group.findall("chain"):
            links.update(chain.get(key, "") for key in ("base_link", "tip_link"))
    for state in root.iter("group_state"):
        joints.update(joint.get("name", "") for joint in state.findall("joint"))
    links.update(effector.get("parent_link", "") for effector in root.iter("end_effector"))
    links.update(joint.get("child_link", "") for joint in root.iter("virtual_joint"))
    joints.update(joint.get("name", "") for joint in root.iter("passive_joint"))
    joints -= {joint.get("name", "") for joint in root.iter("virtual_joint")}
    return SrdfNames(frozenset(disabled - {""}), frozenset(links - {""}), frozenset(joints - {""}))


def check_srdf_names(
    srdf: Path, urdf: Path, links: Collection[str], joints: Collection[str], setting: str = "robot.srdf"
) -> None:
    """Refuse, in one line naming both files, an SRDF written for another robot; warn of a stray name.

    An SRDF is refused when a link of its ``disable_collisions`` pairs (what lwrlab reads) is not the
    URDF's, or when half its names or more are not. A few unknown names elsewhere (groups, chains,
    group states: MoveIt's, not read here) are a warning: shipped SRDFs have such slips
    (example-robot-data's Z1 names a chain base ``base`` its URDF calls ``link00``). ``setting`` says
    where it was given.
    """
    names = srdf_names(srdf)
    links, joints = set(links), set(joints)
    unknown_links = sorted((names.disabled_links | names.other_links) - links)
    unknown_joints = sorted(names.joints - joints)
    if not (unknown_links or unknown_joints):
        return
    named = "; ".join(
        f"{kind} {names}" for kind, names in (("links", unknown_links), ("joints", unknown_joints)) if names
    )
    unknown = len(unknown_links) + len(unknown_joints)
    another_robot = bool(names.disabled_links - links) or 2 * unknown >= len(names.all)
    if another_robot:
        raise UnknownNameError(
            f"{setting} {srdf} names what the URDF {urdf} lacks ({named}): an SRDF of another robot?"
        )
    log.warning(
        "%s %s names what the URDF %s lacks (%s), in parts lwrlab does not read: ignored",
        setting,
        srdf,
        urdf,
        named,
    )


def check_joint_limit_names(path: Path, named: Collection[str], urdf: Path, joints: Collection[str]) -> None:
    """Refuse, in one line naming both files, a MoveIt ``joint_limits.yaml`` naming joints the URDF
    lacks (joints the robot locks are the URDF's, and fine)."""
    unknown = sorted(set(named) - set(joints))
    if unknown:
        raise UnknownNameError(
            f"robot.joint_limits {path} names joints the URDF {urdf} lacks ({unknown}): "
            "the limits of another robot?"
        )


def frame_id(model: pin.Model, name: str) -> int:
    """The frame called ``name``: a link's (BODY) before a joint's, a fixed joint's or an operational
    frame, when a link and a joint share the name."""
    for kind in (pin.FrameType.BODY, pin.FrameType.JOINT, pin.FrameType.FIXED_JOINT, pin.FrameType.OP_FRAME):
        if model.existFrame(name, kind):
            return int(model.getFrameId(name, kind))
    return int(model.getFrameId(name))


def reduced_model(
    model: pin.Model,
    locked: Sequence[int],
    q_reference: np.ndarray,
    geometry: pin.GeometryModel | None = None,
) -> tuple[pin.Model, pin.GeometryModel | None]:
    """``pin.buildReducedModel`` of ``model`` (and ``geometry``): joints ``locked`` merged into their
    parent at ``q_reference``.

    Pinocchio looks the frames of the locked joints and their parents up by name and fails when a
    link (or a fixed joint) has the name of another frame. Every such frame but the joints' own is
    renamed for the reduction and given its name back in the reduced model; ``model`` is unchanged.
    """
    model = model.copy()
    names = [frame.name for frame in model.frames]
    shared = {name for name in names if names.count(name) > 1}
    original: dict[str, str] = {}
    for index, frame in enumerate(model.frames):
        if frame.name in shared and frame.type != pin.FrameType.JOINT:
            temporary = f"{frame.name}{_RENAMED}{index}"
            original[temporary] = frame.name
            model.frames[index].name = temporary
    ids = sorted(int(j) for j in locked)
    if geometry is None:
        reduced, reduced_geometry = pin.buildReducedModel(model, ids, q_reference), None
    else:
        reduced, reduced_geometry = pin.buildReducedModel(model, geometry, ids, q_reference)
    for index, frame in enumerate(reduced.frames):
        if frame.name in original:
            reduced.frames[index].name = original[frame.name]
    return reduced, reduced_geometry


def transmission_reductions(document: ElementTree.Element) -> tuple[dict[str, float], dict[str, str]]:
    """Gear ratio of each joint a ros_control ``<transmission>`` drives: its ``mechanicalReduction``
    (in the ``<actuator>``, or beside it in the older format), by joint name; and, apart, the text of
    those that are no number (a xacro argument left in a generated URDF: ``reduction``), by joint
    name. Transmissions of several joints (differentials) are left out: their coupling goes in
    ``robot.drive.coupling``."""
    reductions, unusable = {}, {}
    for transmission in document.iter("transmission"):
        joints = [j.get("name") for j in transmission.findall("joint")]
        reduction = transmission.find("actuator/mechanicalReduction")
        if reduction is None:
            reduction = transmission.find("mechanicalReduction")
        if len(joints) != 1 or joints[0] is None or reduction is None or not (reduction.text or "").strip():
            continue
        text = str(reduction.text).strip()
        try:
            reductions[joints[0]] = float(text)
        except ValueError:
            unusable[joints[0]] = text
    return reductions, unusable
