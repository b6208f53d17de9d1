"""The linear map φ → pseudo-inertia as a cvxpy expression, and the consistency constraints."""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest

from lwrlab.identification.consistency import (
    consistency_constraints,
    min_pseudo_inertia_eigenvalues,
    pseudo_inertia_expression,
)
from lwrlab.model.inertia import pseudo_inertia, random_consistent_parameters


def test_expression_equals_numeric_pseudo_inertia(rng: np.random.Generator) -> None:
    phi = cp.Variable(10)
    expression = pseudo_inertia_expression(phi)
    for _ in range(5):
        phi.value = rng.normal(size=10)
        np.testing.assert_allclose(expression.value, pseudo_inertia(phi.value), atol=1e-15)


def test_expression_rejects_wrong_shape() -> None:
    with pytest.raises(ValueError, match="10 standard parameters"):
        pseudo_inertia_expression(cp.Variable(9))


def test_projection_onto_consistent_set_is_consistent(rng: np.random.Generator) -> None:
    """The closest consistent pair of segments to an inconsistent one has all eigenvalues ≥ 0."""
    good = np.concatenate([random_consistent_parameters(rng) for _ in range(2)])
    bad = good.copy()
    bad[4] = -0.5  # XX1 < 0: impossible body
    assert min_pseudo_inertia_eigenvalues(bad, 2).min() < 0
    phi = cp.Variable(20)
    cp.Problem(cp.Minimize(cp.sum_squares(phi - bad)), consistency_constraints(phi, 2)).solve(
        solver=cp.CLARABEL
    )
    assert min_pseudo_inertia_eigenvalues(phi.value, 2).min() > -1e-7
    np.testing.assert_allclose(phi.value[10:], good[10:], atol=1e-6)  # the consistent segment does not move
