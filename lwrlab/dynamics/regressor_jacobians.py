"""Exact derivatives of the regressor ``W(q, q̇, q̈)`` with respect to q, q̇ and q̈: the full tensors.

The excitation criteria are functions of the base regressor ``W_b``; their gradient with respect to
the motion needs ``∂W/∂q``, ``∂W/∂q̇`` and ``∂W/∂q̈`` (the chain of Katsumata et al. §III.C:
criterion → ``W_b`` → (q, q̇, q̈) → trajectory parameters). Two products are offered:

* :func:`regressor_jacobians` (here) — the full tensors ``∂W[k, j, p]/∂x_l`` for every sample k (for
  tests and for small batches: it holds N·N_J·P·3N_J numbers);
* :func:`lwrlab.dynamics.regressor_vjp.regressor_vjp` — the vector–Jacobian product
  ``Σ_{j,p} G[k, j, p]·∂W[k, j, p]/∂x_l`` for a weight ``G`` of the regressor's shape: what an
  optimiser needs, in reverse mode, without ever forming the tensors.

Method of the tensors: forward-mode differentiation of the Newton–Euler regressor recursion,
vectorised over the samples (last axis of every array) and carrying all 3·N_J tangent directions at
once. For segment i (joint frame i, Pinocchio's convention: inertia about the frame origin, axes of
the frame)::

    ω_i = Rᵀω_p + a·q̇_i          ω̇_i = Rᵀω̇_p + a·q̈_i + (Rᵀω_p) × a·q̇_i
    acc_i = Rᵀ(acc_p + ω̇_p × p + ω_p × (ω_p × p))        (acc_0 = −g)

with R = E·exp(q_i·[a]) the joint's rotation in its parent, p its origin, a its unit axis; and
``d(Rᵀv)/dq_i = (Rᵀv) × a``. The segment's wrench about its origin is linear in its standard
parameters, ``w_i = Y_i·φ_i``, and ``Y_i`` is linear in ``t_i = (ω̇_i, acc_i, ω_iω_iᵀ)``:
``Y_i = Σ_m t_m·C_m`` with the constant 6×10 matrices of
:data:`~lwrlab.dynamics.segment_wrench.WRENCH_BASIS`. Joint k ≤ i feels ``W[k, i] = u_kiᵀ·Y_i``
with ``u_ki`` the unit twist of joint k seen from frame i, carried forward as ``ang ← Rᵀang``,
``lin ← Rᵀ(lin + ang × p)``. The product rule then gives
``∂W[k, i] = ∂u_kiᵀ·Y_i + u_kiᵀ·Σ_m ∂t_m·C_m``.

The friction columns are differentiated in closed form: Coulomb ``sign(q̇)`` has a zero derivative
(away from q̇ = 0, where it jumps), viscous ``q̇`` a unit one, offset none.

``benchmarks/excitation.py`` compares this with the column-wise alternative
(:func:`regressor_jacobians_pinocchio`); tests compare both with central finite differences of
:func:`lwrlab.dynamics.regressor.regressor`.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from lwrlab.dynamics.batched_vectors import cross, rotate, transposed_rotations
from lwrlab.dynamics.friction_regressor import friction_columns
from lwrlab.dynamics.regressor import joint_states
from lwrlab.dynamics.segment_wrench import WRENCH_BASIS_FLAT
from lwrlab.dynamics.serial_chain import checked_serial_chain
from lwrlab.model.inertia import to_pin_inertia
from lwrlab.model.robot import RobotModel


@dataclass
class Segment:
    """What the forward pass knows about segment i (samples last).

    Only the joints 0…i move segment i: its tangents are kept for those directions alone.
    """

    index: int
    state: np.ndarray
    """(15, N) t = (ω̇, acc, vec(ωωᵀ)) in frame i."""
    state_tangent: np.ndarray
    """(3, i+1, 15, N) ∂t/∂x_l for x = q, q̇, q̈ (first axis) and joints l = 0…i."""
    twists: np.ndarray
    """(i+1, 6, N) unit twists (ang; lin) of joints 0…i seen from frame i."""
    twist_tangent: np.ndarray
    """(i+1, i+1, 6, N) ∂twist_k/∂q_l, [l, k, …] (twists do not depend on q̇, q̈)."""


def _grown(tangent: np.ndarray, m: int) -> np.ndarray:
    """(3, m, 3, N) tangents with room for joint m−1's directions (zero: the parent does not depend on it)."""
    out = np.zeros((3, m, *tangent.shape[2:]))
    out[:, : m - 1] = tangent
    return out


def forward_pass(robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> Iterator[Segment]:
    """Forward Newton–Euler recursion with tangents, one segment at a time (samples last).

    Tangent arrays are [kind (q, q̇, q̈), joint l, xyz, sample]; at segment i only l ≤ i are computed.
    """
    chain = checked_serial_chain(robot.model, "regressor derivatives")
    n_samples = q.shape[0]
    omega = np.zeros((3, n_samples))
    omega_dot = np.zeros((3, n_samples))
    acc = np.broadcast_to(-robot.gravity[:, None], (3, n_samples)).copy()
    d_omega = np.zeros((3, 0, 3, n_samples))
    d_omega_dot = np.zeros((3, 0, 3, n_samples))
    d_acc = np.zeros((3, 0, 3, n_samples))
    twists = np.zeros((0, 6, n_samples))
    d_twists = np.zeros((0, 0, 6, n_samples))
    for i in range(len(chain.axes)):
        rt = transposed_rotations(chain.rotations[i], chain.axes[i], q[:, i])
        a = chain.axes[i][:, None]  # (3, 1)
        p = chain.translations[i][:, None]
        m = i + 1  # directions that move segment i: joints 0…i

        # ω_i = Rᵀω_p + a·q̇_i
        w = rotate(rt, omega)
        w_cross_a = cross(w, a)
        dw = _grown(rotate(rt, d_omega), m)
        dw[0, i] = w_cross_a
        new_omega = w + a * dq[:, i]
        d_new_omega = dw.copy()
        d_new_omega[1, i] += a
        # ω̇_i = Rᵀω̇_p + a·q̈_i + (Rᵀω_p) × a·q̇_i
        wd = rotate(rt, omega_dot)
        new_omega_dot = wd + a * ddq[:, i] + w_cross_a * dq[:, i]
        d_new_omega_dot = _grown(rotate(rt, d_omega_dot), m)
        d_new_omega_dot[0, i] = cross(wd, a)
        d_new_omega_dot += cross(dw, a) * dq[:, i]
        d_new_omega_dot[2, i] += a
        d_new_omega_dot[1, i] += w_cross_a
        # acc_i = Rᵀ(acc_p + ω̇_p × p + ω_p × (ω_p × p))
        w_cross_p = cross(omega, p)
        b = acc + cross(omega_dot, p) + cross(omega, w_cross_p)
        db = d_acc + cross(d_omega_dot, p) + cross(d_omega, w_cross_p) + cross(omega, cross(d_omega, p))
        new_acc = rotate(rt, b)
        d_new_acc = _grown(rotate(rt, db), m)
        d_new_acc[0, i] = cross(new_acc, a)
        # unit twists: ang ← Rᵀang, lin ← Rᵀ(lin + ang × p); joint i's own is (a; 0)
        ang, lin = twists[:, :3], twists[:, 3:]
        new_twists = np.empty((m, 6, n_samples))
        new_twists[:i, :3] = rotate(rt, ang)
        new_twists[:i, 3:] = rotate(rt, lin + cross(ang, p))
        new_twists[i, :3], new_twists[i, 3:] = a, 0.0
        d_new_twists = np.zeros((m, m, 6, n_samples))
        d_ang, d_lin = d_twists[:, :, :3], d_twists[:, :, 3:]
        d_new_twists[:i, :i, :3] = rotate(rt, d_ang)
        d_new_twists[:i, :i, 3:] = rotate(rt, d_lin + cross(d_ang, p))
        d_new_twists[i, :i, :3] = cross(new_twists[:i, :3], a)
        d_new_twists[i, :i, 3:] = cross(new_twists[:i, 3:], a)

        omega, omega_dot, acc = new_omega, new_omega_dot, new_acc
        d_omega, d_omega_dot, d_acc = d_new_omega, d_new_omega_dot, d_new_acc
        twists, d_twists = new_twists, d_new_twists

        state = np.concatenate([omega_dot, acc, (omega[:, None] * omega[None]).reshape(9, n_samples)])
        d_outer = d_omega[..., :, None, :] * omega[None, :, :] + omega[:, None, :] * d_omega[..., None, :, :]
        d_state = np.concatenate([d_omega_dot, d_acc, d_outer.reshape(3, m, 9, n_samples)], axis=2)
        yield Segment(i, state, d_state, twists, d_twists)


def regressor_jacobians(
    robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Full derivatives of the regressor, each of shape (N, N_J, P, N_J).

    ``dW_dq[k, j, p, l] = ∂W[k, j, p]/∂q_l`` at sample k (N·m per rad per unit parameter), likewise
    for q̇ (per rad/s) and q̈ (per rad/s²); ``W`` is :func:`lwrlab.dynamics.regressor.regressor`
    unstacked, columns in the order of ``robot.parameter_names``.

    Parameters
    ----------
    robot : a serial chain of revolute joints.
    q, dq, ddq : joint positions (rad), velocities (rad/s), accelerations (rad/s²), shape (N, N_J).
    """
    q, dq, ddq = joint_states(robot.n_joints, q, dq, ddq)
    n_samples, n = q.shape
    jac = np.zeros((3, n, n_samples, n, robot.n_parameters))  # [kind, l, sample, joint, column]
    for seg in forward_pass(robot, q, dq, ddq):
        i, m = seg.index, seg.index + 1
        y = np.einsum("mr,mn->rn", WRENCH_BASIS_FLAT, seg.state).reshape(6, 10, n_samples)
        dy = np.einsum("mr,cdmn->cdrn", WRENCH_BASIS_FLAT, seg.state_tangent).reshape(3, m, 6, 10, n_samples)
        block = np.einsum("kan,cdapn->cdnkp", seg.twists, dy)
        block[0] += np.einsum("dkan,apn->dnkp", seg.twist_tangent, y)
        jac[:, :m, :, :m, 10 * i : 10 * i + 10] = block
    viscous = friction_columns(robot, "viscous")
    if viscous is not None:
        joints = np.arange(n)
        jac[1, joints, :, joints, viscous.start + joints] = 1.0
    jac = jac.transpose(0, 2, 3, 4, 1)  # [kind, sample, joint, column, l]
    return jac[0], jac[1], jac[2]


def regressor_jacobians_pinocchio(
    robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The inertial columns of :func:`regressor_jacobians` by Pinocchio, column by column (a reference).

    Inverse dynamics is linear in the parameters, so its derivatives are too: column p of ``∂W`` is
    ``∂τ(φ_ref + e_p) − ∂τ(φ_ref)`` from ``pin.computeRNEADerivatives`` with a physical reference
    segment ``φ_ref`` (Pinocchio's inertias need a positive mass). 10·N_L + 1 calls per sample:
    for tests and for the speed comparison of ``benchmarks/excitation.py``. Friction columns are left zero.
    """
    q, dq, ddq = joint_states(robot.n_joints, q, dq, ddq)
    model = robot.model.copy()
    data = model.createData()
    n_samples, n = q.shape
    reference = np.array([1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
    out = np.zeros((3, n_samples, n, robot.n_parameters, n))

    def derivatives(k: int) -> np.ndarray:
        pin.computeRNEADerivatives(model, data, q[k], dq[k], ddq[k])
        return np.stack([data.dtau_dq.copy(), data.dtau_dv.copy(), np.triu(data.M) + np.triu(data.M, 1).T])

    for j in range(1, model.njoints):
        model.inertias[j] = to_pin_inertia(reference)
    base = [derivatives(k) for k in range(n_samples)]
    for column in range(10 * robot.n_links):
        segment, entry = divmod(column, 10)
        phi = reference.copy()
        phi[entry] += 1.0
        model.inertias[segment + 1] = to_pin_inertia(phi)
        for k in range(n_samples):
            out[:, k, :, column, :] = derivatives(k) - base[k]
        model.inertias[segment + 1] = to_pin_inertia(reference)
    return out[0], out[1], out[2]
