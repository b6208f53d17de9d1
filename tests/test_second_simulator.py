"""The second simulator's log generator (benchmarks/second_simulator.py): truth, bookkeeping, sensors."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from lwrlab.model.inertia import is_physically_consistent

_PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "second_simulator.py"
_SPEC = importlib.util.spec_from_file_location("second_simulator", _PATH)
second_simulator = importlib.util.module_from_spec(_SPEC)
sys.modules["second_simulator"] = second_simulator  # dataclasses look their module up there
_SPEC.loader.exec_module(second_simulator)


@pytest.fixture(scope="module")
def short_run(lwr4):
    """A 4 s motion (rest, fade in, 1 s, fade out, rest) tracked in MuJoCo."""
    truth = second_simulator.true_robot(lwr4, np.random.default_rng(0))
    friction, sensors = second_simulator.FrictionTruth(), second_simulator.SensorModel()
    model = second_simulator.mujoco_model(truth, friction)
    spec = second_simulator.MotionSpec("short", 0.5, 2, 1.0, 1.5, 5)
    reference = second_simulator.reference_motion(spec, lwr4)
    run = second_simulator.simulate(model, lwr4, friction, sensors, reference, np.random.default_rng(1))
    return truth, model, reference, run


def test_truth_is_consistent_reproducible_and_not_the_cad(lwr4):
    truth = second_simulator.true_robot(lwr4, np.random.default_rng(3))
    again = second_simulator.true_robot(lwr4, np.random.default_rng(3))
    np.testing.assert_array_equal(truth.parameters, again.parameters)
    assert all(is_physically_consistent(phi) for phi in truth.link_parameters)
    masses = truth.link_parameters[:, 0] / lwr4.link_parameters[:, 0]
    assert np.all(np.abs(masses - 1.0) <= 0.25) and np.any(np.abs(masses - 1.0) > 0.02)


def test_reference_starts_and_ends_at_rest_inside_the_limits(lwr4):
    for spec in second_simulator.MOTIONS:
        t, q, dq, ddq = second_simulator.reference_motion(spec, lwr4)
        for k in (0, -1):
            np.testing.assert_allclose(dq[k], 0.0, atol=1e-12)
            np.testing.assert_allclose(ddq[k], 0.0, atol=1e-12)
        assert np.all(q > lwr4.limits.position_lower) and np.all(q < lwr4.limits.position_upper)
        assert np.isclose(np.abs(dq).max(), spec.peak_velocity)
        # the analytic derivatives are those of the positions
        np.testing.assert_allclose(np.gradient(q, t, axis=0)[1:-1], dq[1:-1], atol=1e-4)


def test_logged_torque_is_mujoco_and_pinocchio_inverse_dynamics_plus_friction(short_run):
    truth, model, reference, run = short_run
    assert second_simulator.mujoco_inverse_check(model, run) < 1e-9
    assert second_simulator.rigid_body_check(truth, model, run) < 1e-9
    assert np.abs(run["q"] - reference[1]).max() < 5e-3  # the PD tracks


def test_sensors_quantise_lag_and_add_offsets(short_run):
    _, _, _, run = short_run
    friction, sensors = second_simulator.FrictionTruth(), second_simulator.SensorModel()
    recorded = second_simulator.recorded_signals(run, friction, sensors, np.random.default_rng(2))
    steps = recorded["positions"] / sensors.encoder_resolution
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
    # the recorder's low-pass delays the velocity by about its time constant (10 samples at 1 kHz)
    delays = np.arange(30)
    mismatch = [
        np.linalg.norm(recorded["velocities"][d:] - run["dq"][: run["dq"].shape[0] - d]) for d in delays
    ]
    assert 7 <= delays[int(np.argmin(mismatch))] <= 13
    residual = recorded["torques"] - run["tau_link"]
    np.testing.assert_allclose(residual.mean(axis=0), friction.sensor_offset, atol=0.02)
    np.testing.assert_allclose(residual.std(axis=0), sensors.torque_noise_std, rtol=0.1)


def test_logs_are_decimated_and_jittered_but_increasing(short_run):
    _, _, _, run = short_run
    recorded = {"times": run["t"], "positions": run["q"], "velocities": run["dq"], "torques": run["tau_link"]}
    half = second_simulator.log_arrays(recorded, 2, 0.0, np.random.default_rng(0))
    assert half["times"].size == (run["t"].size + 1) // 2 and np.allclose(np.diff(half["times"]), 2e-3)
    jittered = second_simulator.log_arrays(recorded, 1, 2e-5, np.random.default_rng(0))
    periods = np.diff(jittered["times"])
    assert np.all(periods > 0) and periods.std() > 1e-5
    assert all(a.dtype == np.float64 and a.flags.c_contiguous for a in jittered.values())


@pytest.mark.slow
def test_written_logs_load_and_fit_lwrlab_model_to_under_one_percent(tmp_path, lwr4):
    from lwrlab.io.logs import load_log

    report = second_simulator.write_logs(tmp_path, seed=0)
    assert all(value < 1e-9 for value in report["checks"].values())
    assert report["least_squares"]["all samples, fit a_1+b, validate c"] < 0.01
    for stem in ("motion_a_1", "motion_a_2", "motion_b", "motion_c"):
        with np.load(tmp_path / f"{stem}.npz", allow_pickle=False) as arrays:
            assert set(arrays.files) == {"times", "positions", "velocities", "torques"}
        column_map = {"t": "times", "q": "positions", "dq": "velocities", "tau": "torques"}
        load_log(tmp_path / f"{stem}.npz", 7, column_map=column_map, limits=lwr4.limits)
    assert (tmp_path / "truth.yaml").is_file() and (tmp_path / "README.md").is_file()
