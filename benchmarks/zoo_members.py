"""The zoo's members: arms nobody here described, each with a known truth, as data, built by seed.

Every member is an arm of ``example-robot-data`` (``robot=example_robot``: Panda, UR3/5/10, xArm7,
Z1, Kinova Gen2) or TIAGo's arm (its URDF with the base, torso and head locked), with

- a **truth** (:class:`Truth`): its rigid bodies are the description's, every segment perturbed by
  10 % (physically consistent, seeded); the engine and the friction differ from member to member:

  - ``mujoco``: rigid bodies integrated by MuJoCo (:class:`lwrlab.plants.pushed_arm.PushedArm`,
    not our dynamics) under joint PD and the description's feed-forward, with the paper's sign law
    (``FC·sign(q̇) + FV·q̇`` as a generalised force, ``sign`` regularised over 5 mrad/s) or MuJoCo's own
    joint friction (``frictionloss``, ``damping``) and ``armature``;
  - ``geared``: the plan played exactly through gears (:class:`lwrlab.plants.geared_arm.GearedArm`):
    LuGre at the motors with a Coulomb level growing with the load, or a memoryless law at the motors
    (:mod:`lwrlab.plants.static_friction`: Stribeck, direction-asymmetric, sign + viscous), rotor
    inertias, and optionally a coupled wrist;

- **sensors** (:class:`Sensors`) as robots have them: joint torque sensors with offset and noise and
  quantised joint encoders, or motor encoders (counts per turn) and currents (or motor torques)
  through the gears and torque constants; 100 Hz to 1 kHz; jittered stamps;
- **motions** (:func:`member_motions`): the product's optimal 10 s exciting motion (``trajectory=
  optimal``, every constraint) played there and back with rests (``fit``), and the same at 0.6 × its
  speed (``fit_slow``): the two fit logs; then new motions: ``faster`` and ``slower`` multi-sines,
  ``p2p`` point-to-point moves with rests, and ``rest``: the arm standing at three postures, pushed
  by hand (known contacts).

Every log comes with its truth: the noise-free reading of the sensors (the true joint torque plus the
sensors' constant offset, which the model's offset columns are meant to predict; no noise, no
quantisation) at every logged sample, and the true external torque ``−J_pᵀ·F`` of the pushes.

:func:`build_member` writes a member's logs, truths and description into a cache folder (seeded: a
second call reads them back); ``member.overrides(logs)`` are the command line's overrides that
identify it (``lwrlab task=identification plant=log …``).
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pinocchio as pin

REPOSITORY = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPOSITORY))

from lwrlab.model.inertia import perturb_consistent  # noqa: E402
from lwrlab.model.robot import RobotModel  # noqa: E402
from lwrlab.plants.geared_arm import GearedArm, LuGreFriction, MotorSensors  # noqa: E402
from lwrlab.plants.planned_motions import (  # noqa: E402
    MultisinePath,
    PlannedMotion,
    PointToPoint,
    RestSchedule,
    WarpedMotion,
)
from lwrlab.plants.pushed_arm import ExternalForce, PushedArm, random_forces  # noqa: E402
from lwrlab.plants.static_friction import StaticFriction  # noqa: E402
from lwrlab.trajectory.core import Trajectory  # noqa: E402

ZOO_VERSION = 4
"""Bumped whenever what a member's logs hold changes: the cache keeps one folder per version."""
CACHE = REPOSITORY / "outputs" / "zoo"
"""Where built members are kept (``outputs/`` is git-ignored)."""
CONTROL_RATE_HZ = 1000.0
"""MuJoCo members: the controller's rate (the logs are decimated from it)."""
DEFAULT_ACCELERATION = 10.0
"""rad/s² where the manufacturer publishes none (the exciting motion needs a limit)."""
TIAGO_URDF = "tiago_description/robots/tiago_no_hand.urdf"
TIAGO_LOCKED = ("wheel_right_joint", "wheel_left_joint", "torso_lift_joint", "head_1_joint", "head_2_joint")
LOG_NAMES = ("fit", "fit_slow", "faster", "slower", "p2p", "rest")
"""Every member's logs: two fit logs, three new motions, and the arm pushed at rest."""
FIT = ("fit", "fit_slow")
"""The logs a member is identified from."""
NEW_MOTIONS = ("faster", "slower", "p2p")
"""The new motions a model is judged on (contact-free)."""


@dataclass(frozen=True)
class Truth:
    """How a member's arm really behaves."""

    engine: str
    """``mujoco`` (rigid bodies in MuJoCo under PD control) or ``geared`` (the plan played through gears)."""
    law: str
    """``sign`` (the paper's), ``mujoco`` (MuJoCo's frictionloss and damping), ``lugre``, ``stribeck``,
    ``asymmetric``."""
    coulomb_share: float = 0.04
    """Each joint's Coulomb level (no load), as a share of its torque scale (:func:`torque_scale`)."""
    viscous_share: float = 0.03
    """Each joint's viscous friction (N·m·s/rad) as a share of its torque scale (per rad/s)."""
    load_factor: float = 0.0
    """μ: the Coulomb level grows by μ·|gravity torque| the drive holds."""
    stribeck_rise: float = 0.0
    """Static level over the Coulomb level, less one (Stribeck, LuGre)."""
    stribeck_speed: float = 0.1
    """Joint-side speed over which the Stribeck excess fades (rad/s)."""
    asymmetry: float = 0.0
    """α: the Coulomb level is (1 ± α)·FC by direction."""
    gear_ratio: float = 100.0
    """Geared members: every drive's gear ratio."""
    coupling: tuple[tuple[int, int, float], ...] = ()
    """Geared members: ``(motor, joint, factor)`` entries of the coupling (1-based), e.g. a wrist."""
    rotor_share: float = 0.004
    """Reflected rotor inertia (kg·m²) per N·m of the joint's torque scale."""
    sign_width: float = 5e-3
    """MuJoCo members' sign law: ``sign(q̇)`` as ``tanh(q̇/ε)`` with this ε (rad/s), the narrowest the
    integration (0.5 ms steps) holds without chattering at rest on a light wrist."""


@dataclass(frozen=True)
class Sensors:
    """What the member's robot measures, and how its logs are written."""

    side: str
    """``joint`` (torque sensors, joint encoders) or ``motor`` (encoders and efforts at the motors)."""
    rate_hz: float
    noise_share: float
    """σ of the torque noise as a share of each joint's torque scale (joint side)."""
    offset_share: float
    """Constant offsets (random sign) as a share of each joint's torque scale."""
    jitter: float = 0.0
    """σ of the stamps' jitter as a share of the period (clipped at 0.4 periods)."""
    effort: str = "current"
    """Motor side: ``current`` (A, torque constants 0.1 N·m/A) or ``tau`` (motor torques)."""
    encoder_resolution: float = 1e-5
    """Joint side: quantisation of the positions (rad)."""
    encoder_noise: float = 1.0 / 3.0
    """Joint side: σ of the noise before quantisation, as a share of the resolution."""
    encoder_counts: int = 2**17
    """Motor side: encoder counts per motor turn."""
    log_format: str = "parquet"
    """``parquet``, ``csv`` or ``npz``."""


@dataclass(frozen=True)
class Member:
    """One arm of the zoo."""

    name: str
    robot: str
    """An ``example-robot-data`` arm of ``robot=example_robot``, or ``tiago``."""
    truth: Truth
    sensors: Sensors
    note: str = ""
    """What is special about it, in words."""
    contact_links: int = 3
    """The last ``contact_links`` links are pushed."""
    motion_constraints: tuple[tuple[str, Any], ...] = ()
    """Settings of the exciting motion's constraints that differ from the shipped ones."""

    @property
    def geared(self) -> bool:
        """Whether its logs are measured at the motors through gears."""
        return self.sensors.side == "motor"


MEMBERS: dict[str, Member] = {
    m.name: m
    for m in (
        Member(
            "panda_sign",
            "panda",
            Truth("mujoco", "sign", coulomb_share=0.03, viscous_share=0.03, rotor_share=0.003),
            Sensors("joint", 1000.0, noise_share=0.004, offset_share=0.01, encoder_resolution=2e-5),
            "the paper's own law in MuJoCo: sign Coulomb + viscous, joint torque sensors at 1 kHz",
        ),
        Member(
            "ur5_mujoco",
            "ur5",
            Truth("mujoco", "mujoco", coulomb_share=0.04, viscous_share=0.04, rotor_share=0.004),
            Sensors("joint", 500.0, noise_share=0.005, offset_share=0.01, jitter=0.1, log_format="csv"),
            "MuJoCo's own dry friction (soft constraint), damping and armature; 500 Hz, jittered stamps",
        ),
        Member(
            "ur10_lugre",
            "ur10",
            Truth(
                "geared", "lugre", coulomb_share=0.05, viscous_share=0.05, load_factor=0.05, stribeck_rise=0.4
            ),
            Sensors("motor", 500.0, noise_share=0.006, offset_share=0.01),
            "LuGre at the motors, Coulomb growing with the load; currents and encoders at the motors",
        ),
        Member(
            "ur3_coupled",
            "ur3",
            Truth(
                "geared",
                "lugre",
                coulomb_share=0.05,
                viscous_share=0.04,
                stribeck_rise=0.3,
                coupling=((6, 5, 0.3),),
                gear_ratio=80.0,
            ),
            Sensors("motor", 500.0, noise_share=0.005, offset_share=0.01, effort="tau", log_format="csv"),
            "a coupled wrist (motor 6 turns with joint 5), LuGre; motor torques at the motors",
        ),
        Member(
            "kinova_stribeck",
            "kinova",
            Truth(
                "geared",
                "stribeck",
                coulomb_share=0.05,
                viscous_share=0.08,
                stribeck_rise=0.6,
                stribeck_speed=0.05,
            ),
            Sensors("motor", 250.0, noise_share=0.006, offset_share=0.01),
            "Stribeck friction at the motors, slow joints; currents at 250 Hz",
        ),
        Member(
            "xarm7_asymmetric",
            "xarm7",
            Truth(
                "geared",
                "asymmetric",
                coulomb_share=0.05,
                viscous_share=0.04,
                asymmetry=0.3,
                gear_ratio=101.0,
            ),
            Sensors("motor", 250.0, noise_share=0.006, offset_share=0.01, jitter=0.05),
            "friction 30 % stronger one way than the other; currents at 250 Hz, jittered stamps",
        ),
        Member(
            "z1_sign",
            "z1",
            Truth("geared", "sign", coulomb_share=0.05, viscous_share=0.05, gear_ratio=50.0),
            Sensors("motor", 100.0, noise_share=0.008, offset_share=0.01, effort="tau", log_format="npz"),
            "sign + viscous at the motors; motor torques logged at 100 Hz",
        ),
        Member(
            "tiago_load",
            "tiago",
            Truth(
                "geared",
                "stribeck",
                coulomb_share=0.06,
                viscous_share=0.05,
                load_factor=0.1,
                stribeck_rise=0.2,
            ),
            Sensors("motor", 100.0, noise_share=0.008, offset_share=0.01, jitter=0.1),
            "a mobile manipulator's arm (placeholder-looking inertials): Coulomb growing with the load; "
            "currents at 100 Hz, jittered stamps (its exciting motion without self-collision "
            "constraints: no SRDF ships with it, and the middle of its joint ranges meets the torso)",
            motion_constraints=(("self_collision", False),),
        ),
        Member(
            "xarm7_sensed",
            "xarm7",
            Truth("mujoco", "sign", coulomb_share=0.02, viscous_share=0.02, rotor_share=0.003),
            Sensors("joint", 1000.0, noise_share=0.01, offset_share=0.01, encoder_resolution=1e-4),
            "the paper's law again, noisier torque sensors (1 %) and coarse encoders",
        ),
        Member(
            "panda_paper",
            "panda",
            Truth("mujoco", "sign", coulomb_share=0.03, viscous_share=0.03, rotor_share=0.003),
            Sensors("joint", 1000.0, noise_share=0.004, offset_share=0.01, encoder_noise=0.0),
            "the paper's law in MuJoCo seen by clean encoders (quantised, no noise: a joint at rest "
            "reads zero speed), torque sensors at 1 kHz",
        ),
    )
}
"""The zoo, by name."""


def nominal_robot(member: Member) -> RobotModel:
    """The arm as its user describes it (the URDF's inertials, no friction, the drive block)."""
    from lwrlab.pipeline.build import build

    settings = robot_settings(member)
    kind = settings.pop("robot")
    return build("robot", kind, **settings)


def robot_settings(member: Member) -> dict[str, Any]:
    """``robot=…`` and its settings, as the command line gives them."""
    settings: dict[str, Any] = {}
    if member.robot == "tiago":
        from plugins.robots.example_robot import example_robot_file

        settings |= {
            "robot": "urdf",
            "path": example_robot_file(TIAGO_URDF),
            "locked_joints": list(TIAGO_LOCKED),
            "flange_frame": "arm_7_link",
            "missing_meshes": "drop",
            "acceleration_limits": DEFAULT_ACCELERATION,
        }
    else:
        from plugins.robots.example_robot import ROBOTS

        known = ROBOTS[member.robot].acceleration_limits is not None
        settings |= {"robot": "example_robot", "robot_name": member.robot}
        settings |= {} if known else {"acceleration_limits": DEFAULT_ACCELERATION}
    if member.geared:
        truth = member.truth
        drive: dict[str, Any] = {
            "gear_ratios": truth.gear_ratio,
            "position_side": "motor",
            "torque_side": "motor",
            "rotor_inertia": "auto",
        }
        if truth.coupling:
            drive["coupling"] = [list(entry) for entry in truth.coupling]
        if member.sensors.effort == "current":
            drive["torque_constants"] = TORQUE_CONSTANT
        settings["drive"] = drive
    return settings


TORQUE_CONSTANT = 0.1
"""N·m/A of every current-measured motor."""


def torque_scale(robot: RobotModel, rng: np.random.Generator, postures: int = 64) -> np.ndarray:
    """(N_J,) each joint's torque scale (N·m): its largest gravity torque over random postures inside
    the limits, at least 5 % of the largest joint's (a wrist's friction is not zero because gravity
    barely loads it)."""
    lower = np.where(np.isfinite(robot.limits.position_lower), robot.limits.position_lower, -np.pi)
    upper = np.where(np.isfinite(robot.limits.position_upper), robot.limits.position_upper, np.pi)
    data = robot.model.createData()
    gravity = np.array(
        [pin.computeGeneralizedGravity(robot.model, data, rng.uniform(lower, upper)) for _ in range(postures)]
    )
    peak = np.abs(gravity).max(axis=0)
    return np.maximum(peak, 0.05 * peak.max())


@dataclass
class MemberLogs:
    """A built member: where its files are, and what they were made from."""

    member: Member
    seed: int
    folder: Path
    scale: np.ndarray
    """(N_J,) the joints' torque scales (N·m)."""
    paths: dict[str, Path] = field(default_factory=dict)
    """Each log by name (:data:`LOG_NAMES`)."""

    def truth(self, name: str) -> pd.DataFrame:
        """``t`` and the noise-free joint-side readings ``tau1…`` (with offsets), the external torques
        ``tau_ext1…`` and the true joint states ``q1…``, ``dq1…``, ``ddq1…`` of log ``name``, one row
        per logged row."""
        return pd.read_parquet(self.folder / f"{name}_truth.parquet")

    @property
    def contacts(self) -> pd.DataFrame:
        """The pushes of the ``rest`` log (:func:`lwrlab.plants.pushed_arm.forces_frame`)."""
        return pd.read_csv(self.folder / "rest_contacts.csv")

    @property
    def noise_std(self) -> np.ndarray:
        """(N_J,) the torque noise σ (joint side, N·m)."""
        return self.member.sensors.noise_share * self.scale

    def overrides(self, fit: tuple[str, ...] = FIT, validation: tuple[str, ...] = NEW_MOTIONS) -> list[str]:
        """``lwrlab task=identification plant=log`` overrides identifying this member."""
        settings = robot_settings(self.member)
        out = [f"robot={settings.pop('robot')}"]
        out += [f"robot.{key}={_override_value(value)}" for key, value in settings.items()]
        out += [
            "task=identification",
            "plant=log",
            "tracking=none",
            f"data.paths=[{','.join(str(self.paths[n]) for n in fit)}]",
            f"data.validation_paths=[{','.join(str(self.paths[n]) for n in validation)}]",
        ]
        if self.member.sensors.log_format == "npz":
            out.append("data.column_map={t: t, q: q, tau: tau}")
        return out


def _override_value(value: Any) -> str:
    """A value as a Hydra override writes it (flow-style YAML)."""
    if isinstance(value, str):
        return value
    return json.dumps(value).replace('"', "")


def true_robot(member: Member, nominal: RobotModel, rng: np.random.Generator) -> RobotModel:
    """The nominal arm with every segment perturbed by 10 % (physically consistent)."""
    links = np.stack([perturb_consistent(phi, 0.1, rng) for phi in nominal.link_parameters])
    return nominal.with_parameters(links.ravel())


@dataclass(frozen=True)
class RepeatedMotion:
    """A parameterised motion (``evaluate(t)``, ``duration``; starting and ending at rest) played
    ``repeats`` times, there and back (every second play runs backwards, so each starts where the
    one before ended), with rests: :class:`lwrlab.plants.planned_motions.PlannedMotion`."""

    motion: Any
    before: float
    after: float
    repeats: int
    pause: float
    speed: float = 1.0
    """Played this many times as fast as the motion itself (0.6: slower)."""

    @property
    def play_s(self) -> float:
        """One play (s)."""
        return float(self.motion.duration) / self.speed

    @property
    def duration(self) -> float:
        """Rests and plays (s)."""
        return self.before + self.repeats * self.play_s + (self.repeats - 1) * self.pause + self.after

    def _local(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The motion's own time at ``t``, whether it plays then, and its direction (±1)."""
        period = self.play_s + self.pause
        shifted = np.asarray(t, dtype=float) - self.before
        index = np.clip(np.floor(shifted / period), 0, self.repeats - 1)
        local = np.clip(shifted - index * period, 0.0, None)
        inside = (shifted >= 0.0) & (local <= self.play_s)
        local = np.clip(local, 0.0, self.play_s) * self.speed
        backwards = index % 2 == 1
        return (
            np.where(backwards, self.motion.duration - local, local),
            inside,
            np.where(backwards, -1.0, 1.0),
        )

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, q̇, q̈ (M, N_J) at times ``t``: held still at the motion's ends outside its plays."""
        local, inside, direction = self._local(t)
        q, dq, ddq = self.motion.evaluate(local)
        return q, dq * (inside * direction * self.speed)[:, None], ddq * (inside * self.speed**2)[:, None]

    def at_rest(self, t: np.ndarray) -> np.ndarray:
        """Outside the plays."""
        return ~self._local(t)[1]


def exciting_motion(member: Member, robot: RobotModel, cache: Path) -> Any:
    """The product's optimal 10 s exciting motion for the member's arm (``trajectory=optimal``, every
    constraint, one start), optimised once per arm and kept in ``cache``."""
    from lwrlab.pipeline.build import build

    optimizer = build("optimizer", "slsqp", show_progress=False, seed=0)
    constraints = dict(member.motion_constraints)
    source = build(
        "trajectory",
        "optimal",
        from_file=None,
        optimizer=optimizer,
        **({"constraints": constraints} if constraints else {}),
    )
    path = cache / "motions" / f"{member.robot}.npy"
    bare = source.bare_parameterisation(source.duration)
    if path.is_file():
        return bare.with_coefficients(np.load(path))
    motion, _, _ = source.optimise(robot)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.save(path, motion.coefficients)
    return motion


def member_motions(fit: Any, rng: np.random.Generator, quick: bool = False) -> dict[str, PlannedMotion]:
    """The fit logs (``fit``: the exciting motion played there and back; ``fit_slow``: the same at 0.6 ×
    its speed) and the new motions, about the fit motion's range: ``faster`` (1.3 × its speeds),
    ``slower`` (0.35 ×), ``p2p`` (point to point with rests), ``rest`` (three postures held 8 s
    each); ``quick``: every new motion about a fifth as long (the tests')."""
    move_s, stops, postures, dwell = (3.0, 3, 2, 3.0) if quick else (14.0, 8, 3, 8.0)
    played = RepeatedMotion(fit, 1.0, 1.5, 2, 1.5)
    t = np.linspace(0.0, fit.duration, 2001)
    q, dq, ddq = fit.evaluate(t)
    center = 0.5 * (q.max(axis=0) + q.min(axis=0))
    reach = np.maximum(0.5 * (q.max(axis=0) - q.min(axis=0)), 0.05)
    speed, acceleration = np.abs(dq).max(axis=0), np.abs(ddq).max(axis=0)
    slow = RepeatedMotion(fit, 1.0, 1.5, 2, 1.5, speed=0.6)
    motions: dict[str, PlannedMotion] = {"fit": played, "fit_slow": slow}
    for name, factor, frequencies in (
        ("faster", 1.3, [0.15, 0.31, 0.47, 0.73, 1.1, 1.45]),
        ("slower", 0.35, [0.05, 0.11, 0.17, 0.26, 0.37]),
    ):
        schedule = RestSchedule((("rest", 0.5), ("up", 0.4), ("move", move_s), ("down", 0.4), ("rest", 1.0)))
        path = MultisinePath.random(
            center, frequencies, reach, factor * speed, factor**2 * acceleration, schedule.path_length, rng
        )
        motions[name] = WarpedMotion(path, schedule)
    motions["p2p"] = _point_to_point(center, reach, speed, acceleration, stops, (0.5, 1.5), rng)
    motions["rest"] = _point_to_point(
        center, 0.6 * reach, 0.6 * speed, 0.5 * acceleration, postures, (dwell, dwell), rng
    )
    return motions


def _point_to_point(
    center: np.ndarray,
    reach: np.ndarray,
    speed: np.ndarray,
    acceleration: np.ndarray,
    count: int,
    dwell: tuple[float, float],
    rng: np.random.Generator,
) -> PointToPoint:
    waypoints = center + rng.uniform(-0.8, 0.8, size=(count + 1, center.size)) * reach
    waypoints[0] = center
    return PointToPoint.within(waypoints, speed, acceleration, rng.uniform(*dwell, size=count + 1), 0.6)


def sampled(motion: PlannedMotion, rate_hz: float) -> Trajectory:
    """``motion`` at ``rate_hz`` (Hz) as a trajectory (what a controller follows)."""
    t = np.arange(int(np.floor(motion.duration * rate_hz + 1e-9)) + 1) / rate_hz
    q, dq, ddq = motion.evaluate(t)
    return Trajectory(t=t, q=q, dq=dq, ddq=ddq)


def pushes(
    member: Member, truth: RobotModel, motion: PlannedMotion, rng: np.random.Generator
) -> list[ExternalForce]:
    """Held pushes (by hand: 10–60 N, 0.2–0.6 s) on the last links while the ``rest`` motion stands still,
    about one every 2 s, none within 0.5 s of a move."""
    trajectory = sampled(motion, CONTROL_RATE_HZ)
    still = motion.at_rest(trajectory.t)
    edges = np.flatnonzero(np.diff(still.astype(int)))
    starts = np.r_[0, edges + 1][still[np.r_[0, edges + 1]]]
    ends = np.r_[edges, len(still) - 1][still[np.r_[edges, len(still) - 1]]]
    links = list(range(truth.n_joints - member.contact_links + 1, truth.n_joints + 1))
    forces = []
    for a, b in zip(starts, ends, strict=True):
        window = (float(trajectory.t[a]) + 0.5, float(trajectory.t[b]) - 0.5)
        if window[1] - window[0] < 1.0:
            continue
        forces += random_forces(
            truth,
            trajectory,
            rng,
            window=window,
            spacing=2.0,
            links=links,
            force_range=(10.0, 60.0),
            push_duration=(0.2, 0.6),
            impact_share=0.0,
        )
    return forces


def external_torques(
    truth: RobotModel, t: np.ndarray, q: np.ndarray, forces: list[ExternalForce]
) -> np.ndarray:
    """(M, N_J) the true external joint torque ``−J_pᵀ·F`` of ``forces`` along ``q`` (N·m)."""
    model, data = truth.model, truth.model.createData()
    out = np.zeros_like(q)
    for force in forces:
        active = np.flatnonzero((t >= force.start) & (t <= force.start + force.duration))
        for k in active:
            pin.computeJointJacobians(model, data, q[k])
            jacobian = pin.getJointJacobian(model, data, force.link, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
            r = data.oMi[force.link].rotation @ force.point
            linear = jacobian[:3] - np.cross(r[:, None], jacobian[3:], axis=0)
            out[k] -= linear.T @ (force.profile(float(t[k])) * force.force)
    return out


BANDWIDTH = 25.0
"""MuJoCo members: the joint PD's closed-loop bandwidth (rad/s), critically damped."""


def _mujoco_run(
    member: Member,
    nominal: RobotModel,
    truth: RobotModel,
    scale: np.ndarray,
    motion: PlannedMotion,
    forces: list[ExternalForce],
    seed: int,
) -> dict[str, np.ndarray]:
    """The member's arm in MuJoCo following ``motion`` (at 1 kHz) under ``forces``: the noise-free
    link-side torques and positions, and the external torques, at the control rate."""
    spec = member.truth
    coulomb, viscous = spec.coulomb_share * scale, spec.viscous_share * scale
    rotor = spec.rotor_share * scale
    values = replace(truth.friction, coulomb=coulomb, viscous=viscous, offset=np.zeros_like(scale))
    arm_truth = replace(truth, friction=values, rotor_inertia=rotor)
    trajectory = sampled(motion, CONTROL_RATE_HZ)
    mass = np.diag(pin.crba(nominal.model, nominal.model.createData(), trajectory.q[0])) + rotor
    joint_friction = None
    if spec.law == "mujoco":  # MuJoCo's own dry friction and damping instead of the sign law
        joint_friction = {"frictionloss": coulomb, "damping": viscous, "time_constant": 0.005}

    def sign_law(dq: np.ndarray) -> np.ndarray:
        return coulomb * np.tanh(dq / spec.sign_width) + viscous * dq

    arm = PushedArm(
        arm_truth,
        nominal,
        kp=mass * BANDWIDTH**2,
        kd=mass * 2 * BANDWIDTH,
        substeps=2,
        torque_noise_std=0.0,
        encoder_noise_std=0.0,
        seed=seed,
        friction=None if joint_friction else sign_law,
        joint_friction=joint_friction,
    )
    run = arm.run(trajectory, forces)
    return {
        "t": trajectory.t,
        "q": run.measurement.q,
        "tau": run.measurement.tau,
        "external": run.external_torque,
        "dq": np.asarray(run.velocity),
        "ddq": np.asarray(run.acceleration),
    }


def _stamps(t: np.ndarray, jitter: float, rng: np.random.Generator) -> np.ndarray:
    """``t`` with each stamp off by σ = ``jitter`` periods (clipped at 0.4 periods, kept increasing)."""
    if jitter <= 0:
        return t
    period = float(t[1] - t[0])
    return t + np.clip(rng.normal(scale=jitter * period, size=t.shape), -0.4 * period, 0.4 * period)


def _write(path: Path, columns: dict[str, np.ndarray], log_format: str) -> Path:
    """A log's columns (``t`` and (M, N) blocks) in the member's format."""
    if log_format == "npz":
        np.savez(path, allow_pickle=False, **columns)
        return path
    frame: dict[str, np.ndarray] = {"t": columns["t"]}
    for key, block in columns.items():
        if key != "t":
            frame |= {f"{key}{j + 1}": block[:, j] for j in range(block.shape[1])}
    table = pd.DataFrame(frame)
    if log_format == "parquet":
        table.to_parquet(path, index=False)
    else:
        table.to_csv(path, index=False, float_format="%.17g")
    return path


def _write_truth(path: Path, t: np.ndarray, blocks: dict[str, np.ndarray]) -> None:
    """A log's truth: ``t`` and each (M, N_J) block as columns ``<name>1…``."""
    columns: dict[str, np.ndarray] = {"t": t}
    for key, block in blocks.items():
        columns |= {f"{key}{j + 1}": block[:, j] for j in range(block.shape[1])}
    pd.DataFrame(columns).to_parquet(path, index=False)


def _joint_readings(
    sensors: Sensors,
    scale: np.ndarray,
    t: np.ndarray,
    q: np.ndarray,
    reading: np.ndarray,
    rng: np.random.Generator,
) -> dict[str, np.ndarray]:
    """What joint encoders and torque sensors log of true positions ``q`` and noise-free readings
    ``reading`` (offsets included) at times ``t``: noisy quantised angles, noisy torques, stamps."""
    resolution = sensors.encoder_resolution
    noise = rng.normal(scale=sensors.encoder_noise * resolution, size=q.shape)
    q_log = np.round((q + noise) / resolution) * resolution
    tau_log = reading + rng.normal(size=reading.shape) * sensors.noise_share * scale
    return {"t": _stamps(t, sensors.jitter, rng), "q": q_log, "tau": tau_log}


def _joint_side_member(
    member: Member,
    nominal: RobotModel,
    truth: RobotModel,
    scale: np.ndarray,
    motions: dict[str, PlannedMotion],
    forces: list[ExternalForce],
    folder: Path,
    seed: int,
) -> dict[str, Path]:
    """A MuJoCo member's logs (joint torque sensors, joint encoders) and their truths."""
    sensors = member.sensors
    rng = np.random.default_rng([seed, 7])
    offset = sensors.offset_share * scale * rng.choice([-1.0, 1.0], size=scale.size)
    keep = round(CONTROL_RATE_HZ / sensors.rate_hz)
    paths = {}
    for k, (name, motion) in enumerate(motions.items()):
        run = _mujoco_run(member, nominal, truth, scale, motion, forces if name == "rest" else [], seed + k)
        rows = slice(None, None, keep)
        t, q, tau, external = run["t"][rows], run["q"][rows], run["tau"][rows], run["external"][rows]
        state = {"q": q, "dq": run["dq"][rows], "ddq": run["ddq"][rows]}
        reading = tau + offset
        paths[name] = _write(
            folder / f"{name}.{sensors.log_format}",
            _joint_readings(sensors, scale, t, q, reading, rng),
            sensors.log_format,
        )
        _write_truth(folder / f"{name}_truth.parquet", t, {"tau": reading, "tau_ext": external} | state)
    return paths


def _drive_friction(member: Member, truth: RobotModel, scale: np.ndarray) -> Any:
    """The geared member's motor friction, from its joint-side figures."""
    spec = member.truth
    drive = truth.drive_train
    coulomb, viscous = spec.coulomb_share * scale, spec.viscous_share * scale
    if spec.law == "lugre":
        return LuGreFriction.from_joint_side(
            drive,
            coulomb,
            viscous,
            stribeck_rise=spec.stribeck_rise,
            stribeck_speed=np.full(scale.size, spec.stribeck_speed),
            load_factor=spec.load_factor,
            presliding=2e-4,
            damping_share=0.2,
        )
    return StaticFriction.from_joint_side(
        drive.gear_ratios,
        coulomb,
        viscous,
        stribeck_rise=spec.stribeck_rise,
        stribeck_speed=spec.stribeck_speed,
        asymmetry=spec.asymmetry,
        load_factor=spec.load_factor,
        width=0.0 if spec.law == "sign" else 1e-3,
    )


def _geared_arm(
    member: Member, truth: RobotModel, scale: np.ndarray, rng: np.random.Generator
) -> tuple[GearedArm, np.ndarray]:
    """The geared member's arm and its sensors' effort offsets (drawn from ``rng``, logged units)."""
    sensors, spec = member.sensors, member.truth
    gears = np.abs(truth.drive_train.gear_ratios)
    per_unit = gears * (TORQUE_CONSTANT if sensors.effort == "current" else 1.0)  # joint N·m per logged unit
    offset = sensors.offset_share * scale * rng.choice([-1.0, 1.0], size=scale.size) / per_unit
    motor_sensors = MotorSensors(
        effort_noise=sensors.noise_share * scale / per_unit,
        effort_offset=offset,
        encoder_counts=sensors.encoder_counts,
        encoder_noise_counts=0.3,
    )
    arm = GearedArm(
        truth,
        spec.rotor_share * scale / gears**2,
        _drive_friction(member, truth, scale),
        motor_sensors,
        rate_hz=sensors.rate_hz,
        substeps=max(20, int(10_000 / sensors.rate_hz)),
    )
    return arm, offset


def _motor_side_member(
    member: Member,
    truth: RobotModel,
    scale: np.ndarray,
    motions: dict[str, PlannedMotion],
    forces: list[ExternalForce],
    folder: Path,
    seed: int,
) -> dict[str, Path]:
    """A geared member's logs (encoders and currents or torques at the motors) and their truths."""
    sensors = member.sensors
    drive = truth.drive_train
    rng = np.random.default_rng([seed, 11])
    arm, offset = _geared_arm(member, truth, scale, rng)
    paths = {}
    for name, motion in motions.items():
        samples = int(np.floor(motion.duration * sensors.rate_hz + 1e-9)) + 1
        t = np.arange(samples) / sensors.rate_hz
        external = np.zeros((samples, truth.n_joints))
        if name == "rest":
            external = external_torques(truth, t, motion.evaluate(t)[0], forces)
        run = arm.play(motion, rng, external=external)
        offset_torque = offset * (TORQUE_CONSTANT if sensors.effort == "current" else 1.0)
        reading = drive.joint_torques(run.motor_torque + offset_torque)
        column = "current" if sensors.effort == "current" else "tau"
        paths[name] = _write(
            folder / f"{name}.{sensors.log_format}",
            {"t": _stamps(t, sensors.jitter, rng), "q": run.measured_angles, column: run.measured_effort},
            sensors.log_format,
        )
        state = {"q": run.q, "dq": run.dq, "ddq": run.ddq}
        _write_truth(folder / f"{name}_truth.parquet", t, {"tau": reading, "tau_ext": external} | state)
    return paths


def _truth_and_motions(
    member: Member, nominal: RobotModel, seed: int, cache: Path, quick: bool
) -> tuple[RobotModel, dict[str, PlannedMotion], np.random.Generator]:
    """The member's true arm and its motions as :func:`build_member` draws them from ``seed``, and the
    generator where they left it (the pushes come next)."""
    rng = np.random.default_rng(seed)
    truth = true_robot(member, nominal, rng)
    fit = quick_motion(nominal) if quick else exciting_motion(member, nominal, cache)
    return truth, member_motions(fit, rng, quick), rng


def noise_realisation(logs: MemberLogs, k: int, name: str = "fit") -> str:
    """Log ``name`` of a built member recorded again (realisation ``k`` ≥ 1): the same truth and motion,
    the sensors' noise, quantisation and stamps drawn anew (the offsets are the arm's and stay). Kept
    beside the member's logs (built once) and added to ``logs.paths``; returns its name there."""
    if k < 1:
        raise ValueError(f"a realisation is numbered from 1 (0 is the log itself), got {k}")
    member, sensors = logs.member, logs.member.sensors
    key = f"{name}-noise{k}"
    path = logs.folder / f"{key}.{sensors.log_format}"
    if not path.is_file():
        if member.truth.engine == "mujoco":
            truth = logs.truth(name)
            n = logs.scale.size
            q = truth[[f"q{j + 1}" for j in range(n)]].to_numpy()
            reading = truth[[f"tau{j + 1}" for j in range(n)]].to_numpy()
            rng = np.random.default_rng([logs.seed, 7, k])
            columns = _joint_readings(sensors, logs.scale, truth["t"].to_numpy(), q, reading, rng)
        else:  # the motion played again: the motor-side sensors are the arm's
            quick = logs.folder.name.endswith("-quick")
            truth_robot, motions, _ = _truth_and_motions(
                member, nominal_robot(member), logs.seed, logs.folder.parents[1], quick
            )
            motion = motions[name]
            arm, _ = _geared_arm(member, truth_robot, logs.scale, np.random.default_rng([logs.seed, 11]))
            rng = np.random.default_rng([logs.seed, 11, k])
            run = arm.play(motion, rng)
            t = np.arange(run.measured_angles.shape[0]) / sensors.rate_hz
            column = "current" if sensors.effort == "current" else "tau"
            columns = {
                "t": _stamps(t, sensors.jitter, rng),
                "q": run.measured_angles,
                column: run.measured_effort,
            }
        _write(path, columns, sensors.log_format)
    logs.paths[key] = path
    return key


def quick_motion(robot: RobotModel) -> WarpedMotion:
    """A 3 s multi-sine about the middle of the joint ranges, from and to rest: what a quick member (the
    tests') plays instead of the optimised exciting motion."""
    lower = np.where(np.isfinite(robot.limits.position_lower), robot.limits.position_lower, -np.pi)
    upper = np.where(np.isfinite(robot.limits.position_upper), robot.limits.position_upper, np.pi)
    schedule = RestSchedule((("rest", 0.3), ("up", 0.3), ("move", 3.0), ("down", 0.3), ("rest", 0.3)))
    n = robot.n_joints
    path = MultisinePath.random(
        0.5 * (lower + upper),
        [0.3, 0.7, 1.3],
        np.minimum(0.25 * (upper - lower), 0.6),
        np.full(n, 1.2),
        np.full(n, 8.0),
        schedule.path_length,
        np.random.default_rng(0),
    )
    return WarpedMotion(path, schedule)


def build_member(member: Member, seed: int = 0, cache: Path | None = None, quick: bool = False) -> MemberLogs:
    """The member's logs and truths (seeded), built once into ``cache`` (default :data:`CACHE`) and
    read back from there afterwards. ``quick``: a 3 s multi-sine instead of the optimised exciting
    motion and short new motions (a few seconds to build: the tests')."""
    cache = CACHE if cache is None else Path(cache)
    folder = cache / f"v{ZOO_VERSION}" / f"{member.name}-seed{seed}{'-quick' if quick else ''}"
    record = folder / "member.json"
    nominal = nominal_robot(member)
    scale = torque_scale(nominal, np.random.default_rng([seed, 3]))
    logs = MemberLogs(member, seed, folder, scale)
    if record.is_file() and json.loads(record.read_text()).get("member") == _plain(asdict(member)):
        logs.paths = {n: next(folder.glob(f"{n}.*")) for n in LOG_NAMES if any(folder.glob(f"{n}.*"))}
        if set(logs.paths) == set(LOG_NAMES):
            return logs
    folder.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    truth, motions, rng = _truth_and_motions(member, nominal, seed, cache, quick)
    forces = pushes(member, truth, motions["rest"], rng)
    if member.truth.engine == "mujoco":
        logs.paths = _joint_side_member(member, nominal, truth, scale, motions, forces, folder, seed)
    else:
        logs.paths = _motor_side_member(member, truth, scale, motions, forces, folder, seed)
    from lwrlab.plants.pushed_arm import forces_frame

    forces_frame(forces).to_csv(folder / "rest_contacts.csv", index=False)
    np.save(folder / "true_parameters.npy", truth.link_parameters)
    record.write_text(
        json.dumps(
            {
                "member": _plain(asdict(member)),
                "seed": seed,
                "version": ZOO_VERSION,
                "torque_scale": scale.tolist(),
                "seconds": round(time.perf_counter() - started, 1),
            },
            indent=1,
        )
    )
    return logs


def _plain(value: Any) -> Any:
    """Tuples as lists (what JSON reads back)."""
    return json.loads(json.dumps(value))
