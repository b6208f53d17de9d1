"""Vector–Jacobian product of the regressor ``W(q, q̇, q̈)``, in reverse mode.

For a weight ``G`` of the regressor's shape (the gradient ``∂J/∂W`` of an excitation criterion J),
:func:`regressor_vjp` gives ``Σ_{j,p} G[k, j, p]·∂W[k, j, p]/∂(q, q̇, q̈)`` sample by sample: what an
optimiser needs, at the cost of a few regressors, without forming the tensors of
:func:`lwrlab.dynamics.regressor_jacobians.regressor_jacobians` (whose module docstring gives the
recursion differentiated here). It is 3× faster than contracting the forward-mode tangents on the
1 001 samples of a 10 s motion at 100 Hz (``benchmarks/excitation.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lwrlab.dynamics.batched_vectors import cross, dot, pull_back, rotate, times, transposed_rotations
from lwrlab.dynamics.friction_regressor import friction_columns
from lwrlab.dynamics.regressor import joint_states
from lwrlab.dynamics.segment_wrench import WRENCH_BASIS_FLAT
from lwrlab.dynamics.serial_chain import SerialChain, checked_serial_chain, skew
from lwrlab.model.robot import RobotModel


@dataclass
class _Tape:
    """What the reverse sweep needs of segment i's forward step (samples last)."""

    rt: np.ndarray
    """(3, 3, N) Rᵀ of joint i (layout of :func:`~lwrlab.dynamics.batched_vectors.transposed_rotations`)."""
    parent: np.ndarray
    """(3, 3, N) ω, ω̇, acc of the parent."""
    w: np.ndarray
    """(3, N) Rᵀω_p."""
    wd: np.ndarray
    """(3, N) Rᵀω̇_p."""
    omega: np.ndarray
    """(3, N) ω_i."""
    acc: np.ndarray
    """(3, N) acc_i."""
    twists: np.ndarray
    """(i+1, 6, N) unit twists of joints 0…i seen from frame i."""


def _forward_tape(
    robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray
) -> tuple[SerialChain, list[_Tape], list[np.ndarray]]:
    """The forward Newton–Euler recursion without tangents: each segment's tape and state t_i (15, N)."""
    chain = checked_serial_chain(robot.model, "regressor derivatives")
    n_samples = q.shape[0]
    omega, omega_dot = np.zeros((3, n_samples)), np.zeros((3, n_samples))
    acc = np.broadcast_to(-robot.gravity[:, None], (3, n_samples)).copy()
    twists = np.zeros((0, 6, n_samples))
    tapes, states = [], []
    for i, (rotation, translation, axis) in enumerate(
        zip(chain.rotations, chain.translations, chain.axes, strict=True)
    ):
        rt = transposed_rotations(rotation, axis, q[:, i])
        a = axis[:, None]
        cross_a, cross_p = -skew(axis), -skew(translation)  # v × c = −S(c)·v
        w, wd = rotate(rt, omega), rotate(rt, omega_dot)
        b = acc + times(cross_p, omega_dot) + cross(omega, times(cross_p, omega))
        new_twists = np.empty((i + 1, 6, n_samples))
        new_twists[:i, :3] = rotate(rt, twists[:, :3])
        new_twists[:i, 3:] = rotate(rt, twists[:, 3:] + times(cross_p, twists[:, :3]))
        new_twists[i, :3], new_twists[i, 3:] = a, 0.0
        parent = np.stack([omega, omega_dot, acc])
        omega = w + a * dq[:, i]
        omega_dot = wd + a * ddq[:, i] + times(cross_a, w) * dq[:, i]
        acc = rotate(rt, b)
        twists = new_twists
        tapes.append(_Tape(rt, parent, w, wd, omega, acc, twists))
        states.append(np.concatenate([omega_dot, acc, (omega[:, None] * omega[None]).reshape(9, n_samples)]))
    return chain, tapes, states


def regressor_vjp(
    robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, weights: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vector–Jacobian products ``Σ_{j,p} G[k, j, p]·∂W[k, j, p]/∂(q, q̇, q̈)_l`` per sample.

    Reverse mode: one forward recursion (no tangents), then the adjoints of every segment's state
    ``t̄_i = ⟨C_m, Σ_k u_ki·g_kiᵀ⟩`` and twists ``ū_ki = Y_i·g_ki`` are swept back to the base
    through the recursion, with ``d(Rᵀv)/dq_i = (Rᵀv) × a`` and the adjoint ``R·v̄`` of ``Rᵀv``. Its
    cost grows with N_J² only through the 6-vector twists, where the forward mode of
    :func:`~lwrlab.dynamics.regressor_jacobians.regressor_jacobians` carries 3·N_J tangents of everything.

    Parameters
    ----------
    robot : a serial chain of revolute joints.
    q, dq, ddq : joint positions (rad), velocities (rad/s), accelerations (rad/s²), shape (N, N_J).
    weights : G, shape (N, N_J, P) or stacked (N·N_J, P): e.g. ``∂J/∂W`` of a criterion J.

    Returns
    -------
    Three (N, N_J) arrays: ``∂(Σ G·W)/∂q`` (per rad), ``/∂q̇`` (per rad/s), ``/∂q̈`` (per rad/s²); with
    ``G = ∂J/∂W`` these are ``∂J/∂q``, ``∂J/∂q̇``, ``∂J/∂q̈`` sample by sample.
    """
    q, dq, ddq = joint_states(robot.n_joints, q, dq, ddq)
    n_samples, n = q.shape
    g = np.asarray(weights, dtype=float).reshape(n_samples, n, robot.n_parameters)
    chain, tapes, states = _forward_tape(robot, q, dq, ddq)
    grad = np.zeros((3, n, n_samples))
    # adjoints of the child's parent quantities (ω, ω̇, acc) and twists, carried down the chain
    parent_bar = np.zeros((3, 3, n_samples))
    twists_bar = np.zeros((n, 6, n_samples))  # of the twists of joints 0…i seen from frame i
    for i in range(n - 1, -1, -1):
        tape = tapes[i]
        a, p = chain.axes[i][:, None], chain.translations[i][:, None]
        cross_a, cross_p = (
            -skew(chain.axes[i]),
            skew(chain.translations[i]),
        )  # v × a = −S(a)·v, p × v = S(p)·v
        # (i+1, 10, N): weights of segment i on joints 0…i, samples last (only this block is transposed)
        gi = np.ascontiguousarray(g[:, : i + 1, 10 * i : 10 * i + 10].transpose(1, 2, 0))
        # Products with the constant basis: a (60 × 15)·(15 × N) product is BLAS's job (5× einsum,
        # one thread under the solver's limit).
        y = (WRENCH_BASIS_FLAT.T @ states[i]).reshape(6, 10, n_samples)
        y_bar = np.einsum("kan,kpn->apn", tape.twists, gi)  # Σ_k u_ki·g_kiᵀ
        state_bar = WRENCH_BASIS_FLAT @ y_bar.reshape(60, n_samples)  # t̄_m = ⟨C_m, Ȳ⟩
        u_bar = np.einsum("apn,kpn->kan", y, gi)  # ū_ki = Y_i·g_ki
        u_bar += twists_bar
        outer_bar = state_bar[6:].reshape(3, 3, n_samples)  # of ω_i·ω_iᵀ
        omega_bar = parent_bar[0] + np.einsum(
            "bdn,dn->bn", outer_bar + outer_bar.transpose(1, 0, 2), tape.omega
        )
        omega_dot_bar = parent_bar[1] + state_bar[:3]
        acc_bar = parent_bar[2] + state_bar[3:6]
        omega_p = tape.parent[0]
        q_bar = dot(acc_bar, times(cross_a, tape.acc))
        # acc_i = Rᵀb, b = acc_p + ω̇_p × p + ω_p × (ω_p × p)
        b_bar = pull_back(tape.rt, acc_bar)
        new_parent_bar = np.empty((3, 3, n_samples))
        new_parent_bar[2] = b_bar
        new_parent_bar[1] = times(cross_p, b_bar)
        new_parent_bar[0] = dot(omega_p, p) * b_bar + p * dot(b_bar, omega_p) - 2.0 * omega_p * dot(p, b_bar)
        # ω̇_i = Rᵀω̇_p + a·q̈_i + (Rᵀω_p) × a·q̇_i  and  ω_i = Rᵀω_p + a·q̇_i
        grad[2, i] += dot(a, omega_dot_bar)
        w_cross_a = times(cross_a, tape.w)
        grad[1, i] += dot(omega_dot_bar, w_cross_a) + dot(a, omega_bar)
        w_bar = omega_bar - times(cross_a, omega_dot_bar) * dq[:, i]
        q_bar += dot(omega_dot_bar, times(cross_a, tape.wd)) + dot(w_bar, w_cross_a)
        new_parent_bar[1] += pull_back(tape.rt, omega_dot_bar)
        new_parent_bar[0] += pull_back(tape.rt, w_bar)
        # twists of joints k < i: ang ← Rᵀang, lin ← Rᵀ(lin + ang × p)
        if i > 0:
            twists_i = tape.twists[:i]
            q_bar += np.einsum(
                "kan,kan->n",
                u_bar[:i],
                times(cross_a, twists_i.reshape(2 * i, 3, n_samples)).reshape(i, 6, n_samples),
            )
            lin_bar = pull_back(tape.rt, u_bar[:i, 3:])
            twists_bar = np.empty((i, 6, n_samples))
            twists_bar[:, :3] = pull_back(tape.rt, u_bar[:i, :3]) + times(cross_p, lin_bar)
            twists_bar[:, 3:] = lin_bar
        grad[0, i] += q_bar
        parent_bar = new_parent_bar
    viscous = friction_columns(robot, "viscous")
    if viscous is not None:
        joints = np.arange(n)
        grad[1, joints] += g[:, joints, viscous.start + joints].T
    return grad[0].T, grad[1].T, grad[2].T
