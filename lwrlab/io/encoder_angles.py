"""A log's position columns as its encoders give them, read as joint positions.

An encoder counts from its own zero and, reading one turn, wraps: a motor's angle jumps by a turn
(from +π to −π, or from the last count of a turn to 0) every turn it makes. With the drive train
(:class:`~lwrlab.model.drive_train.DriveTrain`) saying where the positions were measured, their
counts per turn (``encoder_counts``) and the joint positions at the encoders' zero
(``position_offsets``, ``θ = R·(q − q₀)``), :func:`joint_positions_of_log` gives the joint
positions of the raw columns:

1. counts to angles (``2π / counts`` rad a count), where the encoders give counts;
2. wraps undone (:func:`unwrapped`) on every motor (a motor turns many times per joint turn) and on
   the continuous joints of positions measured at the joints, where a column's values stay within
   one turn (a wrapping encoder's do; a column that spans more has been unwrapped already, and a
   fast motor's half turns between samples are its motion); a jump of more than half a turn
   between two samples is taken as a wrap, so an encoder must turn less than half a turn a sample
   (at 1 kHz, 30 000 rpm);
3. ``q = R⁻¹·θ + q₀`` (:meth:`~lwrlab.model.drive_train.DriveTrain.read_positions`).

Velocity columns are scaled alike (counts/s to rad/s) and taken to the joint side, with no offset.

Examples
--------
>>> import numpy as np
>>> from lwrlab.model.drive_train import DriveTrain
>>> drive = DriveTrain(gear_ratios=np.array([100.0]), coupling=np.eye(1), position_side="motor",
...                    position_offsets=np.array([0.5]))
>>> theta = 100.0 * (np.linspace(0.5, 0.7, 41) - 0.5)  # the motor turns 3 times, 0.5 rad a sample
>>> wrapped = np.angle(np.exp(1j * theta))[:, None]
>>> joint_positions_of_log(wrapped, drive, np.array([False]))[::10].ravel().round(6).tolist()
[0.5, 0.55, 0.6, 0.65, 0.7]
"""

from __future__ import annotations

import numpy as np

from lwrlab.model.drive_train import DriveTrain

TURN = 2.0 * np.pi
"""rad in a turn."""


def unwrapped(angles: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """``angles`` (N, M) (rad) with the jumps of more than half a turn between consecutive samples of
    the ``columns`` (M,) bool undone (a whole number of turns added from each jump on), on the
    columns whose values stay within one turn (the others are continuous already)."""
    angles = np.array(angles, dtype=float)
    columns = np.asarray(columns, dtype=bool) & (np.ptp(angles, axis=0) <= TURN * (1 + 1e-9))
    if np.any(columns):
        angles[:, columns] = np.unwrap(angles[:, columns], period=TURN, axis=0)
    return angles


def wrapping_columns(drive: DriveTrain, continuous: np.ndarray) -> np.ndarray:
    """(N,) bool: the position columns that may wrap: every motor's, or the continuous joints'
    (``continuous``, (N,) bool) when the positions are measured at the joints."""
    return np.ones(drive.n_drives, dtype=bool) if drive.position_side == "motor" else np.asarray(continuous)


def angle_scale(drive: DriveTrain) -> np.ndarray | float:
    """rad per unit of the logged positions: per count where the encoders give counts, else 1."""
    return 1.0 if drive.encoder_counts is None else TURN / drive.encoder_counts


def joint_positions_of_log(positions: np.ndarray, drive: DriveTrain, continuous: np.ndarray) -> np.ndarray:
    """Joint positions (N, N_J) (rad) of a log's position columns (N, N_J) (rad, or counts with
    ``encoder_counts``), see the module docstring; ``continuous``: (N_J,) bool, the joints without
    position limits."""
    angles = np.asarray(positions, dtype=float) * angle_scale(drive)
    return drive.read_positions(unwrapped(angles, wrapping_columns(drive, continuous)))


def joint_velocities_of_log(velocities: np.ndarray, drive: DriveTrain) -> np.ndarray:
    """Joint velocities (N, N_J) (rad/s) of a log's velocity columns (rad/s, or counts/s)."""
    speeds = np.asarray(velocities, dtype=float) * angle_scale(drive)
    return drive.joint_positions(speeds) if drive.position_side == "motor" else speeds


__all__ = [
    "TURN",
    "angle_scale",
    "joint_positions_of_log",
    "joint_velocities_of_log",
    "unwrapped",
    "wrapping_columns",
]
