"""The convex programme of a physically consistent fit: its prior divergence, constraints and cleanup.

The pieces the semidefinite estimator (``plugins/estimators/sdp.py``) assembles its problems from,
each a function of the standard parameters φ (a cvxpy expression) and the
:class:`~lwrlab.identification.context.IdentificationContext`:

- :func:`divergence` and :func:`divergence_metric`: the pull toward the CAD prior (``euclidean`` or
  ``entropic``) and its quadratic form at the prior;
- :func:`physical_constraints`: pseudo-inertias ⪰ ε·1, dissipative friction ≥ 0, optional mass bounds;
- :func:`weighted_programme`: the prior-weighted least-squares programme compiled once for every fold
  and weight of ``weight: auto``, and :func:`chosen_weight`, the weight the folds choose;
- :func:`made_consistent`: the solver's result with its tolerance undone (consistent exactly).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cvxpy as cp
import numpy as np

from lwrlab.identification.consistency import (
    clip_pseudo_inertias,
    consistency_constraints,
    pseudo_inertia_expression,
    segment_slices,
)
from lwrlab.identification.context import IdentificationContext
from lwrlab.identification.prior_weight import entropic_metric
from lwrlab.model.inertia import pseudo_inertia

REGULARIZATIONS = ("none", "euclidean", "entropic")
"""The divergences toward the CAD prior (``none``: only the constraints)."""


@dataclass(frozen=True)
class WeightedProgramme:
    """A compiled prior-weighted programme: its variable and the parameters a re-solve sets."""

    problem: cp.Problem
    phi: cp.Variable
    factor: cp.Parameter
    target: cp.Parameter
    weight: cp.Parameter


def chosen_weight(fold_scores: np.ndarray, selection: str) -> int:
    """Index of the chosen candidate, the candidates sorted by increasing weight.

    ``min``: the smallest held-out error. ``one_se``: the largest weight whose error is within one
    standard error of the smallest (Breiman's rule: the simplest model the data cannot tell from the
    best), the standard error taken over the folds.
    """
    totals = fold_scores.sum(axis=0)
    best = int(np.argmin(totals))
    if selection == "min":
        return best
    folds = fold_scores.shape[0]
    standard_error = float(np.std(fold_scores[:, best], ddof=1)) * np.sqrt(folds)
    return int(np.flatnonzero(totals <= totals[best] + standard_error).max())


def divergence(phi: cp.Variable, context: IdentificationContext, regularization: str) -> cp.Expression:
    """The pull of φ toward the CAD prior: ``euclidean`` or ``entropic`` (log-det Bregman)."""
    n_inertial = 10 * context.n_links
    if regularization == "euclidean":
        return cp.sum_squares(phi[:n_inertial] - context.prior[:n_inertial])
    terms = []
    for part in segment_slices(context.n_links):
        j_prior_inv = np.linalg.inv(pseudo_inertia(context.prior[part]))
        j = pseudo_inertia_expression(phi[part])
        terms.append(-cp.log_det(j) + cp.trace(j_prior_inv @ j))
    return cp.sum(cp.hstack(terms))


def divergence_metric(context: IdentificationContext, regularization: str) -> np.ndarray:
    """(P, P) quadratic form of the regularisation at the prior (zero on friction)."""
    n_inertial = 10 * context.n_links
    if regularization == "entropic":
        return entropic_metric(context.prior, context.n_links)
    metric = np.zeros((context.n_parameters, context.n_parameters))
    if regularization == "euclidean":
        metric[np.arange(n_inertial), np.arange(n_inertial)] = 1.0
    return metric


def physical_constraints(
    phi: cp.Expression,
    context: IdentificationContext,
    *,
    min_eigenvalue: float,
    friction_nonnegative: bool,
    mass_bounds: Sequence[float] | None,
) -> list[cp.Constraint]:
    """Pseudo-inertias ⪰ ``min_eigenvalue``·1, dissipative friction ≥ 0, masses within the bounds."""
    constraints = consistency_constraints(phi, context.n_links, margin=min_eigenvalue)
    if friction_nonnegative:
        dissipative = context.nonnegative_indices()
        if dissipative.size:
            constraints.append(phi[dissipative] >= 0)
    if mass_bounds is not None:
        masses = np.array([part.start for part in segment_slices(context.n_links)])
        low, high = mass_bounds
        constraints += [
            phi[masses] >= low * context.prior[masses],
            phi[masses] <= high * context.prior[masses],
        ]
    return constraints


def made_consistent(
    standard: np.ndarray, context: IdentificationContext, *, min_eigenvalue: float, friction_nonnegative: bool
) -> np.ndarray:
    """Undo the solver's tolerance (eigenvalues ~ −1e-9): clip every pseudo-inertia's eigenvalues
    at ``min_eigenvalue`` and dissipative friction at 0, so the result is consistent exactly;
    the base parameters move by about the solver tolerance."""
    standard = clip_pseudo_inertias(standard, context.n_links, min_eigenvalue)
    if friction_nonnegative:
        index = context.nonnegative_indices()
        standard[index] = np.maximum(standard[index], 0.0)
    return standard


def weighted_programme(
    context: IdentificationContext, metric: np.ndarray, constraints: list[cp.Constraint], phi: cp.Variable
) -> WeightedProgramme:
    """``‖R·K·φ − y‖² + λ·ΔφᵀSΔφ`` under ``constraints`` (on ``phi``), compiled once for every fold
    and weight."""
    n_base = context.regrouping.shape[0]
    factor = cp.Parameter((n_base, n_base), name="R")
    target = cp.Parameter(n_base, name="y")
    weight = cp.Parameter(nonneg=True, name="weight")
    objective = cp.sum_squares(factor @ (context.regrouping @ phi) - target)
    values, vectors = np.linalg.eigh(metric)
    kept = values > 1e-12 * max(float(values.max()), 1e-300)
    if kept.any():
        root = (vectors[:, kept] * np.sqrt(values[kept])).T  # S = rootᵀ·root
        objective = objective + weight * cp.sum_squares(root @ (phi - context.prior))
    problem = cp.Problem(cp.Minimize(objective), constraints)
    return WeightedProgramme(problem, phi, factor, target, weight)
