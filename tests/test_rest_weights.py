"""Rows near rest weighted by their own residual (lwrlab.identification.rest_weights)."""

from __future__ import annotations

import numpy as np
import pytest

from lwrlab.errors import ConfigError
from lwrlab.identification.least_squares import weighted_least_squares
from lwrlab.identification.rest_weights import (
    CLASSES,
    MIN_CLASS_ROWS,
    checked_near_rest,
    reach_rows,
    rest_weights,
    speed_classes,
    speed_scale,
)
from lwrlab.identification.row_statistics import RowAccumulator
from lwrlab.pipeline.build import build

N_JOINTS, COLUMNS = 2, 6


def _rows(rng: np.random.Generator, samples: int, noisy_share: float, ratio: float) -> tuple:
    """Rows of a linear model, each joint's rows in class 0 (``noisy_share`` of them, noise σ·ratio)
    or in the moving class (noise σ)."""
    w = rng.normal(size=(samples * N_JOINTS, COLUMNS))
    phi = rng.normal(size=COLUMNS)
    classes = np.where(rng.random((samples, N_JOINTS)) < noisy_share, 0, CLASSES - 1).astype(np.int8)
    sigma = np.where(classes == 0, 0.01 * ratio, 0.01).ravel()
    tau = w @ phi + sigma * rng.normal(size=sigma.size)
    return w, tau, classes, phi, sigma


def _accumulated(w: np.ndarray, tau: np.ndarray, classes: np.ndarray, block: int = 53):
    samples = classes.shape[0]
    accumulator = RowAccumulator(samples, N_JOINTS, COLUMNS, folds=3, classes=CLASSES)
    for first in range(0, samples, block):
        chosen = slice(first, min(samples, first + block))
        rows = slice(first * N_JOINTS, min(samples, first + block) * N_JOINTS)
        accumulator.add(w[rows], tau[rows], classes[chosen])
    return accumulator


def test_classes_weighted_are_the_rows_scaled_by_the_root_of_their_weight() -> None:
    rng = np.random.default_rng(0)
    w, tau, classes, _, _ = _rows(rng, 400, 0.4, 10.0)
    classed = _accumulated(w, tau, classes).by_class()
    weights = rng.uniform(0.01, 1.0, size=(N_JOINTS, CLASSES))
    root = np.sqrt(np.take_along_axis(weights.T, classes.astype(int), axis=0)).ravel()
    scaled = np.column_stack([w, tau]) * root[:, None]
    combined = classed.combined(weights).factor()
    np.testing.assert_allclose(combined.T @ combined, scaled.T @ scaled, rtol=1e-10, atol=1e-10)
    # unit weights: the classes summed, as an accumulator without classes gives
    plain = RowAccumulator(400, N_JOINTS, COLUMNS, folds=3)
    plain.add(w, tau)
    np.testing.assert_allclose(
        classed.combined().factor().T @ classed.combined().factor(),
        plain.result().factor().T @ plain.result().factor(),
        rtol=1e-10,
    )
    assert classed.class_rows.sum() == w.shape[0]


def test_noisier_rows_are_weighted_by_their_variance_and_the_fit_gains() -> None:
    errors = {"weighted": [], "equal": []}
    for seed in range(20):
        rng = np.random.default_rng(seed)
        w, tau, classes, phi, sigma = _rows(rng, 300, 0.6, 20.0)
        rest = rest_weights(_accumulated(w, tau, classes).by_class())
        # the quiet class keeps its weight, the noisy one gets the ratio of their variances
        np.testing.assert_allclose(rest.weights[:, -1], 1.0)
        assert rest.weights[:, 0] == pytest.approx(1 / 20.0**2, rel=0.5)
        np.testing.assert_allclose(rest.sigma[:, 0] / rest.sigma[:, -1], 20.0, rtol=0.3)
        row_weights = rest.row_weights(classes).ravel()
        errors["weighted"].append(np.linalg.norm(weighted_least_squares(w, tau, row_weights).phi - phi))
        errors["equal"].append(np.linalg.norm(weighted_least_squares(w, tau).phi - phi))
    assert np.median(errors["weighted"]) < 0.5 * np.median(errors["equal"])


def test_rows_as_quiet_as_the_moving_ones_keep_their_weight_and_thin_classes_borrow() -> None:
    rng = np.random.default_rng(3)
    w, tau, classes, _, _ = _rows(rng, 600, 0.5, 1.0)
    classes[: MIN_CLASS_ROWS // 2, 0] = 1  # too few rows for a variance of their own
    rest = rest_weights(_accumulated(w, tau, classes).by_class())
    assert rest.weights[:, 0] == pytest.approx(1.0, abs=0.3)
    assert rest.sigma[0, 1] == 0.0 and rest.weights[0, 1] == rest.weights[0, 2]
    assert "rows near rest" in rest.describe()


def test_a_row_takes_the_least_speed_within_the_filters_reach() -> None:
    speed = np.concatenate([np.zeros(20), np.linspace(0.0, 1.0, 20), np.ones(40)])
    dq = np.column_stack([speed, np.ones_like(speed)])
    scale = np.array([1.0, 1.0])
    classes = speed_classes(dq, scale, reach=3)
    assert np.all(classes[:23, 0] == 0)  # standing, and the rows whose filter reaches the rest
    assert np.all(classes[45:, 0] == CLASSES - 1)
    assert np.all(np.diff(classes[:, 0]) >= 0)  # slower never after faster on a start
    assert np.all(classes[:, 1] == CLASSES - 1)


def test_an_unknown_setting_names_the_choices() -> None:
    with pytest.raises(ConfigError, match=r"estimator.near_rest must be one of \['weighted', 'equal'\]"):
        checked_near_rest("heavy")
    assert build("estimator", "wls").near_rest == "weighted"
    assert build("estimator", "sdp", near_rest="equal").near_rest == "equal"


def test_a_cycle_with_rests_and_noisy_encoders_no_longer_hurts_the_friction_fit() -> None:
    """A one-joint ``τ = Fc·sign(q̇) + Fv·q̇`` read through noisy, quantised encoders: the cycle's rows
    near rest carry the sign of noise and of the filter's spread, so added to a motion with every row
    alike they pull the fit off; weighted by their residual, much less."""
    from lwrlab.plants.planned_motions import PointToPoint
    from lwrlab.signal.processing import process

    rate, truth = 1000.0, np.array([0.4, 0.3])
    rng = np.random.default_rng(5)

    def log(motion: PointToPoint) -> tuple:
        t = np.arange(int(motion.duration * rate)) / rate
        q, dq, _ = motion.evaluate(t)
        resolution = 2 * np.pi / 2**20
        q_log = np.round((q + 1e-5 * rng.standard_normal(q.shape)) / resolution) * resolution
        tau = truth[0] * np.sign(dq) + truth[1] * dq + 1e-3 * rng.standard_normal(dq.shape)
        return t, q_log, tau

    def friction(q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        return np.column_stack([np.sign(dq[:, 0]), dq[:, 0]])

    motion = PointToPoint(np.array([[0.0], [0.8], [-0.4], [0.5]]), np.full(3, 0.9), np.full(4, 0.3))
    cycle = PointToPoint(
        np.array([[0.1], [0.6], [0.2], [0.7]]), np.full(3, 1.2), np.array([2.0, 3.0, 3.0, 4.0])
    )
    errors = {}
    for name, motions in {"motion": [motion], "motion + cycle": [motion, cycle]}.items():
        processed = [process(*log(m), cutoff_hz=5.0) for m in motions]
        samples = sum(len(d.index) for d in processed)
        accumulator = RowAccumulator(samples, 1, 2, classes=CLASSES)
        scale = speed_scale(processed)
        for data in processed:
            for block in data.row_blocks(friction):
                accumulator.add(block.w, block.tau, speed_classes(block.dq, scale, reach_rows(data)))
        classed = accumulator.by_class()
        for weighing in ("equal", "weighted"):
            weights = rest_weights(classed).weights if weighing == "weighted" else None
            factor = classed.combined(weights).factor()
            estimate = np.linalg.solve(factor[:2, :2], factor[:2, 2])
            errors[name, weighing] = np.abs(estimate - truth).max()
    assert errors["motion + cycle", "equal"] > 3 * errors["motion", "equal"]  # the harm, reproduced
    # weighted, the harm falls by more than half (here 6.9 × → 2.2 × the motion alone): a friction
    # model alone has no rigid-body columns the rows near rest could still inform
    assert errors["motion + cycle", "weighted"] < 0.4 * errors["motion + cycle", "equal"]
