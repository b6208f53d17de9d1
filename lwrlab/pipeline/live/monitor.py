"""Task ``live_monitor``: the monitor of ``task=monitor`` on a robot's ROS 2 joint states, live.

The model and the thresholds are those ``task=monitor`` uses (the same settings and calibration,
:func:`~lwrlab.pipeline.monitor.calibrated_thresholds`); the samples come from ``/joint_states``
(``sensor_msgs/JointState``) as the robot publishes them and go through the core's streaming monitor
(:mod:`lwrlab.monitoring.stream`: the computation ``task=monitor`` runs vectorised on logs) on the
subscription's thread (:class:`~lwrlab.live.monitor_loop.LiveMonitorLoop`). For every sample it
publishes the external joint torques, the contact wrench at the frame and the collision flag; a few
times a second and on every contact, ``/diagnostics``::

    lwrlab task=live_monitor task.model=<identification run>

It stops on SIGINT/SIGTERM (a clean stop), after ``task.duration_s``, or when no sample came for
``task.idle_stop_s``, and leaves in its run folder what ``task=monitor`` writes
(``external_torque.parquet``, ``detections.csv``, ``calibration.csv``, ``external_torque.png``,
``summary.md``, ``metrics.json``) and the run as a rosbag2 (MCAP) of its inputs and outputs
(``live_bag``), which ``task=monitor plant=log`` reads.
"""

from __future__ import annotations

import json
import logging
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from lwrlab.errors import ConfigError
from lwrlab.monitoring.contact_force import FrameLoad, default_frame, frame_id
from lwrlab.monitoring.detection import Detection, detection_flags, detections_frame
from lwrlab.monitoring.estimates import MonitorSettings
from lwrlab.monitoring.stream import MonitorStream
from lwrlab.pipeline.config_nodes import tracking_uri
from lwrlab.pipeline.live.calibration_cache import cached_calibration
from lwrlab.pipeline.live.stopping import StopConditions
from lwrlab.pipeline.monitor import calibration_table, format_summary, monitoring_robot
from lwrlab.tracking.models.identified_model import read_identified_model

log = logging.getLogger(__name__)

OUTPUTS = ("external_torque", "contact_wrench", "collision", "diagnostics")
"""The topics the monitor publishes, by their key in ``task.topics``."""
POLL_S = 0.05
"""How often the main thread looks whether to stop (s)."""
SWITCH_INTERVAL_S = 2e-4
"""The interpreter's thread switch interval while the loop runs (s; Python's default 5 ms): a sample
path that waits on the interpreter's lock (a DDS write, a BLAS call) gets it back from the bag's
writer within this, not within 5 ms."""


def _ros2() -> Any:
    """The live edge, or an error saying how to install it (the optional extra ``[ros2]``)."""
    try:
        from lwrlab.live import dds, joint_states, messages, monitor_loop, recorder, wire
    except ImportError as error:  # pragma: no cover - the test suite installs the extra
        raise ConfigError(
            f"task=live_monitor needs Cyclone DDS ({error}): pip install 'lwrlab[ros2]'"
        ) from error
    return dds, joint_states, messages, monitor_loop, recorder, wire


def process_age_s() -> float:
    """Seconds since this process started (Linux: ``/proc/self/stat``), NaN where unknown."""
    try:
        fields = Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()
        started = int(fields[19]) / os.sysconf("SC_CLK_TCK")
        return time.clock_gettime(time.CLOCK_BOOTTIME) - started
    except (OSError, ValueError, IndexError):
        return float("nan")


def run_live_monitor(
    cfg: Any,
    output_dir: Path,
    *,
    model: str | None,
    calibration_paths: Sequence[str] | None,
    observer_gain: float,
    velocity_cutoff_hz: float,
    coulomb_smoothing: float,
    false_alarm_rate: float,
    margin: float,
    residual_margin: float,
    min_duration: float,
    release: float,
    thresholds: str,
    friction_drift: float,
    rest_thresholds: str,
    frame: str | None,
    point: Sequence[float] | None,
    truth_contacts: str | None,
    truth_torque: str | None,
    min_force: float,
    joint_names: Sequence[str] | None,
    drive_gains: Sequence[float] | None,
    topics: dict[str, str],
    input_qos: str,
    output_qos: str,
    domain_id: int | None,
    localhost_only: bool | None,
    rate_hz: float | None,
    duration_s: float | None,
    idle_stop_s: float | None,
    wait_s: float,
    max_gap_s: float,
    diagnostics_hz: float,
    record: bool,
) -> dict[str, float]:
    """Task ``live_monitor`` (see the module). Every setting is required: conf/task/live_monitor.yaml
    gives their values; those it shares with ``task=monitor`` mean the same
    (:func:`~lwrlab.pipeline.monitor.run_monitor`); ``truth_contacts``, ``truth_torque`` and
    ``min_force`` score a recorded run offline and are not used live."""
    entered = time.monotonic()
    dds, joint_states, messages, monitor_loop, recorder, wire = _ros2()
    output_dir.mkdir(parents=True, exist_ok=True)
    if record and (output_dir / "live_bag").exists():
        raise ConfigError(
            f"{output_dir / 'live_bag'} exists already: a live run records into a new folder; give "
            "another hydra.run.dir (or task.record=false)"
        )
    missing = [key for key in ("joint_states", *OUTPUTS) if not topics.get(key)]
    if missing:
        raise ConfigError(f"task.topics: give a topic for {missing}")
    settings = MonitorSettings(
        observer_gain,
        velocity_cutoff_hz,
        coulomb_smoothing,
        false_alarm_rate,
        margin,
        min_duration,
        release,
        residual_margin,
        thresholds,
        friction_drift,
        rest_thresholds,
    )
    # the participant first: its discovery runs while the model is read and the thresholds calibrated
    node = dds.Node(domain_id, localhost_only)
    read = read_identified_model(model, tracking_uri(cfg), "task.model") if model else None
    robot = monitoring_robot(cfg, read)
    frame = frame or default_frame(robot)
    try:
        frame_id(robot, frame)
        if point is not None and len(point) != 3:
            raise ValueError(f"task.point must be [x, y, z] in the frame {frame!r}, got {list(point)}")
        reader = joint_states.JointStateReader(robot, joint_names, drive_gains)
    except ValueError as error:
        raise ConfigError(str(error)) from error
    calibrations, source = cached_calibration(cfg, robot, calibration_paths, read, settings)

    def stream_of(period: float) -> MonitorStream:
        return MonitorStream.of(robot, settings, calibrations["observer"], period)

    publish = {
        key: node.publisher(topics[key], message, output_qos)
        for key, message in zip(
            OUTPUTS,
            (messages.JointState, messages.WrenchStamped, messages.Bool, messages.DiagnosticArray),
            strict=True,
        )
    }
    bag = None
    if record:
        kinds = {
            "joint_states": messages.JointState,
            "external_torque": messages.JointState,
            "contact_wrench": messages.WrenchStamped,
            "collision": messages.Bool,
            "diagnostics": messages.DiagnosticArray,
        }
        bag = recorder.BagRecorder(output_dir / "live_bag", {topics[k]: m for k, m in kinds.items()})
    loop = monitor_loop.LiveMonitorLoop(
        stream_of,
        reader,
        FrameLoad(robot, frame, None if point is None else np.asarray(point, dtype=float)),
        frame,
        list(reader.names),
        publish,
        None if bag is None else bag.record,
        topics,
        rate_hz=rate_hz,
        max_gap_s=max_gap_s,
        diagnostics_hz=diagnostics_hz,
    )
    log.info(
        "live monitor of %s: %s on domain %d%s, thresholds from %s",
        robot.name,
        topics["joint_states"],
        node.domain_id,
        " (loopback only)" if node.localhost else "",
        source,
    )
    cpu_before, wall_before = time.process_time(), time.monotonic()
    first_estimate = float("nan")
    subscription = node.subscribe(
        topics["joint_states"], messages.JointState, loop.on_joint_state, input_qos, wire.decode_joint_state
    )
    switch_interval = sys.getswitchinterval()
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    try:
        with StopConditions(duration_s, idle_stop_s) as stop:
            while True:
                stop.wait(POLL_S)
                if subscription.error is not None:
                    raise RuntimeError(f"the joint states' subscription failed: {subscription.error}")
                if first_estimate != first_estimate and len(loop.estimates):
                    first_estimate = time.monotonic()
                    log.info("first estimate %.2f s after the task started", first_estimate - entered)
                reason = stop.reason(loop.last_message_s)
                if reason is not None:
                    break
                if loop.counts.messages == 0 and time.monotonic() - stop.started > wait_s:
                    raise RuntimeError(
                        f"no joint states on {topics['joint_states']} within {wait_s:g} s (ROS domain "
                        f"{node.domain_id}{', loopback only' if node.localhost else ''}): is the robot "
                        "publishing, on this domain and network?"
                    )
    finally:
        sys.setswitchinterval(switch_interval)
        node.close()
        loop.finish()
        bag_path = None if bag is None else bag.close()
    wall = time.monotonic() - wall_before
    cpu = time.process_time() - cpu_before
    log.info("live monitor stopped: %s", reason)
    return _write_run(
        output_dir,
        loop,
        robot.name,
        calibrations,
        source,
        settings,
        frame,
        read,
        {
            "duration_s": wall,
            "cpu_share": cpu / wall if wall > 0 else float("nan"),
            # from the process's start (imports, model, calibration, discovery) to the first estimate
            "start_to_first_estimate_s": process_age_s() - (time.monotonic() - first_estimate),
        },
        reason,
        bag_path,
    )


def _absolute(detection: Detection, base: float) -> Detection:
    """A detection with its times on the robot's clock (``base`` the stream's first stamp, s)."""
    from dataclasses import replace

    return replace(
        detection, start=detection.start + base, raised=detection.raised + base, end=detection.end + base
    )


def _write_run(
    output_dir: Path,
    loop: Any,
    robot_name: str,
    calibrations: dict[str, Any],
    source: str,
    settings: MonitorSettings,
    frame: str,
    read: Any,
    timing: dict[str, float],
    reason: str,
    bag_path: Path | None,
) -> dict[str, float]:
    """The run's artifacts (those of ``task=monitor``) and metrics."""
    rows = loop.estimates.table()
    counts = loop.counts
    n = len(loop.names)
    base = 0.0 if loop.base_ns is None else loop.base_ns * 1e-9
    detections = [_absolute(d, base) for d in loop.detections]
    frame_table = pd.DataFrame(
        {
            "log": "live",
            "t": rows["t"],
            "monitored": rows["monitored"],
            **{f"observer{j + 1}": rows["external_torque"][:, j] for j in range(n)},
            **{f"threshold{j + 1}": rows["thresholds"][:, j] for j in range(n)},
            "detected": detection_flags(len(rows["t"]), detections),
            "in_contact": rows["in_contact"],
            "latency_ms": 1e3 * rows["latency"],
            **{
                f"{axis}": rows["wrench"][:, i]
                for i, axis in enumerate(
                    ("force_x", "force_y", "force_z", "moment_x", "moment_y", "moment_z")
                )
            },
        }
    )
    frame_table.to_parquet(output_dir / "external_torque.parquet", index=False)
    table = detections_frame(detections)
    peaks = [d.peak_index for d in detections]
    for i, axis in enumerate(("force_x", "force_y", "force_z", "moment_x", "moment_y", "moment_z")):
        table[axis] = rows["wrench"][peaks, i] if peaks else []
    table.insert(0, "estimator", "observer")
    table.insert(0, "log", "live")
    table.to_csv(output_dir / "detections.csv", index=False)
    calibration = calibration_table(calibrations)
    calibration.to_csv(output_dir / "calibration.csv", index=False)
    latency = 1e3 * rows["latency"][np.isfinite(rows["latency"])]  # filled-in samples have none
    metrics = {
        "samples": float(counts.samples),
        "messages": float(counts.messages),
        "dropped_samples": float(counts.dropped),
        "refused_messages": float(counts.refused),
        "other_robot_messages": float(counts.other_robot),
        "out_of_order_samples": float(counts.out_of_order),
        "restarts": float(counts.restarts),
        "latency_median_ms": float(np.median(latency)) if latency.size else float("nan"),
        "latency_p99_ms": float(np.percentile(latency, 99)) if latency.size else float("nan"),
        "latency_max_ms": float(latency.max()) if latency.size else float("nan"),
        "detections": float(len(detections)),
        "observer_us_per_sample": 1e6 * counts.compute_s / max(counts.messages, 1),
        **timing,
    }
    if len(rows["t"]):
        from lwrlab.figures.monitor import external_torques  # matplotlib: after the run, not before it

        external_torques(
            rows["t"],
            rows["external_torque"],
            np.full_like(rows["external_torque"], np.nan),
            rows["thresholds"],
            [(d.start, d.end) for d in detections],
            output_dir / "external_torque.png",
            f"live: external joint torques ({robot_name})",
        )
    summary = format_summary(source, calibration, table, metrics, settings)
    live = [
        "",
        "## Live run",
        "",
        f"- stopped: {reason}",
        f"- {counts.samples} samples of {counts.messages} messages; {counts.dropped} dropped, "
        f"{counts.refused} refused, {counts.other_robot} of another robot, {counts.restarts} restarts",
        "- latency (a sample's publication to its estimates'): median "
        f"{metrics['latency_median_ms']:.3f} ms, 99th percentile {metrics['latency_p99_ms']:.3f} ms",
        f"- contact loads: the wrench at {frame}",
        *(f"- {note}" for note in counts.notes),
        *([f"- bag: {bag_path.name} (inputs and outputs, MCAP)"] if bag_path is not None else []),
    ]
    summary += "\n" + "\n".join(live)
    if read is not None:
        summary += f"\n\nmodel {read.resolved.source}: {read.describe()}"
    (output_dir / "summary.md").write_text(summary + "\n")
    (output_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    print(summary)
    return metrics


__all__ = ["OUTPUTS", "process_age_s", "run_live_monitor"]
