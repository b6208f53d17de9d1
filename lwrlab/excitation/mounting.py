"""Where the robot stands by default: ``trajectory.constraints.world.mounting_surface: auto``.

An arm alone stands on a table at its base's height (the plane ``z = 0`` of its base frame, normal
against gravity). The arm of a bigger robot (``robot.chain``, ``robot.group``: a humanoid's arm on its
torso, a mobile manipulator's on its lifting column) hangs from a link that locked joints separate from
the description's base: a table at that base's height would cut through the torso or the legs. Its
world is the floor the whole description stands on instead: the plane under the lowest point of every
body fixed to the arm's root (the feet of a humanoid standing as its locked joints hold it, the wheels
of a mobile base), with the robot's own geometry; without it (``robot.collision_geometry=false``), no
surface.

Examples
--------
>>> describe_surface(AUTO, None, "torso_2_link")
'no mounting surface (the arm hangs from torso_2_link; no collision geometry to find the floor)'
>>> describe_surface(AUTO, {"height": -1.08, "normal": [0.0, 0.0, 1.0]}, "torso_2_link")[:48]
'the floor under the robot: the plane z = -1.08 m'
"""

from __future__ import annotations

from typing import Any

import numpy as np

from lwrlab.errors import ConfigError
from lwrlab.model.robot import RobotModel

AUTO = "auto"
"""The value of ``mounting_surface`` that asks for the default above."""

TABLE: dict[str, Any] = {"height": 0.0, "normal": [0.0, 0.0, 1.0]}
"""An arm alone: a table at its base's height."""

_FLOORS: dict[int, tuple[RobotModel, dict[str, Any] | None]] = {}
"""The floor of each robot object already asked (loading its meshes costs a second)."""


def resolve_surface(mounting: Any, robot: RobotModel | None) -> dict[str, Any] | None:
    """The mounting surface ``{height, normal}`` (or None) that ``mounting`` (the config's value: a
    mapping, None, or :data:`AUTO`) means for ``robot`` (module docstring)."""
    if isinstance(mounting, str) and mounting != AUTO:
        raise ConfigError(
            f"trajectory.constraints.world.mounting_surface={mounting}: give {{height: …, normal: […]}}, "
            f"null (none) or {AUTO}"
        )
    if mounting != AUTO:
        return None if mounting is None else dict(mounting)
    if robot is None or robot.mounted_on is None:
        return dict(TABLE)
    cached = _FLOORS.get(id(robot))
    if cached is None or cached[0] is not robot:
        cached = (robot, _floor_under(robot))
        if len(_FLOORS) >= 8:
            _FLOORS.pop(next(iter(_FLOORS)))
        _FLOORS[id(robot)] = cached
    return None if cached[1] is None else dict(cached[1])


def _floor_under(robot: RobotModel) -> dict[str, Any] | None:
    """The plane under the lowest point of the bodies fixed to the base frame, normal against gravity;
    None without collision geometry or without gravity."""
    from lwrlab.model.collision_geometry import load_robot_geometry

    gravity = np.asarray(robot.model.gravity.linear, dtype=float)
    if robot.collision_source is None or not np.linalg.norm(gravity) > 0:
        return None
    geometry = load_robot_geometry(robot.collision_source, robot.model)
    fixed = [s.vertices_in_joint_frame() for s in geometry.shapes if s.joint == 0]
    if not fixed:
        return None
    normal = -gravity / np.linalg.norm(gravity)
    height = float(np.min(np.vstack(fixed) @ normal))
    return {"height": height, "normal": [float(v) for v in normal]}


def describe_surface(mounting: Any, surface: dict[str, Any] | None, mounted_on: str | None) -> str:
    """One phrase for the run's log and report: the surface the motion keeps clear of (``surface``,
    what :func:`resolve_surface` made of the config's ``mounting``)."""
    if surface is None:
        if mounting == AUTO:
            missing = "no collision geometry to find the floor"
            return f"no mounting surface (the arm hangs from {mounted_on}; {missing})"
        return "no mounting surface"
    normal = np.asarray(surface.get("normal", (0.0, 0.0, 1.0)), dtype=float)
    normal = normal / np.linalg.norm(normal)
    height = float(surface.get("height", 0.0))
    upward = np.allclose(normal, (0.0, 0.0, 1.0))
    side = "z" if upward else f"n·x (n = [{', '.join(f'{v:.3g}' for v in normal)}])"
    plane = f"the plane {side} = {height:.3g} m of the base frame"
    if mounting != AUTO:
        return f"the configured mounting surface: {plane}"
    if mounted_on is None:
        return f"a table at the base's height: {plane}"
    return f"the floor under the robot: {plane}, under the lowest point of the bodies fixed to {mounted_on}"
