"""External force estimation (eq. 14), force PI (eq. 15) and filters."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from omegaconf import OmegaConf

from lwrlab.control.filters import BackwardDifference, FirstOrderLowPass
from lwrlab.control.force_estimation import ExternalForceEstimator
from lwrlab.control.force_pi import ForcePI
from lwrlab.pipeline.build import build, shipped_config

ESTIMATOR = OmegaConf.to_container(shipped_config("task", "painting").estimator)
"""The force estimate's settings (conf/task/painting.yaml ``estimator``); each test names what it changes."""


def _estimator(robot, tcp, **changes):
    return ExternalForceEstimator(robot, tcp, 1e-3, **{**ESTIMATOR, **changes})


def test_estimator_recovers_a_static_wrench_exactly(lwr4, rng):
    tcp = np.eye(4)
    tcp[:3, 3] = [0.0, 0.0, 0.3]
    estimator = _estimator(lwr4, tcp, wrench_cutoff_hz=np.inf)
    q = np.array([0.3, 0.8, 0.2, -1.2, 0.4, 1.0, 0.1])
    wrench = rng.normal(size=6) * [20, 20, 20, 2, 2, 2]
    jacobian = estimator.jacobian(q)
    # at rest the link-side torque balances gravity, friction offset and the robot's push on the environment
    tau = pin.computeGeneralizedGravity(estimator.model, estimator.data, q) + jacobian.T @ wrench
    estimator.reset(q)
    for _ in range(5):
        state = estimator.update(q, tau)
    np.testing.assert_allclose(state.wrench, wrench, atol=1e-9)


def test_estimator_removes_the_dynamics_of_a_free_motion(lwr4):
    """Free motion, exact torques: the estimate stays near zero (only the causal differences lag)."""
    tcp = np.eye(4)
    estimator = _estimator(
        lwr4, tcp, velocity_cutoff_hz=np.inf, acceleration_cutoff_hz=np.inf, coulomb_smoothing=1e-9
    )
    t = np.arange(0, 1, 1e-3)
    q = 0.2 * np.sin(2 * np.pi * 0.5 * t)[:, None] * np.ones(7) + 0.3
    dq = np.gradient(q, 1e-3, axis=0)
    ddq = np.gradient(dq, 1e-3, axis=0)
    tau = lwr4.inverse_dynamics(q, dq, ddq)
    estimator.reset(q[0])
    wrenches = np.array([estimator.update(q[k], tau[k]).wrench for k in range(len(t))])
    assert np.abs(wrenches[100:-1, :3]).max() < 2.0


def test_force_pi_moves_towards_the_desired_force_and_saturates():
    loop = ForcePI([-30.0, 0.0, 0.0], kp=[1e-5, 0, 0], ki=[1e-3, 0, 0], period=1e-3, max_displacement=0.01)
    displacement = loop.update(np.zeros(3))
    assert displacement[0] < 0 and displacement[1:].tolist() == [0.0, 0.0]  # no contact yet: go towards −x
    for _ in range(10000):
        displacement = loop.update(np.zeros(3))
    assert displacement[0] == pytest.approx(-0.01)
    assert loop.integral[0] == pytest.approx(-0.01)  # anti-windup: the integral stops at the bound
    at_target = loop.update(np.array([-30.0, 0.0, 0.0]))
    assert at_target[0] == pytest.approx(-0.01)


def test_filters_are_causal_and_pass_constants():
    low = FirstOrderLowPass(10.0, 1e-3)
    low.reset(np.zeros(2))
    values = [low(np.ones(2)) for _ in range(2000)]
    np.testing.assert_allclose(values[-1], 1.0, atol=1e-10)
    assert 0 < values[0][0] < 0.1
    diff = BackwardDifference(1e-3, np.inf)
    diff.reset(np.zeros(1))
    assert diff(np.array([2e-3]))[0] == pytest.approx(2.0)


def test_force_controller_rejects_unknown_feedback():
    with pytest.raises(ValueError, match="estimate"):
        build("controller", "force_pi", feedback="camera")


def test_filtered_differences_equal_two_cascaded_backward_differences(rng):
    from lwrlab.control.filters import FilteredDifferences

    x = np.cumsum(rng.normal(size=(300, 7)), axis=0) * 1e-3
    fused = FilteredDifferences(1e-3, 50.0, 10.0)
    velocity, acceleration = BackwardDifference(1e-3, 50.0), BackwardDifference(1e-3, 10.0)
    fused.reset(x[0])
    velocity.reset(x[0])
    acceleration.reset(np.zeros(7))
    for sample in x[1:]:
        v, a = fused(sample)
        expected_v = velocity(sample)
        np.testing.assert_allclose(v, expected_v, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(a, acceleration(expected_v), rtol=1e-10, atol=1e-9)


def test_low_pass_over_a_whole_signal_equals_sample_by_sample(rng):
    signal = rng.normal(size=(500, 3))
    low = FirstOrderLowPass(20.0, 1e-3)
    low.reset(np.full(3, 0.5))
    expected = np.array([low(x) for x in signal])
    np.testing.assert_allclose(
        FirstOrderLowPass(20.0, 1e-3).apply(signal, initial=0.5), expected, rtol=1e-12, atol=1e-14
    )
