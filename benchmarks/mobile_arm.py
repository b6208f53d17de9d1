"""The physically consistent fit on a mobile manipulator's arm: TIAGo's seven arm joints, motor currents.

A description nobody here wrote: example-robot-data's TIAGo (``tiago_description/robots/tiago.urdf``,
the mobile base, torso, head and hand locked: 7 of its joints move). Its hand's inertials look like
placeholders (fingers of 14–50 g with 0.001 kg·m² about every axis), merged into the last segment.
The arm is simulated by :mod:`lwrlab.plants.geared_arm` (harmonic drives 1:100, rotor inertias,
LuGre friction whose Coulomb level grows with the load, 2¹⁷-count encoders, motor currents with
offsets and noise) playing a 59 s multisine with rests, logged at 100 Hz; its truth is the URDF's
arm with every segment perturbed by 10 % (physically consistent, seeded).

    nice .venv/bin/python benchmarks/mobile_arm.py [--folder OUT] [--seconds 59]

writes two logs into OUT (default: a temporary folder; current noise 0.02 A and 0.1 A), then runs
``lwrlab task=identification plant=log robot=urdf …`` with the defaults for logs (``friction=auto``,
``estimator=sdp``) in a process of its own on each, fitting every joint and only joints 1–4
(``data.fitted_joints``), and prints the wall time, how many of the SDP's solves fell back from the
primary solver (CLARABEL) to SCS (the run's log), the prior weight chosen, the held-out error (the
last 30 % of the log) and the smallest pseudo-inertia eigenvalue.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

REPOSITORY = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPOSITORY))

from lwrlab.model.inertia import perturb_consistent  # noqa: E402
from lwrlab.plants.geared_arm import GearedArm, LuGreFriction, MotorSensors  # noqa: E402
from lwrlab.plants.planned_motions import MultisinePath, RestSchedule, WarpedMotion  # noqa: E402

RATE_HZ = 100.0
GEAR = 100.0
TORQUE_CONSTANT = 0.08
NOISE_A = 0.02
"""N·m/A at the motor."""
ARM_JOINTS = tuple(f"arm_{j}_joint" for j in range(1, 8))


def tiago_urdf() -> Path:
    """TIAGo's URDF in example-robot-data."""
    from plugins.robots.example_robot import example_robot_file

    return Path(example_robot_file("tiago_description/robots/tiago.urdf"))


def locked_joints(urdf: Path) -> dict[str, float]:
    """Every moving joint but the arm's, locked: the torso at 0.15 m, the rest at 0."""
    document = ET.parse(urdf).getroot()
    moving = {j.get("name") for j in document.iter("joint") if j.get("type") != "fixed" and j.get("name")}
    return {name: (0.15 if name == "torso_lift_joint" else 0.0) for name in sorted(moving - set(ARM_JOINTS))}


def robot_overrides(urdf: Path) -> list[str]:
    """The ``robot=urdf`` overrides of the arm."""
    locked = ", ".join(f"{name}: {value}" for name, value in locked_joints(urdf).items())
    drive = (
        f"{{gear_ratios: {GEAR:g}, torque_constants: {TORQUE_CONSTANT:g}, torque_side: motor, "
        "position_side: motor, rotor_inertia: auto}"
    )
    return [
        "robot=urdf",
        f"robot.path={urdf}",
        f"robot.locked_joints={{{locked}}}",
        "robot.flange_frame=arm_tool_link",
        "robot.collision_geometry=false",
        "robot.acceleration_limits=8.0",
        f"robot.drive={drive}",
    ]


def write_log(folder: Path, seconds: float, seed: int = 0) -> tuple[Path, list[str]]:
    """Simulate the arm and write its 100 Hz current log; the robot overrides that read it."""
    from hydra.utils import instantiate

    sys.path.insert(0, str(REPOSITORY / "tests"))
    from composing import compose_config

    urdf = tiago_urdf()
    overrides = robot_overrides(urdf)
    nominal = instantiate(compose_config(*overrides).robot)
    rng = np.random.default_rng(seed)
    links = np.stack([perturb_consistent(phi, 0.1, rng) for phi in nominal.link_parameters])
    truth = nominal.with_parameters(np.concatenate([links.ravel(), nominal.parameters[links.size :]]))
    n = truth.n_joints
    friction = LuGreFriction.from_joint_side(
        truth.drive_train,
        coulomb=np.array([2.0, 2.0, 1.2, 1.2, 0.4, 0.3, 0.3]),
        viscous=np.array([2.0, 2.0, 1.0, 1.0, 0.3, 0.2, 0.2]),
        stribeck_rise=0.4,
        stribeck_speed=np.full(n, 0.1),
        load_factor=0.05,
        presliding=2e-4,
        damping_share=0.2,
    )
    sensors = MotorSensors(effort_noise=np.full(n, NOISE_A), effort_offset=rng.normal(0.0, 0.02, n))
    arm = GearedArm(truth, np.full(n, 2.0e-5), friction, sensors, rate_hz=RATE_HZ)
    lower, upper = nominal.limits.position_lower, nominal.limits.position_upper
    center, reach = (lower + upper) / 2, 0.35 * (upper - lower)
    moves = max(1, round((seconds - 3.0) / 14.4))
    segments: list[tuple[str, float]] = [("rest", 1.0)]
    for _ in range(moves):
        segments += [("up", 0.4), ("move", 12.0), ("down", 0.4), ("rest", 1.6)]
    schedule = RestSchedule(tuple(segments))
    path = MultisinePath.random(
        center,
        [0.1, 0.2, 0.3, 0.5, 0.7, 0.9],
        reach,
        np.minimum(0.6 * nominal.limits.velocity, 1.5),
        np.full(n, 4.0),
        schedule.path_length,
        rng,
    )
    run = arm.play(WarpedMotion(path, schedule), rng)
    log = folder / "tiago_arm.parquet"
    run.log_frame().to_parquet(log, index=False)
    return log, overrides


def identify(log: Path, overrides: list[str], folder: Path, *extra: str) -> dict[str, object]:
    """``lwrlab task=identification plant=log`` on the log, timed, in a process of its own."""
    command = [
        sys.executable,
        "-m",
        "lwrlab.cli",
        "task=identification",
        "plant=log",
        *overrides,
        f"data.paths=[{log}]",
        "tracking=none",
        f"hydra.run.dir={folder / 'identified'}",
        *extra,
    ]
    started = time.perf_counter()
    done = subprocess.run(command, cwd=REPOSITORY, capture_output=True, text=True)
    seconds = time.perf_counter() - started
    if done.returncode != 0:
        raise SystemExit(done.stderr[-3000:])
    metrics = json.loads((folder / "identified" / "metrics.json").read_text())
    log_text = (folder / "identified" / "cli.log").read_text()
    return {
        "wall s": round(seconds, 1),
        "fallbacks": log_text.count("the result comes from the fallback solver"),
        "solver_fallback": metrics.get("solver_fallback"),
        "prior weight": metrics.get("prior_weight"),
        "validation %": round(100 * metrics["validation_rel_error"], 2),
        "min eigenvalue": metrics.get("min_pseudo_inertia_eigenvalue"),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--folder", type=Path, default=None)
    parser.add_argument("--seconds", type=float, default=59.0)
    args = parser.parse_args()
    global NOISE_A
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        for noise in (0.02, 0.1):
            NOISE_A = noise
            folder = (args.folder or Path(scratch)) / f"noise_{noise:g}"
            folder.mkdir(parents=True, exist_ok=True)
            log, overrides = write_log(folder, args.seconds)
            for fitted in (None, "[1,2,3,4]"):
                extra = [] if fitted is None else [f"data.fitted_joints={fitted}"]
                row = {"current noise A": noise, "fitted joints": fitted or "all"}
                rows.append(row | identify(log, overrides, folder, *extra))
                print(json.dumps(rows[-1]), flush=True)
    print()
    print("| " + " | ".join(rows[0]) + " |")
    print("|" + "---|" * len(rows[0]))
    for row in rows:
        print("| " + " | ".join(str(v) for v in row.values()) + " |")


if __name__ == "__main__":
    main()
