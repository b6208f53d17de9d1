"""Conformance suite over every estimator plugin of conf/estimator/, and estimator-specific checks.

Every config is instantiated as the pipeline does (a plain object: hyper-parameters only), follows
scikit-learn's parameter protocol (``get_params`` / ``set_params``, ``sklearn.base.clone`` where
scikit-learn is installed), is fitted on noiseless LWR4 data with the identification context given
to ``fit``, and must give back the true base parameters.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import cvxpy as cp
import numpy as np
import pytest
from omegaconf import OmegaConf

from lwrlab.dynamics.base_parameters import BaseParameters, compute_base_parameters
from lwrlab.dynamics.regressor import regressor
from lwrlab.identification.consistency import consistency_margin
from lwrlab.identification.context import IdentificationContext
from lwrlab.identification.hyperparameters import clone_estimator
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from lwrlab.plants.simulation import perturbed_robot
from plugins.estimators.sdp import SolverFailure

CONF = Path(__file__).resolve().parents[1] / "conf" / "estimator"
ESTIMATOR_CONFIGS = sorted(p.stem for p in CONF.glob("*.yaml"))


@pytest.fixture(scope="module")
def problem(lwr4: RobotModel) -> dict:
    """A 4 s LWR4 motion at 200 Hz, a perturbed (consistent) truth, its exact torques."""
    base = compute_base_parameters(lwr4)
    truth = perturbed_robot(lwr4, 0.1, 0.2, np.random.default_rng(7))
    motion = build("trajectory", "multisine", duration=4.0, harmonics=4, seed=3).sample(lwr4, 200.0)
    w = base.base_regressor(regressor(lwr4, motion.q, motion.dq, motion.ddq))
    tau = truth.inverse_dynamics(motion.q, motion.dq, motion.ddq).ravel()
    context = IdentificationContext.from_robot(lwr4, base, reference_regressor=w)
    return {
        "base": base,
        "truth": truth,
        "w": w,
        "tau": tau,
        "context": context,
        "beta": base.base_values(truth.parameters),
    }


def _relative_error(estimate: np.ndarray, truth: np.ndarray) -> float:
    return float(np.linalg.norm(estimate - truth) / np.linalg.norm(truth))


def _estimator(name: str, **changes: Any) -> Any:
    """The estimator of conf/estimator/<name>.yaml, as the pipeline builds it, with ``changes``."""
    return build("estimator", name, **changes)


def _learned(estimator: object) -> list[str]:
    return [key for key in vars(estimator) if key.endswith("_") and not key.startswith("_")]


def _same_params(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(
        np.array_equal(a[k], b[k]) if isinstance(a[k], np.ndarray) else a[k] == b[k] for k in a
    )


@pytest.mark.parametrize("name", ESTIMATOR_CONFIGS)
def test_every_estimator_recovers_true_base_parameters_from_noiseless_data(name: str, problem: dict) -> None:
    estimator = _estimator(name)
    assert estimator.fit(problem["w"], problem["tau"], context=problem["context"]) is estimator
    # an estimator leaning on a prior may keep a trace of it: the sdp's weakest pull (1e-8 of the data's
    # information) biases noiseless base parameters by ~1e-5
    tolerance = 3e-5 if getattr(estimator, "uses_prior", False) else 1e-6
    assert _relative_error(estimator.phi_, problem["beta"]) < tolerance
    for attribute in ("std_", "relative_std_", "residual_std_", "cond_"):
        assert hasattr(estimator, attribute), attribute
    np.testing.assert_allclose(
        estimator.predict(problem["w"]), problem["tau"], atol=tolerance * np.abs(problem["tau"]).max()
    )


@pytest.mark.parametrize("name", ESTIMATOR_CONFIGS)
def test_every_estimator_config_holds_hyper_parameters_only(name: str) -> None:
    """The YAML's keys are exactly the estimator's hyper-parameters, stored untouched: no context, no data."""
    config = OmegaConf.to_container(OmegaConf.load(CONF / f"{name}.yaml"))
    estimator = _estimator(name)
    params = estimator.get_params(deep=False)
    assert "_partial_" not in config and "context" not in params
    assert set(config) - {"_target_"} == set(params)  # every hyper-parameter is set in the YAML
    for key in set(config) - {"_target_"}:
        assert params[key] == config[key], key


@pytest.mark.parametrize("name", ESTIMATOR_CONFIGS)
def test_every_estimator_follows_the_parameter_protocol(name: str, problem: dict) -> None:
    """get_params / set_params round-trip; a clone of a fitted estimator is unfitted with equal settings."""
    estimator = _estimator(name)
    params = estimator.get_params()
    assert estimator.set_params(**params) is estimator
    assert _same_params(estimator.get_params(), params)
    with pytest.raises(ValueError, match="invalid parameter"):
        estimator.set_params(not_a_setting=1)
    estimator.fit(problem["w"], problem["tau"], context=problem["context"])
    assert _learned(estimator)
    copy = clone_estimator(estimator)
    assert type(copy) is type(estimator) and copy is not estimator
    assert _same_params(copy.get_params(), params) and not _learned(copy)
    assert copy.fit(problem["w"], problem["tau"], context=problem["context"]) is copy
    np.testing.assert_allclose(copy.phi_, estimator.phi_, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("name", ESTIMATOR_CONFIGS)
def test_sklearn_clone_copies_every_estimator(name: str, problem: dict) -> None:
    sklearn_base = pytest.importorskip("sklearn.base")
    estimator = _estimator(name).fit(problem["w"], problem["tau"], context=problem["context"])
    copy = sklearn_base.clone(estimator)  # checks that __init__ stores every parameter untouched
    assert type(copy) is type(estimator) and not _learned(copy)
    assert _same_params(copy.get_params(), estimator.get_params())
    assert copy.fit(problem["w"], problem["tau"], context=problem["context"]) is copy


def test_setting_a_hyper_parameter_changes_the_fit(problem: dict) -> None:
    """set_params reaches the fit: an SDP asked for tight mass bounds keeps the masses there."""
    sdp = _estimator("sdp").set_params(mass_bounds=[0.99, 1.01])
    sdp.fit(problem["w"], problem["tau"], context=problem["context"])
    masses, prior = sdp.standard_phi_[0:70:10], problem["context"].prior[0:70:10]
    assert np.all(masses >= 0.99 * prior - 1e-7) and np.all(masses <= 1.01 * prior + 1e-7)


def test_wls_downweights_the_noisy_joint(rng: np.random.Generator) -> None:
    """Joint 2 is 20× noisier: WLS weights it 400× less and beats OLS on the parameter error."""
    w = rng.normal(size=(4000, 5))
    phi = rng.normal(size=5)
    noise = rng.normal(size=4000) * np.tile([0.05, 1.0], 2000)
    wls = _estimator("wls", n_joints=2).fit(w, w @ phi + noise)
    ols = _estimator("ols").fit(w, w @ phi + noise)
    np.testing.assert_allclose(wls.joint_std_, [0.05, 1.0], rtol=0.1)
    assert np.linalg.norm(wls.phi_ - phi) < 0.5 * np.linalg.norm(ols.phi_ - phi)
    assert np.all(wls.std_ < ols.std_)  # the covariance knows it too


def test_wls_without_joint_count_says_what_it_needs(rng: np.random.Generator) -> None:
    with pytest.raises(ValueError, match="n_joints= or call fit"):
        _estimator("wls").fit(rng.normal(size=(10, 2)), np.zeros(10))


def test_irls_resists_outliers_that_drag_ols(rng: np.random.Generator) -> None:
    w = rng.normal(size=(2000, 4))
    phi = np.array([1.0, -2.0, 0.5, 3.0])
    tau = w @ phi + 0.05 * rng.normal(size=2000)
    spikes = rng.choice(2000, 100, replace=False)
    tau[spikes] += 20.0  # sensor glitches on 5 % of the rows
    robust = _estimator("irls", n_joints=2, loss="bisquare").fit(w, tau)
    ols = _estimator("ols").fit(w, tau)
    assert np.linalg.norm(robust.phi_ - phi) < 0.02
    assert np.linalg.norm(ols.phi_ - phi) > 10 * np.linalg.norm(robust.phi_ - phi)
    assert robust.outlier_fraction_ == pytest.approx(0.05, abs=0.01)


def test_iv_removes_the_bias_of_a_noisy_regressor(rng: np.random.Generator) -> None:
    """Errors in the regressor (noisy states) bias OLS toward zero; exact instruments do not."""
    z = rng.normal(size=(20000, 3))
    phi = np.array([1.0, 2.0, -1.0])
    w_measured = z + 0.5 * rng.normal(size=z.shape)
    tau = z @ phi + 0.1 * rng.normal(size=20000)
    iv = _estimator("iv").fit(w_measured, tau, instruments=z)
    ols = _estimator("ols").fit(w_measured, tau)
    assert np.linalg.norm(iv.phi_ - phi) < 0.03
    assert np.linalg.norm(ols.phi_ - phi) > 0.3


def test_iv_without_instruments_names_the_alternatives(rng: np.random.Generator) -> None:
    with pytest.raises(ValueError, match="needs instruments"):
        _estimator("iv").fit(rng.normal(size=(10, 2)), np.zeros(10))


def test_ols_on_short_noisy_data_is_inconsistent_where_sdp_is_not(lwr4: RobotModel, problem: dict) -> None:
    """2 s at 100 Hz with σ_τ = 0.5 N·m: no rigid bodies with dissipative friction reproduce the
    OLS base parameters (negative consistency margin); the SDP's do, by construction."""
    base: BaseParameters = problem["base"]
    context: IdentificationContext = problem["context"]
    motion = build("trajectory", "multisine", duration=2.0, harmonics=3, seed=0).sample(lwr4, 100.0)
    w = base.base_regressor(regressor(lwr4, motion.q, motion.dq, motion.ddq))
    tau = (
        problem["truth"].inverse_dynamics(motion.q, motion.dq, motion.ddq)
        + 0.5 * np.random.default_rng(0).normal(size=(len(motion.t), 7))
    ).ravel()
    dissipative = np.concatenate([context.friction_indices("coulomb"), context.friction_indices("viscous")])
    ols = _estimator("ols").fit(w, tau)
    sdp = _estimator("sdp").fit(w, tau, context=context)
    assert consistency_margin(base.regrouping, ols.phi_, lwr4.n_links, dissipative) < -1e-3
    assert consistency_margin(base.regrouping, sdp.phi_, lwr4.n_links, dissipative) > -1e-9
    assert sdp.min_eigenvalues_.min() >= -1e-12
    assert np.all(sdp.standard_phi_[dissipative] >= 0.0)


@pytest.mark.parametrize("regularization", ["none", "euclidean", "entropic"])
def test_sdp_regularisations_give_consistent_models(regularization: str, problem: dict) -> None:
    noisy = problem["tau"] + 0.2 * np.random.default_rng(1).normal(size=problem["tau"].shape)
    sdp = _estimator("sdp", regularization=regularization, weight=1e-4).fit(
        problem["w"], noisy, context=problem["context"]
    )
    assert sdp.solver_ == "CLARABEL" and not sdp.solver_fallback_
    assert sdp.min_eigenvalues_.min() >= -1e-12
    assert _relative_error(sdp.phi_, problem["beta"]) < 0.05


def test_sdp_compressed_and_uncompressed_agree(problem: dict) -> None:
    noisy = problem["tau"] + 0.2 * np.random.default_rng(2).normal(size=problem["tau"].shape)
    compressed = _estimator("sdp", weight=1e-4).fit(problem["w"], noisy, context=problem["context"])
    full = _estimator("sdp", weight=1e-4, compress=False).fit(problem["w"], noisy, context=problem["context"])
    assert _relative_error(compressed.phi_, full.phi_) < 1e-5
    with pytest.raises(ValueError, match="compress=False needs a fixed weight"):
        _estimator("sdp", compress=False).fit(problem["w"], noisy, context=problem["context"])


def test_sdp_mass_bounds_hold(problem: dict) -> None:
    sdp = _estimator("sdp", mass_bounds=[0.95, 1.05]).fit(
        problem["w"], problem["tau"], context=problem["context"]
    )
    masses = sdp.standard_phi_[0 : 10 * 7 : 10]
    prior = problem["context"].prior[0 : 10 * 7 : 10]
    assert np.all(masses >= 0.95 * prior - 1e-7) and np.all(masses <= 1.05 * prior + 1e-7)


def test_sdp_falls_back_and_says_so(problem: dict, caplog: pytest.LogCaptureFixture) -> None:
    """A primary solver that cannot run the problem (OSQP has no SDP cones) falls back to SCS."""
    noisy = problem["tau"] + 0.2 * np.random.default_rng(3).normal(size=problem["tau"].shape)
    with caplog.at_level(logging.WARNING):
        sdp = _estimator("sdp", solver="OSQP").fit(problem["w"], noisy, context=problem["context"])
    assert sdp.solver_ == "SCS" and sdp.solver_fallback_ and sdp.diagnostics_["solver_fallback"] == 1.0
    assert "fallback solver SCS" in caplog.text


def test_sdp_failure_without_fallback_and_bad_settings_are_clear(problem: dict) -> None:
    w, tau, context = problem["w"], problem["tau"], problem["context"]
    with pytest.raises(SolverFailure, match="OSQP"):
        _estimator("sdp", solver="OSQP", fallback_solver=None).fit(w, tau, context=context)
    with pytest.raises(ValueError, match="mass_bounds"):
        _estimator("sdp", mass_bounds=[2.0, 1.0]).fit(w, tau, context=context)
    with pytest.raises(ValueError, match="valid"):
        _estimator("sdp", regularization="ridge").fit(w, tau, context=context)
    with pytest.raises(ValueError, match="context="):
        _estimator("sdp").fit(w, tau)
    assert cp.CLARABEL in cp.installed_solvers()
