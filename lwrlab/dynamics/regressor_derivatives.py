"""Exact derivatives of the regressor ``W(q, q̇, q̈)`` with respect to q, q̇ and q̈.

The excitation criteria are functions of the base regressor ``W_b``; their gradient with respect to
the motion needs ``∂W/∂q``, ``∂W/∂q̇`` and ``∂W/∂q̈`` (the chain of Katsumata et al. §III.C:
criterion → ``W_b`` → (q, q̇, q̈) → trajectory parameters). Two products are offered:

* :func:`regressor_jacobians` — the full tensors ``∂W[k, j, p]/∂x_l`` for every sample k (for tests
  and for small batches: it holds N·N_J·P·3N_J numbers);
* :func:`regressor_vjp` — the vector–Jacobian product ``Σ_{j,p} G[k, j, p]·∂W[k, j, p]/∂x_l`` for a
  weight ``G`` of the regressor's shape (the gradient of a criterion with respect to W): what an
  optimiser needs, at the cost of a few regressors, without ever forming the tensors. It runs in
  reverse mode (adjoints swept from the last segment to the base, see its docstring): 3× faster
  than contracting the forward-mode tangents on the 1 001 samples of a 10 s motion at 100 Hz.

Method of the tensors: forward-mode differentiation of the Newton–Euler regressor recursion, vectorised over the
samples (last axis of every array) and carrying all 3·N_J tangent directions at once. For segment i
(joint frame i, Pinocchio's convention: inertia about the frame origin, axes of the frame)::

    ω_i = Rᵀω_p + a·q̇_i          ω̇_i = Rᵀω̇_p + a·q̈_i + (Rᵀω_p) × a·q̇_i
    acc_i = Rᵀ(acc_p + ω̇_p × p + ω_p × (ω_p × p))        (acc_0 = −g)

with R = E·exp(q_i·[a]) the joint's rotation in its parent, p its origin, a its unit axis; and
``d(Rᵀv)/dq_i = (Rᵀv) × a``. The segment's wrench about its origin is linear in its standard
parameters, ``w_i = Y_i·φ_i``, and ``Y_i`` is linear in ``t_i = (ω̇_i, acc_i, ω_iω_iᵀ)``:
``Y_i = Σ_m t_m·C_m`` with the constant 6×10 matrices of :data:`WRENCH_BASIS`. Joint k ≤ i feels
``W[k, i] = u_kiᵀ·Y_i`` with ``u_ki`` the unit twist of joint k seen from frame i, carried forward
as ``ang ← Rᵀang``, ``lin ← Rᵀ(lin + ang × p)``. The product rule then gives
``∂W[k, i] = ∂u_kiᵀ·Y_i + u_kiᵀ·Σ_m ∂t_m·C_m``; for the vector–Jacobian product the weights are
first pulled back onto ``t_i`` and ``u_ki`` (``t̄_m = ⟨C_m, Σ_k u_ki·g_kiᵀ⟩``, ``ū_ki = Y_i·g_ki``),
so each direction costs a few dot products per sample.

The friction columns are differentiated in closed form: Coulomb ``sign(q̇)`` has a zero derivative
(away from q̇ = 0, where it jumps), viscous ``q̇`` a unit one, offset none.

``benchmarks/excitation.py`` compares this with the column-wise alternative (Pinocchio's
``computeRNEADerivatives`` once per parameter column and sample); tests compare both with central
finite differences of :func:`lwrlab.dynamics.regressor.regressor`.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from lwrlab.model.robot import RobotModel

_AXES = {"RX": (1.0, 0.0, 0.0), "RY": (0.0, 1.0, 0.0), "RZ": (0.0, 0.0, 1.0)}


def _skew(v: np.ndarray) -> np.ndarray:
    """3×3 matrix S(v) with ``S(v)·w = v × w``."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _inertia_map(v: np.ndarray) -> np.ndarray:
    """3×6 matrix L(v) with ``I·v = L(v)·[XX, YY, ZZ, XY, XZ, YZ]``."""
    x, y, z = v
    return np.array([[x, 0, 0, y, z, 0], [0, y, 0, x, 0, z], [0, 0, z, 0, x, y]], dtype=float)


def _wrench_basis() -> np.ndarray:
    """(15, 6, 10) ``C_m`` with ``Y = Σ_m t_m·C_m`` for ``t = (ω̇, acc, vec(ωωᵀ))``.

    Rows of Y: moment n (about the frame origin), then force f; columns: the standard parameters
    ``[M, MSX, MSY, MSZ, XX, YY, ZZ, XY, XZ, YZ]``. From Newton–Euler about the origin::

        f = M·acc + (S(ω̇) + Ω − tr(Ω)·1)·MS              (ω × (ω × MS) = (Ω − tr(Ω)·1)·MS, Ω = ωωᵀ)
        n = MS × acc + I·ω̇ + ω × (I·ω)                    (ω × I·ω = Σ_bd Ω_bd·e_b × (I·e_d))
    """
    eye = np.eye(3)
    basis = np.zeros((15, 6, 10))
    for m in range(3):
        basis[m, 3:, 1:4] = _skew(eye[m])  # ω̇ × MS
        basis[m, :3, 4:] = _inertia_map(eye[m])  # I·ω̇
        basis[3 + m, 3:, 0] = eye[m]  # M·acc
        basis[3 + m, :3, 1:4] = -_skew(eye[m])  # MS × acc = −acc × MS
    for b in range(3):
        for d in range(3):
            m = 6 + 3 * b + d
            basis[m, 3:, 1:4] = np.outer(eye[b], eye[d]) - (b == d) * eye
            basis[m, :3, 4:] = _skew(eye[b]) @ _inertia_map(eye[d])
    return basis


WRENCH_BASIS = _wrench_basis()
"""(15, 6, 10) constant matrices mapping ``(ω̇, acc, vec(ωωᵀ))`` of a segment to its wrench regressor."""
_WRENCH_BASIS_FLAT = WRENCH_BASIS.reshape(15, 60)
# Products with it use np.einsum, not BLAS: these are tiny matrices times many samples, where BLAS
# calls cost milliseconds each (thread start-up) and einsum microseconds.


@dataclass(frozen=True)
class _Joint:
    """Constant geometry of one revolute joint: placement (E, p) in the parent and unit axis a."""

    rotation: np.ndarray
    translation: np.ndarray
    axis: np.ndarray


def _revolute_chain(model: pin.Model) -> list[_Joint]:
    """The joints of a serial chain of revolute joints (ValueError otherwise)."""
    joints = []
    for j in range(1, model.njoints):
        kind = model.joints[j].shortname().removeprefix("JointModel")
        if model.parents[j] != j - 1:
            raise ValueError(
                f"regressor derivatives need a serial chain; joint {j} has parent {model.parents[j]}"
            )
        if kind in _AXES:
            axis = np.array(_AXES[kind])
        elif kind == "RevoluteUnaligned":
            axis = np.asarray(model.joints[j].extract().axis, dtype=float)
            axis = axis / np.linalg.norm(axis)
        else:
            raise ValueError(f"regressor derivatives need revolute joints; joint {j} is {kind}")
        placement = model.jointPlacements[j]
        joints.append(_Joint(np.array(placement.rotation), np.array(placement.translation), axis))
    return joints


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Cross product along axis −2 (the (x, y, z) axis; samples last), broadcasting.

    Written out: ``np.cross`` moves axes and copies, several times slower on these small arrays.
    """
    ux, uy, uz = u[..., 0:1, :], u[..., 1:2, :], u[..., 2:3, :]
    vx, vy, vz = v[..., 0:1, :], v[..., 1:2, :], v[..., 2:3, :]
    return np.concatenate([uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx], axis=-2)


def _rotate(rt: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``Rᵀ·v`` for per-sample rotations ``rt`` (3, 3, N) = Rᵀ and vectors ``v`` (..., 3, N)."""
    return rt[0] * v[..., 0:1, :] + rt[1] * v[..., 1:2, :] + rt[2] * v[..., 2:3, :]


def _transposed_rotations(joint: _Joint, angles: np.ndarray) -> np.ndarray:
    """Columns of Rᵀ = exp(−q·[a])·Eᵀ, laid out (3, 3, N) so that ``rt[b][:, n]`` is column b of sample n."""
    s, c = np.sin(angles), np.cos(angles)
    k = _skew(joint.axis)
    et = joint.rotation.T
    # exp(−q[a]) = 1 − sin q·[a] + (1 − cos q)·[a]²  (Rodrigues)
    rt = et[..., None] - (k @ et)[..., None] * s + (k @ k @ et)[..., None] * (1.0 - c)  # (3, 3, N) [a, b, n]
    return np.ascontiguousarray(rt.transpose(1, 0, 2))  # [b, a, n]: column b of Rᵀ


@dataclass
class _Segment:
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


def _forward_pass(robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> Iterator[_Segment]:
    """Forward Newton–Euler recursion with tangents, one segment at a time (samples last).

    Tangent arrays are [kind (q, q̇, q̈), joint l, xyz, sample]; at segment i only l ≤ i are computed.
    """
    joints = _revolute_chain(robot.model)
    n = len(joints)
    n_samples = q.shape[0]
    omega = np.zeros((3, n_samples))
    omega_dot = np.zeros((3, n_samples))
    acc = np.broadcast_to(-robot.gravity[:, None], (3, n_samples)).copy()
    d_omega = np.zeros((3, 0, 3, n_samples))
    d_omega_dot = np.zeros((3, 0, 3, n_samples))
    d_acc = np.zeros((3, 0, 3, n_samples))
    twists = np.zeros((0, 6, n_samples))
    d_twists = np.zeros((0, 0, 6, n_samples))
    for i, joint in enumerate(joints):
        rt = _transposed_rotations(joint, q[:, i])
        a = joint.axis[:, None]  # (3, 1)
        p = joint.translation[:, None]
        m = i + 1  # directions that move segment i: joints 0…i

        def grow(tangent: np.ndarray) -> np.ndarray:
            """Room for joint i's directions (zero: the parent does not depend on joint i)."""
            out = np.zeros((3, m, 3, n_samples))
            out[:, :i] = tangent
            return out

        # ω_i = Rᵀω_p + a·q̇_i
        w = _rotate(rt, omega)
        w_cross_a = _cross(w, a)
        dw = grow(_rotate(rt, d_omega))
        dw[0, i] = w_cross_a
        new_omega = w + a * dq[:, i]
        d_new_omega = dw.copy()
        d_new_omega[1, i] += a
        # ω̇_i = Rᵀω̇_p + a·q̈_i + (Rᵀω_p) × a·q̇_i
        wd = _rotate(rt, omega_dot)
        new_omega_dot = wd + a * ddq[:, i] + w_cross_a * dq[:, i]
        d_new_omega_dot = grow(_rotate(rt, d_omega_dot))
        d_new_omega_dot[0, i] = _cross(wd, a)
        d_new_omega_dot += _cross(dw, a) * dq[:, i]
        d_new_omega_dot[2, i] += a
        d_new_omega_dot[1, i] += w_cross_a
        # acc_i = Rᵀ(acc_p + ω̇_p × p + ω_p × (ω_p × p))
        w_cross_p = _cross(omega, p)
        b = acc + _cross(omega_dot, p) + _cross(omega, w_cross_p)
        db = d_acc + _cross(d_omega_dot, p) + _cross(d_omega, w_cross_p) + _cross(omega, _cross(d_omega, p))
        new_acc = _rotate(rt, b)
        d_new_acc = grow(_rotate(rt, db))
        d_new_acc[0, i] = _cross(new_acc, a)
        # unit twists: ang ← Rᵀang, lin ← Rᵀ(lin + ang × p); joint i's own is (a; 0)
        ang, lin = twists[:, :3], twists[:, 3:]
        new_twists = np.empty((m, 6, n_samples))
        new_twists[:i, :3] = _rotate(rt, ang)
        new_twists[:i, 3:] = _rotate(rt, lin + _cross(ang, p))
        new_twists[i, :3], new_twists[i, 3:] = a, 0.0
        d_new_twists = np.zeros((m, m, 6, n_samples))
        d_ang, d_lin = d_twists[:, :, :3], d_twists[:, :, 3:]
        d_new_twists[:i, :i, :3] = _rotate(rt, d_ang)
        d_new_twists[:i, :i, 3:] = _rotate(rt, d_lin + _cross(d_ang, p))
        d_new_twists[i, :i, :3] = _cross(new_twists[:i, :3], a)
        d_new_twists[i, :i, 3:] = _cross(new_twists[:i, 3:], a)

        omega, omega_dot, acc = new_omega, new_omega_dot, new_acc
        d_omega, d_omega_dot, d_acc = d_new_omega, d_new_omega_dot, d_new_acc
        twists, d_twists = new_twists, d_new_twists

        state = np.concatenate([omega_dot, acc, (omega[:, None] * omega[None]).reshape(9, n_samples)])
        d_outer = d_omega[..., :, None, :] * omega[None, :, :] + omega[:, None, :] * d_omega[..., None, :, :]
        d_state = np.concatenate([d_omega_dot, d_acc, d_outer.reshape(3, m, 9, n_samples)], axis=2)
        yield _Segment(i, state, d_state, twists, d_twists)


def _as_states(
    robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n = robot.n_joints
    arrays = []
    for x, name in ((q, "q"), (dq, "dq"), (ddq, "ddq")):
        x = np.atleast_2d(np.asarray(x, dtype=float))
        if x.ndim != 2 or x.shape[1] != n:
            raise ValueError(f"{name} must have shape (N, {n}), got {x.shape}")
        arrays.append(x)
    if not arrays[0].shape == arrays[1].shape == arrays[2].shape:
        raise ValueError(f"q, dq and ddq must have one shape, got {[a.shape for a in arrays]}")
    return arrays[0], arrays[1], arrays[2]


def _friction_slice(robot: RobotModel, term: str) -> slice | None:
    if term not in robot.friction_terms:
        return None
    start = 10 * robot.n_links + robot.friction_terms.index(term) * robot.n_joints
    return slice(start, start + robot.n_joints)


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
    q, dq, ddq = _as_states(robot, q, dq, ddq)
    n_samples, n = q.shape
    jac = np.zeros((3, n, n_samples, n, robot.n_parameters))  # [kind, l, sample, joint, column]
    for seg in _forward_pass(robot, q, dq, ddq):
        i, m = seg.index, seg.index + 1
        y = np.einsum("mr,mn->rn", _WRENCH_BASIS_FLAT, seg.state).reshape(6, 10, n_samples)
        dy = np.einsum("mr,cdmn->cdrn", _WRENCH_BASIS_FLAT, seg.state_tangent).reshape(3, m, 6, 10, n_samples)
        block = np.einsum("kan,cdapn->cdnkp", seg.twists, dy)
        block[0] += np.einsum("dkan,apn->dnkp", seg.twist_tangent, y)
        jac[:, :m, :, :m, 10 * i : 10 * i + 10] = block
    viscous = _friction_slice(robot, "viscous")
    if viscous is not None:
        joints = np.arange(n)
        jac[1, joints, :, joints, viscous.start + joints] = 1.0
    jac = jac.transpose(0, 2, 3, 4, 1)  # [kind, sample, joint, column, l]
    return jac[0], jac[1], jac[2]


def _times(matrix: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``matrix·v`` for a constant 3×3 matrix and vectors ``v`` (..., 3, N): one call, where a
    cross product with a constant vector written out costs ten."""
    return np.einsum("ij,...jn->...in", matrix, v)


def _pull_back(rt: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R·v`` for per-sample rotations given as ``rt`` (3, 3, N) = Rᵀ (see :func:`_rotate`): the adjoint of ``Rᵀ·v``."""
    return np.einsum("ban,...an->...bn", rt, v)


def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Dot products along axis −2 (xyz; samples last)."""
    return np.einsum("...an,...an->...n", u, v)


@dataclass
class _Tape:
    """What the reverse sweep needs of segment i's forward step (samples last)."""

    rt: np.ndarray
    """(3, 3, N) Rᵀ of joint i (layout of :func:`_transposed_rotations`)."""
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
) -> tuple[list[_Joint], list[_Tape], list[np.ndarray]]:
    """The forward Newton–Euler recursion without tangents: each segment's tape and state t_i (15, N)."""
    joints = _revolute_chain(robot.model)
    n_samples = q.shape[0]
    omega, omega_dot = np.zeros((3, n_samples)), np.zeros((3, n_samples))
    acc = np.broadcast_to(-robot.gravity[:, None], (3, n_samples)).copy()
    twists = np.zeros((0, 6, n_samples))
    tapes, states = [], []
    for i, joint in enumerate(joints):
        rt = _transposed_rotations(joint, q[:, i])
        a = joint.axis[:, None]
        cross_a, cross_p = -_skew(joint.axis), -_skew(joint.translation)  # v × c = −S(c)·v
        w, wd = _rotate(rt, omega), _rotate(rt, omega_dot)
        b = acc + _times(cross_p, omega_dot) + _cross(omega, _times(cross_p, omega))
        new_twists = np.empty((i + 1, 6, n_samples))
        new_twists[:i, :3] = _rotate(rt, twists[:, :3])
        new_twists[:i, 3:] = _rotate(rt, twists[:, 3:] + _times(cross_p, twists[:, :3]))
        new_twists[i, :3], new_twists[i, 3:] = a, 0.0
        parent = np.stack([omega, omega_dot, acc])
        omega = w + a * dq[:, i]
        omega_dot = wd + a * ddq[:, i] + _times(cross_a, w) * dq[:, i]
        acc = _rotate(rt, b)
        twists = new_twists
        tapes.append(_Tape(rt, parent, w, wd, omega, acc, twists))
        states.append(np.concatenate([omega_dot, acc, (omega[:, None] * omega[None]).reshape(9, n_samples)]))
    return joints, tapes, states


def regressor_vjp(
    robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, weights: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vector–Jacobian products ``Σ_{j,p} G[k, j, p]·∂W[k, j, p]/∂(q, q̇, q̈)_l`` per sample.

    Reverse mode: one forward recursion (no tangents), then the adjoints of every segment's state
    ``t̄_i = ⟨C_m, Σ_k u_ki·g_kiᵀ⟩`` and twists ``ū_ki = Y_i·g_ki`` are swept back to the base
    through the recursion of the module docstring, with ``d(Rᵀv)/dq_i = (Rᵀv) × a`` and the adjoint
    ``R·v̄`` of ``Rᵀv``. Its cost grows with N_J² only through the 6-vector twists, where the
    forward mode of :func:`regressor_jacobians` carries 3·N_J tangents of everything.

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
    q, dq, ddq = _as_states(robot, q, dq, ddq)
    n_samples, n = q.shape
    g = np.asarray(weights, dtype=float).reshape(n_samples, n, robot.n_parameters)
    joints, tapes, states = _forward_tape(robot, q, dq, ddq)
    grad = np.zeros((3, n, n_samples))
    # adjoints of the child's parent quantities (ω, ω̇, acc) and twists, carried down the chain
    parent_bar = np.zeros((3, 3, n_samples))
    twists_bar = np.zeros((n, 6, n_samples))  # of the twists of joints 0…i seen from frame i
    for i in range(n - 1, -1, -1):
        joint, tape = joints[i], tapes[i]
        a, p = joint.axis[:, None], joint.translation[:, None]
        cross_a, cross_p = -_skew(joint.axis), _skew(joint.translation)  # v × a = −S(a)·v, p × v = S(p)·v
        # (i+1, 10, N): weights of segment i on joints 0…i, samples last (only this block is transposed)
        gi = np.ascontiguousarray(g[:, : i + 1, 10 * i : 10 * i + 10].transpose(1, 2, 0))
        # Products with the constant basis: a (60 × 15)·(15 × N) product is BLAS's job (5× einsum,
        # one thread under the solver's limit).
        y = (_WRENCH_BASIS_FLAT.T @ states[i]).reshape(6, 10, n_samples)
        y_bar = np.einsum("kan,kpn->apn", tape.twists, gi)  # Σ_k u_ki·g_kiᵀ
        state_bar = _WRENCH_BASIS_FLAT @ y_bar.reshape(60, n_samples)  # t̄_m = ⟨C_m, Ȳ⟩
        u_bar = np.einsum("apn,kpn->kan", y, gi)  # ū_ki = Y_i·g_ki
        u_bar += twists_bar
        outer_bar = state_bar[6:].reshape(3, 3, n_samples)  # of ω_i·ω_iᵀ
        omega_bar = parent_bar[0] + np.einsum(
            "bdn,dn->bn", outer_bar + outer_bar.transpose(1, 0, 2), tape.omega
        )
        omega_dot_bar = parent_bar[1] + state_bar[:3]
        acc_bar = parent_bar[2] + state_bar[3:6]
        omega_p, omega_dot_p, acc_p = tape.parent
        q_bar = _dot(acc_bar, _times(cross_a, tape.acc))
        # acc_i = Rᵀb, b = acc_p + ω̇_p × p + ω_p × (ω_p × p)
        b_bar = _pull_back(tape.rt, acc_bar)
        new_parent_bar = np.empty((3, 3, n_samples))
        new_parent_bar[2] = b_bar
        new_parent_bar[1] = _times(cross_p, b_bar)
        new_parent_bar[0] = (
            _dot(omega_p, p) * b_bar + p * _dot(b_bar, omega_p) - 2.0 * omega_p * _dot(p, b_bar)
        )
        # ω̇_i = Rᵀω̇_p + a·q̈_i + (Rᵀω_p) × a·q̇_i  and  ω_i = Rᵀω_p + a·q̇_i
        grad[2, i] += _dot(a, omega_dot_bar)
        w_cross_a = _times(cross_a, tape.w)
        grad[1, i] += _dot(omega_dot_bar, w_cross_a) + _dot(a, omega_bar)
        w_bar = omega_bar - _times(cross_a, omega_dot_bar) * dq[:, i]
        q_bar += _dot(omega_dot_bar, _times(cross_a, tape.wd)) + _dot(w_bar, w_cross_a)
        new_parent_bar[1] += _pull_back(tape.rt, omega_dot_bar)
        new_parent_bar[0] += _pull_back(tape.rt, w_bar)
        # twists of joints k < i: ang ← Rᵀang, lin ← Rᵀ(lin + ang × p)
        if i > 0:
            twists_i = tape.twists[:i]
            q_bar += np.einsum(
                "kan,kan->n",
                u_bar[:i],
                _times(cross_a, twists_i.reshape(2 * i, 3, n_samples)).reshape(i, 6, n_samples),
            )
            lin_bar = _pull_back(tape.rt, u_bar[:i, 3:])
            twists_bar = np.empty((i, 6, n_samples))
            twists_bar[:, :3] = _pull_back(tape.rt, u_bar[:i, :3]) + _times(cross_p, lin_bar)
            twists_bar[:, 3:] = lin_bar
        grad[0, i] += q_bar
        parent_bar = new_parent_bar
    viscous = _friction_slice(robot, "viscous")
    if viscous is not None:
        joints_index = np.arange(n)
        grad[1, joints_index] += g[:, joints_index, viscous.start + joints_index].T
    return grad[0].T, grad[1].T, grad[2].T


def regressor_jacobians_pinocchio(
    robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The inertial columns of :func:`regressor_jacobians` by Pinocchio, column by column (a reference).

    Inverse dynamics is linear in the parameters, so its derivatives are too: column p of ``∂W`` is
    ``∂τ(φ_ref + e_p) − ∂τ(φ_ref)`` from ``pin.computeRNEADerivatives`` with a physical reference
    segment ``φ_ref`` (Pinocchio's inertias need a positive mass). 10·N_L + 1 calls per sample:
    for tests and for the speed comparison of ``benchmarks/excitation.py``. Friction columns are left zero.
    """
    from lwrlab.model.inertia import to_pin_inertia

    q, dq, ddq = _as_states(robot, q, dq, ddq)
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
