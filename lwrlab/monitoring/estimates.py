"""A log's external torques by both estimators, their calibration and detections: the monitor's steps.

The stage ``task=monitor`` (:mod:`lwrlab.pipeline.monitor`) and the benchmark both run these on
measurements: :func:`estimate_external_torques` (observer and direct residual, and which samples are
past the estimators' start-up and the filter's edges), :func:`calibrate` (thresholds per estimator
from contact-free estimates) and :func:`detect` (contacts per estimator).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from lwrlab.model.robot import RobotModel
from lwrlab.monitoring.calibration import (
    Calibration,
    StateCalibration,
    calibrate_state_thresholds,
    calibrate_thresholds,
)
from lwrlab.monitoring.counts import (
    COUNT_WINDOW_S,
    count_gain,
    count_share,
    displacement,
    inertia_bound,
    position_step,
    window_samples,
)
from lwrlab.monitoring.detection import Detection, detect_contacts
from lwrlab.monitoring.direct_residual import joint_motion, model_torque, smooth, uniform_period
from lwrlab.monitoring.observer import MomentumObserver
from lwrlab.monitoring.observer_inputs import filtered_like_velocity, observer_inputs
from lwrlab.monitoring.signal_agreement import (
    SignalDisagreementWarning,
    describe_disagreement,
    disagreeing_samples,
)
from lwrlab.monitoring.spread import (
    first_order_lowpass,
    friction_band,
    regularised,
    resting,
    stamp_deviation,
)
from lwrlab.plants.core import Measurement

ESTIMATORS = ("observer", "residual")
"""The two estimates of the external torque: the momentum observer and the direct residual."""
SETTLING_TIME_CONSTANTS = 5.0
"""The observer's first 5/K seconds are its start-up (r starts at 0): not monitored."""
FILTER_EDGE_PERIODS = 2.0
"""The zero-phase filter's first and last 2/f_c seconds are edge transients: not monitored."""
THRESHOLD_KINDS = ("state", "constant")
"""State-dependent thresholds (the friction band, the stamps) or one constant per joint."""
REST_THRESHOLDS = ("model", "moving")
"""Where state thresholds stand still: from the model at rest, or as a moving arm's."""


@dataclass(frozen=True)
class MonitorSettings:
    """How the external torques are estimated and contacts detected (``task=monitor``'s settings)."""

    observer_gain: float
    """K (1/s) of the momentum observer."""
    velocity_cutoff_hz: float
    """Low-pass of the velocity (Hz): causal for the observer (what a robot's loop has; its q and τ
    through the same filter, :mod:`~lwrlab.monitoring.observer_inputs`), zero-phase on q and τ for the
    direct residual."""
    coulomb_smoothing: float
    """ε (rad/s) of ``FC·tanh(q̇/ε)``."""
    false_alarm_rate: float
    """Stated false alarms per hour."""
    margin: float
    """Factor ≥ 1 on the observer's calibrated levels."""
    min_duration: float
    """Time above threshold before a contact is raised (s)."""
    release: float
    """Share of the threshold every joint must fall below to end a contact."""
    residual_margin: float
    """Factor ≥ 1 on the direct residual's levels (its offline filter and q̈ make it noisier off the
    calibration's motions than the observer)."""
    thresholds: str
    """``state`` (thresholds follow the friction band and the stamps,
    :func:`~lwrlab.monitoring.calibration.calibrate_state_thresholds`) or ``constant`` (one per joint)."""
    friction_drift: float
    """Share of its friction by which a run may differ from the calibration's (``state`` only)."""
    rest_thresholds: str = "model"
    """``state`` only, where the arm stands still: ``model`` (the model at rest: the residual's noise
    within the calibration's rests, the friction band, the gravity model's error;
    :func:`~lwrlab.monitoring.rest_residual.rest_terms`) or ``moving`` (the formula of a moving arm at
    the band at rest)."""

    def __post_init__(self) -> None:
        if self.thresholds not in THRESHOLD_KINDS:
            raise ValueError(f"thresholds must be one of {list(THRESHOLD_KINDS)}, got {self.thresholds!r}")
        if self.rest_thresholds not in REST_THRESHOLDS:
            raise ValueError(
                f"rest_thresholds must be one of {list(REST_THRESHOLDS)}, got {self.rest_thresholds!r}"
            )

    def margin_of(self, estimator: str) -> float:
        """The margin of ``estimator`` (one of :data:`ESTIMATORS`)."""
        return self.residual_margin if estimator == "residual" else self.margin

    @property
    def start_skip(self) -> float:
        """Seconds not monitored at a log's start (observer start-up, filter edge)."""
        return SETTLING_TIME_CONSTANTS / self.observer_gain + FILTER_EDGE_PERIODS / self.velocity_cutoff_hz

    @property
    def end_skip(self) -> float:
        """Seconds not monitored at a log's end (filter edge)."""
        return FILTER_EDGE_PERIODS / self.velocity_cutoff_hz


@dataclass(frozen=True)
class ExternalTorques:
    """One log's external torque estimates (N·m) at its samples."""

    name: str
    """The log's name."""
    t: np.ndarray
    """(N,) stamps (s)."""
    q: np.ndarray
    """(N, N_J) positions (rad): where the force mapping's Jacobians are taken."""
    observer: np.ndarray
    """(N, N_J) momentum observer."""
    residual: np.ndarray
    """(N, N_J) direct residual τ − τ̂(q, q̇, q̈), τ low-passed alike."""
    monitored: np.ndarray
    """(N,) False during the start-up and the filter's edges."""
    seconds: float
    """Wall time of the observer over the log (s)."""
    friction: dict[str, np.ndarray]
    """Per estimator, (N, N_J) the model's friction band through its filter (N·m)."""
    stamps: dict[str, np.ndarray]
    """Per estimator, (N, N_J) the stamps' share of the estimate (N·m; zero for regular stamps)."""
    rest_friction: np.ndarray
    """(N_J,) the friction band at rest (N·m)."""
    disagreeing: np.ndarray
    """(N,) True where the logged velocities contradict the positions
    (:mod:`lwrlab.monitoring.signal_agreement`; all False for a log without velocities)."""
    resting: np.ndarray | None = None
    """(N,) True where the arm stands still (:func:`~lwrlab.monitoring.spread.resting`: every joint
    slower than the observer's Coulomb width for its settling time), or None: not known."""
    started: np.ndarray | None = None
    """(N,) True once the observer's start-up is over: where its contacts are detected (a causal
    estimate has no edge at a log's end, unlike the direct residual's zero-phase filter; the live
    monitor, :mod:`lwrlab.monitoring.stream`, sees the same samples); None: ``monitored``."""
    displacement: np.ndarray | None = None
    """(N, N_J) how far each joint's raw position moved over the last ``COUNT_WINDOW_S`` seconds (rad,
    :func:`~lwrlab.monitoring.counts.displacement`), or None: not known."""
    inertia: np.ndarray | None = None
    """(N_J, N_J) the largest |M_jk| over the log's postures, rotor inertia included (kg·m²), or None."""

    def watched(self, estimator: str) -> np.ndarray:
        """(N,) the samples whose contacts ``estimator`` detects."""
        if estimator == "observer" and self.started is not None:
            return self.started
        return self.monitored

    def estimate(self, estimator: str) -> np.ndarray:
        """The estimate named ``observer`` or ``residual``."""
        if estimator not in ESTIMATORS:
            raise ValueError(f"unknown estimator {estimator!r}; valid: {list(ESTIMATORS)}")
        return self.observer if estimator == "observer" else self.residual

    def state_terms(self, estimator: str) -> tuple[np.ndarray, np.ndarray]:
        """The friction band and the stamps' share (N, N_J) of ``observer`` or ``residual``."""
        self.estimate(estimator)  # checks the name
        return self.friction[estimator], self.stamps[estimator]

    @property
    def period(self) -> float:
        """Sampling period (s)."""
        return float((self.t[-1] - self.t[0]) / (len(self.t) - 1))

    @property
    def monitored_hours(self) -> float:
        """Monitored time (h)."""
        return float(np.count_nonzero(self.monitored) * self.period / 3600.0)


def _estimates(
    robot: RobotModel,
    measurement: Measurement,
    settings: MonitorSettings,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[np.ndarray, np.ndarray, float, np.ndarray, np.ndarray]:
    """Observer, direct residual, the observer's wall time, the causal and the zero-phase velocity."""
    import time

    t = measurement.t
    period = uniform_period(t)
    motion = joint_motion(t, measurement.q, settings.velocity_cutoff_hz)
    observer = MomentumObserver(robot, settings.observer_gain, settings.coulomb_smoothing)
    start = time.perf_counter()
    inputs = observer_inputs(t, measurement.q, measurement.tau, settings.velocity_cutoff_hz)
    estimate, _ = observer.observe(t, inputs.q, inputs.dq, inputs.tau, progress=progress)
    seconds = time.perf_counter() - start
    friction = observer.friction_torque(motion.dq)
    predicted = model_torque(robot.model, motion.q, motion.dq, motion.ddq, friction)
    residual = smooth(measurement.tau, period, settings.velocity_cutoff_hz) - predicted
    return estimate, residual, seconds, inputs.dq, motion.dq


def estimate_external_torques(
    robot: RobotModel,
    measurement: Measurement,
    settings: MonitorSettings,
    progress: Callable[[int, int], None] | None = None,
) -> ExternalTorques:
    """Both estimates of a measurement's external torques with the model ``robot``, and their state
    terms (:mod:`lwrlab.monitoring.spread`): the friction band through each estimator's filter, and
    for a log resampled from irregular stamps, how far each estimate moves when read as regular."""
    t = measurement.t
    observer, residual, seconds, velocity, dq = _estimates(robot, measurement, settings, progress)
    q = measurement.q
    friction = {
        "observer": first_order_lowpass(t, friction_band(robot, velocity, q), settings.observer_gain),
        "residual": smooth(friction_band(robot, dq, q), uniform_period(t), settings.velocity_cutoff_hz),
    }
    stamps = {estimator: np.zeros_like(observer) for estimator in ESTIMATORS}
    deviation = stamp_deviation(measurement)
    if deviation is not None and np.any(deviation != 0):
        regular = _estimates(robot, regularised(measurement, deviation), settings)
        stamps = {"observer": np.abs(observer - regular[0]), "residual": np.abs(residual - regular[1])}
    elapsed = t - t[0]
    monitored = (elapsed >= settings.start_skip) & (elapsed <= elapsed[-1] - settings.end_skip)
    rest = friction_band(robot, np.zeros((1, robot.n_joints)))[0]
    settle = SETTLING_TIME_CONSTANTS / settings.observer_gain
    rotor = MomentumObserver(robot, settings.observer_gain, settings.coulomb_smoothing).rotor_inertia
    inertia = inertia_bound(robot.model, q, rotor)
    disagreeing = np.zeros(len(t), dtype=bool)
    if measurement.dq is not None:
        disagreeing = disagreeing_samples(t, measurement.dq, dq)
        if disagreeing.any():
            warnings.warn(
                describe_disagreement(measurement.name, t, disagreeing),
                SignalDisagreementWarning,
                stacklevel=2,
            )
    return ExternalTorques(
        measurement.name,
        t,
        measurement.q,
        observer,
        residual,
        monitored,
        seconds,
        friction,
        stamps,
        rest,
        disagreeing,
        resting(t, velocity, settings.coulomb_smoothing, settle),
        elapsed >= settings.start_skip,
        displacement(q, window_samples(COUNT_WINDOW_S, float(np.mean(np.diff(t))))),
        inertia,
    )


def calibrate(
    contact_free: Sequence[ExternalTorques], settings: MonitorSettings
) -> dict[str, Calibration | StateCalibration]:
    """Thresholds of each estimator from contact-free logs' monitored samples (``settings.thresholds``)."""
    if not contact_free:
        raise ValueError("no contact-free log to calibrate on")
    calibrations: dict[str, Calibration | StateCalibration] = {}
    for estimator in ESTIMATORS:
        residuals = [e.estimate(estimator)[e.monitored] for e in contact_free]
        periods = [e.period for e in contact_free]
        margin = settings.margin_of(estimator)
        if settings.thresholds == "constant":
            calibrations[estimator] = calibrate_thresholds(
                residuals, periods, settings.false_alarm_rate, margin, contact_free[0].rest_friction
            )
            continue
        calibrations[estimator] = calibrate_state_thresholds(
            residuals,
            [e.friction[estimator][e.monitored] for e in contact_free],
            [e.stamps[estimator][e.monitored] for e in contact_free],
            periods,
            settings.false_alarm_rate,
            margin,
            settings.friction_drift,
            contact_free[0].rest_friction,
            _rests(contact_free) if settings.rest_thresholds == "model" else None,
            *(_count_share(contact_free, settings) if estimator == "observer" else (None, None)),
        )
    return calibrations


def _count_share(
    contact_free: Sequence[ExternalTorques], settings: MonitorSettings
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(N_J, N_J) what an encoder count of each joint does to the observer's estimate and (N_J,) the
    encoders' step, from the calibration logs' positions and postures
    (:mod:`lwrlab.monitoring.counts`); None where a log does not carry its postures' inertia."""
    inertias = [e.inertia for e in contact_free]
    if any(x is None for x in inertias):
        return None, None
    inertia = np.max(np.stack([np.asarray(x) for x in inertias]), axis=0)
    step = position_step([e.q for e in contact_free])
    period = float(np.mean([e.period for e in contact_free]))
    gain = count_gain(period, settings.velocity_cutoff_hz, settings.observer_gain)
    return count_share(inertia, step, gain), step


def _rests(contact_free: Sequence[ExternalTorques]) -> list[np.ndarray] | None:
    """Where each log's monitored samples stand still, or None where a log does not say."""
    rests = [e.resting for e in contact_free]
    if any(r is None for r in rests):
        return None
    return [np.asarray(r)[e.monitored] for r, e in zip(rests, contact_free, strict=True)]


def thresholds_of(
    estimates: ExternalTorques, calibrations: dict[str, Calibration | StateCalibration], estimator: str
) -> np.ndarray:
    """(N, N_J) ``estimator``'s thresholds at every sample of a log (N·m)."""
    moved = estimates.displacement if estimator == "observer" else None
    return calibrations[estimator].thresholds_at(*estimates.state_terms(estimator), estimates.resting, moved)


def detect(
    estimates: ExternalTorques,
    calibrations: dict[str, Calibration | StateCalibration],
    settings: MonitorSettings,
) -> dict[str, list[Detection]]:
    """Each estimator's contacts in a log, on its monitored samples; those overlapping a stretch whose
    logged velocities contradict its positions are labelled ``signals_disagree``."""
    found = {}
    for estimator in ESTIMATORS:
        estimate = np.where(estimates.watched(estimator)[:, None], estimates.estimate(estimator), 0.0)
        thresholds = thresholds_of(estimates, calibrations, estimator)
        detections = detect_contacts(
            estimates.t,
            estimate,
            thresholds,
            min_duration=settings.min_duration,
            release=calibrations[estimator].release_shares(
                thresholds, estimates.friction[estimator], estimates.resting, settings.release
            ),
        )
        found[estimator] = [
            replace(d, signals_disagree=True)
            if estimates.disagreeing[d.start_index : d.end_index].any()
            else d
            for d in detections
        ]
    return found


def held_out_false_alarm_rate(
    contact_free: Sequence[ExternalTorques], settings: MonitorSettings, estimator: str = "observer"
) -> float:
    """Alarms per hour on each contact-free log with thresholds calibrated on the others (NaN for one log)."""
    if len(contact_free) < 2:
        return float("nan")
    alarms, hours = 0, 0.0
    for i, held_out in enumerate(contact_free):
        others = [e for j, e in enumerate(contact_free) if j != i]
        alarms += len(detect(held_out, calibrate(others, settings), settings)[estimator])
        hours += held_out.monitored_hours
    return alarms / hours if hours > 0 else float("nan")


def truth_as_estimated(
    truth: np.ndarray, estimates: ExternalTorques, settings: MonitorSettings
) -> dict[str, np.ndarray]:
    """The true external torque (N, N_J) as each estimator would see it with an exact model and
    noiseless sensors: through the observer's input filter (its torques',
    :mod:`~lwrlab.monitoring.observer_inputs`) and first-order dynamics, through the residual's filter.

    An estimator's error against this is its model and noise error; against the raw truth it also
    holds its lag (the input filter's delay and the observer's 1/K), which the detection delay
    measures on its own.
    """
    torque = filtered_like_velocity(estimates.t, truth, settings.velocity_cutoff_hz)
    observed = first_order_lowpass(estimates.t, torque, settings.observer_gain, initial=0.0)
    filtered = smooth(truth, estimates.period, settings.velocity_cutoff_hz)
    return {"observer": observed, "residual": filtered}
