"""The criterion protocol (config group ``criterion``) and the linear algebra criteria share.

A criterion scores a base regressor ``W_b`` (rows: samples × joints; columns: base parameters):
the lower, the better the motion excites the parameters. It returns its value and its gradient
``∂J/∂W_b`` (same shape as ``W_b``); the excitation problem chains that gradient back to the motion.

Column scaling: the problem hands criteria ``W_b·diag(s)``, with ``s_g`` the inverse RMS of column g
over random states within the joint limits (:func:`lwrlab.excitation.problem.column_scales`), so that
every column is unit-free and of order 1 per row. The gradient is scaled back by the problem.
``logdet`` and ``hadamard`` change only by a constant under any fixed column scaling (their optimum
does not depend on it); ``cond``, ``logcond``, ``a_optimality`` and ``e_optimality`` do.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np


class Criterion(Protocol):
    """An excitation criterion plugin: ``J(W_b)`` (unit-free) and ``∂J/∂W_b``."""

    name: str
    """Short name used in tables and figures (e.g. ``logdet``)."""

    def value_and_gradient(self, w: np.ndarray) -> tuple[float, np.ndarray]:
        """``J`` and ``∂J/∂W`` for a (rows, N_B) regressor ``w`` of full column rank."""
        ...


RANK_TOLERANCE = 1e-13
"""``W`` counts as rank deficient when ``λ_min(WᵀW) ≤ RANK_TOLERANCE·λ_max`` (cond(W) ≳ 3e6)."""


def gram(w: np.ndarray) -> np.ndarray:
    """Information matrix ``WᵀW`` (N_B, N_B), symmetrised."""
    m = w.T @ w
    return 0.5 * (m + m.T)


def singular_system(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Singular values ``σ`` (descending) and right singular vectors ``Vᵀ`` (rows) of ``w``.

    Via the triangular factor R of ``W = Q·R`` (Householder): R has the singular values and right
    singular vectors of W to full accuracy, and its SVD is N_B×N_B. (The eigenvalues of ``WᵀW`` would
    be as cheap but square the condition number: cond(W) ~ 10³ then costs 1e-10 relative accuracy on
    σ_min, too much for gradients checked against finite differences.) LinAlgError if W is rank deficient.
    """
    r = np.linalg.qr(w, mode="r")
    _, sigma, vt = np.linalg.svd(r)
    if sigma[-1] <= np.sqrt(RANK_TOLERANCE) * sigma[0]:
        raise np.linalg.LinAlgError(
            "the regressor is rank deficient: the motion does not excite every base parameter"
        )
    return sigma, vt


def extreme_singular_pairs(
    w: np.ndarray,
) -> tuple[float, np.ndarray, np.ndarray, float, np.ndarray, np.ndarray]:
    """``σ_max, u_max, v_max, σ_min, u_min, v_min`` of ``w`` (``∂σ/∂W = u·vᵀ`` for a simple σ)."""
    sigma, vt = singular_system(w)
    v_max, v_min = vt[0], vt[-1]
    return sigma[0], w @ v_max / sigma[0], v_max, sigma[-1], w @ v_min / sigma[-1], v_min


def information_factor(w: np.ndarray) -> np.ndarray:
    """Lower Cholesky factor L of ``WᵀW = L·Lᵀ`` (LinAlgError naming the cause if W is rank deficient)."""
    try:
        return np.linalg.cholesky(gram(w))
    except np.linalg.LinAlgError:
        raise np.linalg.LinAlgError(
            "the regressor is rank deficient: the motion does not excite every base parameter"
        ) from None


def inverse_information(w: np.ndarray, factor: np.ndarray | None = None) -> np.ndarray:
    """``(WᵀW)⁻¹`` by Cholesky (``factor``: L of :func:`information_factor`, when already known)."""
    inverse_factor = np.linalg.inv(information_factor(w) if factor is None else factor)
    return inverse_factor.T @ inverse_factor
