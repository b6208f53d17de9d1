"""Task ``live_painting``: the painting controller of ``task=painting`` as a process of its own, over ROS 2.

It plans as ``task=painting`` plans (the robot identified, the roller identified and recognised, the
painting path optimised: :func:`lwrlab.pipeline.painting.task.plan_rollers`), then paints through
the robot's joint states and joint position commands, the form a ``ros2_control`` forward position
controller takes:

- in: ``/joint_states`` (``sensor_msgs/JointState``, joints matched by name), each state driving one
  period of :class:`~lwrlab.live.painting_loop.PaintingLoop` (eq. 14's estimator, the ``controller``
  plugin, the guards);
- out: ``/forward_position_controller/commands`` (``std_msgs/Float64MultiArray``), the force estimate
  (``geometry_msgs/WrenchStamped``), the path's progress (``std_msgs/Float64MultiArray``: share of
  the path, its sample), ``/diagnostics`` (phase, progress, the stop's reason).

A robot with a force sensor (``task=sim_painting_robot`` publishes its wall sensor's reading) gives
its truth on ``topics.truth_force``: the run is then scored as ``task=painting`` scores one (Table IV's
estimated/measured force, coverage) and written as its report (tables, Figs. 12–13), with the
metrics of the same names so that live and in-process runs compare in one table. The run's inputs
and outputs are recorded as a rosbag2 (MCAP) in ``live_bag/``.
"""

from __future__ import annotations

import gc
import json
import logging
import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from lwrlab.control.contact_loop import ContactRun
from lwrlab.control.force_estimation import ExternalForceEstimator
from lwrlab.control.joint_pd import ControlSetup
from lwrlab.errors import ConfigError
from lwrlab.kinematics.swivel_ik import SwivelIK
from lwrlab.live.painting_loop import PHASES, PaintingLoop, Records, SafetySettings
from lwrlab.model.payload import attach_payload
from lwrlab.pipeline.live.monitor import SWITCH_INTERVAL_S
from lwrlab.pipeline.live.stopping import StopConditions
from lwrlab.pipeline.painting.runs import RollerPlan, reference_poses, score_run, tcp_transform
from lwrlab.pipeline.painting.task import (
    PaintingReport,
    configured_objects,
    identify_for_painting,
    painting_settings,
    plan_rollers,
)
from lwrlab.plants.mujoco_contact import Wall
from lwrlab.trajectory.core import MotionSource

log = logging.getLogger(__name__)

WALL_NORMAL = np.array([1.0, 0.0, 0.0])
"""The painted face's normal, towards the robot (:class:`~lwrlab.plants.mujoco_contact.Wall`)."""
WATCH_PERIOD_S = 5e-4
"""How often the watchdog looks at the joint states' age (s)."""
LINGER_S = 0.3
"""s the run keeps listening after it stopped commanding (the robot's last states and truth)."""
RECORD_MARGIN_S = 30.0
"""s of joint states recorded beyond the planned motion (the move to the start, the retraction)."""
LIVE_IK_CHUNK = 256
"""Path samples per batched IK call live: a call costs ~3 ms plus ~13 µs a sample, so that its period's
command stays a few ms late, once in 256 periods (in process, 2048: fewer calls in all)."""
FAULT_FREE = "painted the whole path"
"""The start of the stop reason of a run that ended as planned."""


def _diagnostic(messages: Any, loop: PaintingLoop, name: str) -> Any:
    level = 0 if loop.reason is None or loop.reason.startswith(FAULT_FREE) else 2
    values = [
        messages.KeyValue("phase", PHASES[loop.phase]),
        messages.KeyValue("progress", f"{loop.progress:.4f}"),
        messages.KeyValue("commands_clamped", str(loop.limiter.clamped)),
    ]
    status = messages.DiagnosticStatus(level, name, loop.reason or PHASES[loop.phase], "", values)
    return messages.DiagnosticArray(messages.Header(messages.Time.of(time.time())), [status])


def _truth_at(stamps_ns: np.ndarray, truth: list[tuple[int, np.ndarray]]) -> np.ndarray:
    """(N, 3) the truth force at each stamp: the one of the same stamp, else the last before it."""
    if not truth:
        return np.full((stamps_ns.size, 3), np.nan)
    order = np.argsort([stamp for stamp, _ in truth], kind="stable")
    known = np.array([truth[i][0] for i in order])
    forces = np.array([truth[i][1] for i in order])
    index = np.clip(np.searchsorted(known, stamps_ns, side="right") - 1, 0, known.size - 1)
    return forces[index]


def contact_run(
    records: Records, loop: PaintingLoop, truth: np.ndarray, painting: np.ndarray, period: float
) -> ContactRun | None:
    """The painting phase's samples as a :class:`ContactRun` (what ``task=painting`` scores), or None
    when the path was never reached. The tool's position is the controller model's forward
    kinematics of the encoder positions (the controller knows no other)."""
    rows = np.flatnonzero(records.path_index[: records.n] >= 0)
    if rows.size < 2:
        return None
    model, data, frame = loop.estimator.model, loop.estimator.model.createData(), loop.estimator.frame_id
    actual = np.empty((rows.size, 3))
    for i, row in enumerate(rows):
        pin.framesForwardKinematics(model, data, records.q[row])
        actual[i] = data.oMf[frame].translation
    k = records.path_index[rows]
    n_joints = records.q.shape[1]
    return ContactRun(
        t=k * period,
        reference=loop.reference[k, :3, 3],
        commanded=records.commanded_position[rows],
        actual=actual,
        estimated_wrench=records.wrench[rows],
        measured_force=truth[rows],
        q=records.q[rows],
        q_desired=records.command[rows],
        tau=np.zeros((rows.size, n_joints)),
        painting=painting[k],
    )


def _plan(
    cfg: Any, settings: Any, tool_motion: MotionSource | None, timings: dict[str, float]
) -> tuple[Any, RollerPlan]:
    identification = identify_for_painting(cfg, timings)
    started = time.perf_counter()
    plans = plan_rollers(settings, **configured_objects(cfg, identification, tool_motion))
    timings["planning_s"] = time.perf_counter() - started
    return identification, plans[settings.tools[0]]


def run_live_painting(
    cfg: Any,
    output_dir: Path,
    *,
    tools: Sequence[str],
    n_steps: Mapping[str, int],
    wall: Mapping[str, float],
    path: Mapping[str, Any],
    contact: Mapping[str, Any],
    estimator: Mapping[str, Any],
    tool_motion: MotionSource | None,
    rate_hz: float,
    topics: Mapping[str, str | None],
    qos: str,
    domain_id: int | None,
    localhost_only: bool | None,
    wait_s: float,
    diagnostics_hz: float,
    safety: Mapping[str, float],
    record: bool,
    **unused: Any,
) -> dict[str, float]:
    """Task ``live_painting`` (see the module); conf/task/live_painting.yaml gives every setting.

    ``unused``: the settings of ``task=painting``'s in-process cases (``models``, ``feedbacks``,
    ``comparison_controller``) and of the simulated robot (``robot``), which the live run — one
    case, the identified model with its force estimate — does not read.
    """
    from hydra.utils import instantiate

    try:
        from lwrlab.live import dds, messages, wire
        from lwrlab.live.joint_states import JointStateReader, Refusal
        from lwrlab.live.recorder import BagRecorder
    except ImportError as error:  # pragma: no cover - the test suite installs the extra
        raise ConfigError(
            f"task=live_painting needs Cyclone DDS ({error}): pip install 'lwrlab[ros2]'"
        ) from error
    from lwrlab.pipeline.painting.report import write_painting

    if len(tools) != 1:
        raise ConfigError(f"task.tools: a live run paints with one roller, got {list(tools)}")
    if rate_hz <= 0:
        raise ConfigError(f"task.rate_hz must be positive, got {rate_hz}")
    try:
        guards = SafetySettings(**{key: float(value) for key, value in safety.items()})
    except TypeError as error:
        raise ConfigError(f"task.safety: {error}") from error
    controller = instantiate(cfg.controller)
    if getattr(controller, "feedback", "estimate") != "estimate":
        raise ConfigError("task=live_painting feeds back its force estimate: controller.feedback=estimate")
    settings = painting_settings(
        tools=tools,
        n_steps=n_steps,
        models=["identified"],
        feedbacks=["estimate"],
        wall=wall,
        path=path,
        contact=contact,
        estimator=estimator,
    )
    timings: dict[str, float] = {}
    identification, plan = _plan(cfg, settings, tool_motion, timings)
    identified = identification.robot.with_parameters(identification.identified.standard_values)
    model = attach_payload(identified, plan.identified_parameters)
    period = 1.0 / rate_hz
    tcp = tcp_transform(plan.recognised)
    max_duration = contact["max_duration"]
    reference, painting = reference_poses(
        plan,
        settings.wall,
        rate_hz,
        float(contact["approach_s"]),
        float(contact["duration_scale"]),
        None if max_duration is None else float(max_duration),
    )
    start = reference[0].copy()
    start[:3, 3] += float(contact["standoff"]) * WALL_NORMAL
    swivel, branch = plan.path.parameters.swivel, plan.path.branch
    setup = ControlSetup(model, SwivelIK(model), tcp, swivel, branch, period, ik_chunk=LIVE_IK_CHUNK)
    force_estimator = ExternalForceEstimator(model, tcp, period, **estimator)

    output_dir.mkdir(parents=True, exist_ok=True)
    node = dds.Node(domain_id, localhost_only)
    commands = node.publisher(str(topics["commands"]), messages.Float64MultiArray, qos)
    estimate_out = node.publisher(str(topics["force_estimate"]), messages.WrenchStamped, qos)
    progress_out = node.publisher(str(topics["progress"]), messages.Float64MultiArray, qos)
    diagnostics_out = node.publisher(str(topics["diagnostics"]), messages.DiagnosticArray, qos)
    bag_topics: dict[str, type] = {
        str(topics["joint_states"]): messages.JointState,
        str(topics["commands"]): messages.Float64MultiArray,
        str(topics["force_estimate"]): messages.WrenchStamped,
        str(topics["diagnostics"]): messages.DiagnosticArray,
    }
    truth_topic = topics.get("truth_force")
    if truth_topic:
        bag_topics[truth_topic] = messages.WrenchStamped
    bag = BagRecorder(output_dir / "live_bag", bag_topics) if record else None
    encode_command = wire.Float64ArrayEncoder(model.n_joints)
    encode_estimate = wire.StampedEncoder(messages.WrenchStamped(), 6)
    encode_progress = wire.Float64ArrayEncoder(2)
    current = {"received_ns": 0}

    def publish(command: np.ndarray, wrench: np.ndarray, stamp_ns: int) -> None:
        raw = encode_command.encode(command)
        commands.raw(raw)
        records = loop.records
        records.latency_ns[records.n - 1] = time.time_ns() - current["received_ns"]
        estimate = encode_estimate.encode(stamp_ns, wrench)
        estimate_out.raw(estimate)
        if bag is not None:
            now = time.time_ns()
            bag.record(str(topics["commands"]), now, raw)
            bag.record(str(topics["force_estimate"]), now, estimate)

    capacity = round((reference.shape[0] * period + RECORD_MARGIN_S) * rate_hz)
    loop = PaintingLoop(
        setup=setup,
        controller=controller,
        estimator=force_estimator,
        reference=reference,
        painting=painting,
        start=start,
        normal=WALL_NORMAL,
        safety=guards,
        publish=publish,
        capacity=capacity,
    )
    reader = JointStateReader(model)
    refused: list[str] = []
    truth: list[tuple[int, np.ndarray]] = []

    def on_state(received: Any) -> None:
        current["received_ns"] = received.received_ns
        message = received.message
        stamp_ns = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
        sample = reader.read(stamp_ns * 1e-9, message.name, message.position, message.effort)
        if bag is not None:
            bag.record(str(topics["joint_states"]), received.received_ns, received.raw)
        if isinstance(sample, Refusal):
            refused.append(sample.reason)
            return
        loop.on_state(stamp_ns, sample.q, sample.tau, time.monotonic(), received.newer)

    def on_truth(received: Any) -> None:
        stamp_ns, values = received.message
        truth.append((stamp_ns, values[:3]))
        if bag is not None:
            bag.record(str(truth_topic), received.received_ns, received.raw)

    subscription = node.subscribe(
        str(topics["joint_states"]), messages.JointState, on_state, qos, decode=wire.decode_joint_state
    )
    if truth_topic:
        node.subscribe(truth_topic, messages.WrenchStamped, on_truth, qos, decode=wire.decode_wrench_stamped)
    log.info("waiting for joint states on %s", topics["joint_states"])
    # what planning built stays: frozen, the collector's full passes skip it (they took tens of ms on
    # the sample path); the interpreter's lock changes threads every 0.2 ms, not every 5 ms
    gc.collect()
    gc.freeze()
    switch_interval = sys.getswitchinterval()
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    started = time.monotonic()
    diagnostics_period = 1.0 / diagnostics_hz
    next_diagnostics = started
    with StopConditions(None, None) as stop:
        while loop.records.n == 0 and stop.signal is None:
            if subscription.error is not None:
                raise subscription.error
            if time.monotonic() - started > wait_s:
                node.close()
                raise RuntimeError(
                    f"no joint state on {topics['joint_states']} in {wait_s:g} s: is the robot publishing "
                    f"on ROS domain {node.domain_id} (ROS_DOMAIN_ID), with the same localhost setting?"
                )
            time.sleep(0.005)
        timings["start_s"] = time.monotonic() - started
        if loop.records.n:
            loop.prepare()
        while not loop.stopped:
            now = time.monotonic()
            loop.check_stale(now)
            signalled = stop.reason(now)
            if signalled is not None:
                loop.stop(signalled)
            if subscription.error is not None:
                loop.stop(f"the joint-state subscription failed: {subscription.error}")
            if now >= next_diagnostics:
                next_diagnostics = now + diagnostics_period
                publishers = subscription.publishers  # asks DDS: once a diagnostics period
                if publishers > 1:  # another robot's states interleave with this one's
                    loop.stop(
                        f"{publishers} publishers of {topics['joint_states']} on ROS domain "
                        f"{node.domain_id}: the controller commands one robot"
                    )
                diagnostics_out(_diagnostic(messages, loop, "lwrlab: live painting"))
                progress_out.raw(
                    encode_progress.encode(np.array([loop.progress, loop.progress * reference.shape[0]]))
                )
            time.sleep(WATCH_PERIOD_S)
    sys.setswitchinterval(switch_interval)
    final = _diagnostic(messages, loop, "lwrlab: live painting")
    diagnostics_out(final)
    if bag is not None:
        bag.record(str(topics["diagnostics"]), time.time_ns(), final)
    log.info("stopped: %s", loop.reason)
    time.sleep(LINGER_S)
    node.close()
    bag_path = bag.close() if bag is not None else None

    records = loop.records
    stamps = records.stamp_ns[: records.n]
    truth_force = _truth_at(stamps, list(truth))
    gaps = np.diff(stamps) * 1e-9
    latency_ms = 1e-6 * records.latency_ns[: records.n][records.latency_ns[: records.n] > 0]
    reason = str(loop.reason)
    metrics: dict[str, float] = {
        **timings,
        "states": float(records.n),
        "commands": float(latency_ms.size),
        "refused_messages": float(len(refused)),
        "missed_periods": float(np.sum(np.maximum(np.round(gaps / period) - 1, 0))) if gaps.size else 0.0,
        "latency_median_ms": float(np.median(latency_ms)) if latency_ms.size else float("nan"),
        "latency_p99_ms": float(np.percentile(latency_ms, 99)) if latency_ms.size else float("nan"),
        "compute_median_ms": float(1e-6 * np.median(records.compute_ns[: records.n])),
        "compute_p99_ms": float(1e-6 * np.percentile(records.compute_ns[: records.n], 99)),
        "commands_clamped": float(loop.limiter.clamped),
        "states_superseded": float(loop.superseded),
        "path_progress": loop.progress,
        "stopped_on_fault": float(not reason.startswith(FAULT_FREE)),
    }
    run = contact_run(records, loop, truth_force, painting, period) if truth else None
    lines = ["", "## Live run", "", f"- stopped: {reason}"]
    if run is not None and np.any(run.painting):
        desired = None if controller.desired_force is None else float(controller.desired_force[0])
        scored = score_run(
            tools[0], "identified", "estimate", plan, run, desired, float(estimator["wrench_cutoff_hz"]), 0.0
        )
        report = PaintingReport(
            {tools[0]: plan}, [scored], Wall(**{k: float(v) for k, v in wall.items()}), desired, timings, {}
        )
        metrics[f"coverage_{scored.key}"] = scored.summary["coverage"]
        for row in scored.force_errors:
            metrics[f"rms_{scored.key}_{row['comparison'].replace('/', '_vs_')}"] = row["rms"]
        report.metrics = metrics
        write_painting(report, output_dir)
        summary = (output_dir / "summary.md").read_text()
    else:
        summary = "## Live painting\n"
        lines.append("- the path's painting was not reached or no truth force came: nothing scored")
    lines += [
        f"- {records.n} joint states, {latency_ms.size} commands, {len(refused)} messages refused, "
        f"{metrics['missed_periods']:.0f} missed periods, {loop.limiter.clamped} commands clamped, "
        f"{loop.superseded} states answered by a newer one's command",
        f"- latency (state received to command published): median {metrics['latency_median_ms']:.3f} ms, "
        f"99th percentile {metrics['latency_p99_ms']:.3f} ms",
        f"- path progress {100 * loop.progress:.1f} %",
        *([f"- refused: {refused[0]}"] if refused else []),
        *([f"- bag: {bag_path.name} (inputs and outputs, MCAP)"] if bag_path is not None else []),
    ]
    summary += "\n".join(lines) + "\n"
    (output_dir / "summary.md").write_text(summary)
    (output_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    (output_dir / "stop_reason.txt").write_text(reason + "\n")
    print(summary)
    return metrics


__all__ = ["contact_run", "run_live_painting"]
