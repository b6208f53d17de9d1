"""Motion plugins and limit checks."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from lwrlab.signal.processing import central_difference
from lwrlab.trajectory.core import LimitViolation, check_limits


@pytest.mark.parametrize("robot_name", ["lwr4", "panda"])
def test_multisine_starts_and_stops_at_rest_within_limits(
    robot_name: str, request: pytest.FixtureRequest
) -> None:
    robot: RobotModel = request.getfixturevalue(robot_name)
    motion = build("trajectory", "multisine", seed=3).sample(robot, 1000.0)  # 10 s, 6 harmonics, 80 %
    assert motion.q.shape == (10001, robot.n_joints)
    np.testing.assert_allclose(motion.dq[[0, -1]], 0.0, atol=1e-12)
    np.testing.assert_allclose(motion.ddq[[0, -1]], 0.0, atol=1e-12)
    np.testing.assert_allclose(motion.q[0], motion.q[-1], atol=1e-12)
    check_limits(motion, robot)
    # The limiting quantity of each joint is used at exactly limit_fraction.
    lim = robot.limits
    center = 0.5 * (lim.position_lower + lim.position_upper)
    room = np.minimum(center - lim.position_lower, lim.position_upper - center)
    usage = np.max(
        [
            np.abs(motion.q - center).max(0) / room,
            np.abs(motion.dq).max(0) / lim.velocity,
            np.abs(motion.ddq).max(0) / lim.acceleration,
        ],
        axis=0,
    )
    np.testing.assert_allclose(usage, 0.8, rtol=1e-3)


def test_multisine_derivatives_are_consistent(lwr4: RobotModel) -> None:
    motion = build("trajectory", "multisine", seed=5).sample(lwr4, 1000.0)
    dt = 1e-3
    np.testing.assert_allclose(central_difference(motion.q, dt, 4)[5:-5], motion.dq[5:-5], atol=1e-8)
    np.testing.assert_allclose(central_difference(motion.dq, dt, 4)[5:-5], motion.ddq[5:-5], atol=1e-7)


def test_multisine_is_seeded(lwr4: RobotModel) -> None:
    first, again, other = (build("trajectory", "multisine", seed=s).sample(lwr4, 100.0) for s in (1, 1, 2))
    np.testing.assert_array_equal(first.q, again.q)
    assert not np.allclose(first.q, other.q)


def test_limit_violation_names_joint_quantity_and_time(lwr4: RobotModel) -> None:
    motion = build("trajectory", "multisine", seed=0).sample(lwr4, 100.0)
    tight = replace(lwr4, limits=replace(lwr4.limits, velocity=lwr4.limits.velocity * 0.5))
    with pytest.raises(LimitViolation, match=r"joint \d velocity .* rad/s at t = .* s outside"):
        check_limits(motion, tight, what="exciting motion")


def test_bad_parameters_are_refused() -> None:
    with pytest.raises(ValueError, match="limit_fraction"):
        build("trajectory", "multisine", limit_fraction=1.5)
    with pytest.raises(ValueError, match="harmonics"):
        build("trajectory", "multisine", harmonics=1)
