"""Friction columns of the regressor: per joint, a basis function of its velocity q̇ (rad/s).

The columns follow the inertial ones, term by term in the order of ``robot.friction_terms``, each
term one column per joint: ``FC_j·sign(q̇_j)`` (Coulomb, N·m), ``FV_j·q̇_j`` (viscous, N·m·s/rad) and
``FO_j`` (offset, N·m) act on joint j alone.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from lwrlab.model.robot import RobotModel

FRICTION_BASIS: dict[str, Callable[[np.ndarray, np.ndarray], object]] = {
    "coulomb": lambda dq, out: np.sign(dq, out=out),
    "viscous": lambda dq, out: np.copyto(out, dq),
    "offset": lambda dq, out: out.fill(1.0),
}
"""Friction basis functions of q̇ (rad/s), written into ``out``: sign(q̇), q̇, 1."""


def fill_friction_regressor(dq: np.ndarray, terms: tuple[str, ...], out: np.ndarray, first: int = 0) -> None:
    """Write the friction columns' diagonals into the regressor ``out`` (N, N_J, P), from column ``first``.

    ``out`` must be C-contiguous (the diagonals are strided views of it) and hold zeros in the other
    entries of those columns.
    """
    if not out.flags.c_contiguous:
        raise ValueError("the regressor must be a C-contiguous array")
    n_samples, n = dq.shape
    n_columns = out.shape[2]
    flat = out.reshape(n_samples, n * n_columns)  # W[k, j, p] = flat[k, j·P + p]
    for t, term in enumerate(terms):
        start = first + t * n  # W[k, j, start + j] = flat[k, start + j·(P + 1)]
        FRICTION_BASIS[term](dq, flat[:, start : start + (n - 1) * (n_columns + 1) + 1 : n_columns + 1])


def friction_regressor(dq: np.ndarray, terms: tuple[str, ...]) -> np.ndarray:
    """Friction columns, shape (N, N_J, len(terms)·N_J): diagonal blocks of sign(q̇), q̇ or 1."""
    n_samples, n = dq.shape
    out = np.zeros((n_samples, n, len(terms) * n))
    fill_friction_regressor(dq, terms, out)
    return out


def friction_columns(robot: RobotModel, term: str) -> slice | None:
    """The robot's regressor columns of one friction term (one per joint), or None if it has none."""
    if term not in robot.friction_terms:
        return None
    start = 10 * robot.n_links + robot.friction_terms.index(term) * robot.n_joints
    return slice(start, start + robot.n_joints)
