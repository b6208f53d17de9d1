"""Drive columns of the regressor: per drive, a basis function of its joint-side speed (or acceleration).

The columns follow the inertial ones, term by term in the order of ``robot.friction_terms``, each
term one column per drive: ``FC_m·s(v_m)`` (Coulomb, N·m, ``s`` the robot's friction law's shape:
``sign`` for the paper's), ``FV_m·v_m`` (viscous, N·m·s/rad), ``FO_m`` (offset, N·m), ``IA_m·a_m``
(reflected rotor inertia, kg·m²) and the friction law's own terms
(:mod:`lwrlab.model.friction_laws`). ``v = C·q̇`` and ``a = C·q̈`` are the drives' joint-side speeds
and accelerations; a drive's torque loads the joints through ``Cᵀ`` (:mod:`lwrlab.model.drive_train`),
so with uncoupled drives (``C = I``) each column acts on its own joint alone: the diagonal of a block.
"""

from __future__ import annotations

import numpy as np

from lwrlab.model.drive_train import DriveTrain
from lwrlab.model.friction_laws import FrictionLaw, SignCoulomb, drive_basis
from lwrlab.model.robot import RobotModel


def fill_friction_regressor(
    dq: np.ndarray,
    terms: tuple[str, ...],
    out: np.ndarray,
    first: int = 0,
    *,
    law: FrictionLaw | None = None,
    drive: DriveTrain | None = None,
    ddq: np.ndarray | None = None,
    history: dict[str, np.ndarray] | None = None,
    load: np.ndarray | None = None,
) -> None:
    """Write the drive columns into the regressor ``out`` (N, N_J, P), from column ``first``.

    ``out`` must be C-contiguous (the diagonals are strided views of it) and hold zeros in the other
    entries of those columns. ``law`` defaults to the paper's, ``drive`` to direct drives; ``ddq`` is
    needed for the ``rotor`` term only; ``history``: a memory law's columns at these samples
    (:func:`lwrlab.model.friction_laws.history_columns`), else its memoryless approximation;
    ``load``: the drives' transmitted torques (N, N_D), for a law whose terms grow with it
    (:func:`lwrlab.model.friction_laws.drive_loads`).
    """
    if not out.flags.c_contiguous:
        raise ValueError("the regressor must be a C-contiguous array")
    law = SignCoulomb() if law is None else law
    n_samples, n = dq.shape
    direct = drive is None or drive.is_direct
    v = dq if direct or drive is None else drive.drive_values(dq)
    a = None if ddq is None else (ddq if direct or drive is None else drive.drive_values(ddq))
    n_columns = out.shape[2]
    flat = out.reshape(n_samples, n * n_columns)  # W[k, j, p] = flat[k, j·P + p]
    for t, term in enumerate(terms):
        start = first + t * n
        basis = drive_basis(law, term, v, a, history, load)
        if direct or drive is None:  # W[k, j, start + j] = flat[k, start + j·(P + 1)]
            flat[:, start : start + (n - 1) * (n_columns + 1) + 1 : n_columns + 1] = basis
        else:  # W[k, j, start + m] = C[m, j]·basis[k, m]
            out[:, :, start : start + n] = basis[:, None, :] * drive.coupling.T[None, :, :]


def friction_regressor(
    dq: np.ndarray,
    terms: tuple[str, ...],
    *,
    law: FrictionLaw | None = None,
    drive: DriveTrain | None = None,
    ddq: np.ndarray | None = None,
) -> np.ndarray:
    """Drive columns, shape (N, N_J, len(terms)·N_J) (see :func:`fill_friction_regressor`)."""
    n_samples, n = dq.shape
    out = np.zeros((n_samples, n, len(terms) * n))
    fill_friction_regressor(dq, terms, out, law=law, drive=drive, ddq=ddq)
    return out


def friction_columns(robot: RobotModel, term: str) -> slice | None:
    """The robot's regressor columns of one per-drive term (one per drive), or None if it has none."""
    if term not in robot.friction_terms:
        return None
    start = 10 * robot.n_links + robot.friction_terms.index(term) * robot.n_joints
    return slice(start, start + robot.n_joints)
