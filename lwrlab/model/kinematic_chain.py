"""The arm of a bigger robot: the joints of a chain or an SRDF planning group, every other one locked.

A whole description (a humanoid, a mobile manipulator with two arms, a torso and a head) holds more
joints than the arm to identify. MoveIt and KDL take such an arm as a chain between two links or as a
planning group of the SRDF; so does ``robot=urdf`` with ``robot.chain=[<root link>, <tip link>]`` or
``robot.group=<SRDF group>`` (and ``robot.srdf``): :func:`arm_joints` finds the moving joints of the
arm, :func:`locked_outside` locks every other moving joint of the description (at 0, or at the position
``robot.locked_joints`` gives), so that the rest of the robot is merged into the segments it hangs
from, as it stands.

Examples
--------
>>> from xml.etree import ElementTree
>>> urdf = ElementTree.fromstring(
...     '<robot name="r"><link name="base"/><link name="torso"/><link name="arm"/><link name="head"/>'
...     '<joint name="lift" type="prismatic"><parent link="base"/><child link="torso"/></joint>'
...     '<joint name="shoulder" type="revolute"><parent link="torso"/><child link="arm"/></joint>'
...     '<joint name="neck" type="revolute"><parent link="torso"/><child link="head"/></joint></robot>'
... )
>>> arm_joints(urdf, chain=["torso", "arm"])
['shoulder']
>>> locked_outside(urdf, ["shoulder"], {"lift": 0.15})
{'lift': 0.15, 'neck': 0.0}
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from xml.etree import ElementTree

from lwrlab.errors import ConfigError

FIXED = "fixed"


def _moving_joints(urdf: ElementTree.Element) -> list[str]:
    """The description's joints that move, in document order."""
    return [j.get("name", "") for j in urdf.findall("joint") if j.get("type") != FIXED]


def chain_joints(urdf: ElementTree.Element, root: str, tip: str) -> list[str]:
    """The moving joints from link ``root`` down to link ``tip`` (root first); a :class:`ConfigError`
    naming ``robot.chain`` when a link is missing or ``root`` is not above ``tip``."""
    links = {link.get("name", "") for link in urdf.findall("link")}
    missing = [name for name in (root, tip) if name not in links]
    if missing:
        raise ConfigError(f"robot.chain: the description has no link {missing[0]!r}")
    parent_of: dict[str, tuple[str, str, str | None]] = {}  # child link → (joint, parent link, type)
    for joint in urdf.findall("joint"):
        child, parent = joint.find("child"), joint.find("parent")
        if child is not None and parent is not None:
            parent_of[child.get("link", "")] = (
                joint.get("name", ""),
                parent.get("link", ""),
                joint.get("type"),
            )
    joints, link = [], tip
    while link != root:
        if link not in parent_of:
            raise ConfigError(
                f"robot.chain=[{root}, {tip}]: {root!r} is not above {tip!r} in the description "
                "(give the chain's root link first, its tip last)"
            )
        name, link, kind = parent_of[link]
        if kind != FIXED:
            joints.append(name)
    if not joints:
        raise ConfigError(f"robot.chain=[{root}, {tip}]: no joint moves between these links")
    return joints[::-1]


def group_joints(urdf: ElementTree.Element, srdf: Path, group: str) -> list[str]:
    """The moving joints of the SRDF planning group ``group``: its chains, its joints and the groups
    it names, in the description's order; a :class:`ConfigError` naming ``robot.group`` if unknown."""
    try:
        document = ElementTree.parse(srdf).getroot()
    except (ElementTree.ParseError, OSError) as error:
        raise ConfigError(f"robot.srdf {srdf}: cannot read the SRDF ({error})") from error
    groups = {g.get("name", ""): g for g in document.findall("group")}  # not the references inside groups
    if group not in groups:
        raise ConfigError(
            f"robot.group={group}: the SRDF {srdf} has no such group; its groups: {sorted(groups)}"
        )
    members: set[str] = set()
    pending, seen = [group], set()
    while pending:
        name = pending.pop()
        if name in seen:
            continue
        seen.add(name)
        element = groups.get(name)
        if element is None:
            raise ConfigError(f"robot.group={group}: the SRDF {srdf} names a group {name!r} it lacks")
        for chain in element.findall("chain"):
            members.update(chain_joints(urdf, chain.get("base_link", ""), chain.get("tip_link", "")))
        members.update(joint.get("name", "") for joint in element.findall("joint"))
        pending += [sub.get("name", "") for sub in element.findall("group")]
    moving = [name for name in _moving_joints(urdf) if name in members]
    if not moving:
        raise ConfigError(f"robot.group={group}: no joint of the group moves in the description")
    return moving


def arm_joints(
    urdf: ElementTree.Element,
    *,
    chain: Sequence[str] | None = None,
    group: str | None = None,
    srdf: Path | None = None,
) -> list[str]:
    """The moving joints of the arm ``robot.chain`` or ``robot.group`` names (one of them)."""
    if chain is not None and group is not None:
        raise ConfigError("robot.chain and robot.group both name the arm: give one of them")
    if chain is not None:
        if len(chain) != 2:
            raise ConfigError(f"robot.chain must be [<root link>, <tip link>], got {list(chain)}")
        return chain_joints(urdf, str(chain[0]), str(chain[1]))
    if group is None:
        raise ConfigError("arm_joints needs robot.chain or robot.group")
    if srdf is None:
        raise ConfigError(f"robot.group={group} names a planning group of an SRDF: give robot.srdf too")
    return group_joints(urdf, srdf, group)


def _parents(urdf: ElementTree.Element) -> dict[str, tuple[str, str | None]]:
    """Each child link's parent link and the type of the joint between them."""
    out = {}
    for joint in urdf.findall("joint"):
        child, parent = joint.find("child"), joint.find("parent")
        if child is not None and parent is not None:
            out[child.get("link", "")] = (parent.get("link", ""), joint.get("type"))
    return out


def mounted_on(urdf: ElementTree.Element, arm: Sequence[str]) -> str | None:
    """The link the arm (its moving joints) hangs from, when a moving joint of the description (locked
    for the arm) lies between it and the description's root link; None when only fixed joints do (the
    arm stands on the description's base).

    >>> urdf = ElementTree.fromstring(
    ...     '<robot name="r"><link name="base"/><link name="torso"/><link name="arm"/>'
    ...     '<joint name="lift" type="prismatic"><parent link="base"/><child link="torso"/></joint>'
    ...     '<joint name="shoulder" type="revolute"><parent link="torso"/><child link="arm"/></joint></robot>'
    ... )
    >>> mounted_on(urdf, ["shoulder"]), mounted_on(urdf, ["lift", "shoulder"])
    ('torso', None)
    """
    joints = {j.get("name", ""): j for j in urdf.findall("joint")}
    parents = _parents(urdf)
    roots = []
    for name in arm:
        parent = joints[name].find("parent") if name in joints else None
        if parent is not None:
            roots.append(parent.get("link", ""))
    arm_children = {
        c.get("link", "") for name in arm if name in joints for c in joints[name].findall("child")
    }
    above = [link for link in roots if not _below(link, arm_children, parents)]
    if not above:
        return None
    root, link = above[0], above[0]
    while link in parents:  # up to the description's root: any moving joint on the way?
        link, kind = parents[link]
        if kind != FIXED:
            return root
    return None


def _below(link: str, children: set[str], parents: Mapping[str, tuple[str, str | None]]) -> bool:
    """Whether ``link`` is one of ``children`` or hangs from one of them."""
    while True:
        if link in children:
            return True
        if link not in parents:
            return False
        link = parents[link][0]


def locked_outside(
    urdf: ElementTree.Element, arm: Sequence[str], positions: Mapping[str, float]
) -> dict[str, float]:
    """Every moving joint of the description off the arm, locked at its position in ``positions``
    (``robot.locked_joints``) or at 0; the arm's joints ``positions`` names stay locked too."""
    kept = set(arm)
    locked = {name: float(positions.get(name, 0.0)) for name in _moving_joints(urdf) if name not in kept}
    return locked | {name: float(value) for name, value in positions.items() if name in kept}
