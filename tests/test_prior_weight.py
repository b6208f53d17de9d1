"""The prior's metric, the cross-validated weight and the prior share (lwrlab/identification/prior_weight.py).

The metric must be the Hessian of the log-det divergence (checked against finite differences of the
divergence itself); the weight must follow the data: noisy thin data lean on the prior more than
rich data of the same robot; the prior share must be 0 where the data decide and 1 where they
cannot see a parameter at all.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from lwrlab.dynamics.base_parameters import compute_base_parameters
from lwrlab.dynamics.regressor import regressor
from lwrlab.identification.context import IdentificationContext
from lwrlab.identification.prior_weight import (
    contiguous_folds,
    entropic_metric,
    information_scale,
    posterior_covariance,
    prior_doubts,
    prior_share,
)
from lwrlab.model.inertia import pseudo_inertia, random_consistent_parameters
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from lwrlab.plants.simulation import perturbed_robot


def _log_det_divergence(phi: np.ndarray, prior: np.ndarray) -> float:
    """Bregman divergence of −log det at the prior's pseudo-inertia (one segment)."""
    j, j0 = pseudo_inertia(phi), pseudo_inertia(prior)
    inverse = np.linalg.inv(j0)
    return float(-np.linalg.slogdet(j)[1] + np.linalg.slogdet(j0)[1] + np.trace(inverse @ j) - 4)


def test_entropic_metric_is_the_hessian_of_the_log_det_divergence(rng: np.random.Generator) -> None:
    prior = random_consistent_parameters(rng)
    metric = entropic_metric(prior, 1)
    for _ in range(5):
        direction = rng.normal(size=10)
        direction *= 1e-2 / np.sqrt(direction @ metric @ direction)  # a divergence of ~1e-4: quadratic
        # D(φ₀ + εd) = ε²·dᵀSd + O(ε³): a second difference isolates the quadratic term
        quadratic = (
            _log_det_divergence(prior + direction, prior) + _log_det_divergence(prior - direction, prior)
        ) / 2
        assert direction @ metric @ direction == pytest.approx(quadratic, rel=1e-3)


def test_entropic_metric_is_finite_for_a_point_mass_and_zero_on_friction() -> None:
    point_mass = np.zeros(10)
    point_mass[0] = 1.0  # J = diag(0, 0, 0, 1): singular
    metric = entropic_metric(np.concatenate([point_mass, [0.3, 0.2]]), 1)
    assert np.all(np.isfinite(metric)) and np.all(np.linalg.eigvalsh(metric[:10, :10]) > 0)
    assert not metric[10:].any() and not metric[:, 10:].any()


def test_contiguous_folds_cut_whole_samples_in_order() -> None:
    folds = contiguous_folds(7 * 23, 7, 5)
    assert folds.size == 7 * 23 and np.all(np.diff(folds) >= 0) and set(folds) == set(range(5))
    assert np.all(folds.reshape(23, 7) == folds.reshape(23, 7)[:, :1])  # a sample's joints stay together
    with pytest.raises(ValueError, match="whole number of samples"):
        contiguous_folds(10, 7, 2)


def _rows(
    robot: RobotModel, duration: float, seed: int
) -> tuple[np.ndarray, np.ndarray, IdentificationContext]:
    base = compute_base_parameters(robot)
    motion = build("trajectory", "multisine", duration=duration, harmonics=4, seed=seed).sample(robot, 100.0)
    w = base.base_regressor(regressor(robot, motion.q, motion.dq, motion.ddq))
    return w, motion.q, IdentificationContext.from_robot(robot, base)


def test_information_scale_ignores_the_torque_unit_and_the_row_count(lwr4: RobotModel) -> None:
    w, _, context = _rows(lwr4, 2.0, 1)
    metric = entropic_metric(context.prior, context.n_links)
    gram = w.T @ w
    scale = information_scale(context.regrouping, gram, metric)
    assert scale > 0
    assert information_scale(context.regrouping, 2 * gram, metric) == pytest.approx(
        2 * scale
    )  # twice the rows


def test_prior_share_is_zero_where_the_data_decide_and_one_where_they_see_nothing(lwr4: RobotModel) -> None:
    w, _, context = _rows(lwr4, 4.0, 2)
    metric = entropic_metric(context.prior, context.n_links)
    gram = w.T @ w
    assert prior_share(posterior_covariance(context.regrouping, gram, metric, 0.0, 1.0), gram).max() < 1e-6
    blind = gram.copy()
    blind[:, 0] = blind[0, :] = 0.0  # the data never see the first base parameter
    share = prior_share(posterior_covariance(context.regrouping, blind, metric, 1e-9, 1.0), blind)
    assert share[0] == pytest.approx(1.0, abs=1e-6) and np.median(share[1:]) < 1e-3
    # and its posterior spread is the prior's, finite
    covariance = posterior_covariance(context.regrouping, blind, metric, 1e-9, 0.01)
    assert np.isfinite(covariance[0, 0]) and covariance[0, 0] > 0


def test_auto_weight_leans_on_the_prior_for_thin_noisy_data_not_for_rich_data(lwr4: RobotModel) -> None:
    """The same robot, a short slow motion with large noise against a long rich one with small noise."""
    rng = np.random.default_rng(5)
    truth = perturbed_robot(lwr4, 0.05, 0.1, rng)
    chosen = {}
    for name, (duration, harmonics, noise) in {"thin": (3.0, 2, 2.0), "rich": (20.0, 6, 0.01)}.items():
        base = compute_base_parameters(lwr4)
        motion = build("trajectory", "multisine", duration=duration, harmonics=harmonics, seed=4).sample(
            lwr4, 50.0
        )
        w = base.base_regressor(regressor(lwr4, motion.q, motion.dq, motion.ddq))
        tau = truth.inverse_dynamics(motion.q, motion.dq, motion.ddq).ravel()
        tau = tau + noise * rng.normal(size=tau.shape)
        estimator = build("estimator", "sdp").fit(
            w, tau, context=IdentificationContext.from_robot(lwr4, base)
        )
        chosen[name] = estimator
        assert estimator.cv_scores_.shape == (len(estimator.weight_grid),)
        assert estimator.prior_share_.shape == estimator.phi_.shape
        assert estimator.cv_joint_rms_.shape == (lwr4.n_joints,) and np.all(estimator.cv_joint_rms_ > 0)
        assert np.all(estimator.cv_worst_joint_rms_ >= estimator.cv_joint_rms_)  # the worst block, per joint
        assert estimator.min_eigenvalues_.min() >= 0.0  # consistent whatever the weight
    assert chosen["thin"].weight_ > chosen["rich"].weight_
    assert chosen["rich"].weight_ <= 1e-5
    assert (
        chosen["thin"].diagnostics_["prior_dominated_parameters"]
        > chosen["rich"].diagnostics_["prior_dominated_parameters"]
    )


def test_auto_weight_rejects_bad_settings(lwr4: RobotModel) -> None:
    w, _, context = _rows(lwr4, 2.0, 1)
    tau = np.zeros(w.shape[0])
    with pytest.raises(ValueError, match="folds ≥ 2"):
        build("estimator", "sdp", folds=1).fit(w, tau, context=context)
    with pytest.raises(ValueError, match="selection"):
        build("estimator", "sdp", selection="best").fit(w, tau, context=context)
    with pytest.raises(ValueError, match="'auto'"):
        build("estimator", "sdp", weight="automatic").fit(w, tau, context=context)


def test_placeholder_inertials_are_doubted(lwr4: RobotModel) -> None:
    assert prior_doubts(lwr4.parameters, lwr4.n_links) == []  # a CAD model
    placeholder = lwr4.parameters.copy()
    for link in range(lwr4.n_links):
        placeholder[10 * link : 10 * link + 10] = [1.0, 0, 0, 0, 0.01, 0.01, 0.01, 0, 0, 0]
    assert any("same inertial values" in d for d in prior_doubts(placeholder, lwr4.n_links))
    massless = lwr4.parameters.copy()
    massless[20:30] = 0.0
    point = lwr4.parameters.copy()
    point[34:40] = 0.0  # link 4: its inertia about the origin gone, its mass kept
    assert any("no mass on link 3" in d for d in prior_doubts(massless, lwr4.n_links))
    assert any("not a solid body" in d and "link 4" in d for d in prior_doubts(point, lwr4.n_links))


def test_auto_weight_survives_a_placeholder_prior(lwr4: RobotModel) -> None:
    """Cross-validation pulls toward a wrong prior only as far as it helps: close to the CAD prior's fit."""
    rng = np.random.default_rng(8)
    base = compute_base_parameters(lwr4)
    truth = perturbed_robot(lwr4, 0.05, 0.1, rng)
    motion = build("trajectory", "multisine", duration=6.0, harmonics=4, seed=2).sample(lwr4, 50.0)
    w = base.base_regressor(regressor(lwr4, motion.q, motion.dq, motion.ddq))
    tau = truth.inverse_dynamics(motion.q, motion.dq, motion.ddq).ravel() + 0.1 * rng.normal(size=w.shape[0])
    context = IdentificationContext.from_robot(lwr4, base)
    placeholder = context.prior.copy()
    for link in range(lwr4.n_links):
        placeholder[10 * link : 10 * link + 10] = [1.0, 0, 0, 0, 0.01, 0.01, 0.01, 0, 0, 0]
    true_base = base.base_values(truth.parameters)
    errors = {}
    for name, prior in {"cad": context.prior, "placeholder": placeholder}.items():
        fitted = build("estimator", "sdp").fit(w, tau, context=replace(context, prior=prior))
        errors[name] = np.linalg.norm(fitted.phi_ - true_base) / np.linalg.norm(true_base)
    assert errors["placeholder"] < 1.5 * errors["cad"]
