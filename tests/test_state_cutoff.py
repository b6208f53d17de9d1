"""The states' cut-off: as high as the positions' noise allows, and for predictions the factor the fit
logs' raw torques choose."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from lwrlab.dynamics.base_parameters import BaseParameters
from lwrlab.errors import ConfigError
from lwrlab.identification.state_cutoff import StateCutoffChoice
from lwrlab.model.robot import RobotModel
from lwrlab.plants.planned_motions import PointToPoint
from lwrlab.signal.noise_limit import noise_limited_cutoff
from lwrlab.signal.processing import process

RATE = 1000.0


def _cycle(rng: np.random.Generator, joints: int = 3, rate: float = RATE) -> tuple[np.ndarray, ...]:
    """A work cell's cycle: quintic moves of 0.6–1.2 s between random poses, dwells of 0.5–1.5 s."""
    motion = PointToPoint(rng.uniform(-1, 1, (9, joints)), rng.uniform(0.6, 1.2, 8), rng.uniform(0.5, 1.5, 9))
    t = np.arange(round(motion.duration * rate) + 1) / rate
    return (t, *motion.evaluate(t))


def _acceleration_error(t: np.ndarray, q: np.ndarray, ddq: np.ndarray, **settings: object) -> float:
    """‖q̈ − q̈_true‖/‖q̈_true‖ of the states the processing gives (the first and last second left out)."""
    data = process(t, q, q, every_sample=True, **settings)  # type: ignore[arg-type]
    inner = slice(int(RATE), -int(RATE))
    return float(np.linalg.norm(data.ddq[inner] - ddq[inner]) / np.linalg.norm(ddq[inner]))


GRID = (2.0, 3.0, 5.0, 7.0, 10.0, 14.0, 20.0, 28.0, 40.0, 60.0, 80.0, 120.0)


@pytest.mark.parametrize("sigma", [1e-6, 1e-5, 1e-4])
def test_the_noise_limit_lands_where_the_acceleration_error_is_least(sigma: float) -> None:
    """On a log whose true acceleration is known, the positions low-passed at the noise's limit give an
    acceleration within 30 % of the best cut-off's of a grid, where the grid's ends are many times worse."""
    t, q, _, ddq = _cycle(np.random.default_rng(3))
    noisy = q + sigma * np.random.default_rng(4).standard_normal(q.shape)
    limit = noise_limited_cutoff(noisy, RATE)
    errors = {c: _acceleration_error(t, noisy, ddq, cutoff_hz=c, state_cutoff_hz=None) for c in GRID}
    best = min(errors.values())
    assert errors[GRID[0]] > 5 * best and errors[GRID[-1]] > 5 * best  # the choice matters
    assert _acceleration_error(t, noisy, ddq, cutoff_hz=limit, state_cutoff_hz=None) <= 1.3 * best


def test_noisier_positions_get_a_lower_limit_and_noise_free_ones_a_fifth_of_the_rate() -> None:
    _, q, _, _ = _cycle(np.random.default_rng(3))
    rng = np.random.default_rng(4)
    limits = [noise_limited_cutoff(q + s * rng.standard_normal(q.shape), RATE) for s in (1e-6, 1e-5, 1e-4)]
    assert limits[0] > limits[1] > limits[2]
    assert noise_limited_cutoff(q, RATE) == pytest.approx(RATE / 5)
    assert noise_limited_cutoff(q[:40], RATE) == pytest.approx(RATE / 5)  # too short to tell


def test_a_point_to_point_log_is_not_over_filtered() -> None:
    """Moves with rests: the rows' automatic cut-off (15 × the motion's frequency) reads the dwells as a
    slow motion; on the states too it rounds off every start and stop. The default states' cut-off
    keeps the accelerations within 30 % of the best fixed cut-off's, twice better than one filter."""
    t, q, _, ddq = _cycle(np.random.default_rng(5))
    noisy = q + 1e-5 * np.random.default_rng(6).standard_normal(q.shape)
    best = min(_acceleration_error(t, noisy, ddq, cutoff_hz=c, state_cutoff_hz=None) for c in GRID)
    default = _acceleration_error(t, noisy, ddq)
    one_filter = _acceleration_error(t, noisy, ddq, state_cutoff_hz=None)
    assert default <= 1.3 * best
    assert one_filter >= 1.8 * default
    data = process(t, noisy, noisy)
    assert data.state_cutoff_hz == pytest.approx(min(2 * data.cutoff_hz, noise_limited_cutoff(noisy, RATE)))
    assert data.working_rate_hz >= 10 * data.state_cutoff_hz - 1e-9


def test_the_states_cut_off_settings() -> None:
    t, q, _, _ = _cycle(np.random.default_rng(3))
    assert process(t, q, q, cutoff_hz=4.0, state_cutoff_hz=None).state_cutoff_hz == 4.0  # one filter
    assert process(t, q, q, cutoff_hz=4.0, state_cutoff_hz=12.0).state_cutoff_hz == 12.0
    assert process(t, q, q, cutoff_hz=4.0).state_cutoff_hz == pytest.approx(8.0)  # 2 × (no noise)
    assert process(t, q, q, cutoff_hz=4.0, state_factor=3.0).state_cutoff_hz == pytest.approx(12.0)
    assert process(t, q, q, cutoff_hz=None).state_cutoff_hz is None  # no filter at all
    with pytest.raises(ConfigError, match="state_cutoff_hz = 600 Hz must lie in"):
        process(t, q, q, state_cutoff_hz=600.0)
    with pytest.raises(ConfigError, match="state_cutoff_hz must be a number"):
        process(t, q, q, state_cutoff_hz="fast")


@dataclass(frozen=True)
class ExactLog:
    """A log of a cycle whose torques a model predicts exactly."""

    robot: RobotModel
    base: BaseParameters
    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray


@pytest.fixture(scope="module")
def lwr4_cycle() -> ExactLog:
    """The LWR4 with smooth Coulomb friction, a 16 s cycle at 500 Hz and its exact torques."""
    from lwrlab.dynamics.base_parameters import compute_base_parameters
    from lwrlab.pipeline.build import build

    robot = build("robot", "kuka_lwr4").with_friction_law(build("friction", "smooth", width=0.05))
    rng = np.random.default_rng(1)
    low, high = robot.limits.position_lower, robot.limits.position_upper
    poses = 0.5 * (low + high) + rng.uniform(-1, 1, (8, robot.n_joints)) * 0.15 * (high - low)
    motion = PointToPoint.within(
        poses, 0.5 * robot.limits.velocity, 0.5 * robot.limits.acceleration, rng.uniform(0.3, 0.8, 8), 0.5
    )
    t = np.arange(round(motion.duration * 500.0) + 1) / 500.0
    q, dq, ddq = motion.evaluate(t)
    tau = robot.inverse_dynamics(q, dq, ddq, with_friction=True)
    return ExactLog(robot, compute_base_parameters(robot), t, q, tau)


@pytest.mark.parametrize("sigma", [1e-6, 3e-5])
def test_predictions_take_the_factor_whose_states_serve_the_model_best(
    lwr4_cycle: ExactLog, sigma: float
) -> None:
    """With the model exact, the states are the only error left: the factor chosen on the raw (noisy)
    torques predicts the noise-free ones within 5 % of the best factor; a fixed factor of 1 (the rows'
    cut-off) is much worse on fine encoders, and noisier encoders get lower states' cut-offs."""
    from lwrlab.identification.log_predictions import predict_measurement
    from lwrlab.identification.state_cutoff import FACTORS, choose_state_factor
    from lwrlab.plants.core import Measurement

    log = lwr4_cycle
    rng = np.random.default_rng(2)
    phi = log.base.base_values(log.robot.parameters)
    noisy_q = log.q + sigma * rng.standard_normal(log.q.shape)
    logged = Measurement(log.t, noisy_q, log.tau + 0.02 * rng.standard_normal(log.q.shape))
    data = process(logged.t, logged.q, logged.tau)
    choice = choose_state_factor(log.robot, log.base, phi, [logged], [data], {})
    assert choice is not None and choice.factor in choice.errors
    assert "states for predictions" in choice.describe()

    def true_error(factor: float) -> float:
        settings = {"cutoff_hz": data.cutoff_hz, "state_factor": factor}
        p = predict_measurement(log.robot, log.base, phi, logged, settings)
        return float(np.linalg.norm((p.predicted - log.tau)[p.scored]) / np.linalg.norm(log.tau[p.scored]))

    errors = {factor: true_error(factor) for factor in FACTORS}
    assert errors[choice.factor] <= 1.05 * min(errors.values())
    if sigma < 1e-5:
        assert errors[1.0] > 3 * errors[choice.factor] and choice.factor >= 3.0
    else:
        assert choice.factor <= 1.5
    fixed = {"state_cutoff_hz": 10.0}
    assert choose_state_factor(log.robot, log.base, phi, [logged], [data], fixed) is None


def test_the_line_prints_the_cut_off_applied_not_the_factor_times_the_rows() -> None:
    """1 × a 12.6 Hz rows' cut-off held at 4.67 Hz by the positions' noise: 4.67 Hz is printed, and why."""
    line = StateCutoffChoice(1.0, {1.0: 0.0037}, (4.67,), (12.6,)).describe()
    assert line.startswith(
        "states for predictions: q at 4.67 Hz on the fit logs (1 × the rows' cut-off 12.6 Hz"
    )
    assert "held by the positions' noise" in line and "every factor tried gives these cut-offs" in line
