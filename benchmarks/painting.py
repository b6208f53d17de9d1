"""Speed of the painting stage: the 1 kHz contact loop and the painting-path optimisation (eq. 12).

On the KUKA LWR4 (``conf/robot/kuka_lwr4.yaml``) carrying the large roller, pressing −30 N on the
wall of §VI.B along the large roller's optimised path (README, Table IV), it measures in one run:

1. the contact loop in simulated seconds per wall-clock second (and per CPU second of the process:
   on a shared machine the waits for a core drop out), for
   - the five runs a painting task makes of one path — force PI on the estimated and on the sensed
     force, each with the CAD model and with a perturbed one (as the identified model), and the
     position controller — stepped together (:func:`lwrlab.control.contact_loop.simulate_contacts`):
     the throughput over all five, and each run's real-time factor;
   - the same five runs one after another, each a batch of one (:func:`simulate_contact`);
   - one run alone (force PI, estimated force, CAD model);
   - the per-sample loop it replaced (``painting_reference.PerSampleLoop``: one single-pose IK call
     per period, filters one object call each, ``np.linalg.solve``, sensor noise drawn per sample);
   - the floor: MuJoCo alone (the plant's calls per period: the acceleration stage + an Euler step,
     a step without sensors, one ``mj_forward``) replaying the torques of the run alone, no Python
     around it but the calls themselves;
   with the largest difference between each run of the batch and that run alone, and between the
   run alone and the per-sample loop (normal forces);
2. the painting-path optimisation of that roller (2 SLSQP starts) with analytic gradients against
   SLSQP's finite differences, with the costs reached.

Usage::

    .venv/bin/python benchmarks/painting.py --seconds 8 --reference-seconds 3 --repeat 2
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np
from painting_reference import (
    BRANCH,
    ESTIMATOR,
    PATH,
    PERIOD,
    REPO,
    TASK,
    WALL,
    Case,
    PerSampleLoop,
    make_case,
)

from lwrlab.control.contact_loop import ContactCase, ContactRun, simulate_contact, simulate_contacts
from lwrlab.control.force_estimation import ExternalForceEstimator
from lwrlab.control.joint_pd import ControlSetup
from lwrlab.kinematics.swivel_ik import SwivelIK
from lwrlab.pipeline.build import build
from lwrlab.pipeline.painting import path_problem
from lwrlab.pipeline.tools.library import load_tool
from lwrlab.planning.path_optimisation import GRADIENTS, optimise_path
from lwrlab.plants.simulation import perturbed_robot
from plugins.controllers.force_pi import ForcePIControl
from plugins.robots.mdh import load_robot_yaml

FIELDS = ("commanded", "actual", "estimated_wrench", "measured_force", "q", "q_desired", "tau")
"""What a contact run records, compared between a batch and its runs alone."""


def force_pi(feedback: str) -> ForcePIControl:
    """The force controller of conf/controller/force_pi.yaml with ``feedback`` (estimate | sensor)."""
    return build("controller", "force_pi", feedback=feedback)


def estimator(case: Case, model) -> ExternalForceEstimator:
    """Eq. (14) on ``model`` with the painting task's ``estimator`` settings."""
    return ExternalForceEstimator(model, case.tcp, PERIOD, **ESTIMATOR)


def painting_cases(case: Case) -> list[ContactCase]:
    """The five runs of one path in the painting task: force PI (estimate, sensor) × (CAD model, a
    perturbed model standing for the identified one), then the position controller
    (conf/controller/position.yaml: 2 mm in)."""
    perturbed = perturbed_robot(case.model, 0.05, 0.1, np.random.default_rng(1))
    runs = [
        (model, force_pi(feedback))
        for model in (case.model, perturbed)
        for feedback in ("estimate", "sensor")
    ]
    runs.append((case.model, build("controller", "position")))
    return [
        ContactCase(
            case.plant(),
            controller,
            estimator(case, model),
            ControlSetup(model, SwivelIK(model), case.tcp, PATH.swivel, BRANCH, PERIOD),
            case.start,
        )
        for model, controller in runs
    ]


def together(case: Case) -> list[ContactRun]:
    """The five runs stepped together: the painting stage's loop."""
    return simulate_contacts(painting_cases(case), case.reference, case.painting)


def after_another(case: Case) -> list[ContactRun]:
    """The five runs one after another, each a batch of one."""
    return [
        simulate_contact(c.plant, c.controller, c.estimator, c.setup, case.reference, case.painting, c.start)
        for c in painting_cases(case)
    ]


def alone(case: Case) -> ContactRun:
    """One run: force PI on the estimated force, CAD model."""
    return simulate_contact(
        case.plant(),
        force_pi("estimate"),
        estimator(case, case.model),
        case.setup(),
        case.reference,
        case.painting,
        case.start,
    )


def mujoco_floor(case: Case, tau: np.ndarray) -> None:
    """MuJoCo alone, the calls the plant makes per period, replaying ``tau`` (N, 7) N·m: the acceleration
    stage and an Euler step, a step without sensors, a full ``mj_forward`` (the reading)."""
    plant = case.plant()
    model, data = plant.model, plant.data
    data.qpos[:] = case.setup().joint_reference(case.start)
    mujoco.mj_forward(model, data)
    applied = data.qfrc_applied
    acceleration_stage, every_stage = int(mujoco.mjtStage.mjSTAGE_VEL), int(mujoco.mjtStage.mjSTAGE_NONE)
    for row in tau:
        applied[:] = row
        mujoco.mj_forwardSkip(model, data, acceleration_stage, 1)
        mujoco.mj_Euler(model, data)
        mujoco.mj_forwardSkip(model, data, every_stage, 1)
        mujoco.mj_Euler(model, data)
        mujoco.mj_forward(model, data)


def timed(function, *args):
    """(result, wall time in s) of one call."""
    start = time.perf_counter()
    result = function(*args)
    return result, time.perf_counter() - start


def cpu_timed(function, *args):
    """(result, [wall time, CPU time of this process] in s) of one call: on a shared machine the CPU
    time leaves out the waits for a core, closer to what a machine of one's own would do."""
    wall, cpu = time.perf_counter(), time.process_time()
    result = function(*args)
    return result, np.array([time.perf_counter() - wall, time.process_time() - cpu])


def largest_difference(first: list[ContactRun], second: list[ContactRun]) -> float:
    """Largest absolute difference of any recorded value between paired runs."""
    return max(
        float(np.abs(getattr(a, name) - getattr(b, name)).max())
        for a, b in zip(first, second, strict=True)
        for name in FIELDS
    )


def contact_loop_figures(seconds: float, reference_seconds: float, repeat: int) -> None:
    case, short = make_case(seconds), make_case(reference_seconds)
    run = alone(case)  # the torques the floor replays
    loops = {
        "together": (lambda: together(case), 5 * seconds, 5),
        "after another": (lambda: after_another(case), 5 * seconds, 5),
        "alone": (lambda: alone(case), seconds, 1),
        "per-sample": (lambda: PerSampleLoop(short).run(), reference_seconds, 1),
        "floor": (lambda: mujoco_floor(case, run.tau), seconds, 1),
    }
    # interleaved rounds: a change of load on a shared machine hits every loop alike
    best = {name: np.array([np.inf, np.inf]) for name in loops}
    for _ in range(repeat):
        for name, (loop, _, _) in loops.items():
            best[name] = np.minimum(best[name], cpu_timed(loop)[1])
    labels = {
        "together": "5 runs together (the painting stage)",
        "after another": "5 runs one after another",
        "alone": "1 run alone",
        "per-sample": "per-sample loop (before batching)",
        "floor": "MuJoCo alone (floor, 1 run)",
    }
    print("## Contact loop (1 kHz, 2 MuJoCo substeps)\n")
    print("| loop | simulated s per wall s, all runs | each run | all runs, per CPU s |\n|---|---|---|---|")
    rate = {name: simulated / best[name] for name, (_, simulated, _) in loops.items()}  # [wall, CPU]
    for name, (_, _, runs) in loops.items():
        wall, cpu = rate[name]
        print(f"| {labels[name]} | {wall:.1f} | {wall / runs:.1f} | {cpu:.1f} |")

    def ratio(a: str, b: str) -> str:
        return f"{rate[a][0] / rate[b][0]:.1f}x (CPU time: {rate[a][1] / rate[b][1]:.1f}x)"

    print(f"\n5 runs together / one after another: {ratio('together', 'after another')} the throughput")
    print(f"5 runs together / per-sample loop: {ratio('together', 'per-sample')} the throughput")
    print(f"1 run alone / per-sample loop: {ratio('alone', 'per-sample')} faster")
    print(f"MuJoCo's share of a run alone: {rate['alone'][0] / rate['floor'][0]:.0%} (wall time)")
    batch_gap = largest_difference(together(short), after_another(short))
    reference, mine = PerSampleLoop(short).run(), alone(short)
    estimate_gap = np.abs(mine.estimated_wrench[:, 0] - reference.estimated_wrench[:, 0]).max()
    measured_gap = np.abs(mine.measured_force[:, 0] - reference.measured_force[:, 0]).max()
    print(
        f"over the first {reference_seconds:g} s: each run of the batch differs from that run alone by "
        f"at most {batch_gap:.1e} (any recorded value); the run alone and the per-sample loop's normal "
        f"forces by {estimate_gap:.2e} N (estimated) and {measured_gap:.2e} N (measured, unfiltered)"
    )
    painting = run.painting
    if painting.any():
        print(f"run alone: mean measured F_x while painting {run.measured_force[painting, 0].mean():.2f} N")


def optimisation_figures(starts: tuple[float, ...], repeat: int) -> None:
    robot = load_robot_yaml(REPO / "conf" / "robot" / "kuka_lwr4.yaml")
    tool = load_tool("large_roller")
    n_steps = TASK["n_steps"][tool.name]
    problem = path_problem(robot, tool.parameters, tool, WALL, n_steps, TASK["path"])
    title = f"Painting-path optimisation (eq. 12), large roller, N_r = {n_steps}, {len(starts)} SLSQP starts"
    print(f"\n## {title}\n")
    print("| gradients | time (s) | iterations | cost |\n|---|---|---|---|")
    times, solutions = dict.fromkeys(GRADIENTS, np.inf), {}
    for _ in range(repeat):  # interleaved, as the loops
        for gradients in GRADIENTS:
            solutions[gradients], seconds = timed(
                lambda g=gradients: optimise_path(problem, starting_swivels=starts, gradients=g)
            )
            times[gradients] = min(times[gradients], seconds)
    for gradients, solution in solutions.items():
        cost = sum(solution.cost_terms.values())
        print(f"| {gradients} | {times[gradients]:.2f} | {solution.iterations} | {cost:.4f} |")
    print(f"\nanalytic / finite differences: {times['finite_differences'] / times['analytic']:.1f}x faster")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--seconds", type=float, default=6.0, help="simulated seconds of every run of the loop and the floor"
    )
    parser.add_argument(
        "--reference-seconds", type=float, default=3.0, help="simulated seconds of the slow per-sample loop"
    )
    parser.add_argument(
        "--starts",
        type=float,
        nargs="+",
        default=TASK["path"]["starting_swivels"],
        help="starting swivel angles of the optimisation (rad); default: the painting task's",
    )
    parser.add_argument(
        "--repeat",
        type=int,
        default=2,
        help="interleaved rounds of every measurement; each one's least time is reported "
        "(the one other jobs on a shared machine disturbed least)",
    )
    args = parser.parse_args()
    contact_loop_figures(args.seconds, args.reference_seconds, args.repeat)
    optimisation_figures(tuple(args.starts), args.repeat)


if __name__ == "__main__":
    main()
