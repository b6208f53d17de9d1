"""An arm pushed and struck at known times and places, in MuJoCo: logs whose contacts are known.

The robot (the true, perturbed one, with friction and rotor inertia) is written to MuJoCo as the
painting plant writes it (:func:`lwrlab.plants.mujoco_contact.mujoco_xml`), without tool or wall. It
follows a motion under inverse-dynamics feedforward of the nominal model plus joint PD, while
external forces act on its links (MuJoCo's ``xfrc_applied``: a force at a point fixed to a link):

- *pushes*: a force of constant direction and magnitude, raised and lowered over
  :data:`RAMP_S` by a half cosine, held in between;
- *impacts*: a half-sine force pulse (a collision's short, sharp peak).

The sensors are those of the painting plant: the link-side joint torque ``τ − I_a·q̈`` plus white
noise, encoders with noise. Beside the measurement the truth is returned: the external joint torque
in the monitor's convention, ``τ − τ̂ = −J_pᵀ·F`` (F the force on the arm), and the force at every
sample.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from itertools import pairwise

import mujoco
import numpy as np
import pandas as pd
import pinocchio as pin

from lwrlab.model.robot import RobotModel
from lwrlab.plants.core import Measurement
from lwrlab.plants.mujoco_contact import mujoco_xml
from lwrlab.plants.simulation import COULOMB_SMOOTHING
from lwrlab.trajectory.core import Trajectory

RAMP_S = 0.005
"""Rise and fall time of a push (s)."""


@dataclass(frozen=True)
class ExternalForce:
    """A force acting on one link for a while."""

    start: float
    """Onset (s, on the motion's clock)."""
    duration: float
    """How long it acts (s)."""
    link: int
    """Link (1-based: the segment joint ``link`` moves) it acts on."""
    point: np.ndarray
    """(3,) point of application in the link's joint frame (m)."""
    force: np.ndarray
    """(3,) peak force on the arm, base frame (N)."""
    kind: str = "push"
    """``push`` (held, ramped) or ``impact`` (half-sine pulse)."""

    def profile(self, t: float) -> float:
        """Share of the peak force acting at time ``t`` (0 … 1)."""
        s = t - self.start
        if s < 0 or s > self.duration:
            return 0.0
        if self.kind == "impact":
            return float(np.sin(np.pi * s / self.duration))
        ramp = min(RAMP_S, self.duration / 2)
        edge = min(s, self.duration - s)
        return 1.0 if edge >= ramp else float(0.5 - 0.5 * np.cos(np.pi * edge / ramp))

    @property
    def magnitude(self) -> float:
        """Peak force (N)."""
        return float(np.linalg.norm(self.force))


def forces_frame(forces: Sequence[ExternalForce]) -> pd.DataFrame:
    """The forces as a table of true contacts (``start``, ``end``, ``peak_force`` and where and how)."""
    rows = [
        {
            "start": f.start,
            "end": f.start + f.duration,
            "peak_force": f.magnitude,
            "kind": f.kind,
            "link": f.link,
            **{f"point_{a}": float(v) for a, v in zip("xyz", f.point, strict=True)},
            **{f"force_{a}": float(v) for a, v in zip("xyz", f.force, strict=True)},
        }
        for f in forces
    ]
    return pd.DataFrame(rows)


@dataclass(frozen=True)
class PushedRun:
    """What the sensors logged and what truly happened."""

    measurement: Measurement
    """Encoder positions and link-side torques at the control rate."""
    external_torque: np.ndarray
    """(N, N_J) true external joint torque τ − τ̂ = −J_pᵀ·F (N·m)."""
    force: np.ndarray
    """(N, 3) force on the arm at each sample (N, base frame; zero without contact)."""
    contacts: pd.DataFrame
    """The forces as true contacts (:func:`forces_frame`)."""
    velocity: np.ndarray | None = None
    """(N, N_J) true joint velocities at the samples (rad/s)."""
    acceleration: np.ndarray | None = None
    """(N, N_J) true joint accelerations at the samples (rad/s²)."""


class PushedArm:
    """The true robot in MuJoCo, following motions, pushed by known forces.

    Parameters
    ----------
    truth : the true robot (inertia, friction, rotor inertia).
    nominal : the controller's model (inverse-dynamics feedforward).
    kp, kd : joint PD gains (N·m/rad, N·m·s/rad), one per joint.
    substeps : MuJoCo steps per control period.
    torque_noise_std : joint-torque sensor noise σ_τ (N·m).
    encoder_noise_std : encoder noise σ_q (rad).
    seed : seed of the sensor noise.
    friction : the joints' friction torque ``f(q̇)`` (N·m) of (N_J,) velocities (rad/s), applied as a
        generalised force opposing the motion; None: the truth's ``FV·q̇ + FC·tanh(q̇/ε) + FO``.
    joint_friction : MuJoCo's own joint friction instead, per joint: ``frictionloss`` (dry friction
        solved as a soft constraint, N·m), ``damping`` (N·m·s/rad) and ``time_constant`` (s, its
        ``solreffriction``); ``friction`` is then zero unless given.
    """

    def __init__(
        self,
        truth: RobotModel,
        nominal: RobotModel,
        *,
        kp: Sequence[float],
        kd: Sequence[float],
        substeps: int,
        torque_noise_std: float,
        encoder_noise_std: float,
        seed: int,
        friction: Callable[[np.ndarray], np.ndarray] | None = None,
        joint_friction: dict[str, Sequence[float] | float] | None = None,
    ) -> None:
        self.truth, self.nominal = truth, nominal
        self.kp, self.kd = np.asarray(kp, dtype=float), np.asarray(kd, dtype=float)
        self.substeps = int(substeps)
        self.torque_noise_std, self.encoder_noise_std = float(torque_noise_std), float(encoder_noise_std)
        self.seed = seed
        n = truth.n_joints
        self.armature = np.zeros(n) if truth.rotor_inertia is None else np.asarray(truth.rotor_inertia)
        values = truth.friction
        self._coulomb, self._viscous, self._offset = values.coulomb, values.viscous, values.offset
        self.joint_friction = joint_friction
        self._friction: Callable[[np.ndarray], np.ndarray] = (
            friction if friction is not None else np.zeros_like if joint_friction else self._truth_friction
        )

    def _truth_friction(self, dq: np.ndarray) -> np.ndarray:
        return self._viscous * dq + self._coulomb * np.tanh(dq / COULOMB_SMOOTHING) + self._offset

    def _model(self, period: float) -> mujoco.MjModel:
        """The MuJoCo model at ``substeps`` steps per ``period``, with MuJoCo's own joint friction."""
        model = mujoco.MjModel.from_xml_string(
            mujoco_xml(self.truth, timestep=period / self.substeps, with_armature=True)
        )
        if self.joint_friction is not None:
            model.dof_frictionloss[:] = self.joint_friction.get("frictionloss", 0.0)
            model.dof_damping[:] = self.joint_friction.get("damping", 0.0)
            model.dof_solref[:, 0] = self.joint_friction.get("time_constant", 0.005)
            model.opt.tolerance, model.opt.iterations = 1e-12, 200  # friction solved to round-off
        return model

    def run(self, motion: Trajectory, forces: Sequence[ExternalForce], name: str = "pushed_arm") -> PushedRun:
        """Follow ``motion`` (its samples are the control periods) while ``forces`` act."""
        period = float(motion.t[1] - motion.t[0])
        model = self._model(period)
        data = mujoco.MjData(model)
        n, n_samples = self.truth.n_joints, motion.t.shape[0]
        bodies = [model.body(f"link{force.link}").id for force in forces]
        nominal, nominal_data = self.nominal.model, self.nominal.model.createData()
        rng = np.random.default_rng(self.seed)
        q_log, tau_log = np.empty((n_samples, n)), np.empty((n_samples, n))
        external, force_log = np.zeros((n_samples, n)), np.zeros((n_samples, 3))
        velocity, acceleration = np.empty((n_samples, n)), np.empty((n_samples, n))
        push = np.zeros(n)
        data.qpos[:], data.qvel[:] = motion.q[0], motion.dq[0]
        order = np.argsort([f.start for f in forces]) if forces else np.array([], dtype=int)
        windows = [(forces[i].start, forces[i].start + forces[i].duration, i) for i in order]

        def apply_forces(time: float) -> np.ndarray:
            """Write the forces acting at ``time`` into MuJoCo; their total (N) on the arm."""
            data.xfrc_applied[:] = 0.0
            total = np.zeros(3)
            for start, end, i in windows:
                if start > time:
                    break
                if time > end:
                    continue
                force = forces[i]
                value = force.profile(time) * force.force
                body = bodies[i]
                # a force at a point: MuJoCo takes it at the body's centre of mass, with its moment
                point = data.xpos[body] + data.xmat[body].reshape(3, 3) @ force.point
                data.xfrc_applied[body, :3] += value
                data.xfrc_applied[body, 3:] += np.cross(point - data.xipos[body], value)
                total += value
            return total

        def read(k: int, tau: np.ndarray) -> None:
            """Sensors and truth at sample ``k`` under the command ``tau`` (state after mj_forward)."""
            q_log[k] = data.qpos + self.encoder_noise_std * rng.normal(size=n)
            tau_log[k] = tau - self.armature * data.qacc + self.torque_noise_std * rng.normal(size=n)
            velocity[k], acceleration[k] = data.qvel, data.qacc
            push[:] = 0.0
            for start, end, i in windows:
                if start <= motion.t[k] <= end:
                    body = bodies[i]
                    point = data.xpos[body] + data.xmat[body].reshape(3, 3) @ forces[i].point
                    value = forces[i].profile(motion.t[k]) * forces[i].force
                    mujoco.mj_applyFT(model, data, value, np.zeros(3), point, body, push)
            external[k] = -push

        tau = self._command(nominal, nominal_data, motion, 0, data)
        force_log[0] = apply_forces(motion.t[0])
        data.qfrc_applied[:] = tau - self._friction(data.qvel)
        mujoco.mj_forward(model, data)
        read(0, tau)
        for k in range(1, n_samples):
            for s in range(self.substeps):
                time = motion.t[k - 1] + s * period / self.substeps
                apply_forces(time)
                data.qfrc_applied[:] = tau - self._friction(data.qvel)
                mujoco.mj_step(model, data)
            force_log[k] = apply_forces(motion.t[k])
            tau = self._command(nominal, nominal_data, motion, k, data)
            data.qfrc_applied[:] = tau - self._friction(data.qvel)
            mujoco.mj_forward(model, data)
            read(k, tau)
        measurement = Measurement(
            t=motion.t.copy(),
            q=q_log,
            tau=tau_log,
            metadata={
                "source": "mujoco pushed arm",
                "name": name,
                "rate_hz": 1.0 / period,
                "torque_noise_std": self.torque_noise_std,
                "encoder_noise_std": self.encoder_noise_std,
                "seed": self.seed,
            },
        )
        contacts = forces_frame([forces[i] for i in order])
        return PushedRun(measurement, external, force_log, contacts, velocity, acceleration)

    def _command(
        self,
        nominal: pin.Model,
        nominal_data: pin.Data,
        motion: Trajectory,
        k: int,
        data: mujoco.MjData,
    ) -> np.ndarray:
        """Inverse-dynamics feedforward of the nominal model at the reference, plus joint PD."""
        feedforward = pin.rnea(nominal, nominal_data, motion.q[k], motion.dq[k], motion.ddq[k])
        feedforward = feedforward + self.nominal.drive_torque(motion.dq[k])
        if self.nominal.rotor_inertia is not None:  # the drives accelerate their rotors too
            feedforward = feedforward + self.nominal.rotor_inertia * motion.ddq[k]
        return feedforward + self.kp * (motion.q[k] - data.qpos) + self.kd * (motion.dq[k] - data.qvel)


def chained(motions: Sequence[Trajectory]) -> Trajectory:
    """Motions played one after another on one clock (each must start where the previous ended)."""
    if not motions:
        raise ValueError("no motion to chain")
    period = float(motions[0].t[1] - motions[0].t[0])
    parts = list(motions)
    for before, after in pairwise(parts):
        if not np.allclose(before.q[-1], after.q[0], atol=1e-9) or not np.allclose(
            before.dq[-1], after.dq[0]
        ):
            raise ValueError("chained motions must continue each other (position and velocity)")
    # the first sample of each later motion repeats the last of the one before: dropped
    q = np.vstack([parts[0].q, *(m.q[1:] for m in parts[1:])])
    dq = np.vstack([parts[0].dq, *(m.dq[1:] for m in parts[1:])])
    ddq = np.vstack([parts[0].ddq, *(m.ddq[1:] for m in parts[1:])])
    t = period * np.arange(q.shape[0])
    return Trajectory(t=t, q=q, dq=dq, ddq=ddq, metadata={"chained": [m.metadata for m in parts]})


def random_forces(
    robot: RobotModel,
    motion: Trajectory,
    rng: np.random.Generator,
    *,
    window: tuple[float, float],
    spacing: float,
    links: Sequence[int],
    force_range: tuple[float, float] = (5.0, 50.0),
    push_duration: tuple[float, float] = (0.05, 0.5),
    impact_duration: tuple[float, float] = (0.02, 0.05),
    impact_share: float = 0.3,
    min_lever: float = 0.15,
) -> list[ExternalForce]:
    """Pushes and impacts at random within ``window`` (s), one every ``spacing`` s on average.

    Each acts on a random link of ``links``, at a point within 3 cm of the link's centre of mass, in a
    random direction the joints can feel: ‖J_pᵀ·u‖ ≥ ``min_lever`` (m) at the motion's pose when it
    starts (a force through every joint axis moves no joint, and no torque sensor can see it).
    """
    model, data = robot.model, robot.model.createData()
    forces: list[ExternalForce] = []
    start = window[0]
    while True:
        start += spacing * rng.uniform(0.7, 1.3)
        impact = rng.uniform() < impact_share
        duration = rng.uniform(*(impact_duration if impact else push_duration))
        if start + duration > window[1]:
            return forces
        link = int(rng.choice(np.asarray(links)))
        phi = robot.link_parameters[link - 1]
        point = phi[1:4] / phi[0] + rng.uniform(-0.03, 0.03, 3)
        k = int(np.searchsorted(motion.t, start))
        pin.computeJointJacobians(model, data, motion.q[k])
        jacobian = pin.getJointJacobian(model, data, link, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        r = data.oMi[link].rotation @ point
        linear = jacobian[:3] - np.cross(r[:, None], jacobian[3:], axis=0)
        for _ in range(100):
            direction = rng.normal(size=3)
            direction /= np.linalg.norm(direction)
            if np.linalg.norm(linear.T @ direction) >= min_lever:
                break
        else:
            continue  # no direction felt at this pose: no contact here
        magnitude = rng.uniform(*force_range)
        forces.append(
            ExternalForce(
                start=float(start),
                duration=float(duration),
                link=link,
                point=point,
                force=magnitude * direction,
                kind="impact" if impact else "push",
            )
        )
