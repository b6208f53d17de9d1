"""Friction laws (config group ``friction``) and their choice by block cross-validation.

One conformance check runs over every shipped law; the choice is checked on simulated data whose
friction law is known: it must find a law that predicts held-out blocks as well as the truth.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from lwrlab.dynamics.base_parameters import compute_base_parameters
from lwrlab.dynamics.regressor import log_history, regressor
from lwrlab.identification.friction_choice import choose_friction, speed_noise
from lwrlab.identification.log_predictions import process_measurement
from lwrlab.model.friction_laws import FrictionLaw, SignCoulomb, describe_law, law_from_mapping, law_mapping
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from lwrlab.plants.core import Measurement
from lwrlab.resources import config_group
from plugins.friction.holding import HoldingFriction
from plugins.friction.smooth import SmoothCoulomb

LAWS = sorted(config_group("friction"))
SPEEDS = np.linspace(-2.0, 2.0, 401)[:, None] * np.ones((1, 3))


@pytest.mark.parametrize("option", LAWS)
def test_every_law_keeps_the_protocol(option: str) -> None:
    law = build("friction", option)
    assert isinstance(law, FrictionLaw)
    candidates = law.candidates(np.full(3, 1e-3))
    assert candidates, f"{option} offers no candidate"
    for candidate in candidates:
        assert len(candidate.candidates(np.full(3, 1e-3))) == 1, "a candidate is a concrete law"
        shape = candidate.coulomb_shape(SPEEDS)
        assert shape.shape == SPEEDS.shape and np.all(np.abs(shape) <= 1.0)
        np.testing.assert_allclose(shape, -candidate.coulomb_shape(-SPEEDS), atol=1e-15)  # odd
        assert np.all(np.diff(shape, axis=0) >= 0)  # friction never falls as the speed rises
        for term in candidate.extra_terms:
            assert candidate.extra_basis(term.name, SPEEDS).shape == SPEEDS.shape
        rebuilt = law_from_mapping(law_mapping(candidate))  # how an identified model stores it
        np.testing.assert_array_equal(rebuilt.coulomb_shape(SPEEDS), shape)
        assert describe_law(candidate).startswith(candidate.name)


def test_the_default_law_is_the_papers() -> None:
    assert isinstance(build("friction", "sign"), SignCoulomb)
    np.testing.assert_array_equal(SignCoulomb().coulomb_shape(SPEEDS), np.sign(SPEEDS))


def _motion(n: int, seconds: float, rate: float, rest_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Times and positions of a multisine (rad) whose clock stops for ``rest_s`` in the middle: its
    speed ramps down to zero over 0.5 s (a raised cosine), stays there, and ramps up again."""
    t = np.arange(int(seconds * rate)) / rate
    ramp = np.clip((np.abs(t - seconds / 2) - rest_s / 2) / 0.5, 0.0, 1.0) if rest_s else np.ones_like(t)
    clock = np.cumsum(0.5 - 0.5 * np.cos(np.pi * ramp)) / rate  # the multisine's own time (s)
    phases = np.random.default_rng(0).uniform(0, 2 * np.pi, (n, 3))
    q = sum(0.4 / k * np.sin(2 * np.pi * 0.25 * k * clock[:, None] + phases[:, k - 1]) for k in (1, 2, 3))
    return t, np.asarray(q)


def _motion_states(n: int, seconds: float = 12.0, rate: float = 500.0, rest_s: float = 3.0):
    """q, q̇, q̈ of :func:`_motion` (rad, rad/s, rad/s²)."""
    t, q = _motion(n, seconds, rate, rest_s)
    dq = np.gradient(q, t, axis=0)
    return q, dq, np.gradient(dq, t, axis=0)


def _measured(
    robot: RobotModel, seconds: float = 12.0, rate: float = 500.0, noise_q: float = 2e-5, rest_s: float = 3.0
) -> Measurement:
    """The robot's torques (its law) along a motion, measured with encoder and torque noise."""
    t, q = _motion(robot.n_joints, seconds, rate, rest_s)
    dq = np.gradient(q, t, axis=0)
    ddq = np.gradient(dq, t, axis=0)
    tau = (regressor(robot, q, dq, ddq) @ robot.parameters).reshape(q.shape)
    rng = np.random.default_rng(1)
    return Measurement(t=t, q=q + rng.normal(0, noise_q, q.shape), tau=tau + rng.normal(0, 0.05, tau.shape))


@pytest.fixture(scope="module")
def strong_friction(lwr4: RobotModel) -> RobotModel:
    values = lwr4.parameters.copy()
    n = lwr4.n_joints
    values[10 * lwr4.n_links :] = np.concatenate([np.full(n, 4.0), np.full(n, 1.0)])  # FC, FV
    return lwr4.with_parameters(values)


def test_speed_noise_is_the_encoder_noise_through_the_processing(lwr4: RobotModel) -> None:
    # the states' low-pass (on q, before differentiating) sets the speed noise, not the rows' (τ and W)
    settings = {"cutoff_hz": 10.0, "state_cutoff_hz": 20.0}
    quiet = process_measurement(_measured(lwr4, noise_q=2e-5), settings)
    loud = process_measurement(_measured(lwr4, noise_q=2e-4), settings)
    expected = 2e-5 * 2 * np.pi * np.sqrt(2 * 20.0**3 / (3 * 500.0))
    np.testing.assert_allclose(speed_noise([quiet], lwr4), expected, rtol=0.2)
    np.testing.assert_allclose(speed_noise([loud], lwr4) / speed_noise([quiet], lwr4), 10.0, rtol=0.2)


def test_auto_finds_a_smooth_law_where_the_arm_rests(strong_friction: RobotModel) -> None:
    """Truth: FC·tanh(v/0.05); an arm standing still 3 s of 12. The paper's sign law flips on the
    encoder noise at rest; the choice must find a law with a smooth step."""
    truth = strong_friction.with_friction_law(SmoothCoulomb(0.05))
    data = [process_measurement(_measured(truth), {"cutoff_hz": 10.0})]
    candidates = replace(strong_friction.with_friction_law(build("friction", "auto")))
    base = compute_base_parameters(candidates)
    chosen, choice = choose_friction(candidates, base, data)
    assert choice is not None and len(choice.candidates) > 10
    table = choice.table()
    sign = table.loc[table.law == "sign", "cv_nrms_percent"].min()
    assert choice.candidate.law.name != "sign"
    assert table.cv_nrms_percent[choice.chosen] < 0.5 * sign
    assert chosen.friction_law is choice.candidate.law
    assert "rotor" not in chosen.friction_terms  # the truth has no rotor inertia: not worth its columns


def test_a_fixed_law_is_not_cross_validated(strong_friction: RobotModel) -> None:
    data = [process_measurement(_measured(strong_friction, seconds=4.0, rest_s=0.0), {"cutoff_hz": 10.0})]
    robot = strong_friction.with_friction_law(SmoothCoulomb(0.02))
    chosen, choice = choose_friction(robot, compute_base_parameters(robot), data)
    assert choice is None and chosen.friction_terms == robot.friction_terms


def test_the_holding_law_keeps_the_last_direction_at_rest() -> None:
    """Dahl's shape: +1 after moving forwards, held through a rest with encoder-noise speeds, −1 after
    a reversal of a few presliding distances; the breakaway column is the shape at rest."""
    law = HoldingFriction(presliding=0.002, stribeck_speed=0.3, deadband=[6e-3])  # 3 σ of the noise
    rate = 1000.0
    v = np.zeros((3000, 1))
    v[100:600] = 0.5  # forwards 0.25 rad
    v[600:2000] = np.random.default_rng(2).normal(0.0, 2e-3, (1400, 1))  # standing, speed noise
    v[2000:2500] = -0.5  # backwards
    columns = law.history_basis(v, 1.0 / rate)
    shape = columns["coulomb"][:, 0]
    assert shape[99] == 0.0 and shape[599] > 0.999
    assert shape[1999] > 0.9  # held at rest, noise or not
    assert shape[2100] < -0.99 and shape[-1] < -0.99
    np.testing.assert_allclose(columns["breakaway"][1000:2000, 0], shape[1000:2000], atol=1e-3)
    np.testing.assert_allclose(np.sign(SignCoulomb().coulomb_shape(v[1000:2000])).std(), 1.0, atol=0.05)


def test_auto_finds_friction_held_at_rest(strong_friction: RobotModel) -> None:
    """Truth: Coulomb friction held at rest (Dahl, 2 mrad); the choice finds the holding law, far better
    on held-out blocks than the paper's law, whose sign flips on the standing encoder's noise."""
    truth = strong_friction.with_friction_law(HoldingFriction(0.002, 0.3, None))
    measured = _measured(truth, rest_s=3.0)
    t, q = measured.t, measured.q
    # the truth's friction along the true motion (no noise), computed over the whole log
    robot_columns = regressor(
        truth,
        *_motion_states(truth.n_joints),
        history=log_history(truth, _motion_states(truth.n_joints)[1], 500.0),
    )
    measured = replace(
        measured, tau=(robot_columns @ truth.parameters).reshape(q.shape) + 0.05 * np.sin(t)[:, None]
    )
    data = [process_measurement(measured, {"cutoff_hz": 10.0})]
    candidates = strong_friction.with_friction_law(build("friction", "auto"))
    chosen, choice = choose_friction(candidates, compute_base_parameters(candidates), data)
    assert choice is not None and choice.candidate.law.name == "holding"
    table = choice.table()
    sign = table.loc[table.law == "sign", "cv_nrms_percent"].min()
    assert table.cv_nrms_percent[choice.chosen] < 0.3 * sign


def test_a_load_dependent_law_predicts_what_inverse_dynamics_gives(lwr4: RobotModel, rng) -> None:
    """``friction=load``: the regressor's ``load`` column is |τ_rb|·tanh(v/ε) with τ_rb the robot's own
    rigid-body torque at the state, so W·φ is the inverse dynamics with that friction."""
    from plugins.friction.load import LoadCoulomb

    law = LoadCoulomb(0.02)
    robot = lwr4.with_friction_law(law)
    growth = rng.uniform(0.01, 0.1, robot.n_joints)
    robot = replace(robot, friction=robot.friction.with_values({"load": growth}))
    q, dq, ddq = (rng.normal(size=(60, robot.n_joints)) for _ in range(3))
    rigid = lwr4.inverse_dynamics(q, dq, ddq, with_friction=False)
    expected = rigid + robot.drive_torque(dq, ddq, rigid)
    np.testing.assert_allclose(regressor(robot, q, dq, ddq) @ robot.parameters, expected.ravel(), atol=1e-9)
    np.testing.assert_allclose(robot.inverse_dynamics(q, dq, ddq), expected, atol=1e-9)
    # the load term is the growth times the transmitted torque's size, in the motion's direction
    load_only = expected - lwr4.with_friction_law(law).inverse_dynamics(q, dq, ddq)
    np.testing.assert_allclose(load_only, growth * np.abs(rigid) * np.tanh(dq / 0.02), atol=1e-9)
