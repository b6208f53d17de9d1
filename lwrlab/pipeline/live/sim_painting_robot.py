"""Task ``sim_painting_robot``: the painting task's arm, wall and roller, stepped live on joint commands.

The robot ``task=painting`` paints with in one process, as a ``ros2_control`` robot: the MuJoCo
contact plant (:func:`lwrlab.pipeline.painting.runs.contact_plant`: ``plant=simulated``'s true
robot carrying the true roller, the wall with its force sensor, the same sensor noise) steps at
``task.rate_hz`` on the wall clock, its joint controller (joint PD + gravity compensation of the
true robot with its roller, the ``controller``'s joint gains, the reference's speed from the
commands' differences over the periods between them) holding the last joint position command
received on ``/forward_position_controller/commands`` (``std_msgs/Float64MultiArray``, as a
forward position controller hands it to the hardware). Each period it publishes:

- ``/joint_states`` (``sensor_msgs/JointState``: encoder positions, velocities, link-side joint
  torques as efforts), stamped ``t₀ + k·period`` on the wall clock;
- its truth: the force the roller exerts on the wall as its sensor measures it
  (``geometry_msgs/WrenchStamped``, the same stamp).

With ``task.robot.lockstep_s`` it does not keep the wall clock's pace once commanded: each period
waits for the command answering the last state (at most that long), as a simulator stepped in
lockstep with its controller does; the controller then always sees one period of delay, whatever
else the machine runs (the tests' mode: a shared machine holds a real-time loop up by tens of ms
at times).
Before the first command it stands at ``task.robot.start_pose`` (null: the middle of the joint
ranges). Fault drills, each timed in the robot's own periods from the first command it took:
``task.robot.stalls`` withhold the joint states for a while (the driver's stream stalls while the
arm keeps its command),
``task.robot.wall_moves`` move the wall along its normal (it is not where the path was planned),
``task.robot.torque_jumps`` offset the published joint torques for a while (a torque sensor's
glitch: the force estimate jumps). It shares ``task=live_painting``'s settings (the
same YAML), so that the two processes agree on the wall, the roller and the topics::

    lwrlab task=sim_painting_robot
"""

from __future__ import annotations

import gc
import json
import logging
import sys
import threading
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lwrlab.control.joint_pd import JointPDGravity
from lwrlab.errors import ConfigError
from lwrlab.model.payload import attach_payload
from lwrlab.pipeline.live.monitor import SWITCH_INTERVAL_S
from lwrlab.pipeline.live.stopping import StopConditions
from lwrlab.pipeline.painting.runs import contact_plant
from lwrlab.plants.mujoco_contact import Wall

log = logging.getLogger(__name__)

SPIN_S = 2e-4
"""The last stretch before a period's time is waited by spinning, not sleeping (sleep's granularity)."""


class _LatestCommand:
    """The last joint position command received (the subscription's thread writes, the loop reads)."""

    def __init__(self, n_joints: int) -> None:
        self.n_joints = n_joints
        self.q: np.ndarray | None = None
        self.count = 0
        self.refused = 0
        self.arrived = threading.Condition()

    def __call__(self, values: np.ndarray) -> None:
        if values.shape != (self.n_joints,) or not np.all(np.isfinite(values)):
            self.refused += 1  # a forward controller refuses a command of the wrong size, too
            return
        with self.arrived:
            self.q, self.count = values, self.count + 1
            self.arrived.notify()

    def wait_beyond(self, count: int, timeout_s: float) -> None:
        """Wait until more than ``count`` commands came, or ``timeout_s``."""
        with self.arrived:
            self.arrived.wait_for(lambda: self.count > count, timeout_s)


def _drills(name: str, drills: Sequence[Mapping[str, Any]] | None, keys: Sequence[str]) -> list[tuple]:
    """``task.robot.<name>``: per drill, ``after_s`` and the values of ``keys`` (floats, or lists of them)."""
    parsed = []
    for i, drill in enumerate(drills or []):
        try:
            values = [drill[key] for key in ("after_s", *keys)]
            parsed.append(
                tuple(
                    np.asarray(value, dtype=float) if isinstance(value, Sequence) else float(value)
                    for value in values
                )
            )
        except (KeyError, TypeError, ValueError) as error:
            raise ConfigError(
                f"task.robot.{name}[{i}]: give after_s (s after the first command) and "
                f"{', '.join(keys)}: {error!r}"
            ) from error
    return parsed


def _stalls(stalls: Sequence[Mapping[str, float]] | None) -> list[tuple[float, float]]:
    return [(after, after + duration) for after, duration in _drills("stalls", stalls, ["duration_s"])]


def run_sim_painting_robot(
    cfg: Any,
    output_dir: Path,
    *,
    tools: Sequence[str],
    wall: Mapping[str, float],
    contact: Mapping[str, Any],
    rate_hz: float,
    topics: Mapping[str, str | None],
    qos: str,
    domain_id: int | None,
    localhost_only: bool | None,
    robot: Mapping[str, Any],
    **controller_settings: Any,
) -> dict[str, float]:
    """Task ``sim_painting_robot`` (see the module); ``robot``: start_pose, joint_gains, stalls,
    wall_moves, torque_jumps, lockstep_s, duration_s, idle_stop_s. ``controller_settings``:
    ``task=live_painting``'s other settings, which the robot does not read."""
    from hydra.utils import instantiate

    try:
        from lwrlab.live import dds, messages, wire
    except ImportError as error:  # pragma: no cover - the test suite installs the extra
        raise ConfigError(
            f"task=sim_painting_robot needs Cyclone DDS ({error}): pip install 'lwrlab[ros2]'"
        ) from error
    from lwrlab.pipeline.tools.library import load_library

    if len(tools) != 1:
        raise ConfigError(f"task.tools: the robot carries one roller, got {list(tools)}")
    if rate_hz <= 0:
        raise ConfigError(f"task.rate_hz must be positive, got {rate_hz}")
    output_dir.mkdir(parents=True, exist_ok=True)
    nominal = instantiate(cfg.robot)
    truth = instantiate(cfg.plant, tool=None, show_progress=False)(robot=nominal).truth.robot
    tool = load_library(None)[tools[0]]
    the_wall = Wall(**{key: float(value) for key, value in wall.items()})
    plant = contact_plant(truth, tool, the_wall, contact, int(cfg.seed))
    if abs(plant.control_period * rate_hz - 1.0) > 1e-9:
        raise ConfigError(f"task.rate_hz: the contact plant steps at {1 / plant.control_period:g} Hz")
    n = truth.n_joints
    start = robot.get("start_pose")
    q0 = (
        0.5 * (truth.limits.position_lower + truth.limits.position_upper)
        if start is None
        else np.asarray(start, dtype=float)
    )
    if q0.shape != (n,) or not np.all(np.isfinite(q0)):
        raise ConfigError(f"task.robot.start_pose: give {n} finite joint positions (rad)")
    gains = robot["joint_gains"]
    joint = JointPDGravity(
        attach_payload(truth, tool.parameters), gains["kp"], gains["kd"], plant.control_period
    )
    kp, kd = joint.kp, joint.kd
    sensors = plant.reset(q0, joint.gravity(q0))
    stalls = _stalls(robot.get("stalls"))
    wall_moves = sorted(_drills("wall_moves", robot.get("wall_moves"), ["distance"]))
    torque_jumps = [
        (after, after + duration, np.broadcast_to(offset, (n,)))
        for after, duration, offset in _drills(
            "torque_jumps", robot.get("torque_jumps"), ["duration_s", "offset"]
        )
    ]
    lockstep_s = robot.get("lockstep_s")
    names = list(nominal.joint_names)

    node = dds.Node(domain_id, localhost_only)
    states = node.publisher(str(topics["joint_states"]), messages.JointState, qos)
    truth_topic = topics.get("truth_force")
    truth_force = node.publisher(truth_topic, messages.WrenchStamped, qos) if truth_topic else None
    latest = _LatestCommand(n)
    node.subscribe(
        str(topics["commands"]),
        messages.Float64MultiArray,
        lambda received: latest(received.message),
        qos,
        decode=wire.decode_float64_array,
    )
    encode_state = wire.JointStateEncoder(names)
    encode_force = wire.StampedEncoder(messages.WrenchStamped(), 6)
    period_ns = round(1e9 / rate_hz)
    wrench = np.zeros(6)
    published = withheld = late = 0
    log.info(
        "%s with %s at %g Hz on %s; commands on %s",
        truth.name,
        tool.name,
        rate_hz,
        topics["joint_states"],
        topics["commands"],
    )
    gc.collect()
    gc.freeze()  # the collector's full passes skip what the set-up built (they would hold a period up)
    switch_interval = sys.getswitchinterval()
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    with StopConditions(robot.get("duration_s"), robot.get("idle_stop_s")) as stop:
        start_ns, clock = time.time_ns(), time.perf_counter()
        k, last_count, last_command_s, last_command_k = 0, 0, float("nan"), 0
        first_command_k: int | None = None
        q_command, zeros = q0, np.zeros(n)
        dq_command = zeros
        reason = None
        while reason is None:
            if lockstep_s and latest.count:  # the answer to the last state, or the timeout: then step
                latest.wait_beyond(last_count, lockstep_s)
            else:
                due = clock + k * period_ns * 1e-9
                delay = due - time.perf_counter()
                if delay > SPIN_S:
                    time.sleep(delay - SPIN_S)
                while time.perf_counter() < due:
                    pass
                if time.perf_counter() - due > period_ns * 1e-9:
                    late += 1
            if latest.count != last_count and latest.q is not None:
                # the command's speed over the periods since the last one: a late command (the
                # controller held up, then a burst) moves the reference by as much, not faster
                q_new, periods = latest.q, k - last_command_k
                dq_command = (q_new - q_command) / (max(periods, 1) * plant.control_period)
                q_command, last_command_k = q_new, k
                first_command_k = k if first_command_k is None else first_command_k
                last_count, last_command_s = latest.count, time.monotonic()
            elif k - last_command_k > 1:
                dq_command = zeros  # held: a forward controller's reference stands still
            gravity = joint.gravity(sensors.q)
            sensors = plant.step(kp * (q_command - sensors.q) + kd * (dq_command - sensors.dq_true) + gravity)
            stamp_ns = start_ns + (k + 1) * period_ns
            # the drills' clock: the robot's own periods since it took the first command (in lockstep
            # the wall clock runs at the pair's pace, not the robot's)
            since_first = -np.inf if first_command_k is None else (k - first_command_k) / rate_hz
            while wall_moves and since_first >= wall_moves[0][0]:
                _, distance = wall_moves.pop(0)
                plant.move_wall(distance)
                log.info(
                    "drill: the wall moved %+.1f mm along its normal, %.2f s after the first command",
                    1e3 * distance,
                    since_first,
                )
            if any(begin <= since_first < end for begin, end in stalls):
                withheld += 1
            else:
                tau = sensors.tau
                for begin, end, offset in torque_jumps:
                    if begin <= since_first < end:
                        tau = tau + offset
                states.raw(encode_state.encode(stamp_ns, sensors.q, sensors.dq_true, tau))
                if truth_force is not None:
                    wrench[:3] = sensors.wall_force
                    truth_force.raw(encode_force.encode(stamp_ns, wrench))
                published += 1
            k += 1
            reason = stop.reason(last_command_s)
    sys.setswitchinterval(switch_interval)
    node.close()
    metrics = {
        "samples_published": float(published),
        "samples_withheld": float(withheld),
        "late_periods": float(late),
        "commands_received": float(latest.count),
        "commands_refused": float(latest.refused),
    }
    (output_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    log.info("%s after %d periods; %d commands received", reason, k, latest.count)
    return metrics


__all__ = ["run_sim_painting_robot"]
