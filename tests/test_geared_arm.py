"""The geared-arm simulator (lwrlab/plants/geared_arm.py) and its arms (benchmarks/geared_arms.py):
motor-side logs that lwrlab reads back into the joint torques the physics gave."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from geared_logs import geared_arms, warped_multisine

from lwrlab.dynamics.base_parameters import compute_base_parameters
from lwrlab.dynamics.regressor import regressor
from lwrlab.io.logs import load_log
from lwrlab.model.friction_laws import SignCoulomb
from lwrlab.plants.geared_arm import GearedArm, MotorSensors
from lwrlab.plants.planned_motions import (
    PlannedMotion,
    PointToPoint,
    WarpedMotion,
)


def _short_motion(spec, seed: int = 0) -> WarpedMotion:
    """1.6 s: a rest, a ramp, a fast multisine, a ramp and a rest (801 samples at 500 Hz)."""
    return warped_multisine(spec, 0.9, [0.7, 1.5, 2.5], seed, rests=(0.1, 0.2), ramp_s=0.2)


@pytest.mark.parametrize("name", ["ur_like", "industrial"])
def test_motor_side_log_reads_back_as_rigid_body_rotor_and_friction(name, tmp_path) -> None:
    spec = geared_arms.ARMS[name]
    nominal, arm = geared_arms.geared_arm(spec)
    noiseless = replace(arm, sensors=MotorSensors.ideal(6))
    run = noiseless.play(_short_motion(spec), np.random.default_rng(1))
    assert np.any(run.at_rest) and np.any(~run.at_rest)
    drive = nominal.drive_train
    assert drive.position_side == drive.torque_side == "motor"
    path = tmp_path / "log.csv"
    run.log_frame().to_csv(path, index=False, float_format="%.17g")
    read = load_log(path, 6, limits=nominal.limits, drive=drive)
    np.testing.assert_allclose(read.q, run.q, rtol=0, atol=1e-12)
    friction = run.drive.joint_torques(run.friction_motor)  # Rᵀ·F
    expected = run.rigid_body + run.rotor + friction
    np.testing.assert_allclose(read.tau, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())
    np.testing.assert_allclose(
        run.rotor, (run.ddq @ drive.transmission.T * arm.motor_inertia) @ drive.transmission, rtol=1e-12
    )
    assert np.abs(friction).max() > 0.1  # the LuGre friction is in there
    held = run.at_rest & (run.t > 1.0)  # the final rest: the bristles keep their deflection
    assert held.sum() >= 100
    assert np.all(np.abs(run.friction_motor[held]) > 0.5 * arm.friction.coulomb)


def test_sensors_quantise_the_motor_angles_and_offset_the_currents() -> None:
    spec = geared_arms.ARMS["ur_like"]
    _, arm = geared_arms.geared_arm(spec)
    run = arm.play(_short_motion(spec), np.random.default_rng(2))
    count = 2 * np.pi / arm.sensors.encoder_counts
    np.testing.assert_allclose(np.round(run.measured_angles / count) * count, run.measured_angles, atol=1e-9)
    angle_error = run.measured_angles - run.q @ arm.drive.transmission.T
    assert np.abs(angle_error).max() < 3 * count
    current_error = run.measured_effort - run.motor_torque / arm.drive.torque_constants
    np.testing.assert_allclose(current_error.mean(axis=0), arm.sensors.effort_offset, atol=0.01)
    assert run.effort_column == "current"


def test_noiseless_frictionless_log_gives_the_rotor_inertias() -> None:
    """Sign law with rotor columns, least squares on the log's rows: IA3…IA6 to 1e-6 relative.

    IA1 and IA2 are no base parameters: the rotor of joint 1 turns as segment 1 does (IA1 regroups
    into ZZ1R) and, axis 2 being perpendicular to axis 1, so does rotor 2 with segment 2 (ZZ2R).
    """
    spec = geared_arms.ARMS["industrial"]  # the coupled wrist
    _, arm = geared_arms.geared_arm(spec)
    frictionless = GearedArm(arm.robot, arm.motor_inertia, None, MotorSensors.ideal(6))
    run = frictionless.play(_short_motion(spec, seed=3), np.random.default_rng(4))
    truth = replace(arm.robot, rotor_inertia=arm.reflected_inertia).with_friction_law(
        SignCoulomb(), rotor_inertia=True
    )
    base = compute_base_parameters(truth)
    rotor_names = [n for n in base.names if n.startswith("IA")]
    assert rotor_names == ["IA3", "IA4", "IA5", "IA6"]
    tau = run.drive.joint_torques(run.measured_motor_torque())
    w = base.base_regressor(regressor(truth, run.q, run.dq, run.ddq))
    estimate, *_ = np.linalg.lstsq(w, tau.ravel(), rcond=None)
    expected = base.base_values(truth.parameters)
    index = [base.index(n) for n in rotor_names]
    np.testing.assert_allclose(estimate[index], expected[index], rtol=1e-6)
    np.testing.assert_allclose(expected[index], arm.reflected_inertia[2:], rtol=1e-12)


@pytest.mark.parametrize("kind", ["warped", "point_to_point"])
def test_planned_motions_have_consistent_derivatives(kind) -> None:
    spec = geared_arms.ARMS["ur_like"]
    motion: PlannedMotion
    if kind == "warped":
        motion = _short_motion(spec)
    else:
        waypoints = spec.center + np.array([[0.0] * 6, [0.3] * 6, [-0.2] * 6])
        motion = PointToPoint(waypoints, np.array([0.6, 0.5]), np.array([0.2, 0.3, 0.2]))
    t = np.linspace(0.0, motion.duration, 3001)
    q, dq, ddq = motion.evaluate(t)
    step = t[1] - t[0]
    np.testing.assert_allclose(np.gradient(q, step, axis=0)[1:-1], dq[1:-1], atol=2e-4)
    np.testing.assert_allclose(np.gradient(dq, step, axis=0)[1:-1], ddq[1:-1], atol=2e-2)
    rest = motion.at_rest(t)
    assert rest[0] and np.all(dq[rest] == 0.0)
