"""Throughput of the batched regressor against a plain loop over Pinocchio, in the same run.

For a 7-joint LWR4-like arm (``conf/robot/kuka_lwr4.yaml`` if it exists, otherwise the modified-DH
table of the KUKA LWR4 with random physically consistent segments) and N random states, it times

* ``regressor(robot, q, dq, ddq)``: the full regressor, inertial and friction columns, (N·N_J, P), by
  the vectorised recursion from ``SMALL_BATCH`` samples on and by the Pinocchio loop below it (the
  "engine" column);
* the baseline, the same (N, N_J, P) array by a plain Python loop: one
  ``pin.computeJointTorqueRegressor`` per sample stacked into an (N, N_J, 10·N_J) array, one
  ``np.take`` of its columns in the standard order (each segment's 10 from Pinocchio's order
  ``[m, mc, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]``) into a zeroed (N, N_J, P) array, and the friction
  columns (sign(q̇), q̇ or 1 on their diagonals);
* for reference, the bare loop of Pinocchio calls alone (no column order, no friction columns);

and prints samples per second of each (best of ``--repeat``), the ratio of ours to the baseline and
to the bare loop, and the largest absolute difference between ours and the baseline.

Usage::

    .venv/bin/python benchmarks/regressor.py --samples 100 1000 10000 --repeat 5 [--clock cpu]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path

import numpy as np
import pinocchio as pin

from lwrlab.dynamics.regressor import SMALL_BATCH, regressor
from lwrlab.model.dh import ModifiedDH, build_dh_model
from lwrlab.model.inertia import PIN_TO_STANDARD, random_consistent_parameters, to_pin_inertia
from lwrlab.model.robot import Friction, JointLimits, RobotModel

REPO = Path(__file__).resolve().parents[1]
LWR4_YAML = REPO / "conf" / "robot" / "kuka_lwr4.yaml"

LWR4_MDH = ModifiedDH(
    alpha=np.array([0.0, np.pi / 2, -np.pi / 2, -np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2]),
    d=np.zeros(7),
    r=np.array([0.3105, 0.0, 0.4, 0.0, 0.39, 0.0, 0.0]),
    theta_offset=np.zeros(7),
)
"""Modified DH table of the KUKA LWR4 (Khalil–Kleinfinger: α rad, d and r m)."""


def lwr4_like_robot(seed: int = 0) -> RobotModel:
    """The LWR4 from its YAML description if present, else its DH table with random consistent segments."""
    if LWR4_YAML.is_file():
        from plugins.robots.mdh import load_robot_yaml

        return load_robot_yaml(LWR4_YAML)
    rng = np.random.default_rng(seed)
    n = LWR4_MDH.n_joints
    inertias = [to_pin_inertia(random_consistent_parameters(rng)) for _ in range(n)]
    model = build_dh_model(LWR4_MDH, inertias, np.array([0.0, 0.0, -9.81]))
    ones = np.ones(n)
    limits = JointLimits(-2.9 * ones, 2.9 * ones, 2.0 * ones, 10.0 * ones, 100.0 * ones)
    friction = Friction(
        coulomb=rng.uniform(0.5, 3.0, n), viscous=rng.uniform(0.5, 3.0, n), offset=np.zeros(n)
    )
    return RobotModel(name="lwr4_like", model=model, limits=limits, friction=friction)


def bare_loop(model: pin.Model, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
    """One ``pin.computeJointTorqueRegressor`` per sample into (N, N_J, 10·N_J), in Pinocchio's order."""
    data = model.createData()
    out = np.empty((q.shape[0], model.nv, 10 * (model.njoints - 1)))
    for k in range(q.shape[0]):
        out[k] = pin.computeJointTorqueRegressor(model, data, q[k], dq[k], ddq[k])
    return out


FRICTION_BASIS = {"coulomb": np.sign, "viscous": lambda v: v, "offset": np.ones_like}


def baseline_loop(robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
    """Baseline: ``regressor(robot, q, dq, ddq, stacked=False)`` by the bare loop, a permutation, friction."""
    n_samples, n = q.shape
    pinocchio_order = bare_loop(robot.model, q, dq, ddq)
    n_inertial = pinocchio_order.shape[2]
    standard_columns = (10 * np.arange(n_inertial // 10)[:, None] + PIN_TO_STANDARD).ravel()
    out = np.zeros((n_samples, n, robot.n_parameters))
    out[:, :, :n_inertial] = np.take(pinocchio_order, standard_columns, axis=2)
    joints = np.arange(n)
    for t, term in enumerate(robot.friction_terms):
        out[:, joints, n_inertial + t * n + joints] = FRICTION_BASIS[term](dq)
    return out


CLOCKS = {"wall": time.perf_counter, "cpu": time.thread_time}
"""Wall-clock time, or the CPU time of this thread (every product here runs on it: Pinocchio, and
BLAS on one thread). On a loaded machine the best wall-clock time favours the calls short enough to
run within one scheduler slice; CPU time does not count the time the thread waits for a core."""


def best_times(functions: list[Callable[[], object]], repeat: int, clock: str = "wall") -> list[float]:
    """Shortest time (s) of each function over ``repeat`` rounds, by the clock named (:data:`CLOCKS`).

    The functions take turns within each round, so that a machine whose speed drifts (a shared or
    virtual one) slows them alike and their ratio stays meaningful.
    """
    now = CLOCKS[clock]
    best = [np.inf] * len(functions)
    for _ in range(repeat):
        for i, function in enumerate(functions):
            start = now()
            function()
            best[i] = min(best[i], now() - start)
    return best


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--samples", type=int, nargs="+", default=[100, 1000, 10000], help="numbers of samples N"
    )
    parser.add_argument("--repeat", type=int, default=5, help="timed calls per N (the best one counts)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random segments and states")
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="wall", help="what is timed (see CLOCKS)")
    args = parser.parse_args(argv)

    robot = lwr4_like_robot(args.seed)
    model, n = robot.model, robot.n_joints
    rng = np.random.default_rng(args.seed)
    print(
        f"robot {robot.name}: {n} joints, {robot.n_parameters} parameters,"
        f" best {args.clock} time of {args.repeat}"
    )
    print(
        f"{'N':>8} {'engine':>10} {'ours [samples/s]':>17} {'baseline':>10} {'bare loop':>10}"
        f" {'ratio':>6} {'vs bare':>8} {'max |diff|':>11}"
    )
    for n_samples in args.samples:
        q = rng.uniform(robot.limits.position_lower, robot.limits.position_upper, (n_samples, n))
        dq = rng.uniform(-robot.limits.velocity, robot.limits.velocity, (n_samples, n))
        ddq = rng.uniform(-robot.limits.acceleration, robot.limits.acceleration, (n_samples, n))

        ours = regressor(robot, q, dq, ddq, stacked=False)
        difference = float(np.max(np.abs(ours - baseline_loop(robot, q, dq, ddq))))

        times = best_times(
            [
                partial(regressor, robot, q, dq, ddq),
                partial(baseline_loop, robot, q, dq, ddq),
                partial(bare_loop, model, q, dq, ddq),
            ],
            args.repeat,
            args.clock,
        )
        rate_ours, rate_baseline, rate_bare = (n_samples / t for t in times)
        engine = "loop" if n_samples < SMALL_BATCH else "recursion"
        print(
            f"{n_samples:>8} {engine:>10} {rate_ours:>17,.0f} {rate_baseline:>10,.0f} {rate_bare:>10,.0f}"
            f" {rate_ours / rate_baseline:>6.2f} {rate_ours / rate_bare:>8.2f} {difference:>11.1e}"
        )


if __name__ == "__main__":
    main()
