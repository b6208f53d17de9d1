"""The excitation problem: exact gradients, constraints, the solver, and the shipped optimal motion."""

from __future__ import annotations

import functools
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from example_robots import example_robot_files

from lwrlab.dynamics.base_parameters import compute_base_parameters
from lwrlab.excitation.collision_scene import CollisionScene
from lwrlab.excitation.problem import ExcitationProblem
from lwrlab.excitation.solver import (
    InfeasibleExcitationError,
    SlsqpOptimizer,
    check_motion_at,
    feasible_first_step,
    first_step_point,
    verify_motion,
    within_margins,
)
from lwrlab.io.exciting_motion import load_motion_description
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from lwrlab.pipeline.excitation import regressor_condition
from lwrlab.pipeline.studies.duration_study import knee_duration, recommended_duration
from plugins.criteria.logdet import LogDet
from plugins.trajectories.fourier import FourierMotion
from plugins.trajectories.optimal import OptimalExcitingMotion

SHIPPED = (
    Path(__file__).resolve().parents[1] / "lwrlab" / "data" / "exciting_motions" / "kuka_lwr4_logdet_10s.yaml"
)


def directional_check(
    f, jacobian: np.ndarray, x: np.ndarray, n_directions: int = 4, h: float = 1e-6
) -> float:
    """Largest relative gap between ``J·d`` and central differences of f along random unit directions d.

    Random directions exercise every column of the Jacobian at once, for a few evaluations of f.
    Relative to the largest |J·d| (rows near zero are compared in absolute terms against it).
    """
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(n_directions):
        d = rng.normal(size=x.size)
        d /= np.linalg.norm(d)
        numeric = (np.atleast_1d(f(x + h * d)) - np.atleast_1d(f(x - h * d))) / (2 * h)
        analytic = np.atleast_2d(jacobian) @ d
        worst = max(worst, float(np.abs(analytic - numeric).max() / np.abs(numeric).max()))
    return worst


def optimal(**overrides: Any) -> OptimalExcitingMotion:
    """The shipped optimal motion (conf/trajectory/optimal.yaml: constraints, grid, smoothing, logdet) as a
    2 s motion to optimise, with ``overrides``."""
    return build("trajectory", "optimal", **{"duration": 2.0, "from_file": None, **overrides})


def quiet_optimizer(max_iterations: int, **overrides: Any) -> SlsqpOptimizer:
    """The shipped SLSQP settings, ``max_iterations`` per start, no progress bar."""
    return build("optimizer", "slsqp", max_iterations=max_iterations, show_progress=False, **overrides)


@pytest.fixture(scope="module")
def lwr_base(lwr4: RobotModel):
    return compute_base_parameters(lwr4)


@pytest.fixture(scope="module")
def lwr_problem(lwr4: RobotModel, lwr_base) -> ExcitationProblem:
    return optimal(criterion=LogDet()).problem(lwr4, lwr_base)


@pytest.mark.parametrize(
    "parameterisation",
    [None, functools.partial(FourierMotion, harmonics=2)],  # None: the shipped B-spline
    ids=["bspline", "fourier"],
)
@pytest.mark.parametrize("criterion", ["logdet", "cond"])
def test_objective_gradient_equals_central_differences(
    lwr4: RobotModel, lwr_base, parameterisation, criterion: str
) -> None:
    changes = {} if parameterisation is None else {"parameterisation": parameterisation}
    problem = optimal(criterion=build("criterion", criterion), **changes).problem(lwr4, lwr_base)
    x = problem.parameterisation.initial_coefficients(lwr4, np.random.default_rng(1), 0.4).ravel()
    gradient = problem.objective_gradient(x)
    assert directional_check(problem.objective, gradient, x) <= 1e-6
    for i in (0, 8, x.size - 1):  # and a few entries one by one
        e = np.zeros_like(x)
        e[i] = 1.0
        numeric = (problem.objective(x + 1e-6 * e) - problem.objective(x - 1e-6 * e)) / 2e-6
        assert gradient[i] == pytest.approx(numeric, rel=1e-6, abs=1e-6 * np.abs(gradient).max())


def test_every_constraint_family_has_an_exact_jacobian(lwr_problem: ExcitationProblem) -> None:
    x = lwr_problem.parameterisation.initial_coefficients(
        lwr_problem.robot, np.random.default_rng(2), 0.6
    ).ravel()
    windows = lwr_problem.windowed_slacks(x)
    assert [w.family for w in windows] == [
        "position",
        "velocity",
        "acceleration",
        "torque",
        "world",
        "self_collision",
    ]
    analytic = lwr_problem.constraint_jacobian(x)
    assert analytic.shape == (len(lwr_problem.constraint_labels()), x.size)
    start = 0
    for windowed in windows:
        rows = slice(start, start + windowed.values.size)
        gap = directional_check(
            lambda y, rows=rows: lwr_problem.constraint_values(y)[rows], analytic[rows], x
        )
        assert gap <= 1e-6, windowed.family
        start += windowed.values.size


def test_torque_constraint_uses_the_cad_inverse_dynamics(lwr_problem: ExcitationProblem) -> None:
    """Torque slacks = limits ∓ (RNEA + friction), the regressor's smoothed Coulomb term aside."""
    robot = lwr_problem.robot
    x = lwr_problem.parameterisation.initial_coefficients(robot, np.random.default_rng(3), 0.4).ravel()
    q, dq, ddq = (b @ lwr_problem.coefficients(x) for b in lwr_problem.bases)
    exact = lwr_problem.constraint_set.slacks(q, dq, ddq)["torque"]
    keep = 1.0 - lwr_problem.constraint_set.settings.limit_margin
    tau = robot.inverse_dynamics(q, dq, ddq)
    np.testing.assert_allclose(
        exact, np.hstack([keep * robot.limits.torque + tau, keep * robot.limits.torque - tau]), atol=1e-9
    )


@pytest.mark.parametrize("robot_name", ["lwr4", "panda"])
def test_sphere_centres_agree_with_pinocchio(
    robot_name: str, request: pytest.FixtureRequest, rng: np.random.Generator
) -> None:
    robot: RobotModel = request.getfixturevalue(robot_name)
    q = rng.uniform(robot.limits.position_lower, robot.limits.position_upper, size=(4, robot.n_joints))
    scene = lwr_scene(robot)
    centres = scene.sphere_centres(scene.poses(q))
    data = robot.model.createData()
    for k in range(4):
        pin.forwardKinematics(robot.model, data, q[k])
        for s, sphere in enumerate(scene.spheres):  # fitted to the meshes, or hand-written
            pose = data.oMi[sphere.link] if sphere.link else pin.SE3.Identity()
            np.testing.assert_allclose(centres[s, k], pose.act(sphere.center), atol=1e-12)


def lwr_scene(robot: RobotModel) -> CollisionScene:
    """The collision scene of a robot described by spheres, with the shipped settings."""
    return optimal().constraints.scene(robot)


def test_relevant_pairs_skip_neighbours_and_rigid_pairs(lwr4: RobotModel) -> None:
    min_link_gap = optimal().constraints.min_link_gap
    assert min_link_gap == 2
    scene = lwr_scene(lwr4)
    pairs = scene.self_pairs
    names = {(scene.bodies[a], scene.bodies[b]) for a, b in pairs}
    assert ("base", "shoulder") not in names and (
        "elbow",
        "wrist",
    ) not in names  # rigid: distance never changes
    assert ("base", "wrist") in names and ("upper_arm", "flange") in names
    assert all(abs(lwr4.collision_spheres[a].link - lwr4.collision_spheres[b].link) >= 2 for a, b in pairs)
    assert 10 <= len(pairs) <= 14  # the paper keeps 12 distances


def test_unknown_ground_sphere_lists_the_robot_spheres(lwr4: RobotModel) -> None:
    with pytest.raises(ValueError, match=r"ground_spheres \['knee'\].*'elbow'"):
        optimal(constraints={"ground_spheres": ["knee"]}).problem(lwr4)


def test_short_optimisation_is_feasible_and_improves_the_criterion(lwr4: RobotModel, lwr_base) -> None:
    problem = optimal(criterion=LogDet()).problem(lwr4, lwr_base)
    optimizer = quiet_optimizer(40, seed=4)
    start, _ = optimizer._start(problem, np.random.default_rng(4))
    result = optimizer.solve(problem)
    assert result.cost < problem.objective(start)
    assert all(not r.violated for r in result.reports)
    assert "| velocity |" in result.summary()


def test_the_first_step_from_a_narrow_region_is_the_longest_halving_within_the_margins(
    lwr_problem: ExcitationProblem, monkeypatch: pytest.MonkeyPatch
) -> None:
    """From a start moved near the safest pose, the LWR4 (a wide feasible region: its safest pose is
    far from every constraint) keeps the configured first step; where the safest pose rested within
    the distance margin, the step would be the longest halving whose point keeps every true limit and
    the clearance, its double not."""
    optimizer = quiet_optimizer(1, seed=0)
    x0, near_still = optimizer._start(lwr_problem, np.random.default_rng(0))
    assert near_still
    gradient = lwr_problem.objective_gradient(x0)
    constraints, rest = lwr_problem.constraint_set, np.zeros((1, lwr_problem.robot.n_joints))
    slacks = constraints.slacks(lwr_problem.safe_pose()[None], rest, rest)
    smallest = min(float(np.min(v / constraints.scales(f))) for f, v in slacks.items())
    assert lwr_problem.safe_pose_slack() == pytest.approx(smallest, abs=1e-12)
    assert lwr_problem.safe_pose_slack() > constraints.settings.distance_margin
    assert optimizer.first_step_bound(lwr_problem, x0, gradient) == optimizer.first_step
    assert not within_margins(lwr_problem, first_step_point(lwr_problem, x0, gradient, optimizer.first_step))
    step = feasible_first_step(lwr_problem, x0, gradient, optimizer.first_step)
    assert step < optimizer.first_step
    assert within_margins(lwr_problem, first_step_point(lwr_problem, x0, gradient, step))
    assert not within_margins(lwr_problem, first_step_point(lwr_problem, x0, gradient, 2 * step))
    point = first_step_point(lwr_problem, x0, gradient, step)
    assert np.abs(point - x0).max() <= step + 1e-12
    monkeypatch.setattr(lwr_problem, "safe_pose_slack", lambda: 0.0)
    assert optimizer.first_step_bound(lwr_problem, x0, gradient) == step


def test_infeasible_problem_names_the_violated_constraint(lwr4: RobotModel, lwr_base) -> None:
    """The wrist cannot stay above a floor at 1.5 m: the error says so, with a time."""
    constraints = {"world": {"mounting_surface": {"height": 1.5}}}
    problem = optimal(constraints=constraints).problem(lwr4, lwr_base)
    with pytest.raises(
        InfeasibleExcitationError,
        match=r"world constraint (elbow|wrist)–mounting surface violated by .* m at t = ",
    ):
        quiet_optimizer(8).solve(problem)


def test_shipped_motion_is_feasible_at_1khz_and_better_conditioned_than_the_multisine(
    lwr4: RobotModel, lwr_base
) -> None:
    """The default exciting motion (10 s, logdet) respects every constraint on the 1 kHz resampling."""
    description = load_motion_description(SHIPPED)
    assert description["provenance"]["robot"] == lwr4.name and description["duration"] == 10.0
    motion = build("trajectory", "bspline", from_file=str(SHIPPED))
    reports = verify_motion(lwr4, motion, optimal().constraints, rate_hz=1000.0)
    assert {r.family for r in reports} == {
        "position",
        "velocity",
        "acceleration",
        "torque",
        "world",
        "self_collision",
    }
    assert all(not r.violated for r in reports), [r for r in reports if r.violated]
    played = motion.sample(lwr4, 100.0)
    multisine = build("trajectory", "multisine").sample(lwr4, 100.0)  # 10 s, 6 harmonics
    optimal_cond = regressor_condition(lwr4, played.q, played.dq, played.ddq, lwr_base)
    assert optimal_cond < regressor_condition(lwr4, multisine.q, multisine.dq, multisine.ddq, lwr_base)


def test_optimal_plugin_loads_a_matching_file_and_optimises_otherwise(
    lwr4: RobotModel, caplog: pytest.LogCaptureFixture
) -> None:
    def source(**overrides) -> OptimalExcitingMotion:
        settings = dict(
            criterion=LogDet(), optimizer=quiet_optimizer(40), duration=10.0, from_file=str(SHIPPED)
        )
        return optimal(**{**settings, **overrides})

    loaded = source().sample(lwr4, 1000.0)
    shipped = build("trajectory", "bspline", from_file=str(SHIPPED))
    np.testing.assert_allclose(loaded.q, shipped.sample(lwr4, 1000.0).q)
    assert loaded.metadata["criterion"] == "logdet" and "file" in loaded.metadata
    other = source(duration=2.0)  # the file holds a 10 s motion
    settings_before = dict(vars(other))
    with caplog.at_level("WARNING"):
        motion = other.sample(lwr4, 100.0)
    assert "optimising instead" in caplog.text and "cost" in motion.metadata
    assert vars(other) == settings_before  # sampling leaves the source as it was: no state kept
    assert motion.duration == pytest.approx(2.0)


def test_optimal_plugin_refuses_a_motion_that_breaks_the_true_limits(lwr4: RobotModel) -> None:
    slow = replace(lwr4, limits=replace(lwr4.limits, velocity=0.5 * lwr4.limits.velocity))
    source = optimal(criterion=LogDet(), optimizer=quiet_optimizer(1), duration=10.0, from_file=str(SHIPPED))
    with pytest.raises(
        InfeasibleExcitationError, match=r"velocity constraint joint \d (lower|upper) violated"
    ):
        source.sample(slow, 1000.0)


def test_knee_rule_finds_where_the_improvements_stop() -> None:
    durations = np.arange(1.0, 11.0)
    costs = np.array([np.inf, 10.0, 5.0, 3.0, 2.2, 2.1, 2.05, 2.02, 2.01, 2.0])
    knee, relative_cost, relative_step = knee_duration(durations, costs, fraction=0.05)
    assert knee == 5.0  # every step after T = 5 s is below 5 % of the total decrease (8)
    assert np.nanmin(relative_cost) == 0.0 and np.nanmax(relative_cost) == 1.0
    assert (
        not relative_step[1] < 0.05
    )  # the step from an infeasible duration (inf cost) counts as significant


def test_recommended_duration_is_the_median_knee_in_whole_seconds() -> None:
    assert recommended_duration({"cond": 5.0, "logdet": 9.0, "hadamard": 14.0}) == 9.0
    assert recommended_duration({"cond": 5.0, "logdet": 8.0, "bad": float("nan")}) == 7.0
    assert np.isnan(recommended_duration({"cond": float("nan")}))


@pytest.mark.slow
def test_talos_left_arm_in_its_narrow_region_converges_from_its_first_start() -> None:
    """TALOS's shoulder stays within millimetres of the clearance and margin from its torso over most
    of its first joint's range: even the safest pose rests within the distance margin. The first
    step halved to stay within the margins, SLSQP converges from its first start (none abandoned),
    and the motion passes the exact mesh check with no contact."""
    urdf, srdf = example_robot_files("talos_data/robots/talos_full_v2.urdf", "talos_data/srdf/talos.srdf")
    chain = ["torso_2_link", "arm_left_7_link"]
    robot = build("robot", "urdf", path=urdf, srdf=srdf, chain=chain, acceleration_limits=10.0)
    source = optimal(duration=4.0, optimizer=quiet_optimizer(200, seed=0))
    problem = source.problem(robot)
    assert problem.safe_pose_slack() < problem.constraint_set.settings.distance_margin
    result = source.optimizer.solve(problem)
    assert "stalled" not in result.message and len(result.start_costs) == 1
    assert all(not r.violated for r in result.reports)
    check = check_motion_at(
        robot, problem.parameterisation.with_coefficients(result.coefficients), source.constraints, 1000.0
    )
    assert check.passed and check.collisions is not None and not check.collisions.contacts
