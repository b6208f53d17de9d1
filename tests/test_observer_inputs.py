"""What the observer reads (lwrlab.monitoring.observer_inputs): positions and torques through the
velocity's causal filter at its instants, so that the filter's delay leaves the observer's balance.

With an exact model and noise-free signals the observer fed a causally filtered velocity beside the
raw torque reads the filter's delay as an external torque that grows with the motion's speed (its
jerk); fed positions and torques through the same filter, it does not, and a contact is still
recovered whole once the filter has settled.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from lwrlab.model.robot import RobotModel
from lwrlab.monitoring.observer import MomentumObserver
from lwrlab.monitoring.observer_inputs import (
    causal_lowpass,
    causal_velocity,
    filtered_like_velocity,
    observer_inputs,
)
from lwrlab.pipeline.build import build

GAIN = 100.0
CUTOFF_HZ = 30.0


@pytest.fixture(scope="module")
def smooth_robot(lwr4: RobotModel) -> RobotModel:
    """The LWR4 with viscous friction only: the observer's model is exactly the torques' source."""
    return replace(lwr4, friction=replace(lwr4.friction, coulomb=np.zeros(lwr4.n_joints)))


def _played(robot: RobotModel, speed: float):
    """A 3 s multisine played ``speed`` times as fast, sampled at 1 kHz: (t, q, τ) noise-free."""
    motion = build("trajectory", "multisine", duration=3.0, harmonics=4, seed=2, limit_fraction=0.6).sample(
        robot, 1000.0 / speed
    )
    t = motion.t / speed
    tau = robot.inverse_dynamics(motion.q, speed * motion.dq, speed**2 * motion.ddq)
    return t, motion.q, tau


def _rms_after_start(t: np.ndarray, r: np.ndarray) -> float:
    settled = t > t[0] + 0.1
    return float(np.sqrt(np.mean(r[settled] ** 2)))


def test_the_velocity_filters_delay_is_no_external_torque_at_any_speed(smooth_robot: RobotModel) -> None:
    observer = MomentumObserver(smooth_robot, GAIN)
    raw, parallel = {}, {}
    for speed in (1.0, 2.0):
        t, q, tau = _played(smooth_robot, speed)
        r_raw, _ = observer.observe(t, q, causal_velocity(t, q, CUTOFF_HZ), tau)
        inputs = observer_inputs(t, q, tau, CUTOFF_HZ)
        r_parallel, _ = observer.observe(t, inputs.q, inputs.dq, inputs.tau)
        raw[speed], parallel[speed] = _rms_after_start(t, r_raw), _rms_after_start(t, r_parallel)
    # the delay's error: M·q⃛ times the delay, 2³ = 8 times as large played twice as fast
    assert raw[2.0] > 5 * raw[1.0] > 0
    assert parallel[2.0] < 0.05 * raw[2.0] and parallel[1.0] < 0.05 * raw[1.0]


def test_an_external_torque_is_recovered_through_the_input_filter(smooth_robot: RobotModel) -> None:
    t, q, tau = _played(smooth_robot, 1.0)
    external = np.zeros_like(q)
    pushed = (t >= 1.0) & (t < 2.0)
    external[pushed] = [3.0, -5.0, 1.0, 0.0, 0.5, 0.0, -0.2]
    inputs = observer_inputs(t, q, tau + external, CUTOFF_HZ)
    r, _ = MomentumObserver(smooth_robot, GAIN).observe(t, inputs.q, inputs.dq, inputs.tau)
    held = (t >= 1.1) & (t < 2.0)  # the input filter's and the observer's transients have settled
    np.testing.assert_allclose(r[held], external[held], atol=0.02)
    assert np.abs(r[t >= 2.1]).max() < 0.02


def test_filtered_like_velocity_is_the_velocity_filter_at_the_differences_instants() -> None:
    t = np.arange(300) * 0.01  # 100 Hz: half a sample is 5 ms, as much as the filter's own delay
    x = np.column_stack([np.sin(5 * t), t**2])
    # a constant is kept (the filter starts in its steady state): no start-up transient
    np.testing.assert_allclose(causal_lowpass(t, np.ones((300, 2)), CUTOFF_HZ), 1.0, atol=1e-12)
    # linear filters commute with differences: the filtered interval means change at the pace of
    # the filtered backward differences (half a sample later, they would lag by ẍ·Δt/2 = 0.125)
    lagged = filtered_like_velocity(t, x, CUTOFF_HZ)
    velocity = causal_velocity(t, x, CUTOFF_HZ)
    settled = slice(20, -1)
    np.testing.assert_allclose(np.gradient(lagged, t, axis=0)[settled], velocity[settled], atol=0.01)
