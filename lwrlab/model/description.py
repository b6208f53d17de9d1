"""Robots from a description: a mapping of modified Denavit–Hartenberg rows, inertials, limits, friction.

The keys, as in the robot configs (``conf/robot/<name>.yaml``) or any YAML file with the same keys::

    name: my_arm
    gravity: [0, 0, -9.81]                  # m/s², base frame
    mdh:                                    # Khalil–Kleinfinger, one entry per joint
      alpha: [...]                          # rad
      d: [...]                              # m
      theta_offset: [...]                   # rad
      r: [...]                              # m
    flange: [0, 0, 0.078]                   # flange origin in the last frame (m); null: none
    links:                                  # one per moving segment, in its DH frame
      - mass: 2.0                           # kg
        com: [0, 0.02, 0.1]                 # m
        inertia: [xx, yy, zz, xy, xz, yz]   # kg·m², about the CoM, axes of the DH frame
    limits:
      position_lower: [...]                 # rad
      position_upper: [...]                 # rad
      velocity: [...]                       # rad/s
      acceleration: [...]                   # rad/s²
      torque: [...]                         # N·m
    friction:                               # nominal joint friction
      coulomb: [...]                        # N·m
      viscous: [...]                        # N·m·s/rad
      offset: [...]                         # N·m (optional, default 0)
    friction_terms: [coulomb, viscous]      # columns of the regressor; add offset if needed
    rotor_inertia: [...]                    # drive inertia reflected to the joint (kg·m²); null: none
    collision_spheres:                      # self-collision spheres (lwrlab/model/collision.py); null: none
      # link 0 = base; center in the joint frame (m)
      - {name: elbow, link: 4, center: [0, 0, 0], radius: 0.08}
    drive:                                  # optional: lwrlab/model/drive_train.py; null: direct drives
      gear_ratios: [...]                    # motor turns per joint turn
      coupling: [[6, 5, 0.5]]               # [motor, joint, factor] off the diagonal, or a full N×N matrix
      torque_constants: [...]               # N·m/A at the motor (logs of currents); null: logs hold torques
      position_side: joint                  # joint | motor: where logged positions are measured
      torque_side: joint                    # joint | motor: where logged torques/currents are measured
      rotor_inertia: auto                   # reflected rotor-inertia columns: true | false | auto
      position_offsets: [...]               # rad, joint positions where the encoders read 0: θ = R·(q − q₀)
      encoder_counts: null                  # counts per turn when the logged positions are counts
    friction_law: null                      # optional: {_target_: plugins.friction.…}; null: sign law
    collision_urdf:                         # optional: a URDF whose <collision> geometry is this robot's
      path: package://my_arm_description/urdf/my_arm.urdf   # its joint frames must be the table's
      srdf: null                            # MoveIt SRDF (disabled pairs)
      package_dirs: []                      # folders holding ROS packages (before ROS_PACKAGE_PATH)
      locked_joints: {}                     # URDF joints merged into their parent (a gripper's fingers)

Every top-level key but ``drive``, ``friction_law`` and ``collision_urdf`` is required (null where
the robot has none): the description is the one place of its values. With ``collision_urdf``,
exciting motions are kept clear of that URDF's collision meshes (when it can be found; else of the
collision spheres, with a warning). ``build_robot``
takes these keys as keyword arguments (what Hydra's ``instantiate`` passes through the robot plugin
``plugins.robots.mdh``); ``load_robot_yaml`` reads them from a file. ``build_limits`` and
``build_friction`` serve every robot loader (the URDF plugin too).

Examples
--------
>>> from lwrlab.resources import config_group
>>> robot = load_robot_yaml(config_group("robot")["kuka_lwr4"])
>>> robot.name, robot.n_joints
('kuka_lwr4', 7)
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lwrlab.errors import ConfigError, MissingFileError
from lwrlab.model.collision import build_collision_spheres
from lwrlab.model.collision_geometry import CollisionSource
from lwrlab.model.dh import ModifiedDH, build_dh_model
from lwrlab.model.drive_train import build_drive_train
from lwrlab.model.friction_laws import FrictionLaw, SignCoulomb, law_from_mapping
from lwrlab.model.inertia import standard_parameters, to_pin_inertia
from lwrlab.model.robot import Friction, JointLimits, RobotModel
from lwrlab.yaml_files import read_yaml_mapping


def _array(values: Sequence[float], n: int, what: str) -> np.ndarray:
    array = np.asarray(values, dtype=float).ravel()
    if array.shape != (n,):
        raise ConfigError(f"{what}: expected {n} values, got {array.size}")
    return array


def gravity_vector(gravity: Sequence[float]) -> np.ndarray:
    """``robot.gravity`` as a 3-vector (m/s², base frame); a ``ConfigError`` for any other length."""
    return _array(gravity, 3, "robot.gravity")


def _inertia_tensor(values: Sequence[float], what: str) -> np.ndarray:
    xx, yy, zz, xy, xz, yz = _array(values, 6, what)
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def build_limits(limits: Mapping[str, Sequence[float]], n: int, robot: str) -> JointLimits:
    """Joint limits from a mapping of lists (units in the module docstring)."""
    keys = ("position_lower", "position_upper", "velocity", "acceleration", "torque")
    missing = [k for k in keys if k not in limits]
    if missing:
        raise ConfigError(f"robot {robot!r}: limits lack {missing}")
    return JointLimits(**{k: _array(limits[k], n, f"robot {robot!r} limits.{k}") for k in keys})


def build_friction(friction: Mapping[str, Sequence[float]] | None, n: int, robot: str) -> Friction:
    """Friction values; a missing term is zero."""
    friction = friction or {}

    def values(term: str) -> np.ndarray:
        return _array(friction.get(term, [0.0] * n), n, f"robot {robot!r} friction.{term}")

    return Friction(coulomb=values("coulomb"), viscous=values("viscous"), offset=values("offset"))


def build_robot(
    *,
    name: str,
    mdh: Mapping[str, Sequence[float]],
    links: Sequence[Mapping[str, Any]],
    limits: Mapping[str, Sequence[float]],
    friction: Mapping[str, Sequence[float]] | None,
    gravity: Sequence[float],
    friction_terms: Sequence[str],
    flange: Sequence[float] | None,
    rotor_inertia: Sequence[float] | None,
    collision_spheres: Sequence[Mapping[str, Any]] | None,
    collision_urdf: Mapping[str, Any] | None,
    drive: Mapping[str, Any] | None,
    friction_law: FrictionLaw | Mapping[str, Any] | None,
    **documentation: Any,
) -> RobotModel:
    """Build a :class:`RobotModel` from a modified-DH description (keys in the module docstring).

    Extra keys (``source``, ``notes``, …) document the data and are ignored.
    """
    del documentation
    table = ModifiedDH(
        alpha=np.asarray(mdh["alpha"], dtype=float),
        d=np.asarray(mdh["d"], dtype=float),
        r=np.asarray(mdh["r"], dtype=float),
        theta_offset=np.asarray(mdh["theta_offset"], dtype=float),
    )
    n = table.n_joints
    if len(links) != n:
        raise ConfigError(f"robot {name!r}: {n} DH rows but {len(links)} links")
    inertias = [
        to_pin_inertia(
            standard_parameters(
                float(link["mass"]),
                _array(link["com"], 3, f"robot {name!r} link {j} com"),
                _inertia_tensor(link["inertia"], f"robot {name!r} link {j} inertia"),
            )
        )
        for j, link in enumerate(links, start=1)
    ]
    flange_pose = None
    if flange is not None:
        flange_pose = np.eye(4)
        flange_pose[:3, 3] = _array(flange, 3, f"robot {name!r} flange")
    model = build_dh_model(table, inertias, gravity_vector(gravity), flange=flange_pose)
    return RobotModel(
        name=name,
        model=model,
        limits=build_limits(limits, n, name),
        friction=build_friction(friction, n, name),
        friction_terms=tuple(friction_terms),
        rotor_inertia=None
        if rotor_inertia is None
        else _array(rotor_inertia, n, f"robot {name!r} rotor_inertia"),
        collision_spheres=build_collision_spheres(collision_spheres, n, name),
        collision_source=None if collision_urdf is None else collision_source_of(collision_urdf, name),
        drive=build_drive_train(drive, n, name),
        friction_law=friction_law_of(friction_law),
    )


def friction_law_of(law: FrictionLaw | Mapping[str, Any] | None) -> FrictionLaw:
    """A description's ``friction_law``: a built law, its mapping (``_target_`` and settings), or None
    (the paper's sign law)."""
    if law is None:
        return SignCoulomb()
    if isinstance(law, Mapping):
        return law_from_mapping(law)
    return law


def collision_source_of(entry: Mapping[str, Any], robot: str) -> CollisionSource:
    """A :class:`CollisionSource` from a description's ``collision_urdf`` mapping."""
    unknown = set(entry) - {"path", "srdf", "package_dirs", "locked_joints"}
    if unknown or "path" not in entry:
        raise ConfigError(
            f"robot {robot!r} collision_urdf needs `path` (and optionally srdf, package_dirs, "
            f"locked_joints); unknown keys: {sorted(unknown)}"
        )
    dirs = tuple(Path(d) for d in entry.get("package_dirs") or ())
    srdf = entry.get("srdf")
    return CollisionSource(
        urdf=str(entry["path"]),  # a Path would fold the "//" of package://
        package_dirs=dirs,
        srdf=None if srdf is None else str(srdf),
        locked_joints=tuple((str(k), float(v)) for k, v in dict(entry.get("locked_joints") or {}).items()),
    )


DESCRIPTION_KEYS = tuple(
    name for name, p in inspect.signature(build_robot).parameters.items() if p.kind is p.KEYWORD_ONLY
)
"""The top-level keys of a robot description: the keyword arguments of :func:`build_robot`."""


def load_robot_yaml(path: str | Path, **overrides: Any) -> RobotModel:
    """Build a robot from a modified-DH YAML file; keyword arguments override the file's keys (a
    mapping updates the keys it names: ``drive={"rotor_inertia": False}`` keeps the rest of the
    file's ``drive`` block)."""
    path = Path(path)
    if not path.is_file():
        raise MissingFileError(f"robot.path={path}: the robot description does not exist")
    description = read_yaml_mapping(path, "robot")
    description.pop("_target_", None)
    for optional in ("collision_urdf", "drive", "friction_law"):
        description.setdefault(optional, None)
    for key, value in overrides.items():  # a mapping updates the file's mapping (+robot.drive.x=…)
        current = description.get(key)
        merge = isinstance(value, Mapping) and isinstance(current, Mapping)
        description[key] = {**current, **value} if merge else value  # type: ignore[dict-item]
    missing = [key for key in DESCRIPTION_KEYS if key not in description]
    if missing:
        raise ConfigError(
            f"robot description {path} lacks {missing}: every key of lwrlab.model.description is "
            "required (null where the robot has none)"
        )
    return build_robot(**description)
