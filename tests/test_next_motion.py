"""The next exciting motion: known information as rows, the task-aware criterion, the expected std.

Invariants: a conditioned criterion is the criterion of the stacked rows and its gradient the new rows'
part (central differences, every criterion plugin); known rows are a square root of the known
information; a covariance's information is its marginal; information from rows and from their R
factors agree; the expected std is √diag of the inverse (infinite on open directions); the task-aware
criterion is the mean predicted torque variance along its targets; the whole problem's gradient
matches finite differences with known rows and targets; a design conditioned on what is known
excites what is not.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from composing import CONF
from omegaconf import OmegaConf
from test_criteria import central_difference_gradient, regressor_like

from lwrlab.dynamics.base_parameters import compute_base_parameters, random_states
from lwrlab.dynamics.regressor import regressor
from lwrlab.excitation.criteria import DesignSpace, column_scales
from lwrlab.excitation.known_data import measurement_information, model_information
from lwrlab.excitation.known_information import (
    ConditionedCriterion,
    KnownInformation,
    expected_std,
    information_from_covariance,
    information_from_rows,
    information_from_statistics,
    statistics_noise_density,
    torque_std,
)
from lwrlab.identification.identified import IdentifiedModel
from lwrlab.identification.row_statistics import RowStatistics
from lwrlab.io.artifacts import load_identified_model, save_identified_model
from lwrlab.pipeline.build import build, shipped_config
from lwrlab.plants.core import Measurement

CRITERIA = sorted(p.stem for p in (CONF / "criterion").glob("*.yaml"))


def spd(rng: np.random.Generator, n: int) -> np.ndarray:
    a = rng.normal(size=(n, n))
    return a @ a.T + 0.1 * np.eye(n)


@pytest.mark.parametrize("name", CRITERIA)
def test_a_conditioned_criterion_scores_the_stacked_rows_and_differentiates_the_new_ones(
    name: str, rng: np.random.Generator
) -> None:
    criterion = build("criterion", name)
    known_rows = regressor_like(rng, rows=8)
    weights = np.array([0.5, 2.0])  # two "joints", rows sample-major
    w = regressor_like(rng, rows=40)
    conditioned = ConditionedCriterion(criterion, known_rows, weights)
    value, gradient = conditioned.value_and_gradient(w)
    stacked = np.vstack([known_rows, w * np.tile(weights, 20)[:, None]])
    assert value == pytest.approx(criterion.value_and_gradient(stacked)[0], rel=1e-12)
    numeric = central_difference_gradient(conditioned, w)
    assert np.abs(gradient - numeric).max() <= 1e-6 * np.abs(numeric).max()


def test_without_known_rows_and_weights_the_criterion_is_unchanged(rng: np.random.Generator) -> None:
    criterion = build("criterion", "logdet")
    w = regressor_like(rng)
    bare = ConditionedCriterion(criterion, np.zeros((0, w.shape[1])), None).value_and_gradient(w)
    value, gradient = criterion.value_and_gradient(w)
    assert bare[0] == value and np.array_equal(bare[1], gradient)


def test_known_rows_are_a_square_root_of_the_scaled_information(rng: np.random.Generator) -> None:
    information = spd(rng, 5)
    information[:, 4] = information[4, :] = 0.0  # a parameter nothing is known about
    density = np.array([1e-5, 4e-5, 2e-5])
    known = KnownInformation(tuple("abcde"), information, density, ("test",), "given")
    scales = rng.uniform(0.5, 2.0, 5)
    rows = known.rows(scales, 100.0)
    assert rows.shape == (4, 5)  # the open direction gives no row
    reference = np.exp(np.mean(np.log(density)))
    expected = reference * 100.0 * scales[:, None] * information * scales[None, :]
    np.testing.assert_allclose(rows.T @ rows, expected, rtol=1e-10, atol=1e-10 * np.abs(expected).max())
    np.testing.assert_allclose(known.joint_weights(), np.sqrt(reference / density))
    assert np.prod(known.joint_weights()) == pytest.approx(1.0)


def test_a_covariance_gives_the_marginal_information_of_the_shared_parameters(
    rng: np.random.Generator,
) -> None:
    covariance = np.linalg.inv(spd(rng, 4))
    names = ("a", "b", "c", "offset1")  # the model has a parameter the design has not …
    design = ("a", "b", "c", "new")  # … and the design one the model has not
    information = information_from_covariance(covariance, names, design)
    np.testing.assert_allclose(information[:3, :3], np.linalg.inv(covariance[:3, :3]), rtol=1e-10)
    assert not information[3].any() and not information[:, 3].any()
    std = expected_std(information)
    np.testing.assert_allclose(std[:3], np.sqrt(np.diag(covariance)[:3]), rtol=1e-9)
    assert np.isinf(std[3])


def test_information_of_rows_and_of_their_r_factors_agree(rng: np.random.Generator) -> None:
    w = rng.normal(size=(3 * 200, 6))
    tau = w @ rng.normal(size=6) + np.tile([0.1, 0.3, 0.2], 200) * rng.normal(size=600)
    density = np.array([1e-4, 9e-4, 4e-4])
    statistics = RowStatistics.from_rows(w, tau, n_joints=3)
    direct = information_from_rows(w, 100.0, density)
    np.testing.assert_allclose(information_from_statistics(statistics, 100.0, density), direct, rtol=1e-9)
    # the residual gives back each joint's noise: σ_j²/rate
    np.testing.assert_allclose(statistics_noise_density(statistics, 100.0), density, rtol=0.25)


def test_expected_std_is_infinite_exactly_on_the_open_directions(rng: np.random.Generator) -> None:
    information = spd(rng, 4)
    np.testing.assert_allclose(expected_std(information), np.sqrt(np.diag(np.linalg.inv(information))))
    rows = rng.normal(size=(10, 4))
    rows[:, 3] = rows[:, 2]  # parameters 3 and 4 are seen only as their sum
    std = expected_std(rows.T @ rows)
    assert np.all(np.isfinite(std[:2])) and np.all(np.isinf(std[2:]))


def test_torque_std_is_the_rms_of_the_predicted_variance(rng: np.random.Generator) -> None:
    information = spd(rng, 5)
    w_target = rng.normal(size=(2 * 30, 5))
    covariance = np.linalg.inv(information)
    variance = np.einsum("kp,pr,kr->k", w_target, covariance, w_target).reshape(30, 2)
    np.testing.assert_allclose(torque_std(information, w_target, 2), np.sqrt(variance.mean(axis=0)))
    singular = information.copy()
    singular[:, 4] = singular[4, :] = 0.0
    assert np.all(np.isinf(torque_std(singular, w_target, 2)))


def test_the_task_aware_criterion_is_the_mean_predicted_torque_variance_on_its_targets(lwr4, rng) -> None:
    base = compute_base_parameters(lwr4)
    scales = column_scales(lwr4, base)
    q, dq, ddq = random_states(lwr4, 6, rng)
    criterion = build(
        "criterion", "target_variance", targets=[{"q": q.tolist(), "dq": dq.tolist(), "ddq": ddq.tolist()}]
    )
    bound = criterion.bind(DesignSpace(lwr4, base, scales))
    assert criterion.target_root is None and bound.target_root is not None  # binding makes a copy
    w = base.base_regressor(regressor(lwr4, *random_states(lwr4, 60, rng))) * scales
    w_target = base.base_regressor(regressor(lwr4, q, dq, ddq))
    covariance = np.diag(scales) @ np.linalg.inv(w.T @ w) @ np.diag(scales)  # physical units
    variance = np.einsum("kp,pr,kr->k", w_target, covariance, w_target)
    value, _ = bound.value_and_gradient(w)
    assert value == pytest.approx(
        np.log(variance.sum() / 6), rel=1e-9
    )  # summed over joints, mean over states
    unbound = criterion.value_and_gradient(w)[0]
    assert unbound == pytest.approx(build("criterion", "a_optimality").value_and_gradient(w)[0])


def test_the_task_aware_criterion_needs_targets(lwr4) -> None:
    from lwrlab.errors import ConfigError

    base = compute_base_parameters(lwr4)
    with pytest.raises(ConfigError, match=r"task\.targets"):
        build("criterion", "target_variance").bind(DesignSpace(lwr4, base, column_scales(lwr4, base)))


def known_from_random_motion(robot, base, rng, density) -> KnownInformation:
    q, dq, ddq = random_states(robot, 40, rng)
    rows = base.base_regressor(regressor(robot, q, 0.2 * dq, 0.2 * ddq))
    return KnownInformation(base.names, information_from_rows(rows, 10.0, density), density, ("x",), "given")


@pytest.mark.parametrize("criterion", ["logdet", "target_variance"])
def test_the_conditioned_problem_gradient_matches_finite_differences(lwr4, rng, criterion: str) -> None:
    base = compute_base_parameters(lwr4)
    density = 1e-5 * rng.uniform(0.5, 3.0, 7)
    known = known_from_random_motion(lwr4, base, rng, density)
    q = random_states(lwr4, 4, rng)[0]
    settings = {"targets": [{"q": q.tolist()}]} if criterion == "target_variance" else {}
    source = build(
        "trajectory",
        "optimal",
        duration=2.0,
        from_file=None,
        criterion=build("criterion", criterion, **settings),
    )
    problem = source.problem(lwr4, base, known)
    assert isinstance(problem.criterion, ConditionedCriterion) and problem.criterion.name == criterion
    x = problem.parameterisation.initial_coefficients(lwr4, np.random.default_rng(1), 0.4).ravel()
    gradient = problem.objective_gradient(x)
    h = 1e-6
    for i in rng.choice(len(x), 4, replace=False):
        e = np.zeros_like(x)
        e[i] = h
        numeric = (problem.objective(x + e) - problem.objective(x - e)) / (2 * h)
        assert gradient[i] == pytest.approx(numeric, rel=1e-5, abs=1e-8 * np.abs(gradient).max())


def test_known_information_about_other_parameters_is_refused(lwr4) -> None:
    base = compute_base_parameters(lwr4)
    known = KnownInformation(("a",), np.eye(1), np.full(7, 1e-5), ("x",), "given")
    with pytest.raises(ValueError, match="other base parameters"):
        build("trajectory", "optimal", duration=2.0, from_file=None).problem(lwr4, base, known)


def test_a_design_conditioned_on_what_is_known_excites_what_is_not(lwr4) -> None:
    """Everything known but the wrist's last two segments: the conditioned motion leaves their
    parameters better determined than the motion designed alone, and scores better on the combined data."""
    base = compute_base_parameters(lwr4)
    density = np.full(7, 1e-5)
    unknown = np.array([name[-2] in "67" or name[-1] in "67" for name in base.names])
    information = np.diag(np.where(unknown, 0.0, 1e12))
    known = KnownInformation(base.names, information, density, ("everything but joints 6-7",), "given")
    optimizer = build("optimizer", "slsqp", show_progress=False, max_iterations=60, seed=0)
    source = build("trajectory", "optimal", duration=3.0, from_file=None, optimizer=optimizer)
    alone, _, problem = source.optimise(lwr4, base)
    conditioned, _, conditioned_problem = source.optimise(lwr4, base, known)

    def combined(motion) -> np.ndarray:
        q, dq, ddq = motion.evaluate(motion.times(100.0))
        rows = base.base_regressor(regressor(lwr4, q, dq, ddq))
        return information + information_from_rows(rows, 100.0, density)

    std_alone = expected_std(combined(alone), problem.scales)[unknown]
    std_conditioned = expected_std(combined(conditioned), problem.scales)[unknown]
    assert np.median(std_conditioned / std_alone) < 0.95  # 0.91 (both saturate the wrist's limits)
    x_alone = alone.coefficients.ravel()
    assert conditioned_problem.objective(conditioned.coefficients.ravel()) < conditioned_problem.objective(
        x_alone
    )


def test_an_identified_model_keeps_its_covariance_and_noise(tmp_path: Path, rng: np.random.Generator) -> None:
    covariance = np.linalg.inv(spd(rng, 3))
    model = IdentifiedModel(
        ("a", "b", "c"), rng.normal(size=3), np.sqrt(np.diag(covariance)), ("x",), np.zeros(1),
        base_covariance=covariance, noise_density=np.array([1e-5, 2e-5]),
    )  # fmt: skip
    loaded, _ = load_identified_model(save_identified_model(model, {"name": "r"}, tmp_path / "m.yaml"))
    np.testing.assert_array_equal(loaded.base_covariance, covariance)
    np.testing.assert_array_equal(loaded.noise_density, model.noise_density)
    text = (tmp_path / "m.yaml").read_text()
    assert "information:" in text and "  - [" in text  # one row per line
    bare = IdentifiedModel(model.base_names, model.base_values, model.base_std, ("x",), np.zeros(1))
    assert (
        load_identified_model(save_identified_model(bare, {}, tmp_path / "n.yaml"))[0].base_covariance is None
    )


def test_an_identified_model_says_which_parameters_the_prior_gave(tmp_path: Path) -> None:
    model = IdentifiedModel(
        ("a", "b"), np.ones(2), np.ones(2), ("x",), np.zeros(1), prior_share=np.array([0.9, 0.1])
    )
    path = save_identified_model(model, {}, tmp_path / "m.yaml")
    saved = yaml.safe_load(path.read_text())["base_parameters"]
    assert saved["a"]["from"] == "prior" and saved["b"]["from"] == "data"
    np.testing.assert_array_equal(load_identified_model(path)[0].prior_share, model.prior_share)


def test_a_model_gives_back_its_own_std(lwr4, rng) -> None:
    base = compute_base_parameters(lwr4)
    known = known_from_random_motion(lwr4, base, rng, np.full(7, 1e-5))
    covariance = np.linalg.inv(known.information)
    model = IdentifiedModel(
        base.names, base.base_values(lwr4.parameters), np.sqrt(np.diag(covariance)), lwr4.parameter_names,
        lwr4.parameters, base_covariance=covariance, noise_density=np.full(7, 1e-5),
    )  # fmt: skip
    from_model = model_information(model, base, "test")
    np.testing.assert_allclose(expected_std(from_model.information), model.base_std, rtol=1e-6)
    from lwrlab.errors import ConfigError

    with pytest.raises(ConfigError, match="no covariance"):
        model_information(
            IdentifiedModel(base.names, model.base_values, model.base_std, (), np.zeros(0)), base, "m"
        )


def test_a_log_tells_what_its_identification_would_tell(lwr4) -> None:
    """The information of a log (noise from its own residual) gives the std a weighted least-squares
    identification of that log reports."""
    from lwrlab.pipeline.identification import identify

    plant = build("plant", "simulated")(robot=lwr4, show_progress=False, seed=3)
    motion = build("trajectory", "multisine", duration=4.0)
    processing = OmegaConf.to_container(shipped_config("measurement", "default").processing, resolve=True)
    validation = build("trajectory", "multisine", duration=1.0)
    report = identify(lwr4, motion, validation, plant, build("estimator", "wls"), processing=processing)
    measurement: Measurement = report.measurements[0]
    known = measurement_information(lwr4, report.base, [measurement], processing)
    assert known.noise_source.startswith("the residual")
    ratio = expected_std(known.information) / report.identified.base_std
    assert np.median(ratio) == pytest.approx(1.0, rel=0.1)
    # the identified model carries the same: its covariance and noise density
    np.testing.assert_allclose(report.identified.noise_density, known.noise_density, rtol=0.15)


def test_target_motions_are_read_from_motion_files_logs_and_inline_states(tmp_path: Path, lwr4) -> None:
    from lwrlab.errors import ConfigError
    from lwrlab.io.artifacts import save_trajectory, save_trajectory_csv
    from lwrlab.io.logs import write_log
    from lwrlab.io.target_motions import read_target_motions
    from lwrlab.trajectory.core import Trajectory

    t = np.arange(0.0, 3.0, 1e-3)
    q = 0.2 * np.sin(2 * np.pi * 0.5 * t)[:, None] * np.ones(7)
    dq = np.gradient(q, t, axis=0)
    motion = Trajectory(t, q, dq, np.gradient(dq, t, axis=0))
    parquet = save_trajectory(motion, tmp_path / "path.parquet")
    csv = save_trajectory_csv(motion, tmp_path / "path.csv")
    log = write_log(Measurement(t, q, lwr4.inverse_dynamics(q, dq, motion.ddq)), tmp_path / "cycle.csv")
    read = read_target_motions(
        [str(parquet), {"path": str(csv), "weight": 2.0}, str(log), {"q": [[0.0] * 7]}], 7, lwr4.joint_names
    )
    assert [m.name for m in read] == ["path", "path", "cycle", "states3"] and read[1].weight == 2.0
    np.testing.assert_array_equal(read[0].ddq, motion.ddq)  # a motion file is read as it is
    np.testing.assert_allclose(read[1].q, q, atol=1e-9)
    # a log is filtered and differentiated as an identification does
    assert read[2].ddq.shape[1] == 7
    assert np.abs(read[2].dq).max() == pytest.approx(np.abs(dq).max(), rel=0.05)
    assert len(read[0].thinned(100).q) == 100
    with pytest.raises(ConfigError, match=r"weight must be positive"):
        read_target_motions([{"q": [[0.0] * 7], "weight": 0}], 7)
    with pytest.raises(ConfigError, match=r"7 finite values"):
        read_target_motions([{"q": [[0.0] * 6]}], 7)
    with pytest.raises(ConfigError, match=r"give a file"):
        read_target_motions([{"dq": [[0.0] * 7]}], 7)
