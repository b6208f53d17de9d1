"""Several contact plants stepped together: MuJoCo once per plant, the numpy around it once for all.

A painting task simulates several runs of one path (controller model × force feedback); each run has
its own :class:`~lwrlab.plants.mujoco_contact.MujocoContactPlant` (its own ``MjData``), but per
control period the friction torques, the commands written to MuJoCo and the sensor readings of all
of them are a handful of numpy operations on stacked (R, N_J) arrays instead of that many per plant.
Each plant's MuJoCo calls, friction and noise are those of the plant stepped alone (tested).

Per control period every plant reads its sensors at the new state (a full ``mj_forward``, which the
link-side torque needs for q̈), then steps. The first substep starts from that very state, so its
position and velocity stages (kinematics, inertia, collisions) are those of the reading: only the
acceleration stage is redone with the new torque (``mj_forwardSkip``) before integrating
(``mj_Euler``) — the same result as ``mj_step``, with one position/velocity stage less per period.
The later substeps are ``mj_step`` without its sensor stage (``mj_forwardSkip(…, skipsensor=1)``
and ``mj_Euler``: the same state, no wall-force computation nobody reads). Sensor noise is drawn in
blocks, in the order a sample at a time would draw it (same values).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, NamedTuple

import mujoco
import numpy as np

if TYPE_CHECKING:  # the plant module steps itself as a batch of one: a runtime import would cycle
    from lwrlab.plants.mujoco_contact import MujocoContactPlant

_AFTER_VELOCITY_STAGE = int(mujoco.mjtStage.mjSTAGE_VEL)
"""``mj_forwardSkip`` stage: redo the acceleration stage only (looked up once, not per step)."""
_FROM_THE_START = int(mujoco.mjtStage.mjSTAGE_NONE)
"""``mj_forwardSkip`` stage: every stage, as ``mj_forward``."""

NOISE_BLOCK = 1024
"""Samples of sensor noise drawn per call of each plant's random generator."""


class ContactSensors(NamedTuple):
    """One sample of what the sensors read (and the true state, for scoring); a tuple, cheap at 1 kHz.

    From a batch every field has a leading axis of one row per plant.
    """

    q: np.ndarray
    """(N_J,) encoder positions (rad)."""
    tau: np.ndarray
    """(N_J,) link-side joint torques (N·m)."""
    wall_force: np.ndarray
    """(3,) force the tool exerts on the wall, base frame (N), tared."""
    q_true: np.ndarray
    """(N_J,) true positions (rad)."""
    dq_true: np.ndarray
    """(N_J,) true velocities (rad/s)."""


class ContactPlantBatch:
    """R contact plants with the same control period and substeps, stepped in lockstep.

    Parameters
    ----------
    plants : the plants, one per run; each keeps its own MuJoCo model, data and noise generator.
        A plant is stepped by one batch at a time (a new batch starts from its ``reset``).
    """

    def __init__(self, plants: Sequence[MujocoContactPlant]) -> None:
        if not plants:
            raise ValueError("a plant batch needs at least one plant")
        first = plants[0]
        for plant in plants[1:]:
            if (plant.control_period, plant.substeps) != (first.control_period, first.substeps):
                raise ValueError(
                    "plants stepped together need one control period and substep count, got "
                    f"{(first.control_period, first.substeps)} and {(plant.control_period, plant.substeps)}"
                )
        self.plants = list(plants)
        self.substeps = first.substeps
        n_plants, n_joints = len(plants), first.robot.n_joints
        self._steppers = [(plant.model, plant.data) for plant in plants]
        # MjData arrays are views into MuJoCo's memory: fetched once, not per period
        self._positions = [plant.data.qpos for plant in plants]
        self._velocities = [plant.data.qvel for plant in plants]
        self._accelerations = [plant.data.qacc for plant in plants]
        self._readings = [
            plant.data.sensordata[plant.sensor_address : plant.sensor_address + 3] for plant in plants
        ]
        self._tool_points = [plant.data.site_xpos[plant.tcp_site] for plant in plants]
        if n_plants == 1:  # one plant: its own MuJoCo array is the stacked command, nothing to copy
            self._applied, self._to_mujoco = first.data.qfrc_applied[None], []
        else:
            self._applied = np.zeros((n_plants, n_joints))
            self._to_mujoco = list(
                zip([plant.data.qfrc_applied for plant in plants], self._applied, strict=True)
            )
        self._viscous, self._coulomb, self._offset = (
            np.stack([np.asarray(getattr(plant.robot.friction, name), dtype=float) for plant in plants])
            for name in ("viscous", "coulomb", "offset")
        )
        # every per-run constant at the full (R, N_J) shape: a broadcast costs more than the operation
        self._smoothing = np.array([[plant.coulomb_smoothing] * n_joints for plant in plants])
        self._armature = np.stack([plant.armature for plant in plants])
        self._noise_scale = np.stack([plant.noise_scale for plant in plants])
        self._force_noise = bool(np.any(self._noise_scale[:, 2 * n_joints :]))
        self._to_tool_force = np.stack([-np.eye(3)] * n_plants)
        self.tare = np.zeros((n_plants, 3))
        """(R, 3) each wall sensor's force at the reset (N), taken off every reading."""
        self._minus_tare, self._axis_aligned = -self.tare, True
        self._friction_now = np.zeros((n_plants, n_joints))
        self._noise: tuple[np.ndarray, np.ndarray, np.ndarray] = (np.empty(0), np.empty(0), np.empty(0))
        self._noise_row = NOISE_BLOCK  # the first reading draws the first block
        self.tcp_position = np.zeros((n_plants, 3))
        """(R, 3) true position of each tool's contact point (m, base frame) at the last reading."""

    def friction(self, dq: np.ndarray) -> np.ndarray:
        """(R, N_J) joint friction ``FV·q̇ + FC·tanh(q̇/ε) + FO`` (N·m) at the velocities ``dq`` (R, N_J)."""
        return self._viscous * dq + self._coulomb * np.tanh(dq / self._smoothing) + self._offset

    def _command(self, tau: np.ndarray, friction: np.ndarray) -> None:
        """Write ``tau − friction`` (R, N_J) into each plant's applied generalised force."""
        np.subtract(tau, friction, out=self._applied)
        for applied, row in self._to_mujoco:
            applied[...] = row

    def _draw_noise(self) -> None:
        """The next block of scaled sensor noise: encoders, torques, wall sensor, each (NOISE_BLOCK, R, ·)."""
        # a sample at a time drew q, τ then force noise: the rows of one block are the same numbers
        block = np.stack(
            [
                plant.rng.normal(size=(NOISE_BLOCK, scale.size)) * scale
                for plant, scale in zip(self.plants, self._noise_scale, strict=True)
            ],
            axis=1,
        )
        n = self._armature.shape[1]
        # each kind contiguous: an operation on a strided row costs several on a contiguous one
        q_noise, tau_noise, force_noise = (
            np.ascontiguousarray(block[:, :, columns])
            for columns in (slice(0, n), slice(n, 2 * n), slice(2 * n, None))
        )
        self._noise = (q_noise, tau_noise, force_noise)
        self._noise_row = 0

    def _read(self, tau: np.ndarray, velocity: np.ndarray) -> ContactSensors:
        """The sensors at the current states under the command ``tau``; ``velocity`` (R, N_J): the true q̇."""
        if self._noise_row == NOISE_BLOCK:
            self._draw_noise()
        row, (q_noise, tau_noise, force_noise) = self._noise_row, self._noise
        self._noise_row = row + 1
        q = np.array(self._positions)
        link_torque = tau - self._armature * np.array(self._accelerations)
        # MuJoCo's force sensor gives the force on the wall from its parent (the world), in the
        # site frame; the wall is static, so the tool's force on it is the opposite, less the tare
        readings = np.array(self._readings)
        if self._axis_aligned:  # −I·reading − tare, with one operation fewer
            force = self._minus_tare - readings
        else:
            force = np.matmul(self._to_tool_force, readings[:, :, None])[:, :, 0] - self.tare
        if self._force_noise:
            force += force_noise[row]
        self.tcp_position = np.array(self._tool_points)
        return ContactSensors(q + q_noise[row], link_torque + tau_noise[row], force, q, velocity)

    def reset(self, q0: np.ndarray, hold_torque: np.ndarray) -> ContactSensors:
        """Place each robot at rest at ``q0`` (R, N_J) rad, tare the wall sensors, read the sensors.

        ``hold_torque`` (R, N_J) N·m is the torque the controllers apply first (gravity compensation):
        the link-side readings are computed with it.
        """
        hold_torque = np.asarray(hold_torque, dtype=float)
        for p, (plant, (model, data)) in enumerate(zip(self.plants, self._steppers, strict=True)):
            mujoco.mj_resetData(model, data)
            data.qpos[:] = q0[p]
            mujoco.mj_forward(model, data)
            # the wall is static: its sensor's frame is read once
            self._to_tool_force[p] = -data.site_xmat[plant.wall_site].reshape(3, 3)
            self.tare[p] = self._to_tool_force[p] @ self._readings[p]
        self._axis_aligned = bool(np.all(self._to_tool_force == -np.eye(3)))  # as mujoco_xml writes the wall
        self._minus_tare = -self.tare
        velocity = np.array(self._velocities)
        self._friction_now = self.friction(velocity)
        self._command(hold_torque, self._friction_now)
        for model, data in self._steppers:
            mujoco.mj_forward(model, data)
        return self._read(hold_torque, velocity)

    def step(self, tau: np.ndarray) -> ContactSensors:
        """Apply the joint torques ``tau`` (R, N_J) N·m for one control period; read the sensors after it.

        The torque sensors read the link-side torque ``τ − I_a·q̈`` at the new states under the same
        command (a zero-order hold, as the drives' current loop does).
        """
        steppers = self._steppers
        # first substep from the states of the last reading: positions, velocities and friction unchanged
        self._command(tau, self._friction_now)
        for model, data in steppers:
            mujoco.mj_forwardSkip(model, data, _AFTER_VELOCITY_STAGE, 1)
            mujoco.mj_Euler(model, data)
        for _ in range(self.substeps - 1):
            self._command(tau, self.friction(np.array(self._velocities)))
            for model, data in steppers:
                mujoco.mj_forwardSkip(model, data, _FROM_THE_START, 1)
                mujoco.mj_Euler(model, data)
        velocity = np.array(self._velocities)
        self._friction_now = self.friction(velocity)
        self._command(tau, self._friction_now)
        for model, data in steppers:
            mujoco.mj_forward(model, data)
        return self._read(tau, velocity)
