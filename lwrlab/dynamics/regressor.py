"""Batched joint-torque regressor ``W(q, q̇, q̈)`` with friction columns.

For N samples the regressor stacks the per-sample ``N_J × P`` matrices sample-major (rows
``k·N_J + j``), as in eq. (5) of Katsumata et al., so that ``W @ φ`` is the torque of every joint at
every sample; ``P = 10·N_L + (number of friction terms)·N_J`` in the column order of
:attr:`lwrlab.model.robot.RobotModel.parameter_names`.

Serial chains of revolute joints (every robot built from a DH table, most URDF arms) use a
vectorised Newton–Euler recursion over all samples at once. Anything else falls back to a loop over
Pinocchio's ``computeJointTorqueRegressor``.
"""

from __future__ import annotations

from dataclasses import dataclass
import numpy as np
import pinocchio as pin

from lwrlab.model.inertia import PIN_TO_STANDARD
from lwrlab.model.robot import RobotModel

_AXES = {"RX": np.array([1.0, 0.0, 0.0]), "RY": np.array([0.0, 1.0, 0.0]), "RZ": np.array([0.0, 0.0, 1.0])}


@dataclass(frozen=True)
class SerialChain:
    """Constant geometry of a serial revolute chain: per joint, its placement in the parent frame and axis."""

    rotations: np.ndarray
    """(N_J, 3, 3) rotation of each joint frame at q = 0 in its parent frame."""
    translations: np.ndarray
    """(N_J, 3) origin of each joint frame in its parent frame (m)."""
    axes: np.ndarray
    """(N_J, 3) unit joint axis in the joint frame."""
    gravity: np.ndarray
    """Gravity in the base frame (m/s²)."""


def serial_chain(model: pin.Model) -> SerialChain | None:
    """The chain's constant geometry, or None if ``model`` is not a serial chain of revolute joints."""
    rotations, translations, axes = [], [], []
    for j in range(1, model.njoints):
        joint = model.joints[j]
        kind = joint.shortname().removeprefix("JointModel")
        if model.parents[j] != j - 1:
            return None
        if kind in _AXES:
            axis = _AXES[kind]
        elif kind == "RevoluteUnaligned":
            axis = np.asarray(joint.extract().axis, dtype=float)
        else:
            return None
        placement = model.jointPlacements[j]
        rotations.append(np.array(placement.rotation))
        translations.append(np.array(placement.translation))
        axes.append(axis / np.linalg.norm(axis))
    return SerialChain(np.array(rotations), np.array(translations), np.array(axes), np.array(model.gravity.linear))


def _skew(v: np.ndarray) -> np.ndarray:
    """Batched cross-product matrices of (N, 3) vectors → (N, 3, 3)."""
    s = np.zeros(v.shape[:-1] + (3, 3))
    s[..., 0, 1], s[..., 0, 2] = -v[..., 2], v[..., 1]
    s[..., 1, 0], s[..., 1, 2] = v[..., 2], -v[..., 0]
    s[..., 2, 0], s[..., 2, 1] = -v[..., 1], v[..., 0]
    return s


def _inertia_operator(w: np.ndarray) -> np.ndarray:
    """(N, 3, 6) matrix L(w) with ``I·w = L(w)·[XX, YY, ZZ, XY, XZ, YZ]``."""
    op = np.zeros(w.shape[:-1] + (3, 6))
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    op[..., 0, 0], op[..., 0, 3], op[..., 0, 4] = x, y, z
    op[..., 1, 1], op[..., 1, 3], op[..., 1, 5] = y, x, z
    op[..., 2, 2], op[..., 2, 4], op[..., 2, 5] = z, x, y
    return op


def _axis_rotations(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotations by ``angle`` (N,) about the constant unit ``axis`` (Rodrigues)."""
    k = _skew(axis)
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * k + (1.0 - c) * (k @ k)


def chain_inertial_regressor(chain: SerialChain, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
    """Inertial regressor of a serial revolute chain, shape (N, N_J, 10·N_J).

    A forward recursion over all samples at once gives each segment's angular velocity ω, angular
    acceleration ω̇ and the linear acceleration a of its frame origin (gravity enters as a base
    acceleration −g), all in the segment frame. The segment's wrench about its origin is linear in
    its 10 parameters, ``[f; n] = Y·φ_j`` with::

        f = M·a + (S(ω̇) + S(ω)²)·MS
        n = (L(ω̇) + S(ω)·L(ω))·I − S(a)·MS

    Joint k ≤ j feels ``τ_k = z_k·(n_j + (o_j − o_k) × f_j)`` (world frame), i.e. ``u_kjᵀ·Y`` with
    ``u_kj = R_jᵀ·[z_k × (o_j − o_k); z_k]``: one small batched product per segment, no backward pass.
    """
    n_samples, n = q.shape
    rot_world = np.empty((n_samples, n, 3, 3))
    origin_world = np.empty((n_samples, n, 3))
    w = np.zeros((n_samples, 3))
    dw = np.zeros((n_samples, 3))
    acc = np.broadcast_to(-chain.gravity, (n_samples, 3)).copy()
    rot, origin = np.broadcast_to(np.eye(3), (n_samples, 3, 3)), np.zeros((n_samples, 3))
    blocks = np.zeros((n, n_samples, 6, 10))
    for j in range(n):
        rel = chain.rotations[j] @ _axis_rotations(chain.axes[j], q[:, j])
        p = chain.translations[j]
        origin = origin + rot @ p
        rot = rot @ rel
        rot_world[:, j], origin_world[:, j] = rot, origin
        rel_t = np.swapaxes(rel, 1, 2)
        acc = (rel_t @ (acc + np.cross(dw, p) + np.cross(w, np.cross(w, p)))[:, :, None])[:, :, 0]
        w_parent = (rel_t @ w[:, :, None])[:, :, 0]
        joint_rate = dq[:, j, None] * chain.axes[j]
        w = w_parent + joint_rate
        dw = (rel_t @ dw[:, :, None])[:, :, 0] + ddq[:, j, None] * chain.axes[j] + np.cross(w_parent, joint_rate)
        s_w = _skew(w)
        block = blocks[j]
        block[:, :3, 0] = acc
        block[:, :3, 1:4] = _skew(dw) + s_w @ s_w
        block[:, 3:, 1:4] = -_skew(acc)
        block[:, 3:, 4:] = _inertia_operator(dw) + s_w @ _inertia_operator(w)

    axes_world = rot_world @ chain.axes[None, :, :, None]  # (N, n, 3, 1)
    axes_world = axes_world[..., 0]
    regressor = np.zeros((n_samples, n, 10 * n))
    for j in range(n):
        z = axes_world[:, : j + 1]
        lever = np.cross(z, origin_world[:, j : j + 1] - origin_world[:, : j + 1])
        coefficients = np.concatenate([lever, z], axis=2) @ _block_diagonal(rot_world[:, j])  # (N, j+1, 6)
        regressor[:, : j + 1, 10 * j : 10 * j + 10] = coefficients @ blocks[j]
    return regressor


def _block_diagonal(rot: np.ndarray) -> np.ndarray:
    """(N, 6, 6) ``diag(R, R)`` so that a row ``[c; z]ᵀ`` maps to ``[Rᵀc; Rᵀz]ᵀ``."""
    out = np.zeros(rot.shape[:-2] + (6, 6))
    out[..., :3, :3] = rot
    out[..., 3:, 3:] = rot
    return out


def loop_inertial_regressor(model: pin.Model, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
    """Inertial regressor by one ``pin.computeJointTorqueRegressor`` call per sample (any model)."""
    data = model.createData()
    n_samples = q.shape[0]
    out = np.empty((n_samples, model.nv, 10 * (model.njoints - 1)))
    for k in range(n_samples):
        out[k] = pin.computeJointTorqueRegressor(model, data, q[k], dq[k], ddq[k])
    # Pinocchio orders each segment's parameters differently: permute to the standard order.
    return out.reshape(n_samples, model.nv, -1, 10)[..., PIN_TO_STANDARD].reshape(n_samples, model.nv, -1)


def friction_regressor(dq: np.ndarray, terms: tuple[str, ...]) -> np.ndarray:
    """Friction columns, shape (N, N_J, len(terms)·N_J): diagonal blocks of sign(q̇), q̇ or 1."""
    n_samples, n = dq.shape
    out = np.zeros((n_samples, n, len(terms) * n))
    diag = np.arange(n)
    basis = {"coulomb": np.sign, "viscous": lambda v: v, "offset": np.ones_like}
    for t, term in enumerate(terms):
        out[:, diag, t * n + diag] = basis[term](dq)
    return out


def _as_samples(x: np.ndarray, n: int, name: str) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    x = x.reshape(1, -1) if x.ndim == 1 else x
    if x.ndim != 2 or x.shape[1] != n:
        raise ValueError(f"{name} must have shape (N, {n}), got {x.shape}")
    return x


def regressor(robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, *, stacked: bool = True) -> np.ndarray:
    """The full regressor ``W`` so that ``W @ robot.parameters`` is the joint torque (N·m).

    Parameters
    ----------
    robot : the robot (its friction terms select the friction columns).
    q, dq, ddq : joint positions (rad), velocities (rad/s), accelerations (rad/s²), shape (N, N_J).
    stacked : if True return (N·N_J, P) sample-major; otherwise (N, N_J, P).

    Examples
    --------
    >>> from plugins.robots.mdh import load_robot  # doctest: +SKIP
    >>> W = regressor(robot, q, dq, ddq)           # doctest: +SKIP
    >>> np.allclose(W @ robot.parameters, robot.inverse_dynamics(q, dq, ddq).ravel())  # doctest: +SKIP
    True
    """
    n = robot.n_joints
    q, dq, ddq = (_as_samples(x, n, name) for x, name in ((q, "q"), (dq, "dq"), (ddq, "ddq")))
    chain = serial_chain(robot.model)  # a few µs: cheaper than caching on a mutable model
    if chain is not None:
        inertial = chain_inertial_regressor(chain, q, dq, ddq)
    else:
        inertial = loop_inertial_regressor(robot.model, q, dq, ddq)
    full = np.concatenate([inertial, friction_regressor(dq, robot.friction_terms)], axis=2)
    return full.reshape(-1, full.shape[2]) if stacked else full
