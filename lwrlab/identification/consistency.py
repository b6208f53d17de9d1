"""Physical consistency of standard parameters as convex (cvxpy) constraints.

A rigid body's 10 standard parameters ``[M, MSX, MSY, MSZ, XX, YY, ZZ, XY, XZ, YZ]`` (about the
segment's frame origin) map *linearly* to its 4×4 pseudo-inertia

    J = [[Σ, h], [hᵀ, M]],   Σ = ½·tr(I)·1 − I,   h = [MSX, MSY, MSZ]

and the body is physically realisable (positive mass, positive semi-definite inertia, triangle
inequalities; any shape) iff ``J ⪰ 0`` (Wensing, Kim & Slotine, RA-L 2017). That makes physically
consistent identification a semidefinite programme. This module is the one place where the linear
map φ → J is written as a cvxpy expression (:func:`pseudo_inertia_expression`); estimators and the
payload identification build their constraints from it.

Examples
--------
>>> import cvxpy as cp
>>> phi = cp.Variable(10)
>>> pseudo_inertia_expression(phi).shape
(4, 4)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from lwrlab.model.inertia import from_pseudo_inertia, min_pseudo_inertia_eigenvalue, pseudo_inertia

if TYPE_CHECKING:  # cvxpy costs ~1 s to import: only the convex programmes below load it
    import cvxpy as cp

SEGMENT_SIZE = 10
"""Standard parameters per segment."""

_INERTIA_ENTRIES = {(0, 0): 4, (1, 1): 5, (2, 2): 6, (0, 1): 7, (0, 2): 8, (1, 2): 9}


def _pseudo_inertia_basis() -> np.ndarray:
    """(10, 4, 4) matrices E_k with ``J(φ) = Σ_k φ_k·E_k`` (built from :func:`pseudo_inertia`)."""
    return np.stack([pseudo_inertia(np.eye(SEGMENT_SIZE)[k]) for k in range(SEGMENT_SIZE)])


PSEUDO_INERTIA_BASIS: np.ndarray = _pseudo_inertia_basis()
"""(10, 4, 4) basis of the linear map φ → J: ``J = Σ_k φ_k · PSEUDO_INERTIA_BASIS[k]``."""

_BASIS_MATRIX = PSEUDO_INERTIA_BASIS.reshape(SEGMENT_SIZE, 16).T  # vec(J) = _BASIS_MATRIX @ φ (row-major vec)


def pseudo_inertia_expression(phi_segment: cp.Expression) -> cp.Expression:
    """The 4×4 pseudo-inertia ``J(φ)`` of one segment as an affine cvxpy expression.

    Parameters
    ----------
    phi_segment : cvxpy expression of shape (10,): the segment's standard parameters in the order
        ``[M, MSX, MSY, MSZ, XX, YY, ZZ, XY, XZ, YZ]`` (kg, kg·m, kg·m²), about its frame origin.

    Returns
    -------
    cvxpy expression of shape (4, 4), symmetric by construction; constrain it with ``J >> 0``.
    """
    if phi_segment.shape != (SEGMENT_SIZE,):
        raise ValueError(
            f"a segment has {SEGMENT_SIZE} standard parameters, "
            f"got an expression of shape {phi_segment.shape}"
        )
    import cvxpy as cp

    # One matrix product and a reshape: a tenth of the expression tree of Σ_k φ_k·E_k, so cvxpy
    # compiles a 7-segment problem about twice as fast.
    return cp.reshape(_BASIS_MATRIX @ phi_segment, (4, 4), order="C")


def segment_slices(n_links: int) -> list[slice]:
    """Slices of each segment's 10 parameters in a standard vector (segments first)."""
    return [slice(SEGMENT_SIZE * i, SEGMENT_SIZE * (i + 1)) for i in range(n_links)]


def consistency_constraints(
    phi: cp.Expression,
    n_links: int,
    margin: float | cp.Expression = 0.0,
    skip_massless: Sequence[bool] | None = None,
) -> list[cp.Constraint]:
    """``J_i(φ) ⪰ margin·1`` for every segment of a full standard vector ``phi``.

    Parameters
    ----------
    phi : cvxpy expression (P,), the standard vector (segments first, then friction).
    n_links : number of segments N_L.
    margin : smallest eigenvalue asked of every pseudo-inertia (kg·m² scale); 0 = consistent.
    skip_massless : per segment, True to leave it unconstrained (none by default).
    """
    constraints = []
    for i, part in enumerate(segment_slices(n_links)):
        if skip_massless is not None and skip_massless[i]:
            continue
        constraints.append(pseudo_inertia_expression(phi[part]) - margin * np.eye(4) >> 0)
    return constraints


def min_pseudo_inertia_eigenvalues(standard: np.ndarray, n_links: int) -> np.ndarray:
    """Smallest pseudo-inertia eigenvalue of every segment of a standard vector (≥ 0: consistent)."""
    standard = np.asarray(standard, dtype=float)
    return np.array([min_pseudo_inertia_eigenvalue(standard[part]) for part in segment_slices(n_links)])


def clip_pseudo_inertias(standard: np.ndarray, n_links: int, min_eigenvalue: float) -> np.ndarray:
    """``standard`` with every segment's pseudo-inertia eigenvalues clipped at ``min_eigenvalue``: a
    solver's result with its tolerance (eigenvalues ~ −1e-9) undone, consistent exactly."""
    standard = np.array(standard, dtype=float)
    for part in segment_slices(n_links):
        values, vectors = np.linalg.eigh(pseudo_inertia(standard[part]))
        if values[0] < min_eigenvalue:
            standard[part] = from_pseudo_inertia((vectors * np.maximum(values, min_eigenvalue)) @ vectors.T)
    return standard


def consistency_margin(
    regrouping: np.ndarray,
    base_values: np.ndarray,
    n_links: int,
    dissipative: np.ndarray | None = None,
    cap: float = 1.0,
) -> float:
    """The largest ε such that some standard set φ with ``K·φ = φ_B`` has every ``J_i(φ) ⪰ ε·1``.

    Base parameters are consistent iff *some* standard set behind them describes rigid bodies
    (the standard set itself is not identifiable), so the smallest eigenvalue of one particular
    standard set does not decide it: this semidefinite programme does. A negative margin proves
    that no rigid bodies (and, with ``dissipative`` indices, no non-negative friction) reproduce
    ``base_values``.

    Parameters
    ----------
    regrouping : (N_B, P) regrouping matrix K.
    base_values : (N_B,) base parameters φ_B.
    n_links : number of segments.
    dissipative : indices of friction parameters that must be ≥ ε too (Coulomb, viscous).
    cap : upper bound on ε (kg·m² scale) so the programme is bounded.
    """
    import cvxpy as cp

    phi = cp.Variable(regrouping.shape[1])
    margin = cp.Variable()
    constraints = [regrouping @ phi == base_values, margin <= cap]
    constraints += consistency_constraints(phi, n_links, margin=margin)
    if dissipative is not None and len(dissipative):
        constraints.append(phi[dissipative] >= margin)
    problem = cp.Problem(cp.Maximize(margin), constraints)
    problem.solve(solver=cp.CLARABEL)
    if problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or margin.value is None:
        raise RuntimeError(f"consistency margin: solver status {problem.status}")
    return float(margin.value)
