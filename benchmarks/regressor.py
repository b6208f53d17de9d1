"""Throughput of the batched regressor against a plain loop over Pinocchio, in the same run.

For a 7-joint LWR4-like arm (``conf/robot/kuka_lwr4.yaml`` if it exists, otherwise the modified-DH
table of the KUKA LWR4 with random physically consistent segments) and N random states, it times

* ``regressor(robot, q, dq, ddq)``: the full regressor, inertial and friction columns, (N·N_J, P), by
  the vectorised recursion from ``SMALL_BATCH`` samples on and by the Pinocchio loop below (the
  "engine" column);
* the baseline, a Python loop of ``pin.computeJointTorqueRegressor`` stacked into one (N, N_J, 10·N_J)
  array (the loop alone: no column permutation, no friction columns);

and prints samples per second of each (best of ``--repeat``), their ratio, and the largest absolute
difference between the two inertial regressors (after putting Pinocchio's columns in standard order).

Usage::

    .venv/bin/python benchmarks/regressor.py --samples 100 1000 10000 --repeat 5
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
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


def pinocchio_loop(model: pin.Model, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
    """Baseline: one ``pin.computeJointTorqueRegressor`` per sample, stacked into (N, N_J, 10·N_J)."""
    data = model.createData()
    out = np.empty((q.shape[0], model.nv, 10 * (model.njoints - 1)))
    for k in range(q.shape[0]):
        out[k] = pin.computeJointTorqueRegressor(model, data, q[k], dq[k], ddq[k])
    return out


def best_times(functions: list[Callable[[], object]], repeat: int) -> list[float]:
    """Shortest wall-clock time (s) of each function over ``repeat`` rounds.

    The functions take turns within each round, so that a machine whose speed drifts (a shared or
    virtual one) slows them alike and their ratio stays meaningful.
    """
    best = [np.inf] * len(functions)
    for _ in range(repeat):
        for i, function in enumerate(functions):
            start = time.perf_counter()
            function()
            best[i] = min(best[i], time.perf_counter() - start)
    return best


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--samples", type=int, nargs="+", default=[100, 1000, 10000], help="numbers of samples N"
    )
    parser.add_argument("--repeat", type=int, default=5, help="timed calls per N (the best one counts)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random segments and states")
    args = parser.parse_args(argv)

    robot = lwr4_like_robot(args.seed)
    model, n = robot.model, robot.n_joints
    rng = np.random.default_rng(args.seed)
    print(f"robot {robot.name}: {n} joints, {robot.n_parameters} parameters, best of {args.repeat}")
    print(
        f"{'N':>8} {'engine':>10} {'ours [samples/s]':>18} {'loop [samples/s]':>18} {'ratio':>7} {'max |diff|':>11}"
    )
    for n_samples in args.samples:
        q = rng.uniform(robot.limits.position_lower, robot.limits.position_upper, (n_samples, n))
        dq = rng.uniform(-robot.limits.velocity, robot.limits.velocity, (n_samples, n))
        ddq = rng.uniform(-robot.limits.acceleration, robot.limits.acceleration, (n_samples, n))

        ours = regressor(robot, q, dq, ddq, stacked=False)
        looped = pinocchio_loop(model, q, dq, ddq)
        standard = looped.reshape(n_samples, n, -1, 10)[..., PIN_TO_STANDARD].reshape(n_samples, n, -1)
        difference = float(np.max(np.abs(ours[:, :, : standard.shape[2]] - standard)))

        t_ours, t_loop = best_times(
            [lambda: regressor(robot, q, dq, ddq), lambda: pinocchio_loop(model, q, dq, ddq)], args.repeat
        )
        rate_ours, rate_loop = n_samples / t_ours, n_samples / t_loop
        engine = "loop" if n_samples < SMALL_BATCH else "recursion"
        print(
            f"{n_samples:>8} {engine:>10} {rate_ours:>18,.0f} {rate_loop:>18,.0f} {rate_ours / rate_loop:>7.2f} {difference:>11.1e}"
        )


if __name__ == "__main__":
    main()
