"""Inertial parameter conversions and physical consistency."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from hypothesis import given, settings
from hypothesis import strategies as st

from lwrlab.model.inertia import (
    from_pin_inertia,
    from_pseudo_inertia,
    is_physically_consistent,
    mass_com_inertia,
    min_pseudo_inertia_eigenvalue,
    perturb_consistent,
    pseudo_inertia,
    random_consistent_parameters,
    standard_parameters,
    to_pin_inertia,
)

seeds = st.integers(min_value=0, max_value=2**32 - 1)


@given(seeds)
@settings(max_examples=50, deadline=None)
def test_random_parameters_are_consistent_and_round_trip(seed: int) -> None:
    phi = random_consistent_parameters(np.random.default_rng(seed))
    assert is_physically_consistent(phi)
    np.testing.assert_allclose(from_pin_inertia(to_pin_inertia(phi)), phi, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(from_pseudo_inertia(pseudo_inertia(phi)), phi, rtol=1e-12, atol=1e-14)
    mass, com, inertia_com = mass_com_inertia(phi)
    np.testing.assert_allclose(standard_parameters(mass, com, inertia_com), phi, rtol=1e-10, atol=1e-14)


def test_standard_order_matches_pinocchio_quantities() -> None:
    com = np.array([0.1, -0.2, 0.3])
    inertia_com = np.array([[0.5, 0.01, 0.02], [0.01, 0.4, 0.03], [0.02, 0.03, 0.3]])
    phi = standard_parameters(2.0, com, inertia_com)
    reference = pin.Inertia(2.0, com, inertia_com)
    np.testing.assert_allclose(phi[:4], [2.0, 0.2, -0.4, 0.6])
    # Inertia about the origin, as Pinocchio's dynamic parameters give it.
    about_origin = inertia_com + 2.0 * (com @ com * np.eye(3) - np.outer(com, com))
    np.testing.assert_allclose(phi[4:], about_origin[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]])
    np.testing.assert_allclose(from_pin_inertia(reference), phi, rtol=1e-12)


def test_inconsistent_body_is_detected() -> None:
    # Triangle inequality broken: XX > YY + ZZ about the CoM.
    phi = standard_parameters(1.0, np.zeros(3), np.diag([1.0, 0.1, 0.1]))
    assert not is_physically_consistent(phi)
    assert min_pseudo_inertia_eigenvalue(phi) < 0


@given(seeds, st.floats(min_value=0.01, max_value=0.5))
@settings(max_examples=50, deadline=None)
def test_perturbation_keeps_consistency_and_moves_every_entry(seed: int, spread: float) -> None:
    rng = np.random.default_rng(seed)
    # A CAD-like segment: products of inertia exactly zero.
    phi = standard_parameters(2.0, np.array([0.0, 0.02, 0.1]), np.diag([0.02, 0.018, 0.005]))
    perturbed = perturb_consistent(phi, spread, rng)
    assert is_physically_consistent(perturbed)
    assert np.all(perturbed[7:] != 0.0)
    assert abs(perturbed[0] / phi[0] - 1) < 10 * spread


def test_zero_spread_is_identity(rng: np.random.Generator) -> None:
    phi = random_consistent_parameters(rng)
    np.testing.assert_array_equal(perturb_consistent(phi, 0.0, rng), phi)
