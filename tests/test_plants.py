"""The simulated plant: truth, playback, closed-loop tracking, noise."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from lwrlab.model.inertia import is_physically_consistent
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from plugins.plants.simulated import SimulatedPlant


def test_truth_is_a_consistent_perturbation_of_the_nominal_robot(lwr4: RobotModel) -> None:
    plant = SimulatedPlant(lwr4, parameter_spread=0.1, seed=7, show_progress=False)
    truth = plant.truth.robot
    assert all(is_physically_consistent(phi) for phi in truth.link_parameters)
    relative = np.abs(truth.link_parameters[:, 0] / lwr4.link_parameters[:, 0] - 1)
    assert 0 < relative.max() < 0.6
    assert np.all(truth.friction.coulomb >= 0)
    again = SimulatedPlant(lwr4, parameter_spread=0.1, seed=7, show_progress=False).truth.robot
    np.testing.assert_array_equal(truth.parameters, again.parameters)


def test_noiseless_playback_measures_the_true_inverse_dynamics(lwr4: RobotModel) -> None:
    motion = build("trajectory", "multisine", duration=2.0, seed=1).sample(lwr4, 1000.0)
    plant = SimulatedPlant(lwr4, torque_noise_std=0.0, encoder_noise_std=0.0, show_progress=False)
    measurement = plant.measure(motion)
    np.testing.assert_array_equal(measurement.q, motion.q)
    expected = plant.truth.robot.inverse_dynamics(motion.q, motion.dq, motion.ddq)
    np.testing.assert_allclose(measurement.tau, expected, atol=1e-12)
    assert not hasattr(measurement, "truth")


def test_torque_noise_has_the_configured_spread(lwr4: RobotModel) -> None:
    motion = build("trajectory", "multisine", duration=5.0, seed=1).sample(lwr4, 1000.0)
    noisy = SimulatedPlant(lwr4, torque_noise_std=0.3, encoder_noise_std=0.0, seed=2, show_progress=False)
    residual = noisy.measure(motion).tau - noisy.truth.robot.inverse_dynamics(motion.q, motion.dq, motion.ddq)
    np.testing.assert_allclose(residual.std(axis=0), 0.3, rtol=0.05)


def test_encoder_quantisation(lwr4: RobotModel) -> None:
    motion = build("trajectory", "multisine", duration=1.0, seed=1).sample(lwr4, 1000.0)
    step = 1e-4
    measurement = SimulatedPlant(
        lwr4, encoder_noise_std=0.0, encoder_resolution=step, show_progress=False
    ).measure(motion)
    np.testing.assert_allclose(measurement.q / step, np.round(measurement.q / step), atol=1e-9)
    assert np.abs(measurement.q - motion.q).max() <= step / 2 + 1e-12


def test_closed_loop_tracks_and_obeys_the_true_dynamics(lwr4: RobotModel) -> None:
    motion = build("trajectory", "multisine", duration=2.0, seed=4, limit_fraction=0.5).sample(lwr4, 1000.0)
    plant = SimulatedPlant(
        lwr4, mode="closed_loop", torque_noise_std=0.0, encoder_noise_std=0.0, substeps=4, show_progress=False
    )
    measurement = plant.measure(motion)
    assert np.abs(measurement.q - motion.q).max() < 0.02  # rad: PD + gravity compensation tracks
    # Independent check of the ABA integration: RNEA on the simulated states reproduces the applied
    # torque (up to the smoothed Coulomb term and the integration step).
    truth = plant.truth.robot
    dt = 1e-3
    dq = np.gradient(measurement.q, dt, axis=0)
    ddq = np.gradient(dq, dt, axis=0)
    data = truth.model.createData()
    inner = slice(10, -10)
    rnea = np.stack(
        [
            pin.rnea(truth.model, data, q, v, a)
            for q, v, a in zip(measurement.q[inner], dq[inner], ddq[inner], strict=True)
        ]
    )
    friction = truth.friction.viscous * dq[inner] + truth.friction.coulomb * np.tanh(dq[inner] / 1e-3)
    residual = measurement.tau[inner] - rnea - friction
    assert np.sqrt(np.mean(residual**2)) < 0.05 * np.sqrt(np.mean(measurement.tau[inner] ** 2))


def test_unknown_mode_lists_valid_ones(lwr4: RobotModel) -> None:
    with pytest.raises(ValueError, match=r"playback.*closed_loop"):
        SimulatedPlant(lwr4, mode="teleport")
