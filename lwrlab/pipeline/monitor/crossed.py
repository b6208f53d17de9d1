"""Crossed monitoring scenarios: thresholds calibrated on one motion family, contacts on others.

:func:`write_crossed_scenario` simulates, in MuJoCo, a perturbed LWR4 whose friction is that of
the real LWR4+ (about twice the CAD's) and, as on a real arm, **differs from run to run** by
``drift`` (temperature, wear): the identification log (the shipped exciting motion) at its nominal
friction, the calibration family's log (multi-sines at half the limits) at ``1 + drift``. The model
is identified from the first and validated on the second; thresholds come from both (what
``task=monitor`` does by default). Then, with pushes and impacts on links 3–7 every ``spacing``
seconds (5–50 N):

- ``slower`` (multi-sines at a quarter of the limits, friction ``1 − drift``),
- ``faster`` (12 harmonics at 90 % of the limits, friction ``1 + drift``),
- ``stops`` (the calibration family with :data:`STOP_S` of rest between segments, nominal friction),
- ``rest``: the arm standing still at four postures for :data:`REST_S` each, moved between them in
  :data:`MOVE_S`, pushed (held forces, no impacts) only while it stands still (nominal friction).

Each log is written as ``task=monitor`` reads logs, with its true contacts and external torques.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from itertools import pairwise
from pathlib import Path

import numpy as np
import pandas as pd

from lwrlab.io.logs import write_log
from lwrlab.model.robot import RobotModel
from lwrlab.numerics.stretches import true_stretches
from lwrlab.pipeline.build import build
from lwrlab.pipeline.monitor.scenario import CONTACT_LINKS, PD_GAINS, RATE_HZ, SEGMENT_S, identify_logs
from lwrlab.plants.pushed_arm import ExternalForce, PushedArm, chained, random_forces
from lwrlab.plants.simulation import perturbed_robot
from lwrlab.trajectory.core import Trajectory

FAMILIES = {"slower": (4, 0.25), "calibration": (8, 0.5), "faster": (12, 0.9)}
"""Multi-sine families: (harmonics per :data:`SEGMENT_S` segment, share of the limits used)."""
STOP_S = 4.0
"""Rest between the segments of the ``stops`` family (s)."""
REST_S = 10.0
"""Time the ``rest`` log stands still at each posture (s)."""
REST_SPACING_S = 1.5
"""Mean time between the pushes on the arm standing still (s): pushes only, as by hand."""
MOVE_S = 2.0
"""Time the ``rest`` log takes to move from one posture to the next (s)."""
MONITORED = ("slower", "faster", "stops", "rest")
"""The monitored logs, in the order they are written."""


@dataclass(frozen=True)
class MonitoredLog:
    """One monitored log and its truth."""

    log: Path
    contacts: Path
    truth: Path
    friction_factor: float
    """Its friction over the identification log's."""


@dataclass(frozen=True)
class CrossedFiles:
    """Where the crossed scenario's files are."""

    folder: Path
    model: Path
    calibration: tuple[Path, Path]
    """The identification log and the calibration family's log (contact-free)."""
    monitored: dict[str, MonitoredLog]
    drift: float
    """Share by which the runs' friction differs."""


def _hold(q: np.ndarray, seconds: float) -> Trajectory:
    n = round(seconds * RATE_HZ) + 1
    zeros = np.zeros((n, q.size))
    return Trajectory(t=np.arange(n) / RATE_HZ, q=np.tile(q, (n, 1)), dq=zeros, ddq=zeros.copy())


def _move(start: np.ndarray, end: np.ndarray, seconds: float) -> Trajectory:
    """A quintic move from rest to rest (zero velocity and acceleration at both ends)."""
    t = np.arange(round(seconds * RATE_HZ) + 1) / RATE_HZ
    s = (t / seconds)[:, None]
    step = end - start
    return Trajectory(
        t=t,
        q=start + step * (10 * s**3 - 15 * s**4 + 6 * s**5),
        dq=step * (30 * s**2 - 60 * s**3 + 30 * s**4) / seconds,
        ddq=step * (60 * s - 180 * s**2 + 120 * s**3) / seconds**2,
    )


def family_motion(robot: RobotModel, family: str, duration: float, seed: int) -> Trajectory:
    """``family``'s motion (:data:`FAMILIES` or ``stops``) of about ``duration`` seconds; ``rest``:
    four postures held :data:`REST_S` each, whatever ``duration``."""
    if family == "rest":
        rng = np.random.default_rng(seed)
        lower, upper = robot.limits.position_lower, robot.limits.position_upper
        middle = 0.5 * (lower + upper)
        postures = [middle + 0.3 * (upper - lower) * rng.uniform(-0.5, 0.5, robot.n_joints) for _ in range(4)]
        parts = [_move(middle, postures[0], MOVE_S)]
        for here, there in pairwise(postures):
            parts += [_hold(here, REST_S), _move(here, there, MOVE_S)]
        return chained([*parts, _hold(postures[-1], REST_S)])
    harmonics, share = FAMILIES["calibration" if family == "stops" else family]
    segments = max(1, round(duration / (SEGMENT_S + (STOP_S if family == "stops" else 0.0))))
    parts = []
    for i in range(segments):
        motion = build(
            "trajectory",
            "multisine",
            duration=SEGMENT_S,
            harmonics=harmonics,
            seed=seed + i,
            limit_fraction=share,
        ).sample(robot, RATE_HZ)
        parts += [motion, _hold(motion.q[-1], STOP_S)] if family == "stops" else [motion]
    return chained(parts)


def rest_windows(motion: Trajectory, settle: float = 0.5) -> list[tuple[float, float]]:
    """The stretches (s) where ``motion`` stands still, less ``settle`` seconds at each end."""
    starts, ends = true_stretches(np.all(motion.dq == 0.0, axis=1))
    return [
        (float(motion.t[a]) + settle, float(motion.t[b - 1]) - settle)
        for a, b in zip(starts, ends, strict=True)
        if motion.t[b - 1] - motion.t[a] > 2 * settle
    ]


def _arm(truth: RobotModel, nominal: RobotModel, factor: float, seed: int) -> PushedArm:
    friction = truth.friction
    scaled = replace(friction, coulomb=factor * friction.coulomb, viscous=factor * friction.viscous)
    kp, kd = PD_GAINS
    return PushedArm(
        replace(truth, friction=scaled),
        nominal,
        kp=kp,
        kd=kd,
        substeps=2,
        torque_noise_std=0.1,
        encoder_noise_std=1.7e-5,
        seed=seed,
    )


def _write_monitored(
    folder: Path, name: str, arm: PushedArm, motion: Trajectory, forces: list[ExternalForce], factor: float
) -> MonitoredLog:
    run = arm.run(motion, forces, name)
    log = write_log(run.measurement, folder / f"{name}.parquet")
    contacts = folder / f"{name}_contacts.csv"
    run.contacts.to_csv(contacts, index=False)
    truth = folder / f"{name}_truth.parquet"
    n = run.external_torque.shape[1]
    pd.DataFrame(
        {"t": run.measurement.t, **{f"tau_ext{j + 1}": run.external_torque[:, j] for j in range(n)}}
    ).to_parquet(truth, index=False)
    return MonitoredLog(log, contacts, truth, factor)


def write_crossed_scenario(
    folder: Path,
    *,
    seed: int = 0,
    duration: float = 60.0,
    spacing: float = 2.5,
    drift: float = 0.3,
    friction_scale: float = 2.0,
) -> CrossedFiles:
    """Simulate and write the crossed scenario (see the module) in ``folder``: about 25 s on 2 cores
    for 60 s logs."""
    folder.mkdir(parents=True, exist_ok=True)
    cad = build("robot", "kuka_lwr4")
    truth = perturbed_robot(cad, 0.1, 0.2, np.random.default_rng(seed))
    friction = replace(
        truth.friction,
        coulomb=friction_scale * truth.friction.coulomb,
        viscous=friction_scale * truth.friction.viscous,
    )
    truth = replace(truth, friction=friction)
    identification = write_log(
        _arm(truth, cad, 1.0, seed)
        .run(build("trajectory", "optimal").sample(cad, RATE_HZ), [], "identification")
        .measurement,
        folder / "identification.parquet",
    )
    calibration_motion = family_motion(cad, "calibration", 2 * SEGMENT_S, seed=100 * seed + 11)
    validation = write_log(
        _arm(truth, cad, 1.0 + drift, seed + 1).run(calibration_motion, [], "calibration").measurement,
        folder / "calibration.parquet",
    )
    model = identify_logs(folder / "identified_model.yaml", [identification], [validation])
    factors = {"slower": 1.0 - drift, "faster": 1.0 + drift, "stops": 1.0, "rest": 1.0}
    monitored = {}
    rng = np.random.default_rng(seed + 2)
    for k, name in enumerate(MONITORED):
        motion = family_motion(cad, name, duration, seed=100 * seed + 30 + 10 * k)
        windows = rest_windows(motion) if name == "rest" else [(5.0, float(motion.t[-1]) - 1.0)]
        forces = [
            force
            for window in windows
            for force in random_forces(
                cad,
                motion,
                rng,
                window=window,
                spacing=REST_SPACING_S if name == "rest" else spacing,
                links=CONTACT_LINKS,
                impact_share=0.0 if name == "rest" else 0.3,
            )
        ]
        arm = _arm(truth, cad, factors[name], seed + 3 + k)
        monitored[name] = _write_monitored(folder, name, arm, motion, forces, factors[name])
    return CrossedFiles(folder, model, (identification, validation), monitored, drift)
