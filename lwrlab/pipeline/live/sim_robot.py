"""Task ``sim_robot``: a simulated arm that publishes its joint states over ROS 2, pushed at known times.

The user's robot when they have none, and the tests' robot. The true robot is ``plant=simulated``'s
(the robot config perturbed from the plant's seed: the robot ``task=identification`` identifies on
the same defaults), simulated in MuJoCo under inverse-dynamics feedforward of the nominal model and
joint PD (:class:`~lwrlab.plants.pushed_arm.PushedArm`), with the plant's sensor noise and encoder
resolution, and forces pushing its links (scripted in ``task.pushes``, or ``task.random_pushes``
drawn from the seed). It
stands still, plays the configured ``trajectory``, stands still again, and publishes at
``task.rate_hz``:

- ``/joint_states`` (``sensor_msgs/JointState``: positions, velocities, joint torques as efforts),
  stamped as a ``ros2_control`` loop stamps its cycles (``t₀ + k·period``);
- its truth: the true external joint torques (a JointState's effort) and whether a force acts
  (``std_msgs/Bool``), on topics of their own.

The run is simulated before it is published (a few seconds for a minute of motion), so the
publication keeps its pace on a busy machine. Its folder keeps the truth as ``task=monitor`` scores
it: ``contacts.csv`` and ``truth.parquet`` on the published stamps::

    lwrlab task=sim_robot task.random_pushes=10
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from lwrlab.errors import ConfigError
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.live.stopping import StopConditions
from lwrlab.pipeline.monitor.scenario import PD_GAINS
from lwrlab.plants.pushed_arm import ExternalForce, PushedArm, PushedRun, chained, random_forces
from lwrlab.trajectory.core import Trajectory

log = logging.getLogger(__name__)

CONTACT_LINKS_FROM = 3
"""Random pushes act on this link and those after it (the first links barely move under a push)."""
SPIN_S = 2e-4
"""The last stretch before a sample's time is waited by spinning, not sleeping (sleep's granularity)."""


def _gains(n: int) -> tuple[np.ndarray, np.ndarray]:
    kp, kd = (np.asarray(g, dtype=float) for g in PD_GAINS)
    index = np.minimum(np.arange(n) * len(kp) // max(n, 1), len(kp) - 1)
    return kp[index], kd[index]


def _still(q: np.ndarray, seconds: float, period: float) -> Trajectory:
    count = max(round(seconds / period), 1) + 1
    zeros = np.zeros((count, q.size))
    return Trajectory(t=period * np.arange(count), q=np.tile(q, (count, 1)), dq=zeros, ddq=zeros.copy())


def played_motion(
    cfg: Any,
    robot: RobotModel,
    motion: str,
    rate_hz: float,
    *,
    hold_pose: Sequence[float] | None,
    duration_s: float,
    start_delay_s: float,
    hold_after_s: float,
) -> Trajectory:
    """What the robot does: stand, play the configured trajectory, stand; or stand for ``duration_s``."""
    from hydra.utils import instantiate

    period = 1.0 / rate_hz
    if motion == "hold":
        pose = (
            0.5 * (robot.limits.position_lower + robot.limits.position_upper)
            if hold_pose is None
            else np.asarray(hold_pose, dtype=float)
        )
        if pose.shape != (robot.n_joints,) or not np.all(np.isfinite(pose)):
            raise ConfigError(f"task.hold_pose: give {robot.n_joints} finite joint positions (rad)")
        return _still(pose, duration_s, period)
    if motion != "trajectory":
        raise ConfigError(f"task.motion must be 'trajectory' or 'hold', got {motion!r}")
    played = instantiate(cfg.trajectory).sample(robot, rate_hz)
    if not np.allclose(played.dq[[0, -1]], 0.0, atol=1e-6):
        raise ConfigError("task=sim_robot plays a trajectory that starts and ends at rest")
    return chained(
        [_still(played.q[0], start_delay_s, period), played, _still(played.q[-1], hold_after_s, period)]
    )


def _pushes(
    robot: RobotModel,
    motion: Trajectory,
    scripted: Sequence[dict[str, Any]] | None,
    count: int,
    force_range: Sequence[float],
    seed: int,
) -> list[ExternalForce]:
    forces = []
    for i, push in enumerate(scripted or []):
        try:
            forces.append(
                ExternalForce(
                    start=float(push["start"]),
                    duration=float(push["duration"]),
                    link=int(push["link"]),
                    point=np.asarray(push.get("point", [0.0, 0.0, 0.0]), dtype=float),
                    force=np.asarray(push["force"], dtype=float),
                    kind=str(push.get("kind", "push")),
                )
            )
        except (KeyError, TypeError, ValueError) as error:
            raise ConfigError(
                f"task.pushes[{i}]: give start, duration (s), link (1…{robot.n_joints}), force [x, y, z] (N) "
                f"and optionally point [x, y, z] (m): {error}"
            ) from error
        if not 1 <= forces[-1].link <= robot.n_joints:
            raise ConfigError(f"task.pushes[{i}].link: {forces[-1].link} is not a link of 1…{robot.n_joints}")
    if count > 0:
        window = (1.0, motion.duration - 0.6)
        rng = np.random.default_rng(seed)
        links = list(range(min(CONTACT_LINKS_FROM, robot.n_joints), robot.n_joints + 1))
        drawn = random_forces(
            robot,
            motion,
            rng,
            window=window,
            spacing=(window[1] - window[0]) / (count + 0.5),
            links=links,
            force_range=(float(force_range[0]), float(force_range[1])),
            push_duration=(0.1, 0.4),
            impact_share=0.0,
        )
        if len(drawn) < count:
            raise ConfigError(
                f"task.random_pushes={count}: only {len(drawn)} fit in the {motion.duration:.3g} s run; "
                "a longer motion, hold_after_s or fewer pushes"
            )
        forces += drawn[:count]
    return forces


def simulate(cfg: Any, forces_of: Any, motion_of: Any, seed: int) -> tuple[RobotModel, Trajectory, PushedRun]:
    """The nominal robot, the motion and the simulated run (``plant=simulated``'s true robot)."""
    from hydra.utils import instantiate

    nominal: RobotModel = instantiate(cfg.robot)
    plant = instantiate(cfg.plant)
    if getattr(cfg.plant, "_target_", "") != "plugins.plants.simulated.SimulatedPlant":
        raise ConfigError("task=sim_robot simulates plant=simulated's robot: drop the plant=… override")
    simulated = plant(robot=nominal)
    truth = simulated.truth.robot
    motion = motion_of(nominal)
    forces = forces_of(nominal, motion)
    kp, kd = _gains(nominal.n_joints)
    arm = PushedArm(
        truth,
        nominal,
        kp=kp.tolist(),
        kd=kd.tolist(),
        substeps=2,
        torque_noise_std=float(np.max(cfg.plant.torque_noise_std)),
        encoder_noise_std=float(cfg.plant.encoder_noise_std),
        seed=seed,
    )
    log.info("simulating %.1f s of %s with %d pushes", motion.duration, nominal.name, len(forces))
    return nominal, motion, arm.run(motion, forces, "sim_robot")


def run_sim_robot(
    cfg: Any,
    output_dir: Path,
    *,
    motion: str,
    hold_pose: Sequence[float] | None,
    rate_hz: float,
    duration_s: float,
    hold_after_s: float,
    realtime: bool,
    stamps: str,
    pushes: Sequence[dict[str, Any]] | None,
    random_pushes: int,
    seed: int,
    start_delay_s: float,
    push_force: Sequence[float],
    topics: dict[str, str],
    qos: str,
    domain_id: int | None,
    localhost_only: bool | None,
    wait_for_subscriber_s: float,
) -> dict[str, float]:
    """Task ``sim_robot`` (see the module); conf/task/sim_robot.yaml gives every setting's value."""
    try:
        from lwrlab.live import dds, messages, wire
    except ImportError as error:  # pragma: no cover - the test suite installs the extra
        raise ConfigError(
            f"task=sim_robot needs Cyclone DDS ({error}): pip install 'lwrlab[ros2]'"
        ) from error
    if stamps not in ("wall", "sim"):
        raise ConfigError(f"task.stamps must be 'wall' or 'sim', got {stamps!r}")
    if rate_hz <= 0:
        raise ConfigError(f"task.rate_hz must be positive, got {rate_hz}")
    output_dir.mkdir(parents=True, exist_ok=True)
    nominal, _played, run = simulate(
        cfg,
        lambda robot, motion_: _pushes(robot, motion_, pushes, random_pushes, push_force, seed),
        lambda robot: played_motion(
            cfg,
            robot,
            motion,
            rate_hz,
            hold_pose=hold_pose,
            duration_s=duration_s,
            start_delay_s=start_delay_s,
            hold_after_s=hold_after_s,
        ),
        seed,
    )
    names = list(nominal.joint_names)
    node = dds.Node(domain_id, localhost_only)
    publish = node.publisher(topics["joint_states"], messages.JointState, qos)
    truth_torque = (
        node.publisher(topics["truth_torque"], messages.JointState, qos)
        if topics.get("truth_torque")
        else None
    )
    truth_contact = (
        node.publisher(topics["truth_contact"], messages.Bool, qos) if topics.get("truth_contact") else None
    )
    states = wire.JointStateEncoder(names)
    truths = wire.StampedEncoder(
        messages.JointState(messages.Header(), names, [], [], [0.0] * len(names)), len(names)
    )
    waited = time.monotonic()
    while wait_for_subscriber_s > 0 and not publish.matched:
        if time.monotonic() - waited > wait_for_subscriber_s:
            log.warning(
                "no subscriber of %s after %g s: publishing anyway",
                topics["joint_states"],
                wait_for_subscriber_s,
            )
            break
        time.sleep(0.01)
    measurement = run.measurement
    period_ns = round(1e9 / rate_hz)
    contact = np.any(run.force != 0.0, axis=1)
    q, tau, dq = measurement.q, measurement.tau, run.velocity
    resolution = float(cfg.plant.get("encoder_resolution") or 0.0)
    if resolution > 0:  # the plant's encoders read whole steps
        q = np.round(q / resolution) * resolution
    assert dq is not None
    lags = np.zeros(len(measurement.t))
    sent = 0
    log.info("publishing %d joint states at %g Hz on %s", len(measurement.t), rate_hz, topics["joint_states"])
    with StopConditions(None, None) as stop:
        start_ns = time.time_ns()
        origin = start_ns if stamps == "wall" else 0
        clock = time.perf_counter()
        for k in range(len(measurement.t)):
            if stop.signal is not None:
                break
            if realtime:
                due = clock + k * period_ns * 1e-9
                delay = due - time.perf_counter()
                if delay > SPIN_S:
                    time.sleep(delay - SPIN_S)
                while time.perf_counter() < due:
                    pass
                lags[k] = time.perf_counter() - due
            stamp_ns = origin + k * period_ns
            publish.raw(states.encode(stamp_ns, q[k], dq[k], tau[k]))
            if truth_torque is not None:
                truth_torque.raw(truths.encode(stamp_ns, run.external_torque[k]))
            if truth_contact is not None:
                truth_contact.raw(wire.BOOL_BYTES[bool(contact[k])])
            sent += 1
    node.close()
    stamps_s = (origin + np.arange(sent) * period_ns) * 1e-9
    offset = stamps_s[0] - measurement.t[0] if sent else 0.0
    contacts = run.contacts.copy()
    if len(contacts):
        contacts[["start", "end"]] += offset
    contacts.to_csv(output_dir / "contacts.csv", index=False)
    n = nominal.n_joints
    pd.DataFrame(
        {
            "t": stamps_s,
            **{f"tau_ext{j + 1}": run.external_torque[:sent, j] for j in range(n)},
            **{f"force_{a}": run.force[:sent, i] for i, a in enumerate("xyz")},
        }
    ).to_parquet(output_dir / "truth.parquet", index=False)
    late = lags[:sent]
    metrics = {
        "samples_published": float(sent),
        "pushes": float(len(run.contacts)),
        "publication_lag_median_ms": float(1e3 * np.median(late)) if sent else float("nan"),
        "publication_lag_p99_ms": float(1e3 * np.percentile(late, 99)) if sent else float("nan"),
        "late_publications": float(np.count_nonzero(late > period_ns * 1e-9)),
    }
    (output_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    log.info(
        "published %d joint states on %s (%s stamps); truth in %s",
        sent,
        topics["joint_states"],
        stamps,
        output_dir,
    )
    return metrics


__all__ = ["played_motion", "run_sim_robot", "simulate"]
