"""End-effector (payload) identification, eq. (7) of Katsumata et al. (after Khalil, Gautier & Lemoine 2007).

Stacking a motion of the unloaded robot and one of the robot carrying the tool::

    [ Γᵘ ]   [ W_bᵘ    0   ] [ Φ_b ]
    [ Γˡ ] = [ W_bˡ  W_Lˡ  ] [ Φ_L ]                                         eq. (7)

identifies the robot's base parameters Φ_b and the tool's 10 standard parameters Φ_L together:
the unloaded rows pin Φ_b, so all 10 columns of the tool (those of the segment carrying the flange,
in its joint frame) are identifiable from the loaded rows, although 3 of that segment's own
parameters regroup into others. :func:`identify_payload_only` is the cheaper variant: with Φ_b
already identified, ``Γˡ − W_bˡ·Φ_b = W_Lˡ·Φ_L`` needs the loaded motion only.

Both solve a weighted least-squares problem (eq. (6) with P from the residual variance of each
(motion, joint) row group, Gautier 1997; :func:`lwrlab.identification.least_squares.grouped_least_squares`,
the solver of the base-parameter estimators too) and give the covariance ``(Wᵀ·P·W)⁻¹`` hence %σ as in
Table III. ``consistent=True`` solves the same problem as a semidefinite programme with the tool's
pseudo-inertia ``J(Φ_L) ⪰ 0`` (a physically realisable body; :mod:`lwrlab.identification.consistency`).

The covariance assumes white residuals. Low-pass filtered data are correlated over about
``rate/(2·cutoff)`` samples, so the true spread is larger than %σ says (by about √2.5 at the
default decimation, 5 × the cut-off); the relative ordering of parameters, which is what Table III
reads, holds. Rows denser than the default are scaled back to it by the tool bench
(:func:`lwrlab.signal.processing.correlated_rows`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np

from lwrlab.identification.compression import compress
from lwrlab.identification.consistency import pseudo_inertia_expression
from lwrlab.identification.context import row_joints
from lwrlab.identification.core import column_scaled_condition_number, relative_std
from lwrlab.identification.least_squares import grouped_least_squares


@dataclass(frozen=True)
class PayloadEstimate:
    """An identified tool: its 10 parameters in the joint frame of the flange-carrying segment."""

    phi: np.ndarray
    """(10,) Φ_L in the segment's joint frame (frame 7 of the LWR4), as in Table III."""
    covariance: np.ndarray
    """(10, 10) covariance of ``phi``."""
    flange_to_joint: np.ndarray
    """(10, 10) T with ``phi = T·phi_flange`` (:func:`lwrlab.model.payload.frame_change_matrix`)."""
    method: str
    """``joint`` (eq. (7)) or ``payload_only``; ``+consistent`` when solved with J(Φ_L) ⪰ 0."""
    cond: float
    """Condition number of the column-scaled (weighted) regressor that was solved."""
    residual_std: np.ndarray
    """σ of the torque residual of each row group (N·m): per joint, unloaded groups first."""
    robot_base: np.ndarray | None = None
    """(N_B,) base parameters of the robot identified alongside (eq. (7) only)."""
    robot_base_std: np.ndarray | None = None
    """(N_B,) their standard deviations."""
    extras: dict[str, float | str] = field(default_factory=dict)
    """Solver status and the like."""

    @property
    def std(self) -> np.ndarray:
        """σ of each parameter (joint frame)."""
        return np.sqrt(np.diag(self.covariance))

    @property
    def relative_std(self) -> np.ndarray:
        """%σ of each parameter (joint frame), Table III's columns."""
        return relative_std(self.phi, self.std)

    @property
    def phi_flange(self) -> np.ndarray:
        """(10,) the tool's parameters in the flange frame (what the tool library holds)."""
        return np.linalg.solve(self.flange_to_joint, self.phi)

    @property
    def covariance_flange(self) -> np.ndarray:
        """(10, 10) covariance of :attr:`phi_flange`: ``T⁻¹·Σ·T⁻ᵀ``."""
        inverse = np.linalg.inv(self.flange_to_joint)
        return inverse @ self.covariance @ inverse.T


def _consistent_solution(
    weighted_w: np.ndarray, weighted_tau: np.ndarray, tool_columns: slice, solver: str | None
) -> tuple[np.ndarray, str]:
    """argmin ‖τ_w − W_w·θ‖² s.t. J(θ[tool_columns]) ⪰ 0, on the QR-compressed, column-scaled system."""
    scale = np.linalg.norm(weighted_w, axis=0)
    scale[scale == 0] = 1.0
    compressed = compress(weighted_w / scale, weighted_tau)
    theta_scaled = cp.Variable(weighted_w.shape[1])
    phi_tool = cp.multiply(1.0 / scale[tool_columns], theta_scaled[tool_columns])
    objective = cp.sum_squares(compressed.R @ theta_scaled - compressed.y)
    problem = cp.Problem(cp.Minimize(objective), [pseudo_inertia_expression(phi_tool) >> 0])
    problem.solve(solver=solver)
    if theta_scaled.value is None or problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        raise RuntimeError(
            f"payload SDP (tool pseudo-inertia J(Φ_L) ⪰ 0) failed: solver status {problem.status!r}"
        )
    return theta_scaled.value / scale, str(problem.status)


def _fit(
    W: np.ndarray,
    tau: np.ndarray,
    groups: np.ndarray,
    n_base: int,
    flange_to_joint: np.ndarray,
    weighted: bool,
    consistent: bool,
    solver: str | None,
    method: str,
) -> PayloadEstimate:
    """Solve ``τ = W·[Φ_b; Φ_L]`` (the first ``n_base`` columns the robot's, the last 10 the tool's)."""
    fit = grouped_least_squares(W, tau, groups if weighted else None, known_variance=True)
    theta, covariance = fit.phi, fit.covariance
    if fit.group_std is None:
        raise RuntimeError("grouped least squares returned no per-group residual σ")
    weighted_w, weighted_tau = fit.weighted_system(W, tau)
    extras: dict[str, float | str] = {}
    if consistent:
        theta, status = _consistent_solution(weighted_w, weighted_tau, slice(n_base, n_base + 10), solver)
        method, extras = f"{method}+consistent", {"solver_status": status}
    return PayloadEstimate(
        phi=theta[n_base:],
        covariance=covariance[n_base:, n_base:],
        flange_to_joint=flange_to_joint,
        method=method,
        cond=column_scaled_condition_number(weighted_w),
        residual_std=fit.group_std,
        robot_base=theta[:n_base] if n_base else None,
        robot_base_std=np.sqrt(np.diag(covariance)[:n_base]) if n_base else None,
        extras=extras,
    )


def identify_payload(
    w_base_unloaded: np.ndarray,
    tau_unloaded: np.ndarray,
    w_base_loaded: np.ndarray,
    w_tool_loaded: np.ndarray,
    tau_loaded: np.ndarray,
    flange_to_joint: np.ndarray,
    n_joints: int,
    weighted: bool = True,
    consistent: bool = False,
    solver: str | None = "CLARABEL",
) -> PayloadEstimate:
    """Robot base parameters and tool parameters together from an unloaded and a loaded motion, eq. (7).

    Parameters
    ----------
    w_base_unloaded, tau_unloaded : base regressor (rows, N_B) and torques (rows,) without the tool.
    w_base_loaded, w_tool_loaded, tau_loaded : base regressor, the 10 columns of the flange-carrying
        segment (joint frame) and torques, with the tool; rows sample-major.
    flange_to_joint : T (10×10) of :func:`lwrlab.model.payload.flange_to_joint_matrix`.
    n_joints : joints per sample (row groups are per motion and joint).
    weighted : Gautier's weighting per (motion, joint); False = ordinary least squares.
    consistent : constrain the tool's pseudo-inertia to be positive semi-definite (SDP).
    solver : cvxpy solver of the consistent variant.
    """
    n_base = w_base_unloaded.shape[1]
    if w_base_loaded.shape[1] != n_base or w_tool_loaded.shape[1] != 10:
        raise ValueError(
            f"eq. (7) needs the same {n_base} base columns in both motions and 10 tool columns, got "
            f"{w_base_loaded.shape[1]} and {w_tool_loaded.shape[1]}"
        )
    stacked = np.block(
        [[w_base_unloaded, np.zeros((w_base_unloaded.shape[0], 10))], [w_base_loaded, w_tool_loaded]]
    )
    tau = np.concatenate([np.ravel(tau_unloaded), np.ravel(tau_loaded)])
    groups = np.concatenate(
        [
            row_joints(w_base_unloaded.shape[0], n_joints),
            row_joints(w_base_loaded.shape[0], n_joints, offset=n_joints),
        ]
    )
    return _fit(stacked, tau, groups, n_base, flange_to_joint, weighted, consistent, solver, "joint")


def identify_payload_only(
    w_base_loaded: np.ndarray,
    robot_base: np.ndarray,
    w_tool_loaded: np.ndarray,
    tau_loaded: np.ndarray,
    flange_to_joint: np.ndarray,
    n_joints: int,
    weighted: bool = True,
    consistent: bool = False,
    solver: str | None = "CLARABEL",
) -> PayloadEstimate:
    """The tool's parameters alone, from a loaded motion and an already identified robot.

    ``Γˡ − W_bˡ·Φ_b = W_Lˡ·Φ_L``: 10 unknowns, so a short motion suffices; any error of Φ_b goes
    into Φ_L (and is not in its %σ). Arguments as :func:`identify_payload`; ``robot_base`` (N_B,)
    the robot's identified base parameters.
    """
    tau = np.ravel(tau_loaded) - w_base_loaded @ np.asarray(robot_base, dtype=float)
    groups = row_joints(w_tool_loaded.shape[0], n_joints)
    return _fit(w_tool_loaded, tau, groups, 0, flange_to_joint, weighted, consistent, solver, "payload_only")


def tool_columns(n_links: int, joint: int) -> slice:
    """Columns of a full standard regressor that belong to segment ``joint`` (1-based): the tool's."""
    if not 1 <= joint <= n_links:
        raise ValueError(f"segment {joint} is not one of the {n_links} segments")
    return slice(10 * (joint - 1), 10 * joint)
