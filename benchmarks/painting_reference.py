"""The painting benchmark's case and the per-sample contact loop the batched loop replaced.

:func:`make_case` builds the KUKA LWR4 (``conf/robot/kuka_lwr4.yaml``) carrying the large roller in
front of the wall of §VI.B, along the large roller's optimised path (README, Table IV);
:class:`PerSampleLoop` is the contact loop as it was first written, everything one sample at a time,
kept as the reference ``benchmarks/painting.py`` measures the loop against.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

from lwrlab.control.contact_loop import ContactRun
from lwrlab.control.force_estimation import add_tool_frame
from lwrlab.control.joint_pd import ControlSetup
from lwrlab.kinematics.swivel_ik import Branch, SwivelIK
from lwrlab.model.payload import attach_payload
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.tool_library import load_tool
from lwrlab.planning.painting_path import PaintingPathParameters, sample_path
from lwrlab.plants.contact_batch import ContactPlantBatch
from lwrlab.plants.mujoco_contact import ContactTool, MujocoContactPlant, Wall
from plugins.robots.mdh import load_robot_yaml

REPO = Path(__file__).resolve().parents[1]
PATH = PaintingPathParameters(
    duration=38.45, swivel=-1.673, z_upper=0.5355, z_lower=0.2403, y_start=0.1331, y_step=0.1835, n_steps=2
)
"""The large roller's optimised path (identified model, README Table IV)."""
BRANCH = Branch(1, -1, -1)
PERIOD = 1e-3
JOINT_KP, JOINT_KD, FORCE_KI, DESIRED = 2000.0, 60.0, 2e-3, -30.0
WALL = Wall(x=-0.8, center_y=0.3, center_z=0.4, width=0.6, height=0.8)
"""The wall of §VI.B (conf/task/painting.yaml)."""


@dataclass
class Case:
    """Everything a run needs: the true plant's robot and roller, the controller's model, the path."""

    truth: RobotModel
    model: RobotModel
    tool_contact: ContactTool
    tcp: np.ndarray
    wall: Wall
    reference: np.ndarray
    painting: np.ndarray
    start: np.ndarray

    def plant(self) -> MujocoContactPlant:
        return MujocoContactPlant(
            self.truth, self.tool_contact, self.wall, contact_time_constant=0.02, seed=0
        )

    def setup(self) -> ControlSetup:
        return ControlSetup(self.model, SwivelIK(self.model), self.tcp, PATH.swivel, BRANCH, PERIOD)


def make_case(seconds: float) -> Case:
    """The CAD LWR4 + large roller (plant and controller alike), 2 s at the start point, then the path."""
    robot = load_robot_yaml(REPO / "conf" / "robot" / "kuka_lwr4.yaml")
    tool = load_tool("large_roller")
    tcp = np.eye(4)
    tcp[:3, 3] = tool.contact_point
    wall = WALL
    poses = sample_path(PATH, wall.x, 1.0 / PERIOD).poses()
    reference = np.concatenate([np.repeat(poses[:1], 2000, axis=0), poses])[: round(seconds / PERIOD)]
    start = reference[0].copy()
    start[0, 3] += 0.005  # 5 mm off the wall
    contact = ContactTool(tool.parameters, tool.contact_point, tool.contact_axis, tool.width)
    return Case(
        robot,
        attach_payload(robot, tool.parameters),
        contact,
        tcp,
        wall,
        reference,
        np.arange(len(reference)) >= 2000,
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
        self.velocity_gain = 1.0 - np.exp(-2 * np.pi * 50.0 * PERIOD)
        self.acceleration_gain = 1.0 - np.exp(-2 * np.pi * 10.0 * PERIOD)
        self.wrench_gain = 1.0 - np.exp(-2 * np.pi * 20.0 * PERIOD)

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
                tau_friction += friction.coulomb * np.tanh(dq / 0.01)
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
            error = np.array([DESIRED, 0.0, 0.0]) - wrench_state[:3]
            integral = np.clip(integral + np.array([FORCE_KI, 0.0, 0.0]) * error * PERIOD, -0.05, 0.05)
            pose = case.reference[k].copy()
            pose[:3, 3] += np.clip(integral, -0.05, 0.05)
            q_desired = self.joint_reference(pose)
            dq_desired = (q_desired - previous_desired) / PERIOD
            previous_desired = q_desired.copy()
            gravity = pin.computeGeneralizedGravity(case.model.model, self.gravity_data, q_meas).copy()
            tau = JOINT_KP * (q_desired - q_meas) + JOINT_KD * (dq_desired - dq) + gravity
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
