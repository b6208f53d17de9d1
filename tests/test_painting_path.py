"""Painting path (Fig. 7), its optimisation (eq. 12) and the coverage measure."""

from __future__ import annotations

import numpy as np
import pytest
from omegaconf import OmegaConf
from scipy.interpolate import BPoly

from lwrlab.pipeline.build import shipped_config
from lwrlab.pipeline.painting import path_problem
from lwrlab.pipeline.tools.library import load_tool
from lwrlab.planning.coverage import painted_fraction
from lwrlab.planning.painting_path import PaintingPathParameters, sample_path, way_point_times
from lwrlab.planning.path_optimisation import InfeasiblePath, optimise_path
from lwrlab.planning.path_problem import WallBounds
from lwrlab.plants.mujoco_contact import Wall

TASK = OmegaConf.to_container(shipped_config("task", "painting"), resolve=True)
"""The painting task's settings (conf/task/painting.yaml): the wall and eq. (12)'s ``path``."""

PARAMETERS = PaintingPathParameters(
    duration=30.0, swivel=0.0, z_upper=0.6, z_lower=0.2, y_start=0.1, y_step=0.2, n_steps=2
)


def test_zig_zag_way_points():
    np.testing.assert_allclose(
        PARAMETERS.way_points(), [[0.1, 0.2], [0.1, 0.6], [0.3, 0.6], [0.3, 0.2], [0.5, 0.2], [0.5, 0.6]]
    )
    assert PARAMETERS.y_end == pytest.approx(0.5)
    assert PARAMETERS.painted_area(0.2) == pytest.approx(0.4 * 0.6)


def test_path_stops_at_every_way_point_and_is_the_quintic_spline():
    path = sample_path(PARAMETERS, wall_x=-0.8, rate_hz=1000.0)
    times = way_point_times(PARAMETERS.way_points(), PARAMETERS.duration)
    index = np.round(times * 1000).astype(int)
    np.testing.assert_allclose(path.position[index, 1:], PARAMETERS.way_points(), atol=1e-12)
    np.testing.assert_allclose(path.velocity[index], 0.0, atol=1e-6)  # way-point times fall between samples
    np.testing.assert_allclose(path.acceleration[index], 0.0, atol=1e-3)
    assert np.all(path.position[:, 0] == -0.8)
    for axis, column in ((1, 0), (2, 1)):
        spline = BPoly.from_derivatives(times, [[p, 0.0, 0.0] for p in PARAMETERS.way_points()[:, column]])
        np.testing.assert_allclose(path.position[:, axis], spline(path.t), atol=1e-12)
        np.testing.assert_allclose(path.acceleration[:, axis], spline.derivative(2)(path.t), atol=1e-10)
    # the velocity is the derivative of the position
    np.testing.assert_allclose(np.gradient(path.position, 1e-3, axis=0)[1:-1], path.velocity[1:-1], atol=1e-5)


def test_coverage_of_overlapping_and_gapped_stripes():
    z = np.linspace(0.2, 0.6, 2000)
    for step, expected in ((0.2, 1.0), (0.25, 0.4 / 0.45)):  # a 5 cm gap between two 0.2 m stripes
        ys = np.concatenate([np.full_like(z, 0.1), np.full_like(z, 0.1 + step)])
        fraction, _ = painted_fraction(
            ys, np.tile(z, 2), np.ones(ys.size, bool), 0.2, (0.0, 0.2 + step * 1.0, 0.2, 0.6)
        )
        assert fraction == pytest.approx(expected, abs=0.02)


@pytest.fixture(scope="module")
def roller_problem(lwr4):
    """The painting task's eq. (12) for the large roller on the CAD robot, N_r = 1 (quick)."""
    tool = load_tool("large_roller")
    return path_problem(lwr4, tool.parameters, tool, Wall(**TASK["wall"]), 1, TASK["path"])


def test_optimised_path_is_feasible_continuous_and_covers_its_area(roller_problem):
    solution = optimise_path(roller_problem, starting_swivels=(-1.6,))
    assert min(solution.constraints.values()) > -1e-6
    p = solution.parameters
    assert roller_problem.stripe_overlap > 0  # neighbouring stripes overlap by at least that
    assert p.y_step <= roller_problem.roller_width - roller_problem.stripe_overlap + 1e-9
    # the 1 kHz joint trajectory stays on one branch: no jumps, every limit met
    _, q, dq, ddq = roller_problem.joint_trajectory(p.vector(), rate_hz=1000.0)
    assert np.abs(np.diff(q, axis=0)).max() < 5e-3
    lim = roller_problem.robot.limits
    assert np.all(q >= lim.position_lower) and np.all(q <= lim.position_upper)
    assert np.all(np.abs(dq) <= lim.velocity) and np.all(np.abs(ddq[2:-2]) <= lim.acceleration)
    path = roller_problem.path(p.vector(), rate_hz=1000.0)
    fraction, _ = painted_fraction(
        path.position[:, 1],
        path.position[:, 2],
        np.ones(path.t.size, bool),
        roller_problem.roller_width,
        (
            p.y_start - roller_problem.roller_width / 2,
            p.y_end + roller_problem.roller_width / 2,
            p.z_lower,
            p.z_upper,
        ),
    )
    assert fraction > 0.99


def test_infeasible_path_names_the_violated_constraints(roller_problem):
    from dataclasses import replace

    unreachable = replace(roller_problem, wall=WallBounds(-1.5, 0.0, 0.6, 0.0, 0.8))
    with pytest.raises(InfeasiblePath, match="reach"):
        optimise_path(unreachable, starting_swivels=(0.0,))


def test_path_position_derivatives_match_finite_differences():
    from lwrlab.planning.painting_path import sample_path_derivatives

    x = PARAMETERS.vector()
    analytic = sample_path_derivatives(PARAMETERS, 10.0)
    h = 1e-7
    for i in range(6):
        up, down = x.copy(), x.copy()
        up[i] += h
        down[i] -= h
        numeric = (
            sample_path(PaintingPathParameters.from_vector(up, 2), -0.8, 10.0).position
            - sample_path(PaintingPathParameters.from_vector(down, 2), -0.8, 10.0).position
        ) / (2 * h)
        np.testing.assert_allclose(analytic[:, :, i], numeric, atol=1e-7)


# points where T_C·rate is far from a half integer: the sample count does not jump within ±h
GRADIENT_POINTS = [
    np.array([65.0, -1.2, 0.5, 0.3, 0.15, 0.15]),
    np.array([20.0, -0.8, 0.6, 0.2, 0.13, 0.12]),
    np.array([41.23, -1.6, 0.55, 0.25, 0.12, 0.18]),
]


@pytest.mark.parametrize("x", GRADIENT_POINTS)
def test_cost_gradient_and_constraint_jacobian_match_finite_differences(roller_problem, x):
    from dataclasses import replace

    problem = replace(roller_problem, n_steps=2)
    h = 1e-6
    steps = np.eye(6) * h
    numeric_cost = np.array([(problem.cost(x + e) - problem.cost(x - e)) / (2 * h) for e in steps])
    np.testing.assert_allclose(problem.cost_gradient(x), numeric_cost, rtol=1e-6, atol=1e-6)

    def values(y):
        return np.array(list(problem.constraints(y).values()))

    numeric = np.array([(values(x + e) - values(x - e)) / (2 * h) for e in steps]).T
    analytic = problem.constraint_jacobian(x)
    assert analytic.shape == (len(problem.constraints(x)), 6)
    assert np.abs(analytic).max() > 0.1  # the joint constraints were evaluated, not placeholders
    np.testing.assert_allclose(analytic, numeric, rtol=1e-5, atol=1e-6)


def test_analytic_and_finite_difference_gradients_reach_the_same_optimum(roller_problem):
    analytic = optimise_path(roller_problem, starting_swivels=(-1.6,))
    numeric = optimise_path(roller_problem, starting_swivels=(-1.6,), gradients="finite_differences")
    total = sum(analytic.cost_terms.values())
    assert total == pytest.approx(sum(numeric.cost_terms.values()), rel=1e-3)
    assert min(analytic.constraints.values()) > -1e-6
