"""Exciting motions for the arm of a bigger robot, taken from its whole description by its chain.

TALOS's left arm (``talos_full_v2.urdf`` + ``talos.srdf``, legs, torso, head and right arm locked) and
TIAGo Pro's left arm (``tiago_pro.urdf``, wheels, torso, head and right arm locked), both from
example-robot-data, no joint listed by hand: the default 10 s ``task=excitation`` motion (one SLSQP
start, every constraint, the floor under the robot), then lwrlab's exact 1 kHz check. Prints, per arm,
the pairs the optimiser keeps apart, its constraints, the time to build the collision scene, the
optimisation (wall and CPU time: on a shared machine the CPU time is the steadier), the exact check,
the closest approaches and the cost (so that two versions can be compared motion for motion).

    nice -n 10 .venv/bin/python benchmarks/bigger_robot_arms.py [--arms talos tiago_pro] [--profile OUT]
"""

from __future__ import annotations

import argparse
import cProfile
import json
import time

import numpy as np

from lwrlab.excitation.motion_check import check_motion_at
from lwrlab.pipeline.build import build
from plugins.robots.example_robot import example_robot_file

ARMS = {
    "talos": {
        "path": "talos_data/robots/talos_full_v2.urdf",
        "srdf": "talos_data/srdf/talos.srdf",
        "chain": ["torso_2_link", "arm_left_7_link"],
    },
    "tiago_pro": {
        "path": "tiago_pro_description/robots/tiago_pro.urdf",
        "srdf": None,
        "chain": ["torso_lift_link", "arm_left_7_link"],
    },
}


def measure(name: str, seed: int, profile: str | None) -> dict[str, object]:
    arm = ARMS[name]
    srdf = arm["srdf"]
    robot = build(
        "robot",
        "urdf",
        path=example_robot_file(str(arm["path"])),
        srdf=None if srdf is None else example_robot_file(str(srdf)),
        chain=arm["chain"],
        acceleration_limits=10.0,
    )
    optimizer = build("optimizer", "slsqp", show_progress=False, seed=seed)
    source = build("trajectory", "optimal", from_file=None, optimizer=optimizer)
    clock = time.perf_counter()
    scene = source.constraints.scene(robot)
    scene_s = time.perf_counter() - clock
    profiler = cProfile.Profile() if profile else None
    clock, cpu = time.perf_counter(), time.process_time()
    if profiler is not None:
        profiler.enable()
    motion, result, problem = source.optimise(robot)
    if profiler is not None:
        profiler.disable()
        profiler.dump_stats(f"{profile}_{name}.prof")
    optimise_s, optimise_cpu_s = time.perf_counter() - clock, time.process_time() - cpu
    check = check_motion_at(robot, motion, source.constraints, 1000.0)
    collisions = check.collisions
    assert collisions is not None
    closest_self, closest_world = collisions.closest("self"), collisions.closest("world")
    return {
        "arm": name,
        "pairs": len(scene.self_pairs) + len(scene.world_pairs),
        "constraints": int(np.size(problem.constraint_values(result.coefficients.ravel()))),
        "scene [s]": round(scene_s, 1),
        "optimisation [s]": round(optimise_s, 1),
        "optimisation CPU [s]": round(optimise_cpu_s, 1),
        "check [s]": round(collisions.seconds, 2),
        "passed": check.passed,
        "contacts": len(collisions.contacts),
        "closest to itself [mm]": round(1000 * closest_self.distance, 1) if closest_self else None,
        "closest to the world [mm]": round(1000 * closest_world.distance, 1) if closest_world else None,
        "iterations": result.iterations,
        "evaluations": result.evaluations,
        "cost": round(float(result.cost), 6),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arms", nargs="+", default=list(ARMS), choices=list(ARMS))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--profile", default=None, help="write cProfile stats of the optimisation here")
    args = parser.parse_args()
    for name in args.arms:
        print(json.dumps(measure(name, args.seed, args.profile)), flush=True)


if __name__ == "__main__":
    main()
