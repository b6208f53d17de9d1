"""Simulated robots: ground-truth perturbation, ideal playback and closed-loop tracking."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

import numpy as np
import pinocchio as pin

from lwrlab.model.inertia import perturb_consistent
from lwrlab.model.robot import RobotModel
from lwrlab.trajectory.core import Trajectory

COULOMB_SMOOTHING = 1e-3
"""ε (rad/s) of the simulated plants' true Coulomb friction ``FC·tanh(q̇/ε)``: a constant of the
simulation, not a setting — a regularisation so that the integration does not chatter at a stop,
far below the velocities of any motion (the force estimate's own ε, a model choice, is the painting
task's ``estimator.coulomb_smoothing``)."""


def perturbed_robot(
    robot: RobotModel, relative_spread: float, friction_spread: float, rng: np.random.Generator
) -> RobotModel:
    """A physically consistent variant of ``robot``: segments perturbed by ``relative_spread``
    (see :func:`lwrlab.model.inertia.perturb_consistent`), friction values scaled by
    ``1 + friction_spread·ε`` and kept non-negative."""
    links = np.stack([perturb_consistent(phi, relative_spread, rng) for phi in robot.link_parameters])
    friction = robot.friction
    scaled = {
        term: np.maximum(
            0.0, getattr(friction, term) * (1.0 + friction_spread * rng.normal(size=robot.n_joints))
        )
        for term in ("coulomb", "viscous")
    }
    return replace(robot.with_parameters(links.ravel()), friction=replace(friction, **scaled))


def playback_torques(robot: RobotModel, trajectory: Trajectory) -> np.ndarray:
    """Joint torques (N·m) that exactly realise ``trajectory`` on ``robot`` (RNEA + friction)."""
    return robot.inverse_dynamics(trajectory.q, trajectory.dq, trajectory.ddq, with_friction=True)


def track_closed_loop(
    plant_robot: RobotModel,
    controller_robot: RobotModel,
    trajectory: Trajectory,
    kp: np.ndarray,
    kd: np.ndarray,
    substeps: int,
    progress: Iterable[int] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Simulate joint PD + gravity compensation tracking ``trajectory`` (eq. (13) of the paper).

    The controller runs at the trajectory's rate with gravity from ``controller_robot`` (the model
    the user has, e.g. CAD); the true dynamics of ``plant_robot`` are integrated with Pinocchio's ABA
    and semi-implicit Euler at ``substeps`` times that rate. The drives' rotor inertia
    (``plant_robot.rotor_inertia``) moves with the joints, so the commanded torque accelerates
    ``M(q) + diag(I_a)``, while the joint-torque sensor, on the link side of the drive, reads
    ``τ − I_a·q̈``: what the link dynamics (and the regressor) account for. Coulomb friction is smoothed as
    ``FC·tanh(q̇/ε)`` with ε = :data:`COULOMB_SMOOTHING` so the integration does not chatter.

    Returns the true positions (rad), velocities (rad/s) and link-side joint torques (N·m) at the
    trajectory's sample times.
    """
    model = plant_robot.model.copy()
    rotor_inertia = (
        np.zeros(plant_robot.n_joints) if plant_robot.rotor_inertia is None else plant_robot.rotor_inertia
    )
    model.armature = rotor_inertia
    data = model.createData()
    ctrl_model, ctrl_data = controller_robot.model, controller_robot.model.createData()
    friction = plant_robot.friction
    n_samples = trajectory.t.shape[0]
    dt = float(trajectory.t[1] - trajectory.t[0]) / substeps
    q, dq = trajectory.q[0].copy(), trajectory.dq[0].copy()
    q_out, dq_out, tau_out = (np.empty((n_samples, plant_robot.n_joints)) for _ in range(3))
    zero = np.zeros(plant_robot.n_joints)
    steps = progress if progress is not None else range(n_samples)
    for k in steps:
        tau = (
            kp * (trajectory.q[k] - q)
            + kd * (trajectory.dq[k] - dq)
            + pin.rnea(ctrl_model, ctrl_data, q, zero, zero)
        )
        q_out[k], dq_out[k] = q, dq
        for step in range(substeps):
            tau_friction = (
                friction.viscous * dq + friction.coulomb * np.tanh(dq / COULOMB_SMOOTHING) + friction.offset
            )
            ddq = pin.aba(model, data, q, dq, tau - tau_friction)
            if step == 0:
                tau_out[k] = tau - rotor_inertia * ddq
            dq = dq + dt * ddq
            q = q + dt * dq
    return q_out, dq_out, tau_out


def encoder_reading(
    q: np.ndarray, noise_std: float, resolution: float, rng: np.random.Generator
) -> np.ndarray:
    """Encoder output: true position plus white noise (rad), quantised to ``resolution`` (rad; 0 = none)."""
    reading = q + noise_std * rng.normal(size=q.shape)
    return np.round(reading / resolution) * resolution if resolution > 0 else reading
