"""Analytic derivatives of the painting-path problem (eq. 12) in x = [T_C, φ, Z_u, Z_l, Y_0, ΔY].

The path's positions are differentiated in the way points and their times
(:func:`lwrlab.planning.painting_path.sample_path_derivatives`), the closed-form IK forward
(:mod:`lwrlab.kinematics.swivel_ik_derivatives`), q̇ and q̈ through the same differences as the
trajectory, and the torques by Pinocchio's RNEA derivatives at the samples where a limit is
closest. A max/min over the path is differentiated at its arg max/min (a subgradient). The
functions take the :class:`~lwrlab.planning.path_problem.PathProblem`, whose
``cost_gradient``, ``constraint_jacobian`` and ``trajectory_derivatives`` call them; the tests
check each against finite differences.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from lwrlab.kinematics.swivel_ik_derivatives import solve_branch_derivatives
from lwrlab.planning.painting_path import sample_path_derivatives

if TYPE_CHECKING:  # the problem's module calls this one
    from lwrlab.model.robot import RobotModel
    from lwrlab.planning.path_problem import PathProblem


@dataclass(frozen=True)
class TrajectoryDerivatives:
    """The search-grid joint trajectory and its derivatives in x = [T_C, φ, Z_u, Z_l, Y_0, ΔY]."""

    t: np.ndarray
    """(N,) time (s)."""
    q: np.ndarray
    """(N, N_J) positions (rad); ``dq``, ``ddq`` velocities and accelerations as
    :meth:`PathProblem.joint_trajectory`."""
    dq: np.ndarray
    ddq: np.ndarray
    q_x: np.ndarray
    """(N, N_J, 6) ∂q/∂x; ``dq_x``, ``ddq_x`` likewise (at a fixed number of samples)."""
    dq_x: np.ndarray
    ddq_x: np.ndarray


def trajectory_derivatives(problem: PathProblem, x: np.ndarray) -> TrajectoryDerivatives:
    """The search-grid trajectory with its derivatives in x (computed; the problem memoises it).

    Positions along the path do not depend on T_C at a fixed sample count (the samples sit at
    fixed fractions of T_C), so ∂q/∂T_C = 0, ∂q̇/∂T_C = −q̇/T_C and ∂q̈/∂T_C = −2·q̈/T_C.
    """
    parameters = problem.parameters(x)
    path = problem.path(x, problem.search_rate_hz)
    flange = problem.flange_poses(path)
    solution, q_position, q_swivel = solve_branch_derivatives(problem.ik, flange, float(x[1]), problem.branch)
    position_x = sample_path_derivatives(
        parameters, problem.search_rate_hz
    )  # (N, 3, 6); flange moves with tool
    q_x = np.einsum("nja,nax->njx", q_position, position_x)
    q_x[:, :, 1] += q_swivel
    dt, duration = path.t[1] - path.t[0], float(x[0])
    q = solution.q
    dq = np.gradient(q, dt, axis=0, edge_order=2)
    ddq = np.gradient(dq, dt, axis=0, edge_order=2)
    dq_x = np.gradient(q_x, dt, axis=0, edge_order=2)
    dq_x[:, :, 0] -= dq / duration
    ddq_x = np.gradient(dq_x, dt, axis=0, edge_order=2)
    ddq_x[:, :, 0] -= ddq / duration
    return TrajectoryDerivatives(path.t, q, dq, ddq, q_x, dq_x, ddq_x)


def constraint_jacobian(problem: PathProblem, x: np.ndarray) -> np.ndarray:
    """(N_constraints, 6) ∂g/∂x of ``problem.constraints(x)``, rows in its order.

    Placeholders (−1, for constraints that could not be evaluated) have zero rows.
    """
    values, stage = problem.constraints_and_stage(x)
    gradients = {name: np.zeros(6) for name in values}
    gradients.update(geometric_gradients(problem.n_steps))
    if stage != "geometric":
        gradients.update(reach_gradients(problem, x))
    if stage == "joints":
        gradients.update(joint_gradients(problem, x))
    return np.array([gradients[name] for name in values])


def geometric_gradients(n_steps: int) -> dict[str, np.ndarray]:
    """Gradients of the wall, ordering and coverage constraints (linear in x)."""
    rows = {
        "Z_l ≥ Z⁻": (3, 1.0),
        "Z_u ≤ Z⁺": (2, -1.0),
        "Y_0 − w_L/2 ≥ Y⁻": (4, 1.0),
        "ΔY ≤ w_L − overlap": (5, -1.0),
        "ΔY > 0": (5, 1.0),
    }
    gradients = {name: np.eye(6)[i] * sign for name, (i, sign) in rows.items()}
    gradients["Z_u − Z_l ≥ min stroke"] = np.eye(6)[2] - np.eye(6)[3]
    gradients["Y_0 + N_r·ΔY + w_L/2 ≤ Y⁺"] = -np.eye(6)[4] - n_steps * np.eye(6)[5]
    return gradients


def reach_gradients(problem: PathProblem, x: np.ndarray) -> dict[str, np.ndarray]:
    """Gradients of the reach constraints at the farthest and the nearest wrist position."""
    # the wrist moves with the flange, the flange with the tool (fixed orientation): no IK needed
    path = problem.path(x, problem.search_rate_hz)
    wrist = problem.ik.wrist_pose(problem.flange_poses(path))[:, :3, 3]
    wrist_x = sample_path_derivatives(problem.parameters(x), problem.search_rate_hz)
    offset = wrist - [0.0, 0.0, problem.ik.shoulder_height]
    distance = np.linalg.norm(offset, axis=1)
    distance_x = np.einsum("ni,nix->nx", offset, wrist_x) / distance[:, None]
    return {
        "reach (outer)": -distance_x[distance.argmax()],
        "reach (inner)": distance_x[distance.argmin()],
    }


def joint_gradients(problem: PathProblem, x: np.ndarray) -> dict[str, np.ndarray]:
    """Gradients of the joint limits and singularity margins, each at its limiting sample."""
    d = problem.trajectory_derivatives(x)
    lim = problem.robot.limits
    span = lim.position_upper - lim.position_lower
    stride = problem.torque_stride
    tau = problem.strided_torques(x)
    gradients = {}
    for j in range(problem.robot.n_joints):
        gradients[f"q{j + 1} ≥ lower"] = d.q_x[d.q[:, j].argmin(), j] / span[j]
        gradients[f"q{j + 1} ≤ upper"] = -d.q_x[d.q[:, j].argmax(), j] / span[j]
        for name, values, derivative, limit in (
            ("q̇", d.dq, d.dq_x, lim.velocity),
            ("q̈", d.ddq, d.ddq_x, lim.acceleration),
        ):
            k = np.abs(values[:, j]).argmax()
            gradients[f"|{name}{j + 1}| ≤ limit"] = -np.sign(values[k, j]) * derivative[k, j] / limit[j]
        k = np.abs(tau[:, j]).argmax()
        gradients[f"|Γ{j + 1}| ≤ limit"] = (
            -np.sign(tau[k, j]) * torque_gradient(problem.robot, d, stride * k)[j] / lim.torque[j]
        )
    for name, j in zip(("shoulder", "elbow", "wrist"), (1, 3, 5), strict=True):
        k = np.abs(np.sin(d.q[:, j])).argmin()
        gradients[f"{name} singularity margin"] = np.sign(np.sin(d.q[k, j])) * np.cos(d.q[k, j]) * d.q_x[k, j]
    return gradients


def torque_gradient(robot: RobotModel, d: TrajectoryDerivatives, k: int) -> np.ndarray:
    """(N_J, 6) ∂Γ/∂x at sample k: RNEA derivatives chained with ∂(q, q̇, q̈)/∂x, plus viscous friction."""
    model = robot.model
    data = model.createData()  # kept alive while its derivative arrays (views into it) are used
    tau_q, tau_v, tau_a = pin.computeRNEADerivatives(model, data, d.q[k], d.dq[k], d.ddq[k])
    if "viscous" in robot.friction_terms:
        # Coulomb's sign(q̇) has no derivative off q̇ = 0
        tau_v = tau_v + np.diag(robot.friction.viscous)
    return tau_q @ d.q_x[k] + tau_v @ d.dq_x[k] + tau_a @ d.ddq_x[k]


def cost_gradient(problem: PathProblem, x: np.ndarray) -> np.ndarray:
    """(6,) ∂cost/∂x of eq. (12)."""
    p = problem.parameters(x)
    gradient = np.zeros(6)
    gradient[0] = 1.0  # T_C
    area = (p.z_upper - p.z_lower) * p.y_step
    if area > 1e-6:
        gradient[[2, 3, 5]] -= np.array([p.y_step, -p.y_step, p.z_upper - p.z_lower]) / area**2
    try:
        d = problem.trajectory_derivatives(x)
    except ValueError:  # degenerate or unreachable path: the smoothness term is a constant there
        return gradient
    # S = w·rate·trapz(Σ q̈², t); the grid spacing scales with T_C
    squares = np.sum(d.ddq**2, axis=1)
    smoothness = problem.rate_hz * np.trapezoid(squares, d.t)
    gradient += (
        problem.smoothness_weight
        * problem.rate_hz
        * np.trapezoid(2 * np.einsum("nj,njx->nx", d.ddq, d.ddq_x), d.t, axis=0)
    )
    gradient[0] += problem.smoothness_weight * smoothness / float(x[0])
    return gradient
