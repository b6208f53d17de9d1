"""Speed of the exciting-motion optimisation, and of its analytic gradient against finite differences.

On the KUKA LWR4 (``conf/robot/kuka_lwr4.yaml``), for the paper's problem — 10 s quintic B-spline
through 11 via points per joint (77 variables), 100 Hz grid, ``logdet`` criterion, every constraint
of eq. (10)–(11) — it measures, in the same run:

1. one analytic gradient of the criterion (``ExcitationProblem.objective_gradient``) against one
   central finite-difference gradient (2 × 77 criterion evaluations), median of ``--repeat``, with
   the largest relative difference between the two;
2. the derivatives of the regressor on 100 samples: the forward-mode recursion
   (``regressor_jacobians``) against Pinocchio's ``computeRNEADerivatives`` called column by column
   (``regressor_jacobians_pinocchio``), and the vector–Jacobian product the optimiser uses;
3. the wall time of whole optimisations (one start each) for ``--seeds`` seeds: median, spread,
   criterion and iterations.

Usage::

    .venv/bin/python benchmarks/excitation.py --seeds 0 1 2 --repeat 5
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from lwrlab.dynamics.base_parameters import compute_base_parameters, random_states
from lwrlab.dynamics.regressor import regressor
from lwrlab.dynamics.regressor_derivatives import regressor_jacobians, regressor_jacobians_pinocchio, regressor_vjp
from lwrlab.excitation.problem import ExcitationProblem
from lwrlab.excitation.solver import SlsqpOptimizer
from lwrlab.numerics.threads import blas_threads
from plugins.criteria.logdet import LogDet
from plugins.robots.mdh import load_robot_yaml
from plugins.trajectories.bspline import BSplineMotion

REPO = Path(__file__).resolve().parents[1]


def median_seconds(function: Callable[[], object], repeat: int) -> float:
    """Median wall time (s) of ``repeat`` calls, after one warm-up call."""
    function()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def finite_difference_gradient(problem: ExcitationProblem, x: np.ndarray, step: float = 1e-6) -> np.ndarray:
    """Central differences of the criterion, one variable at a time (the baseline)."""
    gradient = np.empty_like(x)
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = step
        gradient[i] = (problem.objective(x + e) - problem.objective(x - e)) / (2 * step)
    return gradient


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="seeds of the timed optimisations")
    parser.add_argument("--repeat", type=int, default=5, help="repetitions of each gradient timing")
    parser.add_argument("--duration", type=float, default=10.0, help="motion duration T_F (s)")
    parser.add_argument("--max-iterations", type=int, default=200)
    args = parser.parse_args()
    with blas_threads(1):  # as the optimiser runs
        run(args)


def run(args: argparse.Namespace) -> None:
    """The three measurements of the module docstring."""
    robot = load_robot_yaml(REPO / "conf" / "robot" / "kuka_lwr4.yaml")
    base = compute_base_parameters(robot)
    problem = ExcitationProblem(robot, BSplineMotion(duration=args.duration), LogDet(), base=base)
    rng = np.random.default_rng(0)
    x = problem.parameterisation.initial_coefficients(robot, rng, 0.3).ravel()

    print(f"robot {robot.name}: {base.count} base parameters, {problem.n_variables} variables, "
          f"{len(problem.times)} samples at {problem.rate_hz:g} Hz, {len(problem.constraint_labels())} aggregated constraints")

    # 1. analytic gradient vs central finite differences
    def analytic() -> np.ndarray:
        problem._cache = None  # time the whole chain, not the cache
        return problem.objective_gradient(x)

    t_analytic = median_seconds(analytic, args.repeat)
    t_fd = median_seconds(lambda: finite_difference_gradient(problem, x), max(1, args.repeat // 2))
    g_analytic, g_fd = analytic(), finite_difference_gradient(problem, x)
    gap = np.abs(g_analytic - g_fd).max() / np.abs(g_fd).max()
    print("\n| criterion gradient (logdet, 10 s) | time [ms] | ratio |")
    print("|---|---|---|")
    print(f"| analytic (regressor VJP + B-spline pull-back) | {1e3 * t_analytic:.1f} | 1 |")
    print(f"| central finite differences ({2 * x.size} evaluations) | {1e3 * t_fd:.1f} | {t_fd / t_analytic:.1f}× slower |")
    print(f"largest relative difference analytic vs finite differences: {gap:.2e}")

    # 2. regressor derivatives: forward-mode recursion vs Pinocchio column by column
    states = random_states(robot, 100, rng)
    t_ours = median_seconds(lambda: regressor_jacobians(robot, *states), args.repeat)
    t_pin = median_seconds(lambda: regressor_jacobians_pinocchio(robot, *states), 1)
    weights = rng.normal(size=(100, robot.n_joints, robot.n_parameters))
    t_vjp = median_seconds(lambda: regressor_vjp(robot, *states, weights), args.repeat)
    t_w = median_seconds(lambda: regressor(robot, *states), args.repeat)
    print("\n| ∂W/∂(q, q̇, q̈) on 100 samples | time [ms] | ratio |")
    print("|---|---|---|")
    print(f"| regressor W itself | {1e3 * t_w:.2f} | |")
    print(f"| vector–Jacobian product (what the optimiser uses) | {1e3 * t_vjp:.2f} | |")
    print(f"| full tensors, forward-mode recursion | {1e3 * t_ours:.2f} | 1 |")
    print(f"| full tensors, Pinocchio computeRNEADerivatives per column | {1e3 * t_pin:.1f} | {t_pin / t_ours:.1f}× slower |")

    # 3. whole optimisations
    rows = []
    for seed in args.seeds:
        result = SlsqpOptimizer(max_iterations=args.max_iterations, seed=seed, show_progress=False).solve(problem)
        rows.append(result)
        print(f"seed {seed}: {result.seconds:.1f} s, {result.iterations} iterations, J = {result.cost:.3f}", flush=True)
    seconds = [r.seconds for r in rows]
    print("\n| optimisation (10 s, 7 joints, logdet, all constraints, 1 start) | value |")
    print("|---|---|")
    print(f"| median wall time [s] | {statistics.median(seconds):.1f} (min {min(seconds):.1f}, max {max(seconds):.1f}, {len(seconds)} seeds) |")
    print(f"| median iterations | {statistics.median([r.iterations for r in rows]):.0f} |")
    print(f"| criterion J (best, worst) | {min(r.cost for r in rows):.2f}, {max(r.cost for r in rows):.2f} |")


if __name__ == "__main__":
    main()
