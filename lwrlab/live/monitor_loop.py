"""The live monitor's sample path: a JointState in, estimates out on topics, nothing slow between.

:class:`LiveMonitorLoop` takes each message as the subscription hands it over
(:meth:`~LiveMonitorLoop.on_joint_state`, on the subscription's thread): it reads the robot's joints
(:class:`~lwrlab.live.joint_states.JointStateReader`), checks the stream (a stamp going back, a
stall, a publisher restarting), steps the core's streaming monitor
(:class:`~lwrlab.monitoring.stream.MonitorStream`) and publishes, for every sample: the external
joint torques (``sensor_msgs/JointState``, effort), the contact wrench at the frame
(``geometry_msgs/WrenchStamped``), the collision state (``std_msgs/Bool``); and, at a few hertz and on
every contact raised or ended, a ``diagnostic_msgs/DiagnosticArray``. The bag and the run's
artifacts are written behind it (a queue, and the end of the run); the samples' estimates are kept
in blocks of arrays for them.

The stream's problems never stop the loop and never reach the estimate silently: each is counted,
said once in the run's log and on ``/diagnostics``, and the samples it spoils are left out:

- a message of another robot (none of the joints): skipped, counted;
- joints missing, arrays of the wrong length, a non-finite value: refused, counted;
- a stamp at or before the last one: dropped (out of order); more than ``restart_back_s`` before
  it: the publisher restarted, the observer starts anew;
- a gap in the stamps: the samples it lacks are counted dropped; beyond ``max_gap_s`` the observer
  (its filter, its momentum) cannot bridge it and starts anew (a new start-up, not monitored).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from lwrlab.live.dds import Publisher, Received
from lwrlab.live.joint_states import JointSample, JointStateReader, Refusal
from lwrlab.live.messages import (
    DIAGNOSTIC_LEVELS,
    DiagnosticArray,
    DiagnosticStatus,
    Header,
    JointState,
    KeyValue,
    Time,
    WrenchStamped,
)
from lwrlab.live.wire import BOOL_BYTES, StampedEncoder
from lwrlab.monitoring.contact_force import FrameLoad
from lwrlab.monitoring.detection import Detection
from lwrlab.monitoring.stream import MonitorStream, SampleEstimate

log = logging.getLogger(__name__)

RATE_SAMPLES = 20
"""Samples whose stamps give the stream's period when no rate is set (the observer's start-up)."""
BLOCK_ROWS = 65_536
"""Rows of each block of kept estimates."""
LATENCY_WINDOW = 1000
"""Latest samples whose latency ``/diagnostics`` states."""


class EstimateLog:
    """The run's estimates, one row a sample, kept in blocks of arrays (no object per sample)."""

    def __init__(self, n_joints: int) -> None:
        self.n = n_joints
        self._blocks: list[np.ndarray] = []
        self._rows = 0
        # t, latency (s), monitored, in_contact, then q, r, thresholds, wrench (6)
        self.width = 4 + 3 * n_joints + 6

    def append(self, estimate: SampleEstimate, t: float, latency: float, wrench: np.ndarray) -> None:
        """Keep one sample's row (``t`` its absolute stamp, s)."""
        if self._rows % BLOCK_ROWS == 0:
            self._blocks.append(np.empty((BLOCK_ROWS, self.width)))
        row = self._blocks[-1][self._rows % BLOCK_ROWS]
        n = self.n
        row[0], row[1], row[2], row[3] = t, latency, estimate.monitored, estimate.in_contact
        row[4 : 4 + n] = estimate.q
        row[4 + n : 4 + 2 * n] = estimate.external_torque
        row[4 + 2 * n : 4 + 3 * n] = estimate.thresholds
        row[4 + 3 * n : 4 + 3 * n + wrench.size] = wrench
        row[4 + 3 * n + wrench.size :] = np.nan  # a pure force has no moment
        self._rows += 1

    def __len__(self) -> int:
        return self._rows

    def table(self) -> dict[str, np.ndarray]:
        """The rows as arrays: ``t``, ``latency``, ``monitored``, ``in_contact`` (N,); ``q``,
        ``external_torque``, ``thresholds`` (N, N_J); ``wrench`` (N, 6)."""
        rows = np.empty((0, self.width)) if not self._rows else np.vstack(self._blocks)[: self._rows]
        n = self.n
        return {
            "t": rows[:, 0],
            "latency": rows[:, 1],
            "monitored": rows[:, 2].astype(bool),
            "in_contact": rows[:, 3].astype(bool),
            "q": rows[:, 4 : 4 + n],
            "external_torque": rows[:, 4 + n : 4 + 2 * n],
            "thresholds": rows[:, 4 + 2 * n : 4 + 3 * n],
            "wrench": rows[:, 4 + 3 * n :],
        }


@dataclass
class StreamCounts:
    """What happened to the stream's messages."""

    messages: int = 0
    """JointState messages received."""
    samples: int = 0
    """Samples the monitor took."""
    dropped: int = 0
    """Samples the stamps say are missing (gaps), plus out-of-order ones dropped."""
    refused: int = 0
    """Messages refused (joints missing, arrays, non-finite values)."""
    other_robot: int = 0
    """Messages naming none of the robot's joints."""
    out_of_order: int = 0
    """Messages stamped at or before the last one."""
    restarts: int = 0
    """Times the observer started anew (a stall it cannot bridge, a publisher restarting)."""
    compute_s: float = 0.0
    """Time spent on the sample path (s)."""
    notes: list[str] = field(default_factory=list)
    """What was said about the stream, once per kind."""


class LiveMonitorLoop:
    """The sample path of ``task=live_monitor`` (see the module).

    Parameters
    ----------
    stream_of : makes the streaming monitor for a sampling period (s).
    reader : the joints out of a message.
    frame_load : the contact wrench (or force) at the frame.
    frame : the frame's name (the wrench's ``frame_id``).
    output_names : the joint names of the published external torques.
    publish : one publishing function per output: ``external_torque``, ``contact_wrench``,
        ``collision``, ``diagnostics``.
    record : ``record(topic, time_ns, message)`` queues a message for the bag; None: no bag.
    topics : ROS 2 topic of each stream (for the bag).
    rate_hz : the stream's rate; None: measured on its first :data:`RATE_SAMPLES` samples.
    max_gap_s : a gap in the stamps beyond which the observer starts anew (s).
    diagnostics_hz : rate of ``/diagnostics``.
    restart_back_s : a stamp this far (s) before the last one means the publisher restarted.
    """

    def __init__(
        self,
        stream_of: Callable[[float], MonitorStream],
        reader: JointStateReader,
        frame_load: FrameLoad,
        frame: str,
        output_names: list[str],
        publish: dict[str, Publisher],
        record: Callable[[str, int, Any], None] | None,
        topics: dict[str, str],
        *,
        rate_hz: float | None,
        max_gap_s: float,
        diagnostics_hz: float,
        restart_back_s: float = 1.0,
    ) -> None:
        self._stream_of = stream_of
        self.reader = reader
        self.frame_load = frame_load
        self.frame = frame
        self.names = list(output_names)
        self.publish = publish
        self.record = record
        self.topics = topics
        n = len(self.names)
        self._torque = StampedEncoder(JointState(Header(Time(), ""), self.names, [], [], [0.0] * n), n)
        self._wrench = StampedEncoder(WrenchStamped(Header(Time(), frame)), 6)
        self._load = np.zeros(6)
        self.period = None if rate_hz is None else 1.0 / float(rate_hz)
        self.stream: MonitorStream | None = None if self.period is None else stream_of(self.period)
        self.max_gap_s = float(max_gap_s)
        self.restart_back_s = float(restart_back_s)
        self.diagnostics_period_ns = int(1e9 / diagnostics_hz) if diagnostics_hz > 0 else 0
        self.counts = StreamCounts()
        self.estimates = EstimateLog(len(self.names))
        self.lock = threading.Lock()
        self.last_message_s = float("nan")
        """Monotonic time of the last message (s), NaN before the first."""
        self.base_ns: int | None = None
        self._pending: list[tuple[JointSample, Received]] = []
        self._last_t = float("nan")
        self._said: set[str] = set()
        self._next_diagnostics = 0
        self._latencies = np.full(LATENCY_WINDOW, np.nan)
        self._last_event: Detection | None = None
        self._zero_stamp = False
        self._unstamped = False
        self._last_sample: JointSample | None = None

    # --- the sample path ------------------------------------------------------------------------

    def on_joint_state(self, received: Received) -> None:
        """Take one message (on the subscription's thread)."""
        started = time.perf_counter()
        with self.lock:
            self.last_message_s = time.monotonic()
            self.counts.messages += 1
            message = received.message
            if self.record is not None:
                self.record(self.topics["joint_states"], received.received_ns, received.raw)
            stamp_ns = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
            if not self._unstamped and stamp_ns == 0 and self._zero_stamp:
                # two stamps of 0 in a row: an unstamped publisher (one 0 is a simulation clock's start)
                self._unstamped = True
                self._say("joint states unstamped (header stamps 0): their publication times used")
                self.base_ns, self._last_t = None, float("nan")  # a new clock: no gap to it
                if self.stream is not None:
                    self.stream.reset()
            self._zero_stamp = stamp_ns == 0
            if self._unstamped:
                stamp_ns = received.published_ns
            if self.base_ns is None:
                self.base_ns = stamp_ns
            sample = self.reader.read(
                (stamp_ns - self.base_ns) * 1e-9, message.name, message.position, message.effort
            )
            if isinstance(sample, Refusal):
                self._refuse(sample)
            elif self.stream is None:
                self._measure_rate(sample, received)
            else:
                self._take(sample, received)
            self.counts.compute_s += time.perf_counter() - started

    def _refuse(self, refusal: Refusal) -> None:
        if refusal.other_robot:
            self.counts.other_robot += 1
            self._say("another robot's joint states skipped: " + refusal.reason, refusal.kind)
        else:
            self.counts.refused += 1
            self._say("joint state refused: " + refusal.reason, refusal.kind)

    def _measure_rate(self, sample: JointSample, received: Received) -> None:
        if self._pending and sample.t <= self._pending[-1][0].t:
            self.counts.out_of_order += 1
            return
        self._pending.append((sample, received))
        if len(self._pending) < RATE_SAMPLES:
            return
        period = self._pending_period()
        self._say(f"joint states at {1.0 / period:.4g} Hz (median of the first {RATE_SAMPLES} periods)")
        self._start_on_pending(period)

    def _pending_period(self) -> float:
        """The median period of the samples held back (s)."""
        return float(np.median(np.diff([s.t for s, _ in self._pending])))

    def _start_on_pending(self, period: float) -> None:
        """The stream at ``period`` (s), then the samples held back."""
        self.period = period
        self.stream = self._stream_of(period)
        pending, self._pending = self._pending, []
        for queued, arrival in pending:
            self._take(queued, arrival)

    def _take(self, sample: JointSample, received: Received) -> None:
        assert self.stream is not None and self.period is not None
        if self._last_t == self._last_t:  # not NaN: a sample before
            gap = sample.t - self._last_t
            if gap <= 0:
                if -gap > self.restart_back_s:
                    self._restart(f"stamps went back {-gap:.3g} s: the publisher restarted")
                else:
                    self.counts.out_of_order += 1
                    self.counts.dropped += 1
                    self._say("a sample stamped at or before the last one dropped")
                    return
            elif gap > 1.5 * self.period:
                missing = round(gap / self.period) - 1
                self.counts.dropped += missing
                if gap > self.max_gap_s:
                    self._restart(f"a stall of {gap:.3g} s (more than {self.max_gap_s:g} s)")
                else:
                    self._fill(sample, missing)
        self._last_t = sample.t
        self._last_sample = sample
        self.counts.samples += 1
        for estimate in self.stream.update(sample.t, sample.q, sample.tau):
            self._emit(estimate, received)

    def _fill(self, sample: JointSample, missing: int) -> None:
        """Samples the stream lacks between the last one and ``sample``, interpolated linearly (as a
        log's reader puts a log with gaps on its grid): the causal filter is designed for the
        stream's period, and one long step would read as a jolt. Their estimates are kept, not
        published."""
        assert self.stream is not None and self._last_sample is not None
        last = self._last_sample
        for i in range(1, missing + 1):
            share = i / (missing + 1)
            t = last.t + share * (sample.t - last.t)
            q = last.q + share * (sample.q - last.q)
            tau = last.tau + share * (sample.tau - last.tau)
            for estimate in self.stream.update(t, q, tau):
                self._keep(estimate)
        self._say("samples missing from the stream: filled in by linear interpolation, not published")

    def _restart(self, why: str) -> None:
        assert self.stream is not None
        self.counts.restarts += 1
        self.stream.reset()  # a contact still raised ends at the last sample
        self._say(f"{why}: the observer starts anew")

    def _emit(self, estimate: SampleEstimate, received: Received) -> None:
        """Publish a sample's estimates (and queue them for the bag), then keep them."""
        assert self.base_ns is not None
        stamp_ns = self.base_ns + round(estimate.t * 1e9)
        wrench = self.frame_load(estimate.q, estimate.external_torque)
        self._load[: wrench.size] = wrench  # a pure force: no moment
        torque = self._torque.encode(stamp_ns, estimate.external_torque)
        load = self._wrench.encode(stamp_ns, self._load)
        flag = BOOL_BYTES[bool(estimate.in_contact)]
        self.publish["external_torque"].raw(torque)
        self.publish["contact_wrench"].raw(load)
        self.publish["collision"].raw(flag)
        now = time.time_ns()
        latency = (now - received.published_ns) * 1e-9
        self._latencies[len(self.estimates) % LATENCY_WINDOW] = latency
        if self.record is not None:
            self.record(self.topics["external_torque"], now, torque)
            self.record(self.topics["contact_wrench"], now, load)
            self.record(self.topics["collision"], now, flag)
        self._keep(estimate, wrench, stamp_ns, latency, now)

    def _keep(
        self,
        estimate: SampleEstimate,
        wrench: np.ndarray | None = None,
        stamp_ns: int | None = None,
        latency: float = float("nan"),
        now: int | None = None,
    ) -> None:
        """Keep a sample's estimates for the run's artifacts; say its contact event on
        ``/diagnostics`` (and the periodic diagnostics when due)."""
        assert self.base_ns is not None
        if stamp_ns is None:
            stamp_ns = self.base_ns + round(estimate.t * 1e9)
        if wrench is None:
            wrench = self.frame_load(estimate.q, estimate.external_torque)
        now = time.time_ns() if now is None else now
        self.estimates.append(estimate, stamp_ns * 1e-9, latency, wrench)
        if estimate.event is not None:
            self._last_event = estimate.event
            self._diagnostics(now, estimate)
        elif self.diagnostics_period_ns and now >= self._next_diagnostics:
            self._diagnostics(now, estimate)

    # --- what the loop says ---------------------------------------------------------------------

    def _say(self, text: str, kind: str | None = None) -> None:
        """Say ``text`` once per ``kind`` (None: the text before its first colon) in the run's log, and
        keep it for ``/diagnostics`` and the summary."""
        kind = kind or text.split(":")[0]
        if kind in self._said:
            return
        self._said.add(kind)
        self.counts.notes.append(text)
        log.warning(text)

    def _diagnostics(self, now: int, estimate: SampleEstimate) -> None:
        self._next_diagnostics = now + self.diagnostics_period_ns
        ratio = np.abs(estimate.external_torque) / estimate.thresholds
        joint = int(np.argmax(ratio))
        latencies = self._latencies[np.isfinite(self._latencies)]
        median, p99 = (np.percentile(latencies, [50, 99]) * 1e3) if latencies.size else (np.nan, np.nan)
        counts = self.counts
        contact = estimate.in_contact
        event = self._last_event
        values = [
            KeyValue("in_contact", str(contact).lower()),
            KeyValue("joint", str(joint + 1)),
            KeyValue("ratio_to_threshold", f"{ratio[joint]:.3f}"),
            KeyValue("external_torque", f"{estimate.external_torque[joint]:.4g}"),
            KeyValue("threshold", f"{estimate.thresholds[joint]:.4g}"),
            KeyValue("last_contact_peak_ratio", "" if event is None else f"{event.peak_ratio:.3f}"),
            KeyValue("last_contact_joint", "" if event is None else str(event.joint)),
            KeyValue("latency_median_ms", f"{median:.3f}"),
            KeyValue("latency_p99_ms", f"{p99:.3f}"),
            KeyValue("samples", str(counts.samples)),
            KeyValue("dropped_samples", str(counts.dropped)),
            KeyValue("refused_messages", str(counts.refused)),
            KeyValue("restarts", str(counts.restarts)),
        ]
        collision = DiagnosticStatus(
            DIAGNOSTIC_LEVELS["warn" if contact else "ok"],
            "lwrlab live monitor: collision",
            f"contact, joint {joint + 1} at {ratio[joint]:.2f} × its threshold" if contact else "no contact",
            "",
            values,
        )
        troubled = counts.refused or counts.restarts or counts.out_of_order
        stream = DiagnosticStatus(
            DIAGNOSTIC_LEVELS["warn" if troubled or not estimate.monitored else "ok"],
            "lwrlab live monitor: joint states",
            (counts.notes[-1] if counts.notes else "ok")
            if estimate.monitored
            else "starting up (observer settling)",
            "",
            [KeyValue("other_robot_messages", str(counts.other_robot))],
        )
        message = DiagnosticArray(Header(Time.of(now * 1e-9), ""), [collision, stream])
        self.publish["diagnostics"](message)
        if self.record is not None:
            self.record(self.topics["diagnostics"], now, message)

    def finish(self) -> None:
        """The stream ends: a contact still raised ends at its last sample."""
        with self.lock:
            if self.stream is None and len(self._pending) > 1:  # fewer samples than the rate needs
                period = self._pending_period()
                if period:
                    self._start_on_pending(period)
            if self.stream is not None:
                self.stream.finish()

    @property
    def detections(self) -> list[Detection]:
        """Every contact ended so far (times on the stream's clock: s since its first stamp)."""
        return [] if self.stream is None else list(self.stream.detector.detections)


__all__ = ["BLOCK_ROWS", "RATE_SAMPLES", "EstimateLog", "LiveMonitorLoop", "StreamCounts"]
