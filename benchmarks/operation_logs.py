"""Logs as robots in operation write them: one exciting motion, a point-to-point cycle with rests, both.

A Panda (the zoo's ``panda_sign`` truth: its bodies perturbed by 10 %, friction sign + viscous) plays
a short exciting multi-sine (``exciting``, 5 s of motion between rests) and a 30 s point-to-point
cycle with rests (``cycle``, what a cell runs), either exactly (``--engine played``, the default: its
torques by RNEA + ``FC·sign(q̇) + FV·q̇``, the model class, friction zero at rest) or in MuJoCo under
PD control (``--engine mujoco``, the zoo member's own arm). Its logs are written as its sensors read
them: torque noise and offsets, and positions with encoder noise (σ 1e-5 rad) and 20-bit
quantisation (``noisy``; ``quiet τ``: a tenth of the torque noise), or exact positions
(``exact q``), or exact torques (``exact τ``), or exact positions and torques (``noise-free``).
Each fit set (exciting alone, exciting + cycle, cycle alone) is identified as ``lwrlab
task=identification plant=log`` identifies a user's logs, and judged on new motions (faster, slower,
point to point) against the **true** torque: over every sample, where the joints move, and where
they stand or stop (a standing joint's friction is anywhere in its static band: no true value to
score a model against). ``--real`` scores the real LWR4+ split 2→3 (``../shared/data/kuka_lwr4_hw``)
beside them, against its measured torques.

    nice -n 10 .venv/bin/python benchmarks/operation_logs.py                # every case (a few minutes)
    nice -n 10 .venv/bin/python benchmarks/operation_logs.py --cases noisy --fits exciting "exciting + cycle"
    nice -n 10 .venv/bin/python benchmarks/operation_logs.py --overrides friction=sign
    nice -n 10 .venv/bin/python benchmarks/operation_logs.py --cases noisy --realisations 5  # noise draws

The logs are built once into ``outputs/operation_logs/`` (seeded) and read back afterwards.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
import pandas as pd

REPOSITORY = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPOSITORY))

from benchmarks.zoo import Subject, identify, prediction_scores, real_subjects  # noqa: E402
from benchmarks.zoo_members import (  # noqa: E402
    MEMBERS,
    Member,
    MemberLogs,
    RepeatedMotion,
    _joint_side_member,
    _point_to_point,
    _write,
    _write_truth,
    exciting_motion,
    member_motions,
    nominal_robot,
    torque_scale,
    true_robot,
)
from lwrlab.dynamics.base_parameters import compute_base_parameters  # noqa: E402
from lwrlab.excitation.known_data import measurement_information  # noqa: E402
from lwrlab.pipeline.build import build as build_plugin  # noqa: E402
from lwrlab.pipeline.build import shipped_config  # noqa: E402
from lwrlab.plants.core import Measurement  # noqa: E402
from lwrlab.plants.planned_motions import MultisinePath, RestSchedule, WarpedMotion  # noqa: E402

FOLDER = REPOSITORY / "outputs" / "operation_logs"
RESOLUTION = 2 * np.pi / 2**20
"""20-bit encoders (rad)."""
ENCODER_NOISE = 1e-5
"""σ of the encoders' noise before quantisation (rad)."""
CASES = {
    "noisy": {"encoder_resolution": RESOLUTION, "encoder_noise": ENCODER_NOISE / RESOLUTION},
    "quiet τ": {
        "encoder_resolution": RESOLUTION,
        "encoder_noise": ENCODER_NOISE / RESOLUTION,
        "noise_share": 4e-4,
    },
    "exact q": {"encoder_resolution": 1e-12, "encoder_noise": 0.0},
    "exact τ": {
        "encoder_resolution": RESOLUTION,
        "encoder_noise": ENCODER_NOISE / RESOLUTION,
        "noise_share": 1e-9,
    },
    "noise-free": {
        "encoder_resolution": 1e-12,
        "encoder_noise": 0.0,
        "noise_share": 1e-9,
        "offset_share": 0.0,
    },
}
"""How the logs are written: what the sensors of ``panda_sign`` are changed to."""
FITS = {
    "exciting": ("exciting",),
    "exciting + cycle": ("exciting", "cycle"),
    "cycle": ("cycle",),
    "fresh 10 s": ("fresh",),
    "cycle + fresh 5 s": ("cycle", "fresh5"),
    "cycle + designed 5 s": ("cycle", "designed"),
}
DESIGNED = ("fresh", "fresh5", "designed")
"""Optimal motions, played only where a fit asks for them: the product's 10 s exciting motion
designed alone (``fresh``), a 5 s one designed alone (``fresh5``) and a 5 s one designed for the
cycle (``task.known_logs``: ``designed``)."""
VALIDATION = ("faster", "slower", "p2p")


def exciting(robot: Any, rng: np.random.Generator) -> WarpedMotion:
    """5 s of a multi-sine about the middle of the joint ranges, from and to rest."""
    lower = np.where(np.isfinite(robot.limits.position_lower), robot.limits.position_lower, -np.pi)
    upper = np.where(np.isfinite(robot.limits.position_upper), robot.limits.position_upper, np.pi)
    schedule = RestSchedule((("rest", 0.5), ("up", 0.3), ("move", 5.0), ("down", 0.3), ("rest", 0.5)))
    path = MultisinePath.random(
        0.5 * (lower + upper),
        [0.2, 0.45, 0.8, 1.3],
        np.minimum(0.3 * (upper - lower), 0.8),
        np.full(robot.n_joints, 1.5),
        np.full(robot.n_joints, 10.0),
        schedule.path_length,
        rng,
    )
    return WarpedMotion(path, schedule)


def member(case: str, seed: int) -> Member:
    """``panda_sign`` with the sensors of ``case``."""
    base = MEMBERS["panda_sign"]
    return replace(base, name=f"panda_sign {case} {seed}", sensors=replace(base.sensors, **CASES[case]))


def build(case: str, seed: int, engine: str = "played", realisation: int = 0) -> MemberLogs:
    """The logs of ``case`` (built once into :data:`FOLDER`): the same motions and truth for every case;
    ``engine``: ``played`` (the plans played exactly, the model class) or ``mujoco`` (the zoo member's
    MuJoCo arm under PD control); ``realisation`` > 0 (played only): the same motions and truth read
    through another draw of the sensors' noise."""
    arm = member(case, seed)
    folder = FOLDER / engine / f"seed{seed}" / case.replace(" ", "_").replace("τ", "tau")
    if realisation:
        if engine != "played":
            raise ValueError("noise realisations are drawn for the played engine only")
        folder = folder / f"noise{realisation}"
    nominal = nominal_robot(arm)
    scale = torque_scale(nominal, np.random.default_rng([seed, 3]))
    logs = MemberLogs(arm, seed, folder, scale)
    names = ("exciting", "cycle", *VALIDATION)
    if all(any(folder.glob(f"{n}.*")) for n in names):
        logs.paths = {n: next(folder.glob(f"{n}.parquet")) for n in names}
        return logs
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    truth = true_robot(arm, nominal, rng)
    fit = exciting(nominal, rng)
    new = member_motions(fit, rng, quick=True)
    t = np.linspace(0.0, fit.duration, 2001)
    q, dq, ddq = fit.evaluate(t)
    center = 0.5 * (q.max(axis=0) + q.min(axis=0))
    reach = np.maximum(0.5 * (q.max(axis=0) - q.min(axis=0)), 0.05)
    speed, acceleration = np.abs(dq).max(axis=0), np.abs(ddq).max(axis=0)
    cycle = _point_to_point(center, reach, 0.5 * speed, 0.3 * acceleration, 8, (1.0, 2.5), rng)
    motions = {"exciting": fit, "cycle": cycle} | {n: new[n] for n in VALIDATION}
    if engine == "mujoco":
        logs.paths = _joint_side_member(arm, nominal, truth, scale, motions, [], folder, seed)
    else:
        logs.paths = _played_member(arm, truth, scale, motions, folder, seed, realisation)
    return logs


def _played_member(
    arm: Member,
    truth: Any,
    scale: np.ndarray,
    motions: dict[str, Any],
    folder: Path,
    seed: int,
    realisation: int = 0,
) -> dict[str, Path]:
    """The plans played exactly by the true arm (RNEA + ``FC·sign(q̇) + FV·q̇`` + offsets: the model
    class), read by the member's sensors at 1 kHz (``realisation``: which draw of their noise)."""
    sensors = arm.sensors
    rng = np.random.default_rng([seed, 7] if not realisation else [seed, 7, realisation])
    offset = sensors.offset_share * scale * rng.choice([-1.0, 1.0], size=scale.size)
    spec = arm.truth
    friction = replace(
        truth.friction,
        coulomb=spec.coulomb_share * scale,
        viscous=spec.viscous_share * scale,
        offset=np.zeros_like(scale),
    )
    arm_truth = replace(truth, friction=friction)
    paths = {}
    for name, motion in motions.items():
        t = np.arange(int(np.floor(motion.duration * sensors.rate_hz)) + 1) / sensors.rate_hz
        q, dq, ddq = motion.evaluate(t)
        reading = arm_truth.inverse_dynamics(q, dq, ddq, with_friction=True) + offset
        resolution = sensors.encoder_resolution
        noise = rng.normal(scale=sensors.encoder_noise * resolution, size=q.shape)
        q_log = np.round((q + noise) / resolution) * resolution
        tau_log = reading + rng.normal(size=reading.shape) * sensors.noise_share * scale
        paths[name] = _write(folder / f"{name}.parquet", {"t": t, "q": q_log, "tau": tau_log}, "parquet")
        _write_truth(
            folder / f"{name}_truth.parquet",
            t,
            {"tau": reading, "tau_ext": 0 * q, "q": q, "dq": dq, "ddq": ddq},
        )
    return paths


MOVING = 0.02
"""rad/s: a joint whose true speed is above this moves (its friction is the law's); below, it stands
or stops (its friction anywhere in the static band: no truth to score a model's point against)."""


def moving_scores(logs: MemberLogs, report: Any) -> dict[str, float]:
    """The error on the new motions (% of the true torque) over the joints' moving samples and over
    their standing ones (true speed above and below :data:`MOVING`)."""
    n = report.robot.n_joints
    sums = np.zeros((2, 2))  # (moving, standing) × (error², truth²)
    for p in report.validation_predictions:
        if p.name not in VALIDATION:
            continue
        truth = logs.truth(p.name)
        tau = truth[[f"tau{j + 1}" for j in range(n)]].to_numpy()
        speed = np.abs(truth[[f"dq{j + 1}" for j in range(n)]].to_numpy())
        scored = np.broadcast_to(p.scored.reshape(len(tau), -1), tau.shape)
        for k, mask in enumerate((scored & (speed > MOVING), scored & (speed <= MOVING))):
            sums[k] += [np.sum((tau - p.predicted)[mask] ** 2), np.sum(tau[mask] ** 2)]
    return {
        "moving %": 100 * float(np.sqrt(sums[0, 0] / sums[0, 1])),
        "standing %": 100 * float(np.sqrt(sums[1, 0] / max(sums[1, 1], 1e-300))),
    }


def designed_logs(logs: MemberLogs, case: str, seed: int, realisation: int = 0) -> MemberLogs:
    """``logs`` with the optimal motions of :data:`DESIGNED` played and read as the others (built once):
    the member's 10 s motion and a 5 s one designed alone, and a 5 s one designed for the cycle's log
    as read by the sensors (its information, its noise from the log's residual), as ``task=excitation
    task.known_logs=[cycle]`` designs it."""
    names = [n for n in DESIGNED if not (logs.folder / f"{n}.parquet").is_file()]
    if names:
        arm = member(case, seed)
        nominal = nominal_robot(arm)
        truth = true_robot(arm, nominal, np.random.default_rng(seed))
        motions: dict[str, Any] = {}
        if "fresh" in names:
            motions["fresh"] = RepeatedMotion(exciting_motion(arm, nominal, FOLDER), 1.0, 1.5, 1, 1.5)
        base = compute_base_parameters(nominal)
        source = build_plugin(
            "trajectory",
            "optimal",
            from_file=None,
            duration=5.0,
            optimizer=build_plugin("optimizer", "slsqp", show_progress=False, seed=0),
            **({"constraints": dict(arm.motion_constraints)} if arm.motion_constraints else {}),
        )
        if "fresh5" in names:
            motions["fresh5"] = RepeatedMotion(source.optimise(nominal, base)[0], 1.0, 1.5, 1, 1.5)
        if "designed" in names:
            cycle = pd.read_parquet(logs.paths["cycle"])
            n = nominal.n_joints
            measurement = Measurement(
                t=cycle["t"].to_numpy(),
                q=cycle[[f"q{j + 1}" for j in range(n)]].to_numpy(),
                tau=cycle[[f"tau{j + 1}" for j in range(n)]].to_numpy(),
            )
            processing = dict(shipped_config("measurement", "default").processing)
            known = measurement_information(nominal, base, [measurement], processing)
            motion, _, _ = source.optimise(nominal, base, known)
            motions["designed"] = RepeatedMotion(motion, 1.0, 1.5, 1, 1.5)
        scale = torque_scale(nominal, np.random.default_rng([seed, 3]))
        _played_member(arm, truth, scale, motions, logs.folder, seed, 100 + realisation)  # noise of their own
    logs.paths |= {n: logs.folder / f"{n}.parquet" for n in DESIGNED}
    return logs


def score(logs: MemberLogs, fit: tuple[str, ...], extra: list[str]) -> dict[str, Any]:
    """Identify from ``fit`` logs; the error on the new motions against the true torque."""
    subject = Subject(logs.member.name, logs.overrides(fit=fit, validation=VALIDATION) + extra, logs)
    _, report = identify(subject.overrides)
    return prediction_scores(subject, report) | moving_scores(logs, report)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="*", default=list(CASES), choices=list(CASES))
    parser.add_argument(
        "--fits", nargs="*", default=["exciting", "exciting + cycle", "cycle"], choices=list(FITS)
    )
    parser.add_argument("--engine", default="played", choices=("played", "mujoco"))
    parser.add_argument("--seeds", nargs="*", type=int, default=[0])
    parser.add_argument(
        "--realisations",
        type=int,
        default=1,
        help="draws of the sensors' noise on the same motions and truth (played engine)",
    )
    parser.add_argument("--overrides", nargs="*", default=[], help="more command-line overrides")
    parser.add_argument("--real", action="store_true", help="the real LWR4+ split 2→3 too")
    args = parser.parse_args()
    rows = []
    for seed in args.seeds:
        for case, realisation in ((c, r) for c in args.cases for r in range(args.realisations)):
            started = time.perf_counter()
            logs = build(case, seed, args.engine, realisation)
            print(f"{case} seed {seed}: logs in {time.perf_counter() - started:.1f} s", flush=True)
            if any(name in DESIGNED for fit in args.fits for name in FITS[fit]):
                logs = designed_logs(logs, case, seed, realisation)
            for fit in args.fits:
                started = time.perf_counter()
                row = score(logs, FITS[fit], args.overrides)
                row = {"seed": seed, "noise": realisation, "positions": case, "fit": fit} | row
                row["s"] = round(time.perf_counter() - started, 1)
                print(
                    "  ",
                    {k: (round(v, 4) if isinstance(v, float) else v) for k, v in row.items()},
                    flush=True,
                )
                rows.append(row)
    if args.real:
        for subject in real_subjects()[:1]:
            _, report = identify(subject.overrides + args.overrides)
            row = {"positions": "real", "fit": subject.name} | prediction_scores(subject, report)
            print("  ", row, flush=True)
            rows.append(row)
    columns = [
        "seed",
        "noise",
        "positions",
        "fit",
        "error %",
        "moving %",
        "standing %",
        "noise floor %",
        "law",
    ]
    table = pd.DataFrame(rows)
    print(table[[c for c in columns if c in table]].to_markdown(index=False, floatfmt=".4g"))
    if args.realisations > 1:  # the spread over the noise: the worst draw against the median
        spread = table.groupby(["seed", "positions", "fit"])["moving %"].agg(["median", "max"])
        spread["worst / median"] = spread["max"] / spread["median"]
        print("\n## Over the noise's draws (moving %)\n")
        print(spread.reset_index().to_markdown(index=False, floatfmt=".4g"))


if __name__ == "__main__":
    main()
