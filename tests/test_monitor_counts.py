"""Thresholds where the encoders count and where the arm stands (lwrlab/monitoring/counts.py, calibration.py).

What one encoder count does to the observer's estimate (the bound the thresholds add, checked
against the observer itself), the displacement the live form tracks equal to the offline one, an
arm crawling a few counts per filter time on coarse encoders (no alarm with the counts' share, an
alarm without it), and a push at rest of three times the residual's noise there: detected with
thresholds from the calibration's rests (not with a moving arm's), and ended once the residual is
back within the friction the standing joint may hold after it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from pushed_logs import SETTINGS

from lwrlab.model.robot import RobotModel
from lwrlab.monitoring.calibration import calibrate_state_thresholds
from lwrlab.monitoring.counts import (
    DisplacementTracker,
    count_gain,
    count_share,
    counted,
    displacement,
    inertia_bound,
    position_step,
)
from lwrlab.monitoring.detection import detect_contacts
from lwrlab.monitoring.estimates import calibrate, detect, estimate_external_torques
from lwrlab.monitoring.observer import MomentumObserver
from lwrlab.monitoring.observer_inputs import observer_inputs
from lwrlab.plants.core import Measurement

STEP = 1e-4
"""rad: coarse joint encoders (0.1 mrad), as the zoo's xArm7 has."""


def _frictionless(robot: RobotModel) -> RobotModel:
    friction = replace(robot.friction, coulomb=0 * robot.friction.coulomb, viscous=0 * robot.friction.viscous)
    return replace(robot, friction=friction)


def _logged(robot: RobotModel, t: np.ndarray, q: np.ndarray, name: str, seed: int) -> Measurement:
    """What the arm logs moving along ``q`` (N, N_J): quantised positions, the paper's friction law
    (a sliding joint holds its full Coulomb level at any speed), torque noise 0.01 N·m."""
    model, data = robot.model, robot.model.createData()
    dq = np.gradient(q, t, axis=0)
    ddq = np.gradient(dq, t, axis=0)
    tau = np.array([pin.rnea(model, data, *state) for state in zip(q, dq, ddq, strict=True)])
    tau += robot.friction.coulomb * np.sign(dq) + robot.friction.viscous * dq
    tau += np.random.default_rng(seed).normal(scale=0.01, size=tau.shape)
    return Measurement(t=t, q=np.round(q / STEP) * STEP, tau=tau, metadata={"name": name})


def test_a_count_moves_the_observer_by_its_share_and_no_more(lwr4: RobotModel) -> None:
    """The arm standing, one joint's encoder steps by one count: the observer's estimate of that joint
    peaks at G·M_kk·δ (the momentum's change the velocity's pulse makes), every joint's within its
    share."""
    robot = _frictionless(lwr4)
    observer = MomentumObserver(robot, SETTINGS.observer_gain, SETTINGS.coulomb_smoothing)
    t = np.arange(400) * 1e-3
    posture = np.array([0.3, 0.8, -0.2, -1.2, 0.4, 0.6, 0.1])
    gravity = pin.computeGeneralizedGravity(robot.model, robot.model.createData(), posture)
    share = count_share(
        inertia_bound(robot.model, posture[None], observer.rotor_inertia),
        np.full(7, STEP),
        count_gain(1e-3, SETTINGS.velocity_cutoff_hz, SETTINGS.observer_gain),
    )
    for joint in (0, 3, 5):
        q = np.tile(posture, (len(t), 1))
        q[100:, joint] += STEP
        inputs = observer_inputs(t, q, np.tile(gravity, (len(t), 1)), SETTINGS.velocity_cutoff_hz)
        peak = np.abs(observer.observe(t, inputs.q, inputs.dq, inputs.tau)[0]).max(axis=0)
        assert peak[joint] == pytest.approx(share[joint, joint], rel=0.05)
        assert np.all(peak <= 1.05 * share[:, joint])


def test_the_displacement_one_sample_at_a_time_equals_the_offline_one_and_flicker_does_not_count() -> None:
    rng = np.random.default_rng(0)
    crawl = np.round(np.cumsum(rng.uniform(0, 2e-5, size=(3000, 2)), axis=0) / STEP) * STEP
    tracker = DisplacementTracker(2, 500)
    stepped = np.array([tracker.update(q).copy() for q in crawl])
    np.testing.assert_array_equal(stepped, displacement(crawl, 500))
    assert position_step([crawl]) == pytest.approx([STEP, STEP])
    # a reading flickering between two steps (noise at a step's edge) moves one step at most
    flicker = np.round((0.5 * STEP + rng.normal(scale=0.15 * STEP, size=(3000, 1))) / STEP) * STEP
    assert not counted(displacement(flicker, 500), position_step([flicker])).any()
    assert counted(displacement(crawl, 500), np.full(2, STEP))[-1].all()
    assert position_step([np.zeros((10, 1))])[0] == 0.0  # a joint that never moves has no step


def test_a_crawl_on_coarse_encoders_raises_no_alarm_with_the_counts_share(lwr4: RobotModel) -> None:
    """Calibrated on a motion at 0.15 rad/s (its counts merge: every sample is a step or two on), the arm
    then crawls at 4.5 mrad/s on 0.1 mrad encoders (a count every 22 ms), and each count's velocity
    pulse reaches the observer whole. No alarm with the counts' share in the thresholds; without it,
    the counts raise alarms."""
    t = np.arange(5000) * 1e-3
    posture = np.array([0.3, 0.5, -0.2, -1.0, 0.2, 0.4, 0.1])
    directions = np.array([1, -1, 1, 1, -1, 1, -1])
    calibration_log = _logged(lwr4, t, posture + np.outer(t, 0.15 * directions), "steady", 0)
    crawling = _logged(lwr4, t[:4000], posture + np.outer(t[:4000], 4.5e-3 * directions), "crawl", 1)
    calibrations = calibrate([estimate_external_torques(lwr4, calibration_log, SETTINGS)], SETTINGS)
    monitored = estimate_external_torques(lwr4, crawling, SETTINGS)
    assert calibrations["observer"].position_step == pytest.approx(np.full(7, STEP))
    assert detect(monitored, calibrations, SETTINGS)["observer"] == []
    without = {**calibrations, "observer": replace(calibrations["observer"], count_share=None)}
    assert detect(monitored, without, SETTINGS)["observer"] != []


def test_a_push_at_rest_of_three_times_the_noise_there_is_detected_and_ends_within_the_held_band() -> None:
    """Calibration logs that move (a large error) and stand (held at +0.3 and −0.4 within a band of
    0.5, noise 0.02). A standing arm holding +0.4 is pushed by three times the residual's RMS at rest;
    after the push its joint holds −0.6 (within the band as another run may hold it, 1.5 × 0.5).
    From the calibration's rests the push is detected and the contact ends with it; a moving arm's
    formula misses it, and a release at half the threshold never ends the contact."""
    rng = np.random.default_rng(4)
    moving = rng.normal(scale=1.0, size=(20_000, 1))
    rests = np.concatenate(
        [0.3 + 0.02 * rng.normal(size=(1000, 1)), -0.4 + 0.02 * rng.normal(size=(1000, 1))]
    )
    residual = np.vstack([moving, rests])
    band = np.full_like(residual, 0.5)
    still = np.r_[np.zeros(20_000, dtype=bool), np.ones(2000, dtype=bool)]
    still[21_000] = False  # two rests
    common = ([residual], [band], [np.zeros_like(band)], [1e-3], 1.0)
    options = {"margin": 1.3, "friction_drift": 0.5, "rest_friction": np.array([0.5])}
    from_rests = calibrate_state_thresholds(*common, **options, rests=[still])
    as_moving = calibrate_state_thresholds(*common, **options)

    t = np.arange(4000) * 1e-3
    held = np.where(t < 1.8, 0.4, -0.6)[:, None] + 0.02 * rng.normal(size=(len(t), 1))
    noise = float(np.sqrt(np.mean(held**2)))
    pushed = held + np.where((t >= 1.5) & (t < 1.8), 3.0 * noise, 0.0)[:, None]
    standing = np.ones(len(t), dtype=bool)
    phi = np.full((len(t), 1), 0.5)
    zeros = np.zeros_like(phi)

    thresholds = from_rests.thresholds_at(phi, zeros, standing)
    release = from_rests.release_shares(thresholds, phi, standing, 0.5)
    found = detect_contacts(t, pushed, thresholds, min_duration=0.003, release=release)
    assert len(found) == 1 and found[0].start == pytest.approx(1.5) and found[0].end == pytest.approx(1.8)
    assert not detect_contacts(t, pushed, as_moving.thresholds_at(phi, zeros, standing), min_duration=0.003)
    stuck = detect_contacts(t, pushed, thresholds, min_duration=0.003, release=0.5)
    assert len(stuck) == 1 and stuck[0].end == t[-1]  # the held −0.6 stays above half the threshold
