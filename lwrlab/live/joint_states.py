"""A ``sensor_msgs/JointState`` read into the robot's joint order, as ``plant=log`` reads a log.

Joints are matched by **name**: a message may list them in any order and carry more (a gripper);
one that carries none of them (another robot on the same topic) is skipped, one that carries only
some is refused naming the missing ones. Positions and efforts must have one value per name and be
finite. Measured at the motors (the model's drive train: ``position_side``/``torque_side: motor``,
encoder counts, motor currents with torque constants or ``drive_gains``), they are taken to the
joint side as :mod:`lwrlab.io.logs` does; a wrapping encoder's angle is unwrapped from one message
to the next (a jump of more than half a turn is a wrap).

:meth:`JointStateReader.read` returns a :class:`JointSample` or a :class:`Refusal` (a reason and
whether the message was another robot's): the monitor counts and reports refusals, it never
estimates from them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from lwrlab.io.encoder_angles import TURN, angle_scale, wrapping_columns
from lwrlab.model.robot import RobotModel


@dataclass(frozen=True)
class JointSample:
    """One message in the robot's joint order, joint side."""

    t: float
    """Header stamp (s)."""
    q: np.ndarray
    """(N_J,) positions (rad)."""
    tau: np.ndarray
    """(N_J,) joint torques (N·m)."""


@dataclass(frozen=True)
class Refusal:
    """Why a message gives no sample."""

    reason: str
    """One line naming what is wrong (joints, array, value)."""
    kind: str
    """What kind of wrong: ``other robot``, ``joints missing``, ``arrays``, ``non-finite``."""

    @property
    def other_robot(self) -> bool:
        """The message names none of the robot's joints: another publisher's, skipped."""
        return self.kind == "other robot"


class JointStateReader:
    """The robot's joints out of JointState messages (see the module).

    Parameters
    ----------
    robot : the model: its joint names (or ``joint_names``) and drive train.
    joint_names : the names the messages use, in the model's joint order; None: the model's.
    drive_gains : N·m/A per joint: efforts are motor currents, torques ``gain·current``; None: as the
        drive train says (torque constants, or torques).
    """

    def __init__(
        self,
        robot: RobotModel,
        joint_names: Sequence[str] | None = None,
        drive_gains: Sequence[float] | None = None,
    ) -> None:
        self.names = tuple(joint_names) if joint_names else tuple(robot.joint_names)
        n = robot.n_joints
        if len(self.names) != n:
            raise ValueError(f"task.joint_names: {len(self.names)} names for the {n} joints of {robot.name}")
        if len(set(self.names)) != n:
            raise ValueError(f"task.joint_names: names repeat in {list(self.names)}")
        if drive_gains is not None and len(drive_gains) != n:
            raise ValueError(f"data.drive_gains has {len(drive_gains)} values for {n} joints")
        self.drive = robot.drive_train
        self.gains = None if drive_gains is None else np.asarray(drive_gains, dtype=float)
        if self.gains is None and self.drive.torque_constants is not None:
            self.gains = np.asarray(self.drive.torque_constants, dtype=float)
        self._scale = angle_scale(self.drive)
        continuous = np.isinf(robot.limits.position_lower) & np.isinf(robot.limits.position_upper)
        self._wraps = wrapping_columns(self.drive, continuous) & (self.drive.position_side == "motor")
        self._turns = np.zeros(n)
        self._last_angle: np.ndarray | None = None
        self._orders: dict[tuple[str, ...], np.ndarray | Refusal] = {}

    def _order(self, names: tuple[str, ...]) -> np.ndarray | Refusal:
        """Where each of the robot's joints sits in a message listing ``names``."""
        known = self._orders.get(names)
        if known is not None:
            return known
        where = {name: i for i, name in enumerate(names)}
        found = [where.get(name) for name in self.names]
        if all(i is None for i in found):
            order: np.ndarray | Refusal = Refusal(
                f"none of the robot's joints {list(self.names)} in a message of {list(names)[:8]}",
                "other robot",
            )
        elif any(i is None for i in found):
            missing = [name for name, i in zip(self.names, found, strict=True) if i is None]
            order = Refusal(f"joints missing: {missing} (the message has {list(names)})", "joints missing")
        else:
            order = np.array(found, dtype=int)
        self._orders[names] = order
        return order

    def read(
        self, stamp: float, names: Sequence[str], position: Sequence[float], effort: Sequence[float]
    ) -> JointSample | Refusal:
        """A message's sample (stamp s, its names, positions and efforts), or why there is none."""
        order = self._order(tuple(names))
        if isinstance(order, Refusal):
            return order
        if len(position) != len(names) or len(effort) != len(names):
            return Refusal(
                f"{len(names)} names but {len(position)} positions and {len(effort)} efforts "
                "(the monitor needs both for every joint)",
                "arrays",
            )
        q = np.asarray(position, dtype=float)[order]
        tau = np.asarray(effort, dtype=float)[order]
        bad = ~np.isfinite(q) | ~np.isfinite(tau)
        if bad.any():
            joints = [self.names[j] for j in np.flatnonzero(bad)]
            return Refusal(f"non-finite position or effort of {joints}", "non-finite")
        return JointSample(float(stamp), self._joint_positions(q), self._joint_torques(tau))

    def _joint_positions(self, measured: np.ndarray) -> np.ndarray:
        angles = measured * self._scale
        if self._wraps.any():
            if self._last_angle is not None:
                jump = angles - self._last_angle
                self._turns[self._wraps] -= np.round(jump[self._wraps] / TURN)
            self._last_angle = angles
            angles = angles + TURN * self._turns
        return self.drive.read_positions(angles)

    def _joint_torques(self, effort: np.ndarray) -> np.ndarray:
        torque = effort if self.gains is None else self.gains * effort
        if self.drive.torque_side == "motor" or self.drive.torque_constants is not None:
            return self.drive.joint_torques(torque)  # τ = Rᵀ·τ_motor, as a log is read
        return torque


__all__ = ["JointSample", "JointStateReader", "Refusal"]
