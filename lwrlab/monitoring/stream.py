"""The monitor's streaming form: one sample in, the external torque, its thresholds and the contact
state out — what a live loop runs, and what the offline monitor computes over whole logs.

:class:`MonitorStream` holds everything one sample needs from the ones before it: the causal
filter's state (the velocity from backward differences, positions and torques at the same instants
through the same filter, :mod:`~lwrlab.monitoring.observer_inputs`), the momentum observer's state
(:func:`~lwrlab.monitoring.observer.observer_step`), the friction band through the observer's
filter (:mod:`~lwrlab.monitoring.spread`), whether the arm stands still, how far each joint moved
over the last half second (the encoder counts' share, :mod:`~lwrlab.monitoring.counts`), and the
contact detector (:class:`ContactDetector`). Each step makes a few small arrays and no I/O: a
source (a log read in blocks, a topic) feeds it and sinks (artifacts, topics, a bag) take its
output.

The offline monitor (:func:`~lwrlab.monitoring.estimates.estimate_external_torques`,
:func:`~lwrlab.monitoring.estimates.detect`) is the same computation vectorised over a log; a test
holds the two equal sample by sample (:func:`replay` runs a log through the stream). Two things the
offline monitor has that a stream cannot: the direct residual (a zero-phase filter needs the
future) and the stamps' share of the thresholds (it compares the log with itself resampled): a
stream runs on its samples' own stamps, which the observer takes at any spacing.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from scipy.signal import butter, sosfilt_zi

from lwrlab.model.robot import RobotModel
from lwrlab.monitoring.calibration import Calibration, StateCalibration
from lwrlab.monitoring.counts import COUNT_WINDOW_S, DisplacementTracker, window_samples
from lwrlab.monitoring.detection import Detection
from lwrlab.monitoring.observer import MomentumObserver, ObserverState, observer_step
from lwrlab.monitoring.observer_inputs import VELOCITY_FILTER_ORDER
from lwrlab.monitoring.spread import FrictionBand

RESTING_TOLERANCE_S = 1e-12
"""Rounding allowance on the settling time a standing arm must have stood (as the offline form)."""


class SampleEstimate(NamedTuple):
    """One sample's output (a tuple: cheap to make at 1 kHz)."""

    t: float
    """The sample's stamp (s)."""
    q: np.ndarray
    """(N_J,) its positions as read (rad): where the contact load is mapped."""
    external_torque: np.ndarray
    """(N_J,) the observer's estimate r (N·m); zero while not yet monitored."""
    thresholds: np.ndarray
    """(N_J,) the thresholds at this sample (N·m)."""
    monitored: bool
    """False during the start-up (the observer settling, the filter's edge)."""
    in_contact: bool
    """True from a contact's raising to its end (what a collision flag says)."""
    event: Detection | None
    """The contact raised (``end`` not yet known: NaN) or ended (whole) at this sample, else None."""


class CausalLowpass:
    """A Butterworth low-pass in second-order sections, stepped one sample of a (rows, N_J) block at
    a time: ``scipy.signal.sosfilt``'s direct form II transposed, started in its steady state."""

    def __init__(self, cutoff_hz: float, period: float, order: int = VELOCITY_FILTER_ORDER) -> None:
        self.sos = butter(order, cutoff_hz, fs=1.0 / period, output="sos")
        self._steady = sosfilt_zi(self.sos)  # (sections, 2)
        self.state = np.zeros(0)

    def start(self, x: np.ndarray) -> None:
        """The filter at rest at ``x`` (rows, N_J): its output is ``x`` until the input moves."""
        self.state = self._steady[:, :, None, None] * np.asarray(x, dtype=float)[None, None]

    def step(self, x: np.ndarray) -> np.ndarray:
        """The output (rows, N_J) for the input ``x``; the state moves on."""
        y = np.asarray(x, dtype=float)
        for section in range(self.sos.shape[0]):
            b0, b1, b2, _, a1, a2 = self.sos[section]
            z = self.state[section]
            out = b0 * y + z[0]
            z[0] = b1 * y - a1 * out + z[1]
            z[1] = b2 * y - a2 * out
            y = out
        return y


@dataclass
class ContactDetector:
    """:func:`~lwrlab.monitoring.detection.detect_contacts` one sample at a time.

    A contact starts at the first sample of a stretch where some joint's ratio ``|r|/threshold``
    exceeds 1, is raised once the stretch has lasted ``min_duration``, and ends at the first sample
    after its raising where every joint is below ``release``; its peak is the largest ratio from its
    start to its end (the first of equal ones), as the offline form finds them.
    """

    min_duration: float
    release: float
    detections: list[Detection] = field(default_factory=list)
    _start: tuple[int, float] | None = None
    _raised: tuple[int, float] | None = None
    _peak: tuple[float, int, int, float] = (-1.0, 0, 0, 0.0)  # ratio, sample, joint, torque

    @property
    def in_contact(self) -> bool:
        """A contact is raised and not yet ended."""
        return self._raised is not None

    def update(
        self,
        index: int,
        t: float,
        ratio: np.ndarray,
        torque: np.ndarray,
        release: np.ndarray | float | None = None,
    ) -> Detection | None:
        """Feed sample ``index`` (stamp ``t``, ratios and torques per joint, and the share of each
        threshold its joint must fall below to end a contact: None, :attr:`release`); the contact
        raised or ended at it, else None."""
        joint = int(np.argmax(ratio))
        highest = float(ratio[joint])
        if self._raised is not None:
            if np.all(ratio < (self.release if release is None else release)):
                return self._end(index, t)
            self._track(highest, index, joint, torque)
            return None
        if highest <= 1.0:
            self._start = None  # a stretch too short to raise
            return None
        if self._start is None:
            self._start = (index, t)
            self._peak = (-1.0, 0, 0, 0.0)
        self._track(highest, index, joint, torque)
        if t >= self._start[1] + self.min_duration - 1e-12:
            self._raised = (index, t)
            return self._detection(float("nan"), -1)
        return None

    def finish(self, index: int, t: float) -> Detection | None:
        """The contact still raised when the stream ends at sample ``index`` − 1 (stamp ``t``), ended
        there; None if none."""
        if self._raised is None:
            return None
        detection = self._detection(t, index)
        self.detections.append(detection)
        self._start, self._raised = None, None
        return detection

    def _track(self, highest: float, index: int, joint: int, torque: np.ndarray) -> None:
        if highest > self._peak[0]:
            self._peak = (highest, index, joint, float(torque[joint]))

    def _end(self, index: int, t: float) -> Detection:
        detection = self._detection(t, index)
        self.detections.append(detection)
        self._start, self._raised = None, None
        return detection

    def _detection(self, end: float, end_index: int) -> Detection:
        assert self._start is not None and self._raised is not None
        ratio, peak_index, joint, torque = self._peak
        return Detection(
            start=self._start[1],
            raised=self._raised[1],
            end=end,
            joint=joint + 1,
            peak_torque=torque,
            peak_ratio=ratio,
            peak_index=peak_index,
            start_index=self._start[0],
            end_index=end_index,
        )


class MonitorStream:
    """The monitor of one robot, a sample at a time (see the module).

    Parameters
    ----------
    robot : the model (identified or CAD).
    calibration : the observer's thresholds (:func:`~lwrlab.monitoring.estimates.calibrate`).
    observer_gain, velocity_cutoff_hz, coulomb_smoothing, min_duration, release, start_skip : as
        :class:`~lwrlab.monitoring.estimates.MonitorSettings` has them.
    period : the nominal sampling period (s) the causal filter is designed for.

    Examples
    --------
    >>> stream = MonitorStream.of(robot, settings, calibrations["observer"], 1e-3)  # doctest: +SKIP
    >>> for t, q, tau in samples:  # doctest: +SKIP
    ...     for estimate in stream.update(t, q, tau):
    ...         publish(estimate)
    """

    def __init__(
        self,
        robot: RobotModel,
        calibration: Calibration | StateCalibration,
        *,
        observer_gain: float,
        velocity_cutoff_hz: float,
        coulomb_smoothing: float,
        min_duration: float,
        release: float,
        start_skip: float,
        period: float,
    ) -> None:
        if not period > 0:
            raise ValueError(f"the sampling period must be positive, got {period}")
        self.robot = robot
        self.calibration = calibration
        self.period = float(period)
        self.start_skip = float(start_skip)
        self.observer = MomentumObserver(robot, observer_gain, coulomb_smoothing)
        self.filter = CausalLowpass(velocity_cutoff_hz, self.period)
        self.band = FrictionBand(robot)
        self.resting_speed = float(coulomb_smoothing)
        self.settle = 5.0 / float(observer_gain)
        self.detector = ContactDetector(min_duration, release)
        n = robot.n_joints
        self.displacement = DisplacementTracker(n, window_samples(COUNT_WINDOW_S, self.period))
        self._zero_stamps = np.zeros((1, n))
        self._negative_gain = -float(observer_gain)
        self._index = 0
        self._last_t = float("nan")
        self.reset()

    @classmethod
    def of(
        cls, robot: RobotModel, settings: object, calibration: Calibration | StateCalibration, period: float
    ) -> MonitorStream:
        """The stream with a :class:`~lwrlab.monitoring.estimates.MonitorSettings`' values."""
        from lwrlab.monitoring.estimates import MonitorSettings

        assert isinstance(settings, MonitorSettings)
        return cls(
            robot,
            calibration,
            observer_gain=settings.observer_gain,
            velocity_cutoff_hz=settings.velocity_cutoff_hz,
            coulomb_smoothing=settings.coulomb_smoothing,
            min_duration=settings.min_duration,
            release=settings.release,
            start_skip=settings.start_skip,
            period=period,
        )

    def reset(self) -> None:
        """Start anew: the next sample is a first one (after a stall the filter cannot bridge); a
        contact raised before is ended at the last sample."""
        self.detector.finish(self._index, self._last_t)
        self.displacement.reset()
        self._first: tuple[float, np.ndarray, np.ndarray] | None = None
        self._state: ObserverState | None = None
        self._t0 = float("nan")
        self._last_fast = float("nan")
        self._filtered_band = np.zeros(0)
        self._last_band = np.zeros(0)
        self._last = (np.zeros(0), np.zeros(0))

    @property
    def samples(self) -> int:
        """Samples taken since the stream was made (across restarts)."""
        return self._index

    def update(self, t: float, q: np.ndarray, tau: np.ndarray) -> tuple[SampleEstimate, ...]:
        """Take one sample (stamp ``t`` s, positions ``q`` rad, link-side torques ``tau`` N·m, after
        the last one's stamp); the estimates it completes: none for a first sample (its velocity
        needs the next), both for the second, one after."""
        q = np.asarray(q, dtype=float)
        tau = np.asarray(tau, dtype=float)
        if self._first is None:
            self._first = (float(t), q.copy(), tau.copy())
            return ()
        if self._state is None:
            return self._begin(float(t), q, tau)
        return (self._step(float(t), q, tau),)

    def finish(self) -> Detection | None:
        """The stream ends: a contact still raised ends at its last sample (None if none)."""
        return self.detector.finish(self._index, self._last_t)

    def _begin(self, t: float, q: np.ndarray, tau: np.ndarray) -> tuple[SampleEstimate, SampleEstimate]:
        assert self._first is not None
        t0, q0, tau0 = self._first
        if not t > t0:
            raise ValueError(f"stamps must increase: {t} after {t0}")
        velocity = (q - q0) / (t - t0)
        # the offline form copies the first backward difference back to the first sample
        self.filter.start(np.stack([velocity, q0, tau0]))
        first = self.filter.step(np.stack([velocity, q0, tau0]))
        self._t0, self._last_fast = t0, float("nan")
        self._state = self.observer.start(t0, first[1], first[0], first[2])
        self._filtered_band = self.band(first[0][None], q0[None])[0]
        self._last_band = self._filtered_band
        estimate = self._finish_sample(t0, q0, first[0], self._state.external_torque)
        self._last = (q, tau)
        filtered = self.filter.step(np.stack([velocity, 0.5 * (q0 + q), 0.5 * (tau0 + tau)]))
        return estimate, self._advance(t, q, filtered)

    def _step(self, t: float, q: np.ndarray, tau: np.ndarray) -> SampleEstimate:
        assert self._state is not None
        previous_q, previous_tau = self._last
        period = t - self._state.t
        if not period > 0:
            raise ValueError(f"stamps must increase: {t} after {self._state.t}")
        velocity = (q - previous_q) / period
        filtered = self.filter.step(np.stack([velocity, 0.5 * (previous_q + q), 0.5 * (previous_tau + tau)]))
        self._last = (q, tau)
        return self._advance(t, q, filtered)

    def _advance(self, t: float, q: np.ndarray, filtered: np.ndarray) -> SampleEstimate:
        assert self._state is not None
        velocity = filtered[0]
        r, self._state = observer_step(self.observer, self._state, t, filtered[1], velocity, filtered[2])
        # the band through the observer's filter: interval means, exact at the stamps
        band = self.band(velocity[None], q[None])[0]
        alpha = np.exp(self._negative_gain * (t - self._last_t))
        self._filtered_band = alpha * self._filtered_band + (1.0 - alpha) * 0.5 * (self._last_band + band)
        self._last_band = band
        return self._finish_sample(t, q, velocity, r)

    def _finish_sample(self, t: float, q: np.ndarray, velocity: np.ndarray, r: np.ndarray) -> SampleEstimate:
        slow = bool(np.all(np.abs(velocity) < self.resting_speed))
        if not slow:
            self._last_fast = t
        since = t - (self._t0 if np.isnan(self._last_fast) else self._last_fast)
        still = np.array([slow and since >= self.settle - RESTING_TOLERANCE_S])
        band = self._filtered_band[None]
        moved = self.displacement.update(q)[None]
        thresholds = self.calibration.thresholds_at(band, self._zero_stamps, still, moved)
        release = self.calibration.release_shares(thresholds, band, still, self.detector.release)
        thresholds = thresholds[0]
        monitored = t - self._t0 >= self.start_skip
        estimate = r if monitored else np.zeros_like(r)
        shares = release if isinstance(release, float) else release[0]
        event = self.detector.update(self._index, t, np.abs(estimate) / thresholds, estimate, shares)
        self._index, self._last_t = self._index + 1, t
        return SampleEstimate(t, q, estimate, thresholds, monitored, self.detector.in_contact, event)


@dataclass(frozen=True)
class StreamRecord:
    """A stream's outputs over a run, stacked (what :func:`replay` returns)."""

    t: np.ndarray
    """(N,) stamps (s)."""
    external_torque: np.ndarray
    """(N, N_J) observer estimates, zero where not monitored (N·m)."""
    thresholds: np.ndarray
    """(N, N_J) thresholds (N·m)."""
    monitored: np.ndarray
    """(N,) monitored samples."""
    in_contact: np.ndarray
    """(N,) contact raised and not ended."""
    detections: list[Detection]
    """Every contact, ended."""


def replay(
    stream: MonitorStream,
    t: np.ndarray,
    q: np.ndarray,
    tau: np.ndarray,
    sink: Callable[[SampleEstimate], None] | None = None,
) -> StreamRecord:
    """A log (stamps ``t`` (N,), ``q``, ``tau`` (N, N_J)) through ``stream`` sample by sample, ended
    at its last sample; each estimate also goes to ``sink``."""
    rows: list[SampleEstimate] = []
    for k in range(len(t)):
        for estimate in stream.update(float(t[k]), q[k], tau[k]):
            rows.append(estimate)
            if sink is not None:
                sink(estimate)
    stream.finish()
    return StreamRecord(
        np.array([e.t for e in rows]),
        np.array([e.external_torque for e in rows]),
        np.array([e.thresholds for e in rows]),
        np.array([e.monitored for e in rows]),
        np.array([e.in_contact for e in rows]),
        list(stream.detector.detections),
    )


__all__ = [
    "CausalLowpass",
    "ContactDetector",
    "MonitorStream",
    "SampleEstimate",
    "StreamRecord",
    "replay",
]
