"""Exciting motions for robots nobody here wrote, each checked independently against its own meshes.

For every arm of ``example-robot-data`` that ``robot=example_robot`` loads (Panda with hand and SRDF,
UR3/UR5/UR10, xArm7, Z1, Kinova Gen2 with its continuous joints) it optimises the default 10 s
``logdet`` exciting motion with every constraint (limits, torques, self-collision, the mounting
surface), one start, and reports:

* the optimiser's wall time and cond(W_b) of the optimum;
* the same motion optimised **without** collision constraints (self_collision off, no world): its
  cond(W_b) is the baseline the collision-free motion is compared with (the ratio);
* lwrlab's own exact 1 kHz check (closest approach to itself and to the world, its time);
* an **independent** check that shares no code with lwrlab's: Pinocchio's URDF and SRDF parsers,
  ``pin.computeCollisions`` on the URDF's collision meshes at every 1 kHz sample (padding = the
  clearance), and the lowest mesh vertex above the mounting surface — poses in contact counted.

Usage::

    .venv/bin/python benchmarks/own_robot_motion.py [--robots panda ur5] [--seed 0]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from independent_mesh_check import independent_check  # beside this script

from lwrlab.excitation.solver import check_motion_at
from lwrlab.pipeline.build import build
from lwrlab.pipeline.excitation import regressor_condition
from plugins.robots.example_robot import ROBOTS, example_robot_file

DEFAULT_ACCELERATION = 10.0
"""rad/s² where the manufacturer publishes none."""


def mesh_check(name: str, q: np.ndarray, clearance: float) -> tuple[int, int, float]:
    """:func:`independent_mesh_check.independent_check` of the arm ``name`` from its own files."""
    entry = ROBOTS[name]
    urdf = example_robot_file(entry.urdf)
    share = urdf[: urdf.index("/example-robot-data/")]
    srdf = None if entry.srdf is None else example_robot_file(entry.srdf)
    return independent_check(urdf, share, q, clearance, srdf, dict(entry.locked_joints))


def measure(name: str, seed: int) -> dict[str, object]:
    entry = ROBOTS[name]
    acceleration = None if entry.acceleration_limits is not None else DEFAULT_ACCELERATION
    robot = build("robot", "example_robot", robot_name=name, acceleration_limits=acceleration)
    optimizer = build("optimizer", "slsqp", show_progress=False, seed=seed)
    source = build("trajectory", "optimal", from_file=None, optimizer=optimizer)
    clock = time.perf_counter()
    motion, result, problem = source.optimise(robot)
    optimise_s = time.perf_counter() - clock
    check = check_motion_at(robot, motion, source.constraints, 1000.0)
    q, dq, ddq = (b @ result.coefficients for b in problem.bases)
    cond = regressor_condition(robot, q, dq, ddq, problem.base)
    free_constraints = {"self_collision": False, "world": {"mounting_surface": None, "obstacles": []}}
    free_source = build(
        "trajectory", "optimal", from_file=None, optimizer=optimizer, constraints=free_constraints
    )
    _, free_result, free_problem = free_source.optimise(robot)
    fq, fdq, fddq = (b @ free_result.coefficients for b in free_problem.bases)
    free_cond = regressor_condition(robot, fq, fdq, fddq, free_problem.base)
    sampled = motion.sample(robot, 1000.0)
    self_contacts, below, lowest = mesh_check(name, sampled.q, source.constraints.clearance)
    collisions = check.collisions
    assert collisions is not None
    closest_self, closest_world = collisions.closest("self"), collisions.closest("world")
    return {
        "robot": name,
        "joints": robot.n_joints,
        "optimiser [s]": round(optimise_s, 1),
        "cond": round(cond, 2),
        "cond without collisions": round(free_cond, 2),
        "ratio": round(cond / free_cond, 3),
        "closest to itself [mm]": round(1000 * closest_self.distance, 1) if closest_self else None,
        "closest to the world [mm]": round(1000 * closest_world.distance, 1) if closest_world else None,
        "check [s]": round(collisions.seconds, 2),
        "accepted": check.passed,
        "independent: poses in self-contact": self_contacts,
        "independent: poses below the surface": below,
        "independent: lowest point [mm]": round(1000 * lowest, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--robots", nargs="*", default=sorted(ROBOTS))
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    import pandas as pd

    rows = []
    for name in args.robots:
        print(f"{name} …", flush=True)
        rows.append(measure(name, args.seed))
        print(pd.DataFrame(rows[-1:]).to_markdown(index=False), flush=True)
    print("\n## Exciting motions of robots nobody here wrote\n")
    print(pd.DataFrame(rows).to_markdown(index=False))


if __name__ == "__main__":
    main()
