"""The criterion protocol (config group ``criterion``) and the linear algebra criteria share.

A criterion scores a base regressor ``W_b`` (rows: samples × joints; columns: base parameters):
the lower, the better the motion excites the parameters. It returns its value and its gradient
``∂J/∂W_b`` (same shape as ``W_b``); the excitation problem chains that gradient back to the motion.

Column scaling: the problem hands criteria ``W_b·diag(s)``, with ``s_g`` the inverse RMS of column g
over random states within the joint limits (:func:`column_scales`), so that
every column is unit-free and of order 1 per row. The gradient is scaled back by the problem.
``logdet`` and ``hadamard`` change only by a constant under any fixed column scaling (their optimum
does not depend on it); ``cond``, ``logcond``, ``a_optimality`` and ``e_optimality`` do.

A criterion aimed at where the model will be used needs the robot (to build the regressor of its
target motions): it may define ``bind(space) -> Criterion``, called once with the problem's
:class:`DesignSpace` before the optimisation (:func:`bound_criterion`); the protocol is unchanged.
Known information enters as rows stacked on ``W_b`` (:mod:`lwrlab.excitation.known_information`),
so no criterion needs to know about it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from lwrlab.dynamics.base_parameters import BaseParameters, random_states
from lwrlab.dynamics.regressor import regressor
from lwrlab.model.robot import RobotModel


def column_scales(robot: RobotModel, base: BaseParameters, n_samples: int = 400, seed: int = 0) -> np.ndarray:
    """(N_B,) inverse RMS of each base-regressor column over random states within the limits.

    Multiplying ``W_b`` by ``diag(s)`` makes every column unit-free with an RMS of 1 per row over
    the robot's whole state space, whatever its units (kg·m², kg·m, N·m); the module's
    docstring says which criteria depend on it.
    """
    w = base.base_regressor(regressor(robot, *random_states(robot, n_samples, np.random.default_rng(seed))))
    return 1.0 / np.sqrt(np.mean(w**2, axis=0))


class Criterion(Protocol):
    """An excitation criterion plugin: ``J(W_b)`` (unit-free) and ``∂J/∂W_b``."""

    name: str
    """Short name used in tables and figures (e.g. ``logdet``)."""

    def value_and_gradient(self, w: np.ndarray) -> tuple[float, np.ndarray]:
        """``J`` and ``∂J/∂W`` for a (rows, N_B) regressor ``w`` of full column rank."""
        ...


@dataclass(frozen=True)
class DesignSpace:
    """The robot, base parameters and column scaling a criterion is evaluated in (what ``bind`` gets)."""

    robot: RobotModel
    base: BaseParameters
    scales: np.ndarray
    """(N_B,) the column scaling ``s`` of the design (``W_b·diag(s)`` is what criteria see)."""

    def scaled_rows(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        """``W_b·diag(s)`` (n·N_J, N_B) of joint states (n, N_J), sample-major, exact sign friction."""
        return self.base.base_regressor(regressor(self.robot, q, dq, ddq)) * self.scales


def bound_criterion(criterion: Criterion, space: DesignSpace) -> Criterion:
    """``criterion.bind(space)`` for a criterion that needs the robot, else the criterion itself."""
    bind = getattr(criterion, "bind", None)
    return criterion if bind is None else bind(space)


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
