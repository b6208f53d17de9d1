"""3-vectors and rotations of many samples, laid out (…, 3, N): components on axis −2, samples last.

The pieces of the Newton–Euler recursion that :mod:`lwrlab.dynamics.regressor_jacobians` (forward
mode) and :mod:`lwrlab.dynamics.regressor_vjp` (reverse mode) differentiate. Products with constant
matrices use ``np.einsum``: for a 3×3 matrix and a few thousand samples it is one call of a few
microseconds, where BLAS would be called once per leading index.
"""

from __future__ import annotations

import numpy as np

from lwrlab.dynamics.serial_chain import skew


def cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Cross product along axis −2, broadcasting.

    Written out: ``np.cross`` moves axes and copies, several times slower on these small arrays.
    """
    ux, uy, uz = u[..., 0:1, :], u[..., 1:2, :], u[..., 2:3, :]
    vx, vy, vz = v[..., 0:1, :], v[..., 1:2, :], v[..., 2:3, :]
    return np.concatenate([uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx], axis=-2)


def rotate(rt: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``Rᵀ·v`` for per-sample rotations given as ``rt`` (3, 3, N) (see :func:`transposed_rotations`)."""
    return rt[0] * v[..., 0:1, :] + rt[1] * v[..., 1:2, :] + rt[2] * v[..., 2:3, :]


def pull_back(rt: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R·v`` for per-sample rotations given as ``rt`` (3, 3, N): the adjoint of :func:`rotate`."""
    return np.einsum("ban,...an->...bn", rt, v)


def times(matrix: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``matrix·v`` for a constant 3×3 matrix and vectors ``v`` (…, 3, N): one call, where a
    cross product with a constant vector written out costs ten."""
    return np.einsum("ij,...jn->...in", matrix, v)


def dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Dot products along axis −2."""
    return np.einsum("...an,...an->...n", u, v)


def transposed_rotations(rotation: np.ndarray, axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rᵀ of a revolute joint's rotation ``R = E·exp(q·[a])`` in its parent for N angles (rad).

    ``rotation`` is E (the joint frame at q = 0), ``axis`` the unit axis a. The result is laid out
    (3, 3, N) so that ``rt[b][:, n]`` is column b of Rᵀ at sample n.
    """
    s, c = np.sin(angles), np.cos(angles)
    k = skew(axis)
    et = rotation.T
    # exp(−q[a]) = 1 − sin q·[a] + (1 − cos q)·[a]²  (Rodrigues)
    rt = et[..., None] - (k @ et)[..., None] * s + (k @ k @ et)[..., None] * (1.0 - c)  # (3, 3, N) [a, b, n]
    return np.ascontiguousarray(rt.transpose(1, 0, 2))  # [b, a, n]: column b of Rᵀ
