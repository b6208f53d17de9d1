"""The 1 kHz contact simulation loop of Fig. 8: sensors → estimator → controller → plant.

The plant is anything with ``reset(q0, hold_torque) -> sensors`` and ``step(tau) -> sensors``
(:class:`lwrlab.plants.mujoco_contact.MujocoContactPlant`); the controller any object of the
:class:`PaintingController` protocol (plugins in ``plugins/controllers/``).

The loop does per period only what feedback forces it to: the controller receives the whole
reference path at reset (its IK is solved in batches, :class:`lwrlab.kinematics.DisplacedPathIK`),
the estimator's filters are O(1) state updates, and the values passed around are tuples.
``benchmarks/painting.py`` measures it against the per-sample loop it replaced and against MuJoCo alone.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any, NamedTuple, Protocol

import numpy as np

from lwrlab.control.force_estimation import ExternalForceEstimator, StateEstimate
from lwrlab.control.joint_pd import ControlSetup, JointPDGravity


class ControlOutput(NamedTuple):
    """A controller's decision for one period (a tuple: cheap to make at 1 kHz)."""

    tau: np.ndarray
    """(N_J,) commanded joint torques (N·m)."""
    commanded_position: np.ndarray
    """(3,) tool-centre-point position it aimed at, reference + ΔP_c (m)."""
    q_desired: np.ndarray
    """(N_J,) joint reference (rad)."""


class PaintingController(Protocol):
    """A controller plugin (config group ``controller``)."""

    @property
    def uses_force_feedback(self) -> bool:
        """Whether a force loop closes on a measured or estimated force; such a controller takes a
        ``feedback`` argument (``estimate``: eq. 14, ``sensor``: the wall's sensor)."""
        ...

    @property
    def desired_force(self) -> np.ndarray | None:
        """(3,) F_d (N) the controller regulates, base axes; None without a force target."""
        ...

    def reset(self, setup: ControlSetup, q0: np.ndarray, reference: np.ndarray) -> None:
        """Prepare for a run starting at rest at ``q0`` (rad) along the tool poses ``reference`` (N, 4, 4).

        Knowing the whole reference lets a controller solve its IK in batches
        (:meth:`ControlSetup.path_ik`) instead of one pose per period.
        """
        ...

    def command(self, k: int, state: StateEstimate, measured_force: np.ndarray) -> ControlOutput:
        """Torques for period ``k`` (reference pose ``reference[k]``), the estimated state, and the wall sensor's force (N)."""
        ...


@dataclass
class ContactRun:
    """One simulated painting run, sampled at the control rate (value object of the painting stage)."""

    t: np.ndarray
    """(N,) time (s)."""
    reference: np.ndarray
    """(N, 3) desired tool-centre-point position, the painting path (m)."""
    commanded: np.ndarray
    """(N, 3) reference + ΔP_c the inner loop tracked (m)."""
    actual: np.ndarray
    """(N, 3) true tool-centre-point position (m)."""
    estimated_wrench: np.ndarray
    """(N, 6) estimated wrench on the environment at the tool centre point, eq. (14) (N, N·m)."""
    measured_force: np.ndarray
    """(N, 3) force measured by the wall sensor (N)."""
    q: np.ndarray
    """(N, N_J) true joint positions (rad)."""
    q_desired: np.ndarray
    """(N, N_J) joint reference (rad)."""
    tau: np.ndarray
    """(N, N_J) commanded torques (N·m)."""
    painting: np.ndarray
    """(N,) True during the painting path (False during the approach)."""
    metadata: dict[str, Any] = field(default_factory=dict)


def simulate_contact(
    plant: Any,
    controller: PaintingController,
    estimator: ExternalForceEstimator,
    setup: ControlSetup,
    reference: np.ndarray,
    painting: np.ndarray,
    start: np.ndarray | None = None,
    progress: Iterable[int] | None = None,
) -> ContactRun:
    """Run the loop over the reference tool poses (N, 4, 4), one per control period.

    The robot starts at rest at the joint solution of ``start`` (a tool pose, 4×4; default the
    first reference pose), held by gravity compensation; ``painting`` (N,) marks the samples that
    belong to the painting path.
    """
    n = reference.shape[0]
    n_joints = setup.robot.n_joints
    q0 = setup.joint_reference(reference[0] if start is None else start)
    controller.reset(setup, q0, reference)
    # the controller's model holds the arm at rest at the start
    sensors = plant.reset(q0, JointPDGravity(setup.robot, 0.0, 0.0, setup.period).gravity(q0))
    estimator.reset(sensors.q)
    commanded, actual, measured_force = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    wrench = np.empty((n, 6))
    q, q_desired, tau = (np.empty((n, n_joints)) for _ in range(3))
    update, command, step = estimator.update, controller.command, plant.step  # bound once: 1 kHz loop
    for k in progress if progress is not None else range(n):
        state = update(sensors.q, sensors.tau)
        decision = command(k, state, sensors.wall_force)
        commanded[k], actual[k], measured_force[k] = (
            decision.commanded_position,
            plant.tcp_position,
            sensors.wall_force,
        )
        wrench[k], q[k], q_desired[k], tau[k] = state.wrench, sensors.q_true, decision.q_desired, decision.tau
        sensors = step(decision.tau)
    return ContactRun(
        t=np.arange(n) * setup.period,
        reference=reference[:, :3, 3].copy(),
        commanded=commanded,
        actual=actual,
        estimated_wrench=wrench,
        measured_force=measured_force,
        q=q,
        q_desired=q_desired,
        tau=tau,
        painting=np.asarray(painting, dtype=bool),
    )
