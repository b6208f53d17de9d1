"""The rigid bodies nearest a model's standard parameters: what a simulator, a URDF or a prior needs.

An identification determines base parameters; the standard set reported beside them is one of many
that reproduce them, and after a least-squares fit it need not describe real rigid bodies (a
pseudo-inertia with a negative eigenvalue). Inverse dynamics does not care, but whatever treats the
set as bodies does: a simulated plant drawing a true robot around it, a MuJoCo model, a URDF, a
prior whose divergence measures bodies. :func:`nearest_rigid_bodies` finds, among the standard sets
whose every segment is a rigid body (``J_i ⪰ 0``), the one whose torques are closest to the given
set's over random states of the robot (and, among those, the one closest to it), so that:

- where some rigid bodies reproduce the base parameters (the set was only one bad choice among the
  equivalent ones), the torques do not change at all;
- where none do (the data, their noise, gave base parameters no rigid bodies have), the torques
  change as little as rigid bodies allow, and :attr:`RigidBodies.torque_change` says by how much.

Examples
--------
>>> from lwrlab.model.description import load_robot_yaml  # doctest: +SKIP
>>> fitted = nearest_rigid_bodies(robot)                   # doctest: +SKIP
>>> robot.with_parameters(fitted.standard)                 # doctest: +SKIP
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from lwrlab.dynamics.base_parameters import random_states
from lwrlab.dynamics.regressor import regressor
from lwrlab.identification.consistency import (
    SEGMENT_SIZE,
    clip_pseudo_inertias,
    consistency_constraints,
    min_pseudo_inertia_eigenvalues,
)
from lwrlab.model.robot import RobotModel

NULL_SPACE_WEIGHT = 1e-6
"""Weight, relative to the torque term's scale, of the pull toward the given set: it only chooses
among sets with the same torques (the directions the regressor does not see)."""


@dataclass(frozen=True)
class RigidBodies:
    """What :func:`nearest_rigid_bodies` found."""

    standard: np.ndarray
    """(P,) the standard parameters: every segment a rigid body, friction unchanged."""
    torque_change: float
    """‖W·(φ − φ₀)‖ / ‖W·φ₀‖ over random states, rigid-body torques only: how much they moved (0: not
    at all, up to the solver's accuracy)."""
    min_eigenvalue: float
    """Smallest pseudo-inertia eigenvalue of the given set (kg·m²; < 0: not rigid bodies)."""
    worst_segment: int
    """1-based segment of that eigenvalue."""


def are_rigid_bodies(standard: np.ndarray, n_links: int, tolerance: float = 1e-12) -> bool:
    """Whether every segment of a standard vector is a rigid body (``J ⪰ 0`` up to ``tolerance``
    relative to its mass)."""
    eigenvalues = min_pseudo_inertia_eigenvalues(standard, n_links)
    masses = np.abs(np.asarray(standard, dtype=float)[: SEGMENT_SIZE * n_links : SEGMENT_SIZE])
    return bool(np.all(eigenvalues >= -tolerance * np.maximum(1.0, masses)))


def nearest_rigid_bodies(robot: RobotModel, n_samples: int = 200, seed: int = 0) -> RigidBodies:
    """The rigid bodies whose torques are nearest ``robot``'s own (module docstring).

    First the rigid bodies with exactly the same base parameters, nearest the given set; where there
    are none, those whose torques are nearest over random states.

    Parameters
    ----------
    robot : the robot with the standard parameters to replace (its friction is kept).
    n_samples : random states (positions, velocities, accelerations within the limits) on which the
        torques are compared.
    seed : seed of those states.
    """
    import cvxpy as cp

    n_inertial = SEGMENT_SIZE * robot.n_links
    given = np.asarray(robot.parameters, dtype=float)
    eigenvalues = min_pseudo_inertia_eigenvalues(given, robot.n_links)
    w = regressor(robot, *random_states(robot, n_samples, np.random.default_rng(seed)))[:, :n_inertial]
    phi = cp.Variable(n_inertial)
    change = phi - given[:n_inertial]
    bodies = consistency_constraints(phi, robot.n_links)
    same_torques = cp.Problem(cp.Minimize(cp.sum_squares(change)), [*bodies, w @ change == 0])
    same_torques.solve(solver=cp.CLARABEL)
    if same_torques.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or phi.value is None:
        factor = scipy.linalg.qr(w / np.sqrt(w.shape[0]), mode="economic")[1]  # ‖W·Δ‖/√N = ‖R·Δ‖
        scale = float(np.sum(factor**2)) / n_inertial
        objective = cp.sum_squares(factor @ change) + NULL_SPACE_WEIGHT * scale * cp.sum_squares(change)
        nearest = cp.Problem(cp.Minimize(objective), bodies)
        nearest.solve(solver=cp.CLARABEL)
        if nearest.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or phi.value is None:
            raise RuntimeError(f"{robot.name}: nearest rigid bodies: solver status {nearest.status}")
    standard = given.copy()
    standard[:n_inertial] = np.asarray(phi.value, dtype=float)
    standard = clip_pseudo_inertias(standard, robot.n_links, 0.0)
    torque = np.linalg.norm(w @ given[:n_inertial])
    moved = np.linalg.norm(w @ (standard[:n_inertial] - given[:n_inertial]))
    return RigidBodies(
        standard=standard,
        torque_change=float(moved / torque) if torque > 0 else 0.0,
        min_eigenvalue=float(eigenvalues.min()),
        worst_segment=int(np.argmin(eigenvalues)) + 1,
    )


__all__ = ["RigidBodies", "are_rigid_bodies", "nearest_rigid_bodies"]
