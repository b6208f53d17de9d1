"""State-dependent collision thresholds (lwrlab/monitoring/spread.py, calibration.py; task.thresholds).

The friction band the thresholds follow, their growth with it and their floor at rest, the
calibration data raising no alarm, a crossed case (calibrated on a slow motion, a faster one
monitored, its friction drifted: the state thresholds stay quiet where constant ones alarm), a push
on the arm standing still that the state thresholds see and motion-sized constant ones cannot, the
stamps' share of a log with jittered stamps, a stop the logged velocities deny (labelled, a push
not), and the real LWR4+ crossed from run 2 to run 3
(``../shared/data/kuka_lwr4_hw``, skipped without it).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from pushed_logs import SETTINGS

from lwrlab.model.robot import RobotModel
from lwrlab.monitoring.calibration import calibrate_state_thresholds
from lwrlab.monitoring.estimates import (
    calibrate,
    detect,
    estimate_external_torques,
    thresholds_of,
)
from lwrlab.monitoring.spread import first_order_lowpass, friction_band, regularised, stamp_deviation
from lwrlab.pipeline.build import build
from lwrlab.pipeline.monitor.scenario import PD_GAINS
from lwrlab.plants.core import Measurement
from lwrlab.plants.pushed_arm import ExternalForce, PushedArm
from lwrlab.signal.filters import central_difference
from lwrlab.trajectory.core import Trajectory

REAL_LWR4 = Path(__file__).resolve().parents[2] / "shared" / "data" / "kuka_lwr4_hw"
CONSTANT = replace(SETTINGS, thresholds="constant")


@pytest.fixture(scope="module")
def arm_robot(lwr4: RobotModel) -> RobotModel:
    """The LWR4 with the real LWR4+'s friction (about twice the CAD's): the model of every log here."""
    friction = replace(lwr4.friction, coulomb=2 * lwr4.friction.coulomb, viscous=2 * lwr4.friction.viscous)
    return replace(lwr4, friction=friction)


def _arm(robot: RobotModel, friction_factor: float, seed: int) -> PushedArm:
    """The robot in MuJoCo with its friction scaled by ``friction_factor`` (another day's friction)."""
    friction = robot.friction
    truth = replace(
        robot,
        friction=replace(
            friction, coulomb=friction_factor * friction.coulomb, viscous=friction_factor * friction.viscous
        ),
    )
    kp, kd = PD_GAINS
    return PushedArm(
        truth,
        robot,
        kp=kp,
        kd=kd,
        substeps=1,
        torque_noise_std=0.05,
        encoder_noise_std=1e-6,
        seed=seed,
    )


def _multisine(robot: RobotModel, harmonics: int, share: float, seed: int) -> Trajectory:
    return build(
        "trajectory", "multisine", duration=10.0, harmonics=harmonics, seed=seed, limit_fraction=share
    ).sample(robot, 1000.0)


def test_the_friction_band_is_the_coulomb_band_at_rest_and_follows_the_law(lwr4: RobotModel) -> None:
    dq = np.array([[0.0] * 7, [0.5] * 7, [-2.0] * 7])
    band = friction_band(lwr4, dq)
    friction = lwr4.friction
    np.testing.assert_allclose(band, friction.coulomb + friction.viscous * np.abs(dq), atol=1e-5)
    # offsets are no friction; a Stribeck excess widens the band at low speed only
    stribeck = lwr4.with_friction_law(build("friction", "stribeck", width=0.01, stribeck_speed=0.1))
    excess = np.full(7, 0.4)
    stribeck = replace(
        stribeck,
        friction_terms=(*stribeck.friction_terms, "offset"),
        friction=stribeck.friction.with_values({"stribeck": excess, "offset": np.full(7, 3.0)}),
    )
    widened = friction_band(stribeck, dq) - friction_band(lwr4, dq)
    # at rest: the breakaway level, as sliding begins (the smooth shapes at 95 % of their level)
    np.testing.assert_allclose(widened[0], excess, rtol=0.1)
    assert np.all(widened[2] < 1e-6)  # far above the Stribeck speed: Coulomb and viscous only
    # through the observer's filter a step reaches 1 − e^{−K·t}
    t = np.arange(101) * 1e-3
    step = np.where(t[:, None] > 0.0, 1.0, 0.0)
    filtered = first_order_lowpass(t, step, 100.0)
    assert filtered[11, 0] == pytest.approx(1 - np.exp(-100.0 * t[11]), rel=0.06)


def test_state_thresholds_grow_with_the_friction_and_fall_to_the_floor_at_rest() -> None:
    rng = np.random.default_rng(1)
    n = 40_000
    band = 0.5 + 2.0 * np.abs(np.sin(np.linspace(0, 40, n)))[:, None] * np.ones((1, 2))
    # joint 1's error follows its friction band, joint 2's does not
    residual = rng.normal(size=(n, 2)) * np.column_stack(
        [np.sqrt(0.02**2 + (0.3 * band[:, 0]) ** 2), 0.2 + 0 * band[:, 1]]
    )
    calibration = calibrate_state_thresholds(
        [residual], [band], [np.zeros_like(band)], [1e-3], 1.0, margin=1.3, rest_friction=np.array([0.5, 0.5])
    )
    assert calibration.friction_share[0] == pytest.approx(0.3, rel=0.1)
    grid = np.linspace(0.0, 3.0, 7)[:, None] * np.ones((1, 2))
    thresholds = calibration.thresholds_at(grid, np.zeros_like(grid))
    assert np.all(np.diff(thresholds[:, 0]) > 0)  # grows with the friction band
    assert thresholds[-1, 0] > 4 * thresholds[1, 0]
    # at rest: the floor, the noise's level and the band of friction held still
    np.testing.assert_allclose(calibration.at_rest, np.maximum(calibration.floor, calibration.at_rest))
    np.testing.assert_allclose(
        calibration.floor,
        1.3 * np.sqrt((calibration.level * calibration.noise) ** 2 + 0.5**2),
    )
    assert np.all(thresholds >= calibration.floor - 1e-12)
    # a joint whose error does not follow its friction: ρ about zero, thresholds about constant
    assert calibration.friction_share[1] < 0.05
    assert thresholds[-1, 1] < 1.2 * thresholds[1, 1]
    # the calibration data raise no alarm: every sample below its own threshold
    own = calibration.thresholds_at(band, np.zeros_like(band))
    assert np.all(np.abs(residual) < own)


def test_thresholds_from_the_model_at_rest_follow_the_rests_noise_not_the_motions_error() -> None:
    """With the calibration's rests given, a standing arm's threshold is the noise within its rests, the
    band as another run may hold it and the largest rest mean beyond the band; moving, nothing changes."""
    rng = np.random.default_rng(2)
    moving = rng.normal(scale=1.0, size=(20_000, 1))  # a large error while the arm moves
    held = np.concatenate(
        [0.3 + rng.normal(scale=0.02, size=(1000, 1)), -0.7 + rng.normal(scale=0.02, size=(1000, 1))]
    )
    residual = np.vstack([moving, held])
    band = np.full_like(residual, 0.5)
    still = np.r_[np.zeros(20_000, dtype=bool), np.ones(2000, dtype=bool)]
    still[21_000] = False  # two rests: held at +0.3, then at −0.7 (0.2 beyond the band)
    common = ([residual], [band], [np.zeros_like(band)], [1e-3], 1.0)
    without = calibrate_state_thresholds(
        *common, margin=1.3, friction_drift=0.5, rest_friction=np.array([0.5])
    )
    with_rests = calibrate_state_thresholds(
        *common, margin=1.3, friction_drift=0.5, rest_friction=np.array([0.5]), rests=[still]
    )
    assert without.rest_noise is None and with_rests.rest_noise[0] == pytest.approx(0.02, rel=0.1)
    assert with_rests.rest_error[0] == pytest.approx(0.2, abs=0.01)
    expected = 1.3 * np.sqrt(
        (with_rests.level * with_rests.rest_noise) ** 2 + (1.5 * 0.5 + with_rests.rest_error) ** 2
    )
    np.testing.assert_allclose(with_rests.at_rest, expected)
    assert with_rests.at_rest[0] < 0.5 * without.at_rest[0]  # not the moving arm's error
    np.testing.assert_allclose(  # moving: the same thresholds either way
        with_rests.thresholds_at(band[:5], np.zeros((5, 1)), np.zeros(5, dtype=bool)),
        without.thresholds_at(band[:5], np.zeros((5, 1)), np.zeros(5, dtype=bool)),
    )


def test_a_faster_motion_with_drifted_friction_raises_no_alarm_where_constant_thresholds_do(
    arm_robot: RobotModel,
) -> None:
    """Calibrated on a slow motion at one friction, a fast one monitored with 50 % more friction (the
    drift the state thresholds are stated to cover): no false alarm with state thresholds (10 s at a
    stated 1 per hour), where constant ones, sized by the slow motion, alarm."""
    slow = _arm(arm_robot, 1.0, 0).run(_multisine(arm_robot, 4, 0.3, 5), [], "slow").measurement
    fast = _arm(arm_robot, 1.5, 1).run(_multisine(arm_robot, 8, 0.9, 6), [], "fast").measurement
    calibration_log = estimate_external_torques(arm_robot, slow, SETTINGS)
    monitored = estimate_external_torques(arm_robot, fast, SETTINGS)
    state = calibrate([calibration_log], SETTINGS)
    constant = calibrate([calibration_log], CONSTANT)
    for calibrations, settings in ((state, SETTINGS), (constant, CONSTANT)):
        assert not any(detect(calibration_log, calibrations, settings).values())  # its own data: quiet
    assert detect(monitored, state, SETTINGS)["observer"] == []
    assert detect(monitored, state, SETTINGS)["residual"] == []
    assert len(detect(monitored, constant, CONSTANT)["observer"]) >= 1
    # where the motion is fast the thresholds of the joints of most friction rise well off the floor
    thresholds = thresholds_of(monitored, state, "observer")
    assert np.all(thresholds.max(axis=0)[:2] > 1.5 * state["observer"].floor[:2])


def test_a_push_at_rest_is_detected_with_thresholds_calibrated_on_moving_logs(arm_robot: RobotModel) -> None:
    """Thresholds from a fast motion with drifted friction; the arm then stands still and an 11 N
    push on link 3 loads joint 1 with less than its constant threshold but more than its state one."""
    moving = _arm(arm_robot, 1.3, 0).run(_multisine(arm_robot, 8, 0.9, 6), [], "moving").measurement
    posture = _multisine(arm_robot, 8, 0.9, 6).q[0] + 0.3
    n = 3001
    still = Trajectory(
        t=np.arange(n) * 1e-3, q=np.tile(posture, (n, 1)), dq=np.zeros((n, 7)), ddq=np.zeros((n, 7))
    )
    push = ExternalForce(
        start=1.5, duration=0.4, link=3, point=np.array([0.0, 0.05, 0.1]), force=np.array([0.0, 11.0, 0.0])
    )
    run = _arm(arm_robot, 1.0, 1).run(still, [push], "pushed at rest")
    reference = estimate_external_torques(arm_robot, moving, SETTINGS)
    monitored = estimate_external_torques(arm_robot, run.measurement, SETTINGS)
    state = calibrate([reference], SETTINGS)
    constant = calibrate([reference], CONSTANT)
    felt = np.abs(run.external_torque).max(axis=0)
    assert np.all(felt < constant["observer"].thresholds)  # motion-sized: no constant threshold sees it
    found = detect(monitored, state, SETTINGS)["observer"]
    assert len(found) == 1 and 1.5 <= found[0].raised <= 1.54  # the input filter's and observer's delays
    assert detect(monitored, constant, CONSTANT)["observer"] == []


def test_jittered_stamps_raise_their_own_share_of_the_threshold(arm_robot: RobotModel) -> None:
    """A log whose samples are regular but one stamp is 1.7 ms late: the reader's interpolation moves
    the positions there, and the stamps' share of the threshold covers the spike it makes."""
    motion = _multisine(arm_robot, 8, 0.9, 6)
    truth = _arm(arm_robot, 1.0, 0).run(motion, [], "regular").measurement
    late = int(np.argmax(np.abs(motion.dq[:, 0])))  # where the arm is fast
    logged_t = truth.t.copy()
    logged_t[late] += 0.6e-3
    interpolated = Measurement(
        t=truth.t,
        q=np.column_stack([np.interp(truth.t, logged_t, truth.q[:, j]) for j in range(7)]),
        tau=np.column_stack([np.interp(truth.t, logged_t, truth.tau[:, j]) for j in range(7)]),
        logged_t=logged_t,
        metadata={"name": "jittered"},
    )
    deviation = stamp_deviation(interpolated)
    # at the grid's sample the interpolation mixes the late sample's neighbours: 0.6 · (1 − 1/1.6) ms
    assert deviation is not None and deviation[late] == pytest.approx(0.375e-3, rel=0.01)
    assert stamp_deviation(truth) is None
    repaired = regularised(interpolated, deviation)
    assert np.abs(repaired.q - truth.q).max() < 0.1 * np.abs(interpolated.q - truth.q).max()
    regular = estimate_external_torques(arm_robot, truth, SETTINGS)
    jittered = estimate_external_torques(arm_robot, interpolated, SETTINGS)
    window = slice(late - 10, late + 40)
    spike = np.abs(jittered.observer - regular.observer)[window].max()
    assert spike > 0.5  # N·m: what the interpolation made of a late stamp
    assert jittered.stamps["observer"][window].max() > 0.8 * spike
    assert np.all(regular.stamps["observer"] == 0.0)
    state = calibrate([regular], SETTINGS)
    assert detect(jittered, state, SETTINGS)["observer"] == []
    assert detect(jittered, calibrate([regular], CONSTANT), CONSTANT)["observer"] != []


def test_a_stop_the_logged_velocities_deny_is_labelled_and_a_push_is_not(arm_robot: RobotModel) -> None:
    """A log whose last 0.3 s the recorder spoiled: the positions come to rest while the logged
    velocities and torques carry on. The observer sees a collision there (the arm stopped, no torque
    stopped it) and raises it, labelled ``signals_disagree`` with a warning; a real push earlier in
    the same log is not labelled."""
    from lwrlab.monitoring.signal_agreement import SignalDisagreementWarning

    motion = _multisine(arm_robot, 8, 0.9, 6)
    push = ExternalForce(
        start=4.0, duration=0.3, link=4, point=np.array([0.0, 0.05, 0.1]), force=np.array([0.0, 40.0, 0.0])
    )
    reference = _arm(arm_robot, 1.0, 0).run(motion, [], "reference").measurement
    logged = _arm(arm_robot, 1.0, 1).run(motion, [push], "spoiled").measurement
    velocity = central_difference(logged.q, 1e-3)  # what the recorder logs as q̇
    spoiled = len(logged.t) - 300
    q = logged.q.copy()
    speed = velocity[spoiled]
    elapsed = logged.t[spoiled:] - logged.t[spoiled]
    q[spoiled:] = q[spoiled] + speed * 0.05 * (1 - np.exp(-elapsed / 0.05))[:, None]  # braking in 0.15 s
    spoiled_log = replace(logged, q=q, dq=np.vstack([velocity[:spoiled], np.tile(speed, (300, 1))]))
    calibrations = calibrate([estimate_external_torques(arm_robot, reference, SETTINGS)], SETTINGS)
    with pytest.warns(SignalDisagreementWarning, match=r"spoiled: the logged velocities contradict"):
        estimates = estimate_external_torques(arm_robot, spoiled_log, SETTINGS)
    found = detect(estimates, calibrations, SETTINGS)["observer"]
    assert [round(d.start, 1) for d in found] == [4.0, round(logged.t[spoiled], 1)]
    assert [d.signals_disagree for d in found] == [False, True]
    assert not estimates.disagreeing[: spoiled - 100].any() and estimates.disagreeing[-1]


@pytest.mark.skipif(
    not (REAL_LWR4 / "measurements_1.npz").is_file(),
    reason=f"real KUKA LWR4+ logs not found at {REAL_LWR4} (in ../shared, beside a clone, not in it)",
)
def test_real_lwr4_run_3_monitored_with_run_2s_model_and_thresholds(tmp_path: Path) -> None:
    """Model and thresholds from run 2, the faster contact-free run 3 monitored. The log reader keeps
    run 3's samples on their regular grid (its stamps only jitter), so its late stamp at 11.5 s, which
    interpolation turned into a 10 N·m spike, raises nothing; what either kind of thresholds may
    raise is the final stop (after 24.7 s), where the positions stop while the logged velocities and
    torques do not (run 3's own model leaves it too)."""
    from lwrlab.io.logs import load_log
    from lwrlab.pipeline.monitor.scenario import identify_logs

    runs = {i: REAL_LWR4 / f"measurements_{i}.npz" for i in (2, 3)}
    overrides = [
        "robot=urdf",
        f"robot.path={REAL_LWR4 / 'kuka_lwr4.urdf'}",
        "data.column_map={t: times, q: positions, dq: velocities, tau: torques}",
    ]
    model = identify_logs(tmp_path / "identified_model.yaml", [runs[2]], [runs[3]], overrides)
    robot = build("robot", "identified", source=str(model))
    column_map = {"t": "times", "q": "positions", "dq": "velocities", "tau": "torques"}
    logs = {i: load_log(path, 7, column_map=column_map).to_measurement() for i, path in runs.items()}
    reference = estimate_external_torques(robot, logs[2], SETTINGS)
    monitored = estimate_external_torques(robot, logs[3], SETTINGS)
    starts = {}
    for settings in (SETTINGS, CONSTANT):
        found = detect(monitored, calibrate([reference], settings), settings)["observer"]
        starts[settings.thresholds] = [d.start - monitored.t[0] for d in found]
    assert logs[3].metadata["stamp_jitter"] is not None and not logs[3].metadata["resampled"]
    for kind in ("state", "constant"):
        assert len(starts[kind]) <= 1 and all(s > 24.7 for s in starts[kind]), (kind, starts[kind])
    # that stop is where the logged velocities contradict the positions, and nowhere before it
    elapsed = monitored.t - monitored.t[0]
    assert monitored.disagreeing[elapsed > 25.0].all() and not monitored.disagreeing[elapsed < 24.5].any()
    found = detect(monitored, calibrate([reference], SETTINGS), SETTINGS)["observer"]
    assert all(d.signals_disagree for d in found)
