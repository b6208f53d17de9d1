"""The painting benchmark's case and the per-sample contact loop the batched loop replaced.

:func:`make_case` builds the KUKA LWR4 (``conf/robot/kuka_lwr4.yaml``) carrying the large roller in
front of the wall of §VI.B, along the large roller's optimised path (README, Table IV);
:class:`PerSampleLoop` is the contact loop as it was first written, everything one sample at a time,
kept as the reference ``benchmarks/painting.py`` measures the loop against. Every setting (wall,
contact plant, force estimate, the force controller's gains) is the shipped YAML's
(conf/task/painting.yaml, conf/controller/force_pi.yaml).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
from omegaconf import OmegaConf

from lwrlab.control.contact_loop import ContactRun
from lwrlab.control.filters import low_pass_gain
from lwrlab.control.force_estimation import add_tool_frame
from lwrlab.control.joint_pd import ControlSetup
from lwrlab.kinematics.swivel_ik import Branch, SwivelIK
from lwrlab.model.payload import attach_payload
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build, shipped_config
from lwrlab.pipeline.painting.runs import CONTROL_RATE_HZ, contact_plant
from lwrlab.pipeline.tools.library import load_tool
from lwrlab.planning.painting_path import PaintingPathParameters, sample_path
from lwrlab.plants.contact_batch import ContactPlantBatch
from lwrlab.plants.mujoco_contact import MujocoContactPlant, Wall
from lwrlab.tools.model import Tool
from plugins.robots.mdh import load_robot_yaml

REPO = Path(__file__).resolve().parents[1]
PATH = PaintingPathParameters(
    duration=38.45, swivel=-1.673, z_upper=0.5355, z_lower=0.2403, y_start=0.1331, y_step=0.1835, n_steps=2
)
"""The large roller's optimised path (identified model, README Table IV)."""
TASK = OmegaConf.to_container(shipped_config("task", "painting"), resolve=True)
"""The painting task's settings (conf/task/painting.yaml)."""
CONTACT, ESTIMATOR = TASK["contact"], TASK["estimator"]
FORCE_PI = build("controller", "force_pi")
"""The force controller of conf/controller/force_pi.yaml (estimated force fed back)."""
BRANCH = Branch(*TASK["path"]["branch"])
PERIOD = 1.0 / CONTROL_RATE_HZ
WALL = Wall(**TASK["wall"])
"""The wall of §VI.B."""


@dataclass
class Case:
    """Everything a run needs: the true plant's robot and roller, the controller's model, the path."""

    truth: RobotModel
    model: RobotModel
    tool: Tool
    tcp: np.ndarray
    wall: Wall
    reference: np.ndarray
    painting: np.ndarray
    start: np.ndarray

    def plant(self) -> MujocoContactPlant:
        return contact_plant(self.truth, self.tool, self.wall, CONTACT, seed=0)

    def setup(self) -> ControlSetup:
        return ControlSetup(self.model, SwivelIK(self.model), self.tcp, PATH.swivel, BRANCH, PERIOD)


def make_case(seconds: float) -> Case:
    """The CAD LWR4 + large roller (plant and controller alike), the task's approach at the start point
    (2 s), then the path."""
    robot = load_robot_yaml(REPO / "conf" / "robot" / "kuka_lwr4.yaml")
    tool = load_tool("large_roller")
    tcp = np.eye(4)
    tcp[:3, 3] = tool.contact_point
    wall = WALL
    poses = sample_path(PATH, wall.x, 1.0 / PERIOD).poses()
    approach = round(CONTACT["approach_s"] / PERIOD)
    reference = np.concatenate([np.repeat(poses[:1], approach, axis=0), poses])[: round(seconds / PERIOD)]
    start = reference[0].copy()
    start[0, 3] += CONTACT["standoff"]  # off the wall
    return Case(
        robot,
        attach_payload(robot, tool.parameters),
        tool,
        tcp,
        wall,
        reference,
        np.arange(len(reference)) >= approach,
        start,
    )


class PerSampleLoop:
    """The contact loop as it was before batching, kept as the reference: everything one sample at a time.

    The same plant model, equations, gains and noise as :func:`simulate_contact` with
    :class:`ForcePIControl` (estimate fed back) and :class:`ExternalForceEstimator`.
    """

    def __init__(self, case: Case) -> None:
        self.case, self.plant, self.setup = case, case.plant(), case.setup()
        self.tare = np.zeros(3)
        self.model, frame = add_tool_frame(case.model, case.tcp)
        self.frame, self.data = frame, self.model.createData()
        self.gravity_data = case.model.model.createData()
        self.kp, self.kd = (np.asarray(gains, dtype=float) for gains in (FORCE_PI.kp, FORCE_PI.kd))
        self.force_ki = np.asarray(FORCE_PI.force_ki, dtype=float)
        self.velocity_gain = low_pass_gain(ESTIMATOR["velocity_cutoff_hz"], PERIOD)
        self.acceleration_gain = low_pass_gain(ESTIMATOR["acceleration_cutoff_hz"], PERIOD)
        self.wrench_gain = low_pass_gain(ESTIMATOR["wrench_cutoff_hz"], PERIOD)

    def joint_reference(self, pose: np.ndarray) -> np.ndarray:
        flange = pose @ np.linalg.inv(self.case.tcp)  # inverted per call, as before
        return self.setup.ik.solve_branch(flange[None], PATH.swivel, BRANCH).q[0]

    def plant_step(self, tau: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
        plant, model, data = self.plant, self.plant.model, self.plant.data
        for _ in range(plant.substeps):
            data.qfrc_applied[:] = tau - plant.friction_torque(data.qvel)
            mujoco.mj_step(model, data)
        data.qfrc_applied[:] = tau - plant.friction_torque(data.qvel)
        mujoco.mj_forward(model, data)
        return self.read(tau - plant.armature * data.qacc, rng)

    def read(self, link_torque: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
        data, plant = self.plant.data, self.plant
        q = data.qpos.copy()
        rotation = data.site_xmat[plant.wall_site].reshape(3, 3)
        force = -rotation @ data.sensordata[plant.sensor_address : plant.sensor_address + 3] - self.tare
        return (
            q + plant.encoder_noise_std * rng.normal(size=7),
            link_torque + plant.torque_noise_std * rng.normal(size=7),
            force + plant.force_noise_std * rng.normal(size=3),
            q,
        )

    def run(self) -> ContactRun:
        case = self.case
        n = len(case.reference)
        q0 = self.joint_reference(case.start)
        gravity = pin.computeGeneralizedGravity(case.model.model, self.gravity_data, q0).copy()
        stepper = ContactPlantBatch([self.plant])  # places the robot at rest and tares the wall sensor
        stepper.reset(q0[None], gravity[None])
        self.tare = stepper.tare[0]  # the noise below is drawn per sample
        rng = np.random.default_rng(0)
        q_meas, tau_meas, force_meas, _ = self.read(gravity - self.plant.armature * self.plant.data.qacc, rng)
        previous_q, velocity, previous_velocity, acceleration = (
            q_meas.copy(),
            np.zeros(7),
            np.zeros(7),
            np.zeros(7),
        )
        wrench_state, integral = np.zeros(6), np.zeros(3)
        previous_desired = q0.copy()
        friction, terms = case.model.friction, case.model.friction_terms
        out = {name: np.empty((n, 3)) for name in ("actual", "measured")}
        wrench_log = np.empty((n, 6))
        for k in range(n):
            # eq. (14) with backward differences, each low-passed, one filter call at a time
            rate = (q_meas - previous_q) / PERIOD
            previous_q = q_meas.copy()
            velocity = velocity + self.velocity_gain * (rate - velocity)
            dq = velocity.copy()
            rate = (dq - previous_velocity) / PERIOD
            previous_velocity = dq.copy()
            acceleration = acceleration + self.acceleration_gain * (rate - acceleration)
            ddq = acceleration.copy()
            tau_friction = np.zeros(7)
            if "coulomb" in terms:
                tau_friction += friction.coulomb * np.tanh(dq / ESTIMATOR["coulomb_smoothing"])
            if "viscous" in terms:
                tau_friction += friction.viscous * dq
            if "offset" in terms:
                tau_friction += friction.offset
            external = tau_meas - pin.rnea(self.model, self.data, q_meas, dq, ddq) - tau_friction
            jacobian = pin.computeFrameJacobian(
                self.model, self.data, q_meas, self.frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
            )
            wrench = np.linalg.solve(jacobian @ jacobian.T, jacobian @ external)
            wrench_state = wrench_state + self.wrench_gain * (wrench - wrench_state)
            # eq. (15) then eq. (13), the IK of one pose per period
            error = FORCE_PI.desired_force - wrench_state[:3]
            bound = FORCE_PI.max_displacement
            integral = np.clip(integral + self.force_ki * error * PERIOD, -bound, bound)
            pose = case.reference[k].copy()
            pose[:3, 3] += np.clip(integral, -bound, bound)
            q_desired = self.joint_reference(pose)
            dq_desired = (q_desired - previous_desired) / PERIOD
            previous_desired = q_desired.copy()
            gravity = pin.computeGeneralizedGravity(case.model.model, self.gravity_data, q_meas).copy()
            tau = self.kp * (q_desired - q_meas) + self.kd * (dq_desired - dq) + gravity
            out["actual"][k], out["measured"][k], wrench_log[k] = (
                self.plant.tcp_position,
                force_meas,
                wrench_state,
            )
            q_meas, tau_meas, force_meas, _ = self.plant_step(tau, rng)
        empty = np.empty((n, 7))
        return ContactRun(
            np.arange(n) * PERIOD,
            case.reference[:, :3, 3],
            out["actual"],
            out["actual"],
            wrench_log,
            out["measured"],
            empty,
            empty,
            empty,
            case.painting,
        )
