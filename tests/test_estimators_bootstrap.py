"""Block bootstrap: agrees with the covariance on white noise, widens on correlated noise."""

from __future__ import annotations

import numpy as np
import scipy.signal

from lwrlab.identification.bootstrap import block_bootstrap, clone_estimator
from lwrlab.pipeline.build import build


def _problem(rng: np.random.Generator, noise: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(noise.shape[0] // 2) * 0.01
    w = np.column_stack([np.sin(t), np.cos(0.7 * t), np.ones_like(t)]).repeat(
        2, axis=0
    )  # 2 joints, same rows
    phi = np.array([1.0, -0.5, 0.2])
    return w, w @ phi + noise, phi


def test_bootstrap_std_matches_covariance_on_white_noise(rng: np.random.Generator) -> None:
    w, tau, _ = _problem(rng, 0.1 * rng.normal(size=4000))
    ols = build("estimator", "ols").fit(w, tau)
    result = block_bootstrap(
        ols, w, tau, n_joints=2, block_samples=20, resamples=300, seed=1, show_progress=False
    )
    np.testing.assert_allclose(result.std, ols.std_, rtol=0.3)
    assert np.all((result.lower <= ols.phi_) & (ols.phi_ <= result.upper))


def test_block_bootstrap_sees_correlated_noise_that_the_covariance_misses(rng: np.random.Generator) -> None:
    b, a = scipy.signal.butter(2, 0.02)  # low-passed noise: samples correlated over ~50 samples
    noise = scipy.signal.lfilter(b, a, rng.normal(size=4000))
    w, tau, _ = _problem(rng, noise / noise.std() * 0.1)
    ols = build("estimator", "ols").fit(w, tau)
    result = block_bootstrap(
        ols, w, tau, n_joints=2, block_samples=200, resamples=200, seed=2, show_progress=False
    )
    assert np.all(result.std > 2.0 * ols.std_)


def test_clone_keeps_hyperparameters_and_drops_learned_values(rng: np.random.Generator) -> None:
    fitted = build("estimator", "wls", n_joints=2, min_relative_std=1e-3).fit(
        rng.normal(size=(40, 2)), rng.normal(size=40)
    )
    clone = clone_estimator(fitted)
    assert clone.min_relative_std == 1e-3 and clone.n_joints == 2 and not hasattr(clone, "phi_")


def test_identification_adds_bootstrap_intervals(lwr4) -> None:
    from lwrlab.pipeline.identification import identify
    from plugins.plants.simulated import SimulatedPlant

    report = identify(
        lwr4,
        build("trajectory", "multisine", duration=3.0, harmonics=3),
        build("trajectory", "multisine", duration=2.0, seed=9),
        SimulatedPlant(lwr4, seed=2, show_progress=False),
        build("estimator", "ols"),
        200.0,
        {"cutoff_hz": 10.0, "trim_s": 0.2},
        {"resamples": 10, "block_s": 0.5, "confidence": 0.9, "seed": 0},
    )
    table = report.parameters
    assert {"ci_lower", "ci_upper", "bootstrap_std"} <= set(table.columns)
    assert np.all(table["ci_lower"] <= table["ci_upper"]) and np.all(table["bootstrap_std"] > 0)
