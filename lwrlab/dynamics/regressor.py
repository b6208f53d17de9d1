"""Batched joint-torque regressor ``W(q, q̇, q̈)`` with friction columns.

For N samples the regressor stacks the per-sample ``N_J × P`` matrices sample-major (rows
``k·N_J + j``), as in eq. (5) of Katsumata et al., so that ``W @ φ`` is the torque of every joint at
every sample; ``P = 10·N_L + (number of friction terms)·N_J`` in the column order of
:attr:`lwrlab.model.robot.RobotModel.parameter_names`: the standard parameters of each segment
(:mod:`lwrlab.model.inertia`), then the friction columns (:mod:`lwrlab.dynamics.friction_regressor`).

Two engines compute the inertial columns:

* serial chains of revolute joints (every robot built from a DH table, most URDF arms), from
  :data:`SMALL_BATCH` samples on: a Newton–Euler recursion vectorised over the samples
  (:mod:`lwrlab.dynamics.chain_regressor`);
* anything else, and smaller batches: a loop over Pinocchio's ``computeJointTorqueRegressor``
  (:mod:`lwrlab.dynamics.pinocchio_regressor`).

Both agree to round-off (~1e-15 relative); ``benchmarks/regressor.py`` measures their speed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from lwrlab.dynamics.chain_regressor import fill_chain_regressor
from lwrlab.dynamics.friction_regressor import fill_friction_regressor
from lwrlab.dynamics.pinocchio_regressor import loop_inertial_regressor
from lwrlab.dynamics.serial_chain import serial_chain
from lwrlab.model.friction_laws import drive_loads, has_load, has_memory, history_columns, history_window
from lwrlab.model.robot import RobotModel

SMALL_BATCH = 48
"""Below this many samples a serial chain goes through the Pinocchio loop too: the vectorised
recursion costs ~0.15 ms whatever the batch (about a hundred numpy calls) and ~1.5 µs per sample,
the loop ~4.5 µs per sample; on the LWR4 the two cross between 40 and 60 samples, depending on the
load of the machine (``benchmarks/regressor.py``)."""


def joint_states(
    n: int, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q̇, q̈ as float arrays of shape (N, n), a single state (n,) as N = 1; a ValueError otherwise."""
    states = []
    for x, name in ((q, "q"), (dq, "dq"), (ddq, "ddq")):
        x = np.asarray(x, dtype=float)
        x = x.reshape(1, -1) if x.ndim == 1 else x
        if x.ndim != 2 or x.shape[1] != n:
            raise ValueError(f"{name} must have shape (N, {n}), got {x.shape}")
        states.append(x)
    q, dq, ddq = states
    if not len(q) == len(dq) == len(ddq):
        raise ValueError(
            f"q, dq and ddq must have the same number of samples, got {len(q)}, {len(dq)}, {len(ddq)}"
        )
    return q, dq, ddq


def regressor(
    robot: RobotModel,
    q: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
    *,
    stacked: bool = True,
    history: dict[str, np.ndarray] | None = None,
) -> np.ndarray:
    """The full regressor ``W`` so that ``W @ robot.parameters`` is the joint torque (N·m).

    Parameters
    ----------
    robot : the robot (its friction terms select the friction columns).
    q, dq, ddq : joint positions (rad), velocities (rad/s), accelerations (rad/s²), shape (N, N_J).
    stacked : if True return (N·N_J, P) sample-major; otherwise (N, N_J, P).
    history : for a friction law with memory, its columns at these samples, by term
        (:class:`LogRegressor` slices them from the whole log's); None: memoryless.

    Examples
    --------
    >>> from lwrlab.model.description import load_robot_yaml  # doctest: +SKIP
    >>> W = regressor(robot, q, dq, ddq)           # doctest: +SKIP
    >>> np.allclose(W @ robot.parameters, robot.inverse_dynamics(q, dq, ddq).ravel())  # doctest: +SKIP
    True
    """
    n = robot.n_joints
    q, dq, ddq = joint_states(n, q, dq, ddq)
    n_inertial = 10 * robot.n_links
    # Zeros where no column is written: calloc'd, so large outputs come zeroed by the system for free.
    full = np.zeros((q.shape[0], n, n_inertial + robot.n_friction))
    chain = serial_chain(robot.model) if q.shape[0] >= SMALL_BATCH else None
    if chain is not None:
        fill_chain_regressor(chain, q, dq, ddq, full[:, :, :n_inertial])
    else:
        loop_inertial_regressor(robot.model, q, dq, ddq, out=full[:, :, :n_inertial])
    load = None
    if has_load(robot.friction_law):  # the rigid-body torque of the robot's own inertial parameters
        load = drive_loads(robot.drive, full[:, :, :n_inertial] @ robot.link_parameters.ravel())
    fill_friction_regressor(
        dq,
        robot.friction_terms,
        full,
        first=n_inertial,
        law=robot.friction_law,
        drive=robot.drive,
        ddq=ddq,
        history=history,
        load=load,
    )
    return full.reshape(-1, full.shape[2]) if stacked else full


def log_history(robot: RobotModel, dq: np.ndarray, rate_hz: float) -> dict[str, np.ndarray] | None:
    """The friction law's columns over a whole log's consecutive velocities ``dq`` (N, N_J) at
    ``rate_hz``, for a law with memory; None for a memoryless law."""
    if not has_memory(robot.friction_law):
        return None
    return history_columns(robot.friction_law, robot.drive_train.drive_values(dq), 1.0 / rate_hz)


@dataclass(frozen=True)
class LogRegressor:
    """The regressor of one log's working samples, called on consecutive runs of them.

    A friction law with memory (a Coulomb level held at rest) needs the motion before each sample:
    its columns are computed once over the whole log (:func:`log_history`) and read here by the
    index ``start`` of the run's first sample, which the block processing passes
    (:attr:`takes_start`). ``columns``: keep only these columns (the base ones), or all.
    """

    robot: RobotModel
    history: dict[str, np.ndarray] | None = None
    columns: np.ndarray | None = None
    takes_start: ClassVar[bool] = True
    """Called as ``(q, q̇, q̈, start=…)`` by :meth:`lwrlab.signal.processing.ProcessedData.row_blocks`."""

    @classmethod
    def of(
        cls,
        robot: RobotModel,
        velocities: Callable[[], np.ndarray],
        rate_hz: float,
        columns: np.ndarray | None = None,
    ) -> LogRegressor:
        """The regressor of a log whose consecutive velocities (all of them, rad/s) ``velocities()``
        gives at ``rate_hz``: read only for a friction law with memory."""
        history = log_history(robot, velocities(), rate_hz) if has_memory(robot.friction_law) else None
        return cls(robot, history, columns)

    def __call__(
        self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, start: int = 0, *, stacked: bool = True
    ) -> np.ndarray:
        """Rows of the samples ``start … start + N − 1`` of the log: stacked ``(N·N_J, P)``, or
        ``(N, N_J, P)`` with ``stacked=False``."""
        part = history_window(self.history, start, len(q))
        full = regressor(self.robot, q, dq, ddq, stacked=stacked, history=part)
        return full if self.columns is None else np.take(full, self.columns, axis=-1)
