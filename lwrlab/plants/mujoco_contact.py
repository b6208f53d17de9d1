"""A contact plant in MuJoCo: the robot, its tool and a wall with a force sensor (§VI.B).

The MuJoCo model is written from the same :class:`~lwrlab.model.robot.RobotModel` the rest of the
lab uses (one body per joint frame, placements and inertias copied from the Pinocchio model), so
MuJoCo's and Pinocchio's inverse dynamics agree to round-off (tested). What the plant adds:

- the tool: a body fixed to the flange with its inertial parameters (flange frame) and one contact
  geometry, a capsule of ``contact_radius`` along the tool's contact axis whose surface touches
  the tool's contact point (a roller cover);
- the wall: a static box whose painted face is the plane ``x = wall.x`` (normal +x, towards the
  robot), with a 3-axis force sensor at its centre (the paper's ATI Mini45), tared at start;
- the drives: the commanded torque acts on the link dynamics plus the rotor inertia (MuJoCo
  ``armature``); the joint-torque sensor, on the link side, reads ``τ − I_a·q̈`` plus white noise;
- joint friction ``FV·q̇ + FC·tanh(q̇/ε)`` (the plant's true values) as a generalised force;
- encoder noise on the positions.

The controller runs at ``1 / control_period`` (1 kHz), MuJoCo integrates ``substeps`` steps per
control period. Everything is in SI units and in the robot's base frame (= MuJoCo's world).

The stepping (sensor reading, substeps, noise) is that of
:class:`~lwrlab.plants.contact_batch.ContactPlantBatch`, which steps the several plants of a painting
task together; a plant stepped alone is a batch of one.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from lwrlab.kinematics.tree import joint_axes
from lwrlab.model.inertia import mass_com_inertia
from lwrlab.model.robot import RobotModel
from lwrlab.plants.contact_batch import ContactPlantBatch, ContactSensors
from lwrlab.plants.simulation import COULOMB_SMOOTHING

# Constants of the contact model; its settings (friction, time constant) are the painting task's.
CONTACT_DAMPING_RATIO = 1.0
"""Damping ratio of MuJoCo's soft contact (``solref``'s second value): critically damped, no bounce."""
CONTACT_IMPEDANCE = (0.95, 0.99, 0.001)
"""MuJoCo ``solimp`` (impedance at zero and full penetration, its width in m): a stiff contact."""
TORSIONAL_ROLLING_FRICTION = "0.005 0.0001"
"""MuJoCo's torsional and rolling friction of the geoms (no part in a ``condim="3"`` contact)."""


@dataclass(frozen=True, kw_only=True)
class Wall:
    """A flat wall facing the robot: painted face in the plane ``x = x``, normal +x.

    The painting task's ``wall`` (conf/task/painting.yaml) gives the face; only the box's depth,
    which the contact does not feel, has a value here.
    """

    x: float
    """Position of the painted face along the base x axis (m)."""
    center_y: float
    """Horizontal centre (m)."""
    center_z: float
    """Vertical centre (m)."""
    width: float
    """Extent along y (m)."""
    height: float
    """Extent along z (m)."""
    thickness: float = 0.02
    """Extent along x, behind the face (m)."""

    @property
    def y_bounds(self) -> tuple[float, float]:
        """Lowest and highest y of the face (m)."""
        return self.center_y - self.width / 2, self.center_y + self.width / 2

    @property
    def z_bounds(self) -> tuple[float, float]:
        """Lowest and highest z of the face (m)."""
        return self.center_z - self.height / 2, self.center_z + self.height / 2


@dataclass(frozen=True)
class ContactTool:
    """What the plant needs of a tool: inertia and the contact geometry, in the flange frame."""

    parameters: np.ndarray
    """(10,) standard parameters about the flange origin (kg, kg·m, kg·m²)."""
    contact_point: np.ndarray
    """Middle of the contact line (m)."""
    contact_axis: np.ndarray
    """Unit direction of the contact line (a roller's axis)."""
    width: float
    """Length of the contact line (m)."""
    contact_radius: float
    """Radius of the capsule modelling the roller cover (m): the painting task's ``contact_radius``."""


def _vector(values: ArrayLike) -> str:
    return " ".join(f"{v:.17g}" for v in np.ravel(values))


def _quaternion(rotation: np.ndarray) -> str:
    x, y, z, w = pin.Quaternion(np.asarray(rotation, dtype=float)).coeffs()
    return _vector([w, x, y, z])


def _inertial(phi: np.ndarray) -> str:
    mass, com, inertia = mass_com_inertia(phi)
    full = [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]]
    return f'<inertial pos="{_vector(com)}" mass="{mass:.17g}" fullinertia="{_vector(full)}"/>'


def _tool_body(tool: ContactTool, flange: pin.SE3) -> str:
    axis = np.asarray(tool.contact_axis, dtype=float) / np.linalg.norm(tool.contact_axis)
    centre = np.asarray(tool.contact_point, dtype=float) - tool.contact_radius * np.array([0.0, 0.0, 1.0])
    half = tool.width / 2 - tool.contact_radius  # capsule caps end at the cover's ends
    ends = np.concatenate([centre - max(half, 1e-4) * axis, centre + max(half, 1e-4) * axis])
    return (
        f'<body name="tool" pos="{_vector(flange.translation)}" quat="{_quaternion(flange.rotation)}">'
        f"{_inertial(tool.parameters)}"
        f'<geom name="roller" type="capsule" fromto="{_vector(ends)}" size="{tool.contact_radius:.17g}" '
        f'contype="1" conaffinity="1" mass="0"/>'
        f'<site name="tcp" pos="{_vector(tool.contact_point)}"/>'
        "</body>"
    )


def mujoco_xml(
    robot: RobotModel,
    tool: ContactTool | None = None,
    wall: Wall | None = None,
    *,
    timestep: float,
    with_armature: bool,
    friction: float | None = None,
    contact_time_constant: float | None = None,
) -> str:
    """MJCF text of ``robot`` (+ ``tool`` on the flange, + ``wall``), from its Pinocchio model.

    Parameters
    ----------
    robot : a serial chain of revolute joints (any axis); its inertias become the bodies' inertials.
    tool : the tool fixed to the flange, or None.
    wall : the wall with its force sensor, or None.
    timestep : MuJoCo integration step (s).
    with_armature : put the robot's ``rotor_inertia`` on the joints.
    friction : sliding friction coefficient between tool and wall (a wet roller slides easily).
    contact_time_constant : time constant of MuJoCo's soft contact (``solref``, s).
        The contact's two settings (the painting task's ``contact``) are required with a wall and
        may be left out without one (nothing to touch: MuJoCo's own contact defaults then apply).
    """
    if wall is not None and (friction is None or contact_time_constant is None):
        raise ValueError("a wall needs the contact's friction and contact_time_constant")
    model = robot.model
    gravity = robot.gravity
    armature = (
        robot.rotor_inertia
        if (with_armature and robot.rotor_inertia is not None)
        else np.zeros(robot.n_joints)
    )
    bodies, closing = [], []
    try:
        axes = joint_axes(model)
    except ValueError as error:
        raise ValueError(f"the MuJoCo plant needs a serial chain of revolute joints: {error}") from None
    for j in range(1, model.njoints):
        if not axes[j - 1].revolute or model.parents[j] != j - 1:
            raise ValueError(
                "the MuJoCo plant needs a serial chain of revolute joints; "
                f"joint {j} is {model.joints[j].shortname()}"
            )
        placement = model.jointPlacements[j]
        bodies.append(
            f'<body name="link{j}" pos="{_vector(placement.translation)}" '
            f'quat="{_quaternion(placement.rotation)}">'
            f'<joint name="joint{j}" type="hinge" axis="{_vector(axes[j - 1].axis)}" '
            f'armature="{armature[j - 1]:.17g}" limited="false"/>'
            f"{_inertial(np.asarray(robot.link_parameters[j - 1]))}"
        )
        closing.append("</body>")
    if tool is not None:
        if not model.existFrame("flange"):
            raise ValueError(f"robot {robot.name!r} has no flange frame to carry a tool")
        bodies.append(_tool_body(tool, model.frames[model.getFrameId("flange")].placement))
    wall_xml, sensor_xml = "", ""
    if wall is not None:
        centre = [wall.x - wall.thickness / 2, wall.center_y, wall.center_z]
        size = [wall.thickness / 2, wall.width / 2, wall.height / 2]
        wall_xml = (
            f'<body name="wall" pos="{_vector(centre)}">'
            f'<geom name="wall" type="box" size="{_vector(size)}" contype="1" conaffinity="1" mass="1"/>'
            f'<site name="wall_sensor" pos="{wall.thickness / 2:.17g} 0 0"/>'
            "</body>"
        )
        sensor_xml = '<sensor><force name="wall_force" site="wall_sensor"/></sensor>'
    contact_xml = ""
    if friction is not None and contact_time_constant is not None:
        solref = (contact_time_constant, CONTACT_DAMPING_RATIO)
        contact_xml = (
            f'<default><geom friction="{friction:.17g} {TORSIONAL_ROLLING_FRICTION}" '
            f'solref="{_vector(solref)}" solimp="{_vector(CONTACT_IMPEDANCE)}" condim="3"/></default>'
        )
    return (
        f'<mujoco model="{robot.name}">'
        f'<option timestep="{timestep:.17g}" gravity="{_vector(gravity)}" integrator="Euler">'
        '<flag contact="enable"/></option>'
        f"{contact_xml}"
        f"<worldbody>{wall_xml}{''.join(bodies)}{''.join(closing)}</worldbody>"
        f"{sensor_xml}</mujoco>"
    )


def mujoco_inverse_dynamics(
    robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, *, with_armature: bool
) -> np.ndarray:
    """Joint torques (N·m, (N, N_J)) by MuJoCo's ``mj_inverse`` on the model of :func:`mujoco_xml`
    (no friction); with the rotor inertia when ``with_armature``."""
    # mj_inverse integrates nothing: the model's time step plays no part in its torques
    xml = mujoco_xml(robot, timestep=1e-3, with_armature=with_armature)
    mj_model = mujoco.MjModel.from_xml_string(xml)
    mj_data = mujoco.MjData(mj_model)
    q, dq, ddq = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, dq, ddq))
    tau = np.empty_like(q)
    for k in range(q.shape[0]):
        mj_data.qpos[:], mj_data.qvel[:], mj_data.qacc[:] = q[k], dq[k], ddq[k]
        mujoco.mj_inverse(mj_model, mj_data)
        tau[k] = mj_data.qfrc_inverse
    return tau


class MujocoContactPlant:
    """The robot with its tool pressing on a wall, simulated by MuJoCo, read by noisy sensors.

    Parameters
    ----------
    robot : the true robot (perturbed parameters, true friction, rotor inertia).
    tool : the true tool on the flange.
    wall : the wall and its force sensor.
    control_period : period of the controller (s); sensors are read once per period.
    substeps : MuJoCo steps per control period.
    torque_noise_std : joint-torque sensor noise σ_τ (N·m), scalar or per joint.
    encoder_noise_std : encoder noise σ_q (rad).
    force_noise_std : wall force-sensor noise (N).
    friction : tool–wall sliding friction coefficient.
    contact_time_constant : time constant of MuJoCo's soft contact (s): the cover's compliance.
    seed : seed of the sensor noise.

    The settings are the painting task's ``contact`` (conf/task/painting.yaml), the one place of
    their values; :func:`lwrlab.pipeline.painting.runs.contact_plant` builds the plant from them.
    The joint friction's Coulomb term is smoothed with the plants' constant
    :data:`~lwrlab.plants.simulation.COULOMB_SMOOTHING`.
    """

    def __init__(
        self,
        robot: RobotModel,
        tool: ContactTool,
        wall: Wall,
        *,
        control_period: float,
        substeps: int,
        torque_noise_std: float | np.ndarray,
        encoder_noise_std: float,
        force_noise_std: float,
        friction: float,
        contact_time_constant: float,
        seed: int,
    ) -> None:
        self.robot, self.tool, self.wall = robot, tool, wall
        self.control_period, self.substeps = control_period, substeps
        self.model = mujoco.MjModel.from_xml_string(
            mujoco_xml(
                robot,
                tool,
                wall,
                timestep=control_period / substeps,
                with_armature=True,
                friction=friction,
                contact_time_constant=contact_time_constant,
            )
        )
        self.data = mujoco.MjData(self.model)
        self.torque_noise_std = np.broadcast_to(np.asarray(torque_noise_std, dtype=float), (robot.n_joints,))
        self.encoder_noise_std = encoder_noise_std
        self.force_noise_std = force_noise_std
        self.coulomb_smoothing = COULOMB_SMOOTHING
        """ε of the true Coulomb friction ``FC·tanh(q̇/ε)`` (rad/s)."""
        self.armature = (
            np.zeros(robot.n_joints)
            if robot.rotor_inertia is None
            else np.asarray(robot.rotor_inertia, dtype=float)
        )
        self.rng = np.random.default_rng(seed)
        """Generator of the sensor noise."""
        self.noise_scale = np.concatenate(
            [np.full(robot.n_joints, encoder_noise_std), self.torque_noise_std, np.full(3, force_noise_std)]
        )
        """(2 N_J + 3,) standard deviations of one sample's noise: encoders, torques, wall sensor."""
        self.sensor_address = int(self.model.sensor("wall_force").adr[0])
        """Index of the wall force sensor's 3 values in ``data.sensordata``."""
        self.wall_site, self.tcp_site = self.model.site("wall_sensor").id, self.model.site("tcp").id
        self._stepper: ContactPlantBatch | None = None

    def friction_torque(self, dq: np.ndarray) -> np.ndarray:
        """Joint friction ``FV·q̇ + FC·tanh(q̇/ε) + FO`` (N·m) at the velocities ``dq`` (rad/s)."""
        friction = self.robot.friction
        return (
            friction.viscous * dq + friction.coulomb * np.tanh(dq / self.coulomb_smoothing) + friction.offset
        )

    def reset(self, q0: np.ndarray, hold_torque: np.ndarray) -> ContactSensors:
        """Place the robot at rest at ``q0`` (rad), tare the wall sensor, read the sensors.

        ``hold_torque`` (N·m) is the torque the controller applies first (gravity compensation):
        the link-side reading is computed with it.
        """
        self._stepper = ContactPlantBatch([self])
        sensors = self._stepper.reset(
            np.asarray(q0, dtype=float)[None], np.asarray(hold_torque, dtype=float)[None]
        )
        return ContactSensors(*(value[0] for value in sensors))

    def step(self, tau: np.ndarray) -> ContactSensors:
        """Apply the joint torques ``tau`` (N·m) for one control period; read the sensors after it.

        The torque sensor reads the link-side torque ``τ − I_a·q̈`` at the new state under the
        same command (a zero-order hold, as the drives' current loop does).
        """
        if self._stepper is None:
            raise RuntimeError("reset the plant before stepping it")
        sensors = self._stepper.step(np.asarray(tau, dtype=float)[None])
        return ContactSensors(*(value[0] for value in sensors))

    def move_wall(self, distance: float) -> None:
        """Move the wall ``distance`` (m) along its normal (+x, towards the robot), from the next step on.

        A fault drill: the wall is not where the path was planned (a static body, placed anew by
        MuJoCo's kinematics at every step). Its force sensor keeps its tare.
        """
        self.model.body("wall").pos[0] += float(distance)

    @property
    def tcp_position(self) -> np.ndarray:
        """True position of the tool's contact point (m, base frame)."""
        return self.data.site_xpos[self.tcp_site].copy()
