"""Fourier-series parameterisation with its polynomial boundary correction."""

from __future__ import annotations

import numpy as np
import pytest

from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from lwrlab.signal.processing import central_difference


@pytest.mark.parametrize("harmonics", [1, 3, 6])
def test_any_coefficients_start_and_stop_at_rest(harmonics: int, rng: np.random.Generator) -> None:
    fourier = build("trajectory", "fourier", duration=7.0, harmonics=harmonics)
    c = rng.normal(size=(fourier.n_coefficients, 7))
    _, dq, ddq = fourier.evaluate(np.array([0.0, 7.0]), c)
    np.testing.assert_allclose(dq, 0.0, atol=1e-10)
    np.testing.assert_allclose(ddq, 0.0, atol=1e-10)


def test_derivatives_are_consistent(lwr4: RobotModel, rng: np.random.Generator) -> None:
    fourier = build("trajectory", "fourier", duration=5.0, harmonics=4)
    motion = fourier.with_coefficients(fourier.initial_coefficients(lwr4, rng, 0.5)).sample(lwr4, 1000.0)
    np.testing.assert_allclose(central_difference(motion.q, 1e-3, 4)[5:-5], motion.dq[5:-5], atol=1e-8)
    np.testing.assert_allclose(central_difference(motion.dq, 1e-3, 4)[5:-5], motion.ddq[5:-5], atol=1e-7)


def test_motion_is_linear_in_its_coefficients(rng: np.random.Generator) -> None:
    """The Jacobian of the samples with respect to the coefficients is the (corrected) basis."""
    fourier = build("trajectory", "fourier", duration=4.0, harmonics=3)
    t = fourier.times(100.0)
    a, b = (rng.normal(size=(fourier.n_coefficients, 2)) for _ in range(2))
    for d, (qa, qb, qab) in enumerate(
        zip(fourier.evaluate(t, a), fourier.evaluate(t, b), fourier.evaluate(t, a + 2 * b), strict=True)
    ):
        np.testing.assert_allclose(qab, qa + 2 * qb, atol=1e-10)
        np.testing.assert_allclose(qa, fourier.basis(t, d) @ a, atol=1e-12)


def test_at_least_one_harmonic() -> None:
    with pytest.raises(ValueError, match="harmonic"):
        build("trajectory", "fourier", harmonics=0)
