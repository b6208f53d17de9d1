"""Estimator protocol and the OLS estimator's statistics."""

from __future__ import annotations

import numpy as np
import pytest

from lwrlab.identification.core import relative_std, torque_errors
from lwrlab.pipeline.build import build


def test_ols_fit_returns_self_and_recovers_parameters_exactly(rng: np.random.Generator) -> None:
    w = rng.normal(size=(500, 6))
    phi = rng.normal(size=6)
    estimator = build("estimator", "ols")
    assert estimator.fit(w, w @ phi) is estimator
    np.testing.assert_allclose(estimator.phi_, phi, rtol=1e-12)
    np.testing.assert_allclose(estimator.predict(w), w @ phi, atol=1e-10)


def test_ols_standard_deviations_match_monte_carlo(rng: np.random.Generator) -> None:
    w = rng.normal(size=(300, 4)) * [1.0, 0.1, 3.0, 0.5]
    phi = np.array([1.0, -2.0, 0.5, 0.1])
    sigma = 0.2
    estimates, predicted = [], []
    for _ in range(400):
        est = build("estimator", "ols").fit(w, w @ phi + sigma * rng.normal(size=300))
        estimates.append(est.phi_)
        predicted.append(est.std_)
        assert est.residual_std_ == pytest.approx(sigma, rel=0.25)
    empirical = np.std(estimates, axis=0)
    np.testing.assert_allclose(np.mean(predicted, axis=0), empirical, rtol=0.15)


def test_relative_std_and_errors() -> None:
    np.testing.assert_allclose(relative_std(np.array([2.0, -4.0]), np.array([0.02, 0.4])), [1.0, 10.0])
    assert np.isinf(relative_std(np.array([0.0]), np.array([1.0]))[0])
    measured = np.array([[0.0, 1.0], [2.0, 3.0]])
    errors = torque_errors(measured, measured + np.array([[1.0, 0.0], [-1.0, 0.0]]))
    np.testing.assert_allclose(errors["rms"], [1.0, 0.0])
    np.testing.assert_allclose(errors["nrms"], [50.0, 0.0])


def test_ols_rejects_mismatched_rows(rng: np.random.Generator) -> None:
    with pytest.raises(ValueError, match="rows"):
        build("estimator", "ols").fit(rng.normal(size=(10, 2)), np.zeros(9))
