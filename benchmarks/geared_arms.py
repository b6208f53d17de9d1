"""Geared arms as they are built: logs measured at the motors, and what lwrlab identifies from them.

Two six-axis arms, simulated by :mod:`lwrlab.plants.geared_arm` (LuGre friction whose Coulomb level
grows with the load, reflected rotor inertias, encoders and currents or torques at the motors, 500 Hz):

- ``ur_like``: a UR5-like collaborative arm. Kinematics: Universal Robots' published DH of the UR5
  (a = 0, −0.425, −0.39225, 0, 0, 0 m; d = 0.089159, 0, 0, 0.10915, 0.09465, 0.0823 m; α = π/2, 0,
  0, π/2, −π/2, 0), rewritten as modified DH; masses and centres of mass: UR's published table (in the
  standard-DH frames, moved here into the modified-DH ones), with a 0.8 kg gripper on link 6;
  inertia tensors: solid-cylinder estimates (UR publishes none; the example-robot-data URDF's wrist
  tensors, 0.11–0.22 kg·m² for 1.2 kg links, are not physical). Harmonic drives of ratio 100 on
  every joint, no coupling; motor currents measured with torque constants 0.1 N·m/A.
- ``industrial``: an ABB IRB 120-like six-axis arm (its DH: 0.29 m shoulder height, 0.27 m upper arm,
  0.07 m elbow offset, 0.302 m forearm, 0.072 m flange), invented masses and inertias of the right
  size (25 kg arm); gear ratios 48, 48, 40, 36, 32, 32; **coupled wrist**: motor 6 also turns with
  joint 5, ``C[5, 4] = 0.3`` (joint units: θ6 = 32·(q6 + 0.3·q5)); motor encoder angles and motor
  torques logged.

Each arm's truth is the nominal description with every segment perturbed (10 %, physically
consistent, seeded); the description written for lwrlab is the nominal one, with its ``drive:``
block and datasheet rotor inertias 20 % below the truth. Logs (motor side, CSV for one arm and
Parquet for the other): ``fit`` (two 12 s multisines with a 2 s pause between, rests at both ends),
``val_multisine`` (another multisine, other frequencies), ``val_p2p`` (quintic point-to-point moves
with stops).

    .venv/bin/python benchmarks/geared_arms.py [--folder OUT] [--cli]

writes the logs into OUT (default: a temporary folder; ``--logs-only`` stops there: the logs and the
description of each arm, for ``lwrlab`` to read), identifies each arm with the defaults for logs
(``friction=auto``, ``estimator=sdp``), with ``friction=sign`` (the paper's law, the former default)
and with ``robot.drive.rotor_inertia=false``, and prints the figures: held-out error, the noise floor,
the error on the rows at rest against the noise of the hold torque, the friction chosen, and the drive
parameters (rotor inertias, friction of the coupled motor) against the truth. ``--cli`` also runs the
command line (``lwrlab task=identification plant=log …``) once per arm.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

REPOSITORY = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPOSITORY))

from lwrlab.dynamics.base_parameters import compute_base_parameters  # noqa: E402
from lwrlab.io.logs import load_log  # noqa: E402
from lwrlab.model.description import build_robot, load_robot_yaml  # noqa: E402
from lwrlab.model.inertia import mass_com_inertia, perturb_consistent  # noqa: E402
from lwrlab.model.robot import RobotModel  # noqa: E402
from lwrlab.plants.core import Measurement  # noqa: E402
from lwrlab.plants.geared_arm import GearedArm, GearedRun, LuGreFriction, MotorSensors  # noqa: E402
from lwrlab.plants.planned_motions import (  # noqa: E402
    MultisinePath,
    PlannedMotion,
    PointToPoint,
    RestSchedule,
    WarpedMotion,
)

HALF_PI = float(np.pi / 2)


def _standard_to_modified(
    a: list[float], d: list[float], alpha: list[float]
) -> tuple[dict[str, list[float]], np.ndarray]:
    """Modified DH rows of a standard DH table, and the (N, 4, 4) poses of the standard frame i in
    the modified frame i (``Tx(a_i)·Rx(α_i)``), both attached to segment i."""
    n = len(a)
    poses = np.zeros((n, 4, 4))
    for i in range(n):
        c, s = np.cos(alpha[i]), np.sin(alpha[i])
        poses[i] = [[1, 0, 0, a[i]], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]]
    mdh = {"alpha": [0.0, *alpha[:-1]], "d": [0.0, *a[:-1]], "theta_offset": [0.0] * n, "r": list(d)}
    return mdh, poses


def _link_in_modified_frame(pose: np.ndarray, mass: float, com: list[float], inertia: list[float]) -> dict:
    """A segment given in the standard-DH frame, expressed in the modified-DH frame (``pose``)."""
    rotation = pose[:3, :3]
    xx, yy, zz, xy, xz, yz = inertia
    tensor = rotation @ np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]) @ rotation.T
    centre = pose[:3, 3] + rotation @ np.asarray(com)
    return {
        "mass": mass,
        "com": [round(float(c), 6) for c in centre],
        "inertia": [round(float(v), 7) for v in tensor[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]]],
    }


def ur_like_description() -> dict[str, Any]:
    """The UR5-like arm's description (modified DH, nominal inertials, drive block)."""
    a = [0.0, -0.425, -0.39225, 0.0, 0.0, 0.0]
    d = [0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823]
    alpha = [HALF_PI, 0.0, 0.0, HALF_PI, -HALF_PI, 0.0]
    mdh, poses = _standard_to_modified(a, d, alpha)
    # UR's published masses and centres of mass (standard-DH frames); cylinder estimates of the
    # tensors about the CoM (xx, yy, zz, xy, xz, yz, standard-DH axes); link 6 with a 0.8 kg gripper.
    links = [
        (3.7, [0.0, -0.02561, 0.00193], [0.0084, 0.0064, 0.0084, 0, 0, 0]),
        (8.393, [0.2125, 0.0, 0.11336], [0.0122, 0.1325, 0.1325, 0, 0, 0]),
        (2.33, [0.15, 0.0, 0.0265], [0.0019, 0.0308, 0.0308, 0, 0, 0]),
        (1.219, [0.0, -0.0018, 0.01634], [0.0020, 0.0013, 0.0020, 0, 0, 0]),
        (1.219, [0.0, 0.0018, 0.01634], [0.0020, 0.0013, 0.0020, 0, 0, 0]),
        (0.9879, [0.0, 0.0, 0.0484], [0.0026, 0.0026, 0.0012, 0, 0, 0]),
    ]
    return {
        "name": "ur_like",
        "source": "UR5 DH and masses/CoM (Universal Robots), cylinder inertias; benchmarks/geared_arms.py",
        "gravity": [0.0, 0.0, -9.81],
        "mdh": mdh,
        "flange": [0.0, 0.0, 0.0],
        "links": [_link_in_modified_frame(pose, *link) for pose, link in zip(poses, links, strict=True)],
        "limits": {
            "position_lower": [-6.2832, -6.2832, -3.1416, -6.2832, -6.2832, -6.2832],
            "position_upper": [6.2832, 6.2832, 3.1416, 6.2832, 6.2832, 6.2832],
            "velocity": [3.15, 3.15, 3.15, 3.2, 3.2, 3.2],
            "acceleration": [15.0, 15.0, 15.0, 25.0, 25.0, 25.0],
            "torque": [150.0, 150.0, 150.0, 28.0, 28.0, 28.0],
        },
        "friction": None,
        "friction_terms": ["coulomb", "viscous"],
        "rotor_inertia": None,
        "collision_spheres": None,
        "collision_urdf": None,
        "friction_law": None,
        "drive": {
            "gear_ratios": [100.0] * 6,
            "coupling": None,
            "torque_constants": [0.1] * 6,
            "position_side": "motor",
            "torque_side": "motor",
            "rotor_inertia": "auto",
        },
    }


WRIST_COUPLING = 0.3
"""C[5, 4] of the industrial arm: motor 6 turns by 0.3 × (its gear ratio) per radian of joint 5."""


def industrial_description() -> dict[str, Any]:
    """The IRB 120-like arm's description, with its coupled wrist."""
    return {
        "name": "industrial",
        "source": "ABB IRB 120-like DH, invented inertials; benchmarks/geared_arms.py",
        "gravity": [0.0, 0.0, -9.81],
        "mdh": {
            "alpha": [0.0, -HALF_PI, 0.0, -HALF_PI, HALF_PI, -HALF_PI],
            "d": [0.0, 0.0, 0.27, 0.07, 0.0, 0.0],
            "theta_offset": [0.0, -HALF_PI, 0.0, 0.0, 0.0, 0.0],
            "r": [0.29, 0.0, 0.0, 0.302, 0.0, 0.0],
        },
        "flange": [0.0, 0.0, 0.072],
        "links": [
            {"mass": 3.07, "com": [0.0, 0.0, -0.06], "inertia": [0.0142, 0.0144, 0.0104, 0, 0, 0]},
            {"mass": 3.91, "com": [0.135, 0.0, 0.02], "inertia": [0.0060, 0.0262, 0.0262, 0, 0, 0]},
            {"mass": 2.94, "com": [0.04, 0.05, 0.0], "inertia": [0.0125, 0.0110, 0.0095, 0, 0, 0]},
            {"mass": 1.33, "com": [0.0, 0.0, -0.12], "inertia": [0.0069, 0.0069, 0.0011, 0, 0, 0]},
            {"mass": 0.55, "com": [0.0, 0.02, 0.0], "inertia": [0.0007, 0.0005, 0.0007, 0, 0, 0]},
            {"mass": 0.6, "com": [0.0, 0.0, 0.06], "inertia": [0.0012, 0.0012, 0.0005, 0, 0, 0]},
        ],
        "limits": {
            "position_lower": [-2.87, -1.92, -1.92, -2.79, -2.09, -6.98],
            "position_upper": [2.87, 1.92, 1.22, 2.79, 2.09, 6.98],
            "velocity": [4.36, 4.36, 4.36, 5.58, 5.58, 7.33],
            "acceleration": [20.0, 20.0, 20.0, 30.0, 30.0, 40.0],
            "torque": [80.0, 80.0, 40.0, 10.0, 10.0, 8.0],
        },
        "friction": None,
        "friction_terms": ["coulomb", "viscous"],
        "rotor_inertia": None,
        "collision_spheres": None,
        "collision_urdf": None,
        "friction_law": None,
        "drive": {
            "gear_ratios": [48.0, 48.0, 40.0, 36.0, 32.0, 32.0],
            "coupling": [[6, 5, WRIST_COUPLING]],
            "torque_constants": None,
            "position_side": "motor",
            "torque_side": "motor",
            "rotor_inertia": "auto",
        },
    }


@dataclass(frozen=True)
class ArmSpec:
    """One arm: its description, the truth of its drives and sensors, and how it is moved."""

    name: str
    description: dict[str, Any]
    motor_inertia: np.ndarray
    """(6,) true rotor inertias at the motors (kg·m²)."""
    coulomb: np.ndarray
    """(6,) joint-side Coulomb level of each drive without load (N·m)."""
    viscous: np.ndarray
    """(6,) joint-side viscous friction of each drive (N·m·s/rad)."""
    sensors: MotorSensors
    center: np.ndarray
    """(6,) posture the motions move about (rad)."""
    reach: np.ndarray
    """(6,) largest excursion from ``center`` (rad)."""
    speed: np.ndarray
    """(6,) largest joint speed of the motions (rad/s)."""
    acceleration: np.ndarray
    """(6,) largest joint acceleration of the multisines (rad/s²)."""
    log_format: str = "csv"
    friction_settings: dict[str, float] = field(
        default_factory=lambda: {
            "stribeck_rise": 0.4,
            "stribeck_speed": 0.1,  # rad/s, joint side: between lwrlab's Stribeck grid points
            "load_factor": 0.05,  # Coulomb level + 5 % of the gravity torque the motor holds
            "presliding": 2e-4,  # rad, joint side
            "damping_share": 0.2,
        }
    )


ARMS: dict[str, ArmSpec] = {
    "ur_like": ArmSpec(
        "ur_like",
        ur_like_description(),
        motor_inertia=np.array([3.5e-5, 3.5e-5, 2.0e-5, 9e-6, 9e-6, 9e-6]),  # IA = 0.35 … 0.09 kg·m²
        coulomb=np.array([6.0, 6.0, 4.0, 1.5, 1.5, 1.5]),
        viscous=np.array([6.0, 6.0, 4.0, 1.0, 1.0, 1.0]),
        sensors=MotorSensors(
            effort_noise=np.array([0.03, 0.03, 0.03, 0.01, 0.01, 0.01]),  # A
            effort_offset=np.array([0.02, -0.03, 0.015, 0.01, -0.01, 0.008]),  # A
        ),
        center=np.array([0.0, -1.2, 1.2, -1.6, -1.57, 0.0]),
        reach=np.array([1.2, 0.6, 0.8, 1.0, 1.0, 1.5]),
        speed=np.array([1.5, 1.2, 1.5, 2.0, 2.0, 2.5]),
        acceleration=np.array([8.0, 6.0, 8.0, 12.0, 12.0, 15.0]),
        log_format="parquet",
    ),
    "industrial": ArmSpec(
        "industrial",
        industrial_description(),
        motor_inertia=np.array([1.2e-4, 1.2e-4, 6e-5, 2.5e-5, 2.5e-5, 2.5e-5]),  # IA = 0.28 … 0.026
        coulomb=np.array([4.0, 4.0, 2.5, 0.8, 0.8, 0.5]),
        viscous=np.array([5.0, 5.0, 3.0, 0.6, 0.6, 0.4]),
        sensors=MotorSensors(
            effort_noise=np.array([0.004, 0.004, 0.003, 0.0012, 0.001, 0.001]),  # N·m at the motor
            effort_offset=np.array([0.01, -0.008, 0.005, 0.002, -0.002, 0.001]),  # N·m at the motor
        ),
        center=np.array([0.0, 0.2, 0.1, 0.0, 0.6, 0.0]),
        reach=np.array([1.2, 0.6, 0.6, 1.2, 0.8, 1.5]),
        speed=np.array([1.5, 1.2, 1.5, 2.5, 2.5, 3.0]),
        acceleration=np.array([8.0, 6.0, 8.0, 15.0, 15.0, 20.0]),
    ),
}
"""The two arms."""

DATASHEET_ROTOR_SHARE = 0.8
"""The description's rotor inertias are this share of the truth (a datasheet leaves the gear out)."""


def true_robot(nominal: RobotModel, rng: np.random.Generator, spread: float = 0.1) -> RobotModel:
    """The nominal robot with every segment perturbed by about ``spread`` (physically consistent)."""
    links = np.stack([perturb_consistent(phi, spread, rng) for phi in nominal.link_parameters])
    return nominal.with_parameters(links.ravel())


def geared_arm(spec: ArmSpec, seed: int = 0) -> tuple[RobotModel, GearedArm]:
    """The nominal robot (what the user describes) and the simulated true arm."""
    nominal = build_robot(**spec.description)
    truth = true_robot(nominal, np.random.default_rng(seed))
    settings = spec.friction_settings
    friction = LuGreFriction.from_joint_side(
        truth.drive_train,
        spec.coulomb,
        spec.viscous,
        stribeck_rise=settings["stribeck_rise"],
        stribeck_speed=np.full(6, settings["stribeck_speed"]),
        load_factor=settings["load_factor"],
        presliding=settings["presliding"],
        damping_share=settings["damping_share"],
    )
    return nominal, GearedArm(truth, spec.motor_inertia, friction, spec.sensors)


def motions(spec: ArmSpec, rng: np.random.Generator) -> dict[str, PlannedMotion]:
    """The fit motion and the two validation motions of ``spec``."""
    fit_schedule = RestSchedule(
        (
            ("rest", 1.0),
            ("up", 0.4),
            ("move", 12.0),
            ("down", 0.4),
            ("rest", 2.0),
            ("up", 0.4),
            ("move", 12.0),
            ("down", 0.4),
            ("rest", 1.5),
        )
    )
    bounds = (spec.reach, spec.speed, spec.acceleration)
    fit = MultisinePath.random(
        spec.center, [0.1, 0.2, 0.3, 0.5, 0.7, 0.9, 1.2], *bounds, fit_schedule.path_length, rng
    )
    other_schedule = RestSchedule((("rest", 0.5), ("up", 0.4), ("move", 16.0), ("down", 0.4), ("rest", 1.5)))
    other = MultisinePath.random(
        spec.center, [0.13, 0.29, 0.41, 0.61, 0.83, 1.1], *bounds, other_schedule.path_length, rng
    )
    waypoints = spec.center + rng.uniform(-0.8, 0.8, size=(8, 6)) * spec.reach
    waypoints[0] = spec.center
    dwells = rng.uniform(0.6, 1.2, size=8)
    dwells[-1] = 1.5
    return {
        "fit": WarpedMotion(fit, fit_schedule),
        "val_multisine": WarpedMotion(other, other_schedule),
        "val_p2p": PointToPoint.within(waypoints, spec.speed, spec.acceleration, dwells, 0.8),
    }


@dataclass
class ArmLogs:
    """One arm's files and the simulated runs behind them."""

    spec: ArmSpec
    nominal: RobotModel
    arm: GearedArm
    description: Path
    runs: dict[str, GearedRun]
    paths: dict[str, Path]

    @property
    def fit_paths(self) -> list[Path]:
        """The identification log."""
        return [self.paths["fit"]]

    @property
    def validation_paths(self) -> list[Path]:
        """The validation logs."""
        return [p for name, p in self.paths.items() if name != "fit"]

    @property
    def lugre(self) -> LuGreFriction:
        """The arm's friction (every arm here has LuGre friction)."""
        assert self.arm.friction is not None
        return self.arm.friction


def _yaml_ready(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {k: _yaml_ready(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_yaml_ready(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.floating):
        return float(value)
    return value


def truth_mapping(logs: ArmLogs) -> dict[str, Any]:
    """The true values (segments, drives, friction) as a YAML-ready mapping."""
    arm = logs.arm
    segments = []
    for phi in arm.robot.link_parameters:
        mass, com, inertia = mass_com_inertia(phi)
        segments.append(
            {
                "mass": float(mass),
                "com": com.tolist(),
                "inertia": inertia[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]].tolist(),
            }
        )
    lugre = {k: getattr(logs.lugre, k).tolist() for k in logs.lugre.__dataclass_fields__}
    return _yaml_ready(
        {
            "links": segments,
            "motor_inertia": arm.motor_inertia,
            "reflected_rotor_inertia": arm.reflected_inertia,
            "lugre_motor_side": lugre,
            "sensors": {
                "effort": "current (A)" if arm.drive.torque_constants is not None else "motor torque (N·m)",
                "effort_noise": arm.sensors.effort_noise,
                "effort_offset": arm.sensors.effort_offset,
                "encoder_counts": arm.sensors.encoder_counts,
                "encoder_noise_counts": arm.sensors.encoder_noise_counts,
            },
        }
    )


def write_arm(folder: Path, spec: ArmSpec, seed: int = 0) -> ArmLogs:
    """Simulate ``spec``'s motions and write its description, logs and truth into ``folder/<name>``."""
    target = folder / spec.name
    target.mkdir(parents=True, exist_ok=True)
    nominal, arm = geared_arm(spec, seed)
    description = dict(spec.description)
    description["rotor_inertia"] = (DATASHEET_ROTOR_SHARE * arm.reflected_inertia).round(4).tolist()
    description_path = target / f"{spec.name}.yaml"
    description_path.write_text(yaml.safe_dump(_yaml_ready(description), sort_keys=False))
    nominal = load_robot_yaml(description_path)
    rng = np.random.default_rng(seed + 1)
    runs, paths = {}, {}
    for name, motion in motions(spec, rng).items():
        run = arm.play(motion, rng)
        path = target / f"{name}.{spec.log_format}"
        frame = run.log_frame()
        if spec.log_format == "parquet":
            frame.to_parquet(path, index=False)
        else:
            frame.to_csv(path, index=False, float_format="%.17g")
        runs[name], paths[name] = run, path
    logs = ArmLogs(spec, nominal, arm, description_path, runs, paths)
    (target / "truth.yaml").write_text(yaml.safe_dump(truth_mapping(logs), sort_keys=False))
    return logs


def write_arms(folder: Path, seed: int = 0) -> dict[str, ArmLogs]:
    """Both arms' logs in ``folder``."""
    return {name: write_arm(folder, spec, seed) for name, spec in ARMS.items()}


def measurements(logs: ArmLogs, names: list[str]) -> list[Measurement]:
    """Logs read as lwrlab reads them (motor side → joint side), as measurements."""
    robot = logs.nominal
    return [
        load_log(logs.paths[n], robot.n_joints, limits=robot.limits, drive=robot.drive).to_measurement()
        for n in names
    ]


def splits(
    folder: Path, seed: int = 0
) -> list[tuple[str, str, RobotModel, list[Measurement], list[Measurement]]]:
    """The model study's splits: each arm's fit log → each validation log (data, split, robot, fit,
    validation)."""
    out = []
    for name, logs in write_arms(folder, seed).items():
        fit = measurements(logs, ["fit"])
        for validation in ("val_multisine", "val_p2p"):
            out.append(
                (
                    f"geared {name}",
                    f"fit → {validation.removeprefix('val_')}",
                    logs.nominal,
                    fit,
                    measurements(logs, [validation]),
                )
            )
    return out


def compose(*overrides: str) -> Any:
    """The repository's config composed with ``overrides``, as the command line composes it."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir

    import lwrlab.conf  # noqa: F401  (registers the schemas the config tree links)

    with initialize_config_dir(config_dir=str(REPOSITORY / "conf"), version_base="1.3"):
        return hydra_compose("config", overrides=list(overrides))


def command_line(logs: ArmLogs, *extra: str) -> list[str]:
    """The overrides of ``lwrlab task=identification plant=log`` for these logs."""
    return [
        "task=identification",
        "plant=log",
        "robot=mdh_file",
        f"robot.path={logs.description}",
        f"data.paths=[{','.join(str(p) for p in logs.fit_paths)}]",
        f"data.validation_paths=[{','.join(str(p) for p in logs.validation_paths)}]",
        "tracking=none",
        *extra,
    ]


def true_drive_values(logs: ArmLogs, robot: RobotModel) -> np.ndarray:
    """The truth in ``robot``'s standard layout (its friction law and terms): the true segments; the
    drives' terms as far as the regressor has them (joint side, per drive):

    - ``rotor``: n²·I_m (exact);
    - ``viscous``: n²·σ2 (exact in sliding; LuGre's σ1 adds a transient viscous part);
    - ``coulomb``: n·(Fc0 + μ·mean load over the fit's moving samples) — LuGre's level varies with
      the load, so no constant is *the* truth: a comparison, not a check;
    - ``offset``: the sensors' offset through the gears (exact);
    - a law's own terms (Stribeck, asymmetry): ``stribeck`` n·(Fs0 − Fc0), others 0.
    """
    arm, lugre, run = logs.arm, logs.lugre, logs.runs["fit"]
    n = arm.drive.gear_ratios
    moving = ~run.at_rest
    load = np.abs(arm.gravity_load(run.q[moving])).mean(axis=0)
    offset = arm.sensors.effort_offset * (
        arm.drive.torque_constants if arm.drive.torque_constants is not None else 1
    )
    values = {
        "coulomb": n * (lugre.coulomb + lugre.load_factor * load),
        "viscous": n**2 * lugre.viscous,
        "offset": n * offset,
        "rotor": arm.reflected_inertia,
        "stribeck": n * (lugre.stribeck - lugre.coulomb),
    }
    friction = np.concatenate([values.get(term, np.zeros(6)) for term in robot.friction_terms])
    return np.concatenate([arm.robot.link_parameters.ravel(), friction])


def figures(logs: ArmLogs, report: Any) -> dict[str, Any]:
    """Held-out error (all rows, moving rows, rest rows), noise floor, rest rows per joint, friction
    choice and drive parameters of one report.

    On the validation logs' scored samples (joint side): ``noise floor`` is ‖noise‖/‖τ‖ (the sensors'
    noise through the gears, offset removed: what perfect knowledge leaves); ``sliding floor`` is
    ‖τ − τ_sliding‖/‖τ‖ with the true arm's friction replaced by its steady-sliding curve (the best a
    model without friction state can do, offsets known); ``moving`` and ``rest`` split the error
    ‖τ − τ̂‖/‖τ‖ into the rows where the plan moves and where it holds still (their squares add up).
    """
    row: dict[str, Any] = {"validation %": 100 * report.metrics["validation_rel_error"]}
    sums: dict[str, list[Any]] = {key: [] for key in ("floor", "sliding", "sliding moving", "moving", "rest")}
    rest_errors, rest_noise, hold_friction = [], [], []
    for prediction in report.validation_predictions:
        run = logs.runs[prediction.name]
        index = np.rint(prediction.t * logs.arm.rate_hz).astype(int)
        measured = run.measured_joint_torque()[index]
        error = run.drive.joint_torques(run.measured_motor_torque()[index] - run.motor_torque[index])
        offset = error.mean(axis=0)  # the sensors' offset through the gears
        noise = error - offset
        sliding = logs.arm.sliding_joint_torque(run)[index] + offset
        scored = prediction.scored
        rest = scored & run.at_rest[index]
        moving = scored & ~run.at_rest[index]
        residual = prediction.measured - prediction.predicted
        scale = np.linalg.norm(measured[scored])
        sums["floor"].append(np.linalg.norm(noise[scored]) / scale)
        sums["sliding"].append(np.linalg.norm((measured - sliding)[scored]) / scale)
        sums["sliding moving"].append(np.linalg.norm((measured - sliding)[moving]) / scale)
        sums["moving"].append(np.linalg.norm(residual[moving]) / scale)
        sums["rest"].append(np.linalg.norm(residual[rest]) / scale)
        row[f"validation {prediction.name} %"] = 100 * prediction.relative_error
        if rest.any():
            rest_errors.append(np.sqrt(np.mean(residual[rest] ** 2, axis=0)))
            rest_noise.append(noise[rest].std(axis=0))
            held = run.drive.joint_torques(run.friction_motor[index][rest])
            hold_friction.append(np.sqrt(np.mean(held**2, axis=0)))
    row["noise floor %"] = 100 * float(np.mean(sums["floor"]))
    row["sliding floor %"] = 100 * float(np.mean(sums["sliding"]))
    row["sliding floor, moving rows %"] = 100 * float(np.mean(sums["sliding moving"]))
    row["moving rows %"] = 100 * float(np.mean(sums["moving"]))
    row["rest rows %"] = 100 * float(np.mean(sums["rest"]))
    row["rest RMS error N·m"] = np.round(np.mean(rest_errors, axis=0), 3).tolist()
    row["rest noise σ N·m"] = np.round(np.mean(rest_noise, axis=0), 3).tolist()
    row["hold friction RMS N·m"] = np.round(np.mean(hold_friction, axis=0), 3).tolist()
    choice = report.friction_choice
    row["friction"] = choice.candidate.label if choice is not None else report.robot.friction_law.name
    robot = report.robot
    base = compute_base_parameters(robot)
    truth = pd.Series(base.base_values(true_drive_values(logs, robot)), index=base.names)
    table = report.parameters
    compared = [
        name
        for name in table.index
        if name.startswith("IA") or (name.startswith(("FC", "FV", "FS", "FO")) and name.endswith("6"))
    ]
    for name in compared:
        estimate, std = table.loc[name, "estimate"], table.loc[name, "std"]
        sigmas = (estimate - truth[name]) / std if std > 0 else np.inf
        row[name] = f"{estimate:.4g} ± {std:.2g} (truth {truth[name]:.4g}, {sigmas:+.1f}σ)"
    return row


VARIANTS = {
    "defaults (friction=auto, sdp)": (),
    "friction=sign (former)": ("friction=sign",),
    "auto, rotor_inertia=false": ("robot.drive.rotor_inertia=false",),
    "sign, rotor_inertia=true": ("friction=sign", "robot.drive.rotor_inertia=true"),
}
"""The identifications compared per arm: extra overrides of the command line."""


def _robot_override(logs: ArmLogs, folder: Path, extra: tuple[str, ...]) -> tuple[Path, tuple[str, ...]]:
    """``robot.drive.rotor_inertia=…`` as a description file: with ``robot=mdh_file`` the command line
    cannot override one key of the file's ``drive`` block (see the report)."""
    rest = tuple(e for e in extra if not e.startswith("robot.drive."))
    if len(rest) == len(extra):
        return logs.description, extra
    description = yaml.safe_load(logs.description.read_text())
    for entry in extra:
        if entry.startswith("robot.drive."):
            key, value = entry.removeprefix("robot.drive.").split("=")
            description["drive"][key] = yaml.safe_load(value)
    path = folder / f"{logs.spec.name}_{'_'.join(e.replace('=', '-').replace('.', '-') for e in extra)}.yaml"
    path.write_text(yaml.safe_dump(description, sort_keys=False))
    return path, rest


def identify(logs: ArmLogs, folder: Path, extra: tuple[str, ...] = ()) -> Any:
    """lwrlab's identification of ``logs`` with the command line's config (plus ``extra``)."""
    from lwrlab.pipeline.identification import identify_configured

    description, rest = _robot_override(logs, folder, extra)
    cfg = compose(*command_line(replace(logs, description=description), *rest))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return identify_configured(cfg)


def run_command_line(logs: ArmLogs, folder: Path) -> str:
    """``lwrlab task=identification plant=log …`` on the arm's logs; its printed report."""
    command = [
        str(REPOSITORY / ".venv" / "bin" / "lwrlab"),
        *command_line(logs, f"hydra.run.dir={folder / ('cli_' + logs.spec.name)}"),
    ]
    done = subprocess.run(command, capture_output=True, text=True, check=False, cwd=folder)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed:\n{done.stderr[-3000:]}")
    return done.stdout


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--folder", type=Path, default=None, help="where to write the logs (default: temporary)"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cli", action="store_true", help="also run the command line once per arm")
    parser.add_argument("--arms", nargs="*", default=list(ARMS))
    parser.add_argument(
        "--logs-only", action="store_true", help="write the arms' descriptions and logs, identify nothing"
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as temporary:
        folder = args.folder or Path(temporary)
        folder.mkdir(parents=True, exist_ok=True)
        rows = []
        for name in args.arms:
            started = time.perf_counter()
            logs = write_arm(folder, ARMS[name], args.seed)
            print(
                f"{name}: logs in {logs.description.parent} ({time.perf_counter() - started:.1f} s)",
                flush=True,
            )
            if args.logs_only:
                continue
            if args.cli:
                started = time.perf_counter()
                printed = run_command_line(logs, folder)
                print(f"command line ({time.perf_counter() - started:.0f} s):\n{printed[-2500:]}", flush=True)
            for variant, extra in VARIANTS.items():
                started = time.perf_counter()
                report = identify(logs, folder, extra)
                row = {"arm": name, "variant": variant} | figures(logs, report)
                row["s"] = round(time.perf_counter() - started, 1)
                rows.append(row)
                print("\n".join(f"  {k}: {v}" for k, v in row.items()), flush=True)
                if report.friction_choice is not None:
                    print(report.friction_choice.table().to_string(), flush=True)
        if rows:
            table = pd.DataFrame(rows)
            print(
                table[["arm", "variant", "validation %", "noise floor %", "friction"]].to_markdown(
                    index=False
                )
            )


if __name__ == "__main__":
    main()
