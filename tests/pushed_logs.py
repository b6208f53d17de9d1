"""The monitor tests' logs: the LWR4 in MuJoCo following multi-sines, pushed at known times.

Shared by the offline, streaming and live monitor tests (``test_monitor*.py``, ``test_live_monitor.py``):
the arm's model is its own truth, the sensors are quiet (σ_τ 0.05 N·m, σ_q 1e-6 rad), 1 kHz.
"""

from __future__ import annotations

from collections.abc import Sequence

from lwrlab.model.robot import RobotModel
from lwrlab.monitoring.estimates import MonitorSettings
from lwrlab.pipeline.build import build
from lwrlab.plants.core import Measurement
from lwrlab.plants.pushed_arm import ExternalForce, PushedArm, PushedRun

SETTINGS = MonitorSettings(
    observer_gain=100.0,
    velocity_cutoff_hz=30.0,
    coulomb_smoothing=0.01,
    false_alarm_rate=1.0,
    margin=1.3,
    min_duration=0.003,
    release=0.5,
    residual_margin=1.5,
    thresholds="state",
    friction_drift=0.5,
)
"""The monitor's settings as conf/task/monitor.yaml has them."""


def pushed_arm(robot: RobotModel) -> PushedArm:
    """``robot`` in MuJoCo under feedforward and PD, its own model, quiet sensors."""
    return PushedArm(
        robot,
        robot,
        kp=[2000, 2000, 1000, 1000, 300, 300, 100],
        kd=[100, 100, 50, 50, 15, 15, 5],
        substeps=1,
        torque_noise_std=0.05,
        encoder_noise_std=1e-6,
        seed=0,
    )


def pushed_run(
    robot: RobotModel, seed: int, forces: Sequence[ExternalForce], name: str, duration: float = 3.0
) -> PushedRun:
    """A multi-sine of ``duration`` s (motion seed ``seed``) under ``forces``."""
    motion = build("trajectory", "multisine", duration=duration, harmonics=4, seed=seed, limit_fraction=0.4)
    return pushed_arm(robot).run(motion.sample(robot, 1000.0), list(forces), name)


def pushed_log(
    robot: RobotModel, seed: int, forces: Sequence[ExternalForce], name: str, duration: float = 3.0
) -> Measurement:
    """:func:`pushed_run`'s measurement."""
    return pushed_run(robot, seed, forces, name, duration).measurement
