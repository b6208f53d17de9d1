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
   and, on the optimisation grid, the reverse-mode VJP against the forward-mode tangents contracted
   (the baseline, how the VJP worked before);
3. the wall time of whole optimisations (one start each) for ``--seeds`` seeds: median, spread,
   criterion and iterations;
4. ``logdet`` (the baseline) against the smooth ``cond`` and the exact σ_max/σ_min: time and
   iterations with their ratios to logdet, and the condition number of the optimum resampled at
   1 kHz (the quality the criterion is after).

Usage::

    .venv/bin/python benchmarks/excitation.py --seeds 0 1 2 --repeat 5 [--skip-criteria]
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
from lwrlab.dynamics.regressor_jacobians import (
    forward_pass,
    regressor_jacobians,
    regressor_jacobians_pinocchio,
)
from lwrlab.dynamics.regressor_vjp import regressor_vjp
from lwrlab.dynamics.segment_wrench import WRENCH_BASIS_FLAT
from lwrlab.excitation.criteria import Criterion
from lwrlab.excitation.problem import ExcitationProblem
from lwrlab.excitation.solver import SlsqpOptimizer
from lwrlab.numerics.threads import blas_threads
from lwrlab.pipeline.build import build
from plugins.robots.mdh import load_robot_yaml

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


def optimal_problem(robot, base, duration: float, criterion: Criterion) -> ExcitationProblem:
    """The excitation problem of conf/trajectory/optimal.yaml (constraints, 100 Hz grid, smoothing) for a
    ``duration`` s motion and ``criterion``."""
    source = build("trajectory", "optimal", duration=duration, criterion=criterion, from_file=None)
    return source.problem(robot, base)


def quiet_optimizer(max_iterations: int | None, seed: int) -> SlsqpOptimizer:
    """conf/optimizer/slsqp.yaml's solver with ``seed``, no progress bar, ``max_iterations`` if given."""
    changes = {} if max_iterations is None else {"max_iterations": max_iterations}
    return build("optimizer", "slsqp", seed=seed, show_progress=False, **changes)


def finite_difference_gradient(problem: ExcitationProblem, x: np.ndarray, step: float = 1e-6) -> np.ndarray:
    """Central differences of the criterion, one variable at a time (the baseline)."""
    gradient = np.empty_like(x)
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = step
        gradient[i] = (problem.objective(x + e) - problem.objective(x - e)) / (2 * step)
    return gradient


def forward_mode_vjp(
    robot, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, weights: np.ndarray
) -> np.ndarray:
    """Baseline: the vector–Jacobian product by contracting the forward-mode tangents segment by segment
    (how ``regressor_vjp`` worked before its reverse mode), ∂/∂(q, q̇, q̈) stacked (3, N_J, N)."""
    n_samples, n = q.shape
    g_t = np.ascontiguousarray(weights.reshape(n_samples, n, -1).transpose(1, 2, 0))
    grad = np.zeros((3, n, n_samples))
    for seg in forward_pass(robot, q, dq, ddq):
        i, m = seg.index, seg.index + 1
        gi = g_t[:m, 10 * i : 10 * i + 10]
        y = np.einsum("mr,mn->rn", WRENCH_BASIS_FLAT, seg.state).reshape(6, 10, n_samples)
        y_bar = np.einsum("kan,kpn->apn", seg.twists, gi)
        state_bar = np.einsum("mr,rn->mn", WRENCH_BASIS_FLAT, y_bar.reshape(60, n_samples))
        grad[:, :m] += np.einsum("cdmn,mn->cdn", seg.state_tangent, state_bar)
        grad[0, :m] += np.einsum("dkan,kan->dn", seg.twist_tangent, np.einsum("apn,kpn->kan", y, gi))
    return grad


def condition_at_1khz(problem: ExcitationProblem, coefficients: np.ndarray) -> float:
    """cond of the column-scaled base regressor of the motion resampled at 1 kHz (the optimum's quality)."""
    motion = problem.parameterisation.with_coefficients(coefficients)
    w = (
        problem.base.base_regressor(regressor(problem.robot, *motion.evaluate(motion.times(1000.0))))
        * problem.scales
    )
    sigma = np.linalg.svd(w, compute_uv=False)
    return float(sigma[0] / sigma[-1])


def compare_criteria(robot, base, duration: float, seeds: list[int], max_iterations: int | None) -> None:
    """Whole optimisations with logdet (the baseline), the smooth cond and the exact cond, same seeds."""
    smooth = build("criterion", "cond")
    criteria: dict[str, Criterion] = {
        "logdet": build("criterion", "logdet"),
        f"cond (smooth, p = {smooth.sharpness:g})": smooth,
        "cond (exact σ_max/σ_min)": build("criterion", "cond", sharpness=None),
    }
    rows = {}
    for name, criterion in criteria.items():
        problem = optimal_problem(robot, base, duration, criterion)
        results = [quiet_optimizer(max_iterations, seed).solve(problem) for seed in seeds]
        rows[name] = (
            statistics.median(r.seconds for r in results),
            statistics.median(r.iterations for r in results),
            statistics.median(r.evaluations for r in results),
            statistics.median(condition_at_1khz(problem, r.coefficients) for r in results),
        )
    t_ref, it_ref = rows["logdet"][0], rows["logdet"][1]
    print(
        f"\n| criterion ({duration:g} s, medians over seeds {seeds}) | time [s] | × logdet | iterations"
        " | × logdet | evaluations | cond(W_b) at 1 kHz |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name, (seconds, iterations, evaluations, condition) in rows.items():
        print(
            f"| {name} | {seconds:.1f} | {seconds / t_ref:.2f} | {iterations:.0f} | {iterations / it_ref:.2f}"
            f" | {evaluations:.0f} | {condition:.3f} |"
        )


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--seeds", type=int, nargs="+", default=[0, 1, 2], help="seeds of the timed optimisations"
    )
    parser.add_argument("--repeat", type=int, default=5, help="repetitions of each gradient timing")
    parser.add_argument("--duration", type=float, default=10.0, help="motion duration T_F (s)")
    parser.add_argument("--max-iterations", type=int, help="per start (default: conf/optimizer/slsqp.yaml's)")
    parser.add_argument(
        "--skip-criteria", action="store_true", help="skip the logdet / cond comparison (section 4)"
    )
    args = parser.parse_args()
    with blas_threads(1):  # as the optimiser runs
        run(args)


def run(args: argparse.Namespace) -> None:
    """The three measurements of the module docstring."""
    robot = load_robot_yaml(REPO / "conf" / "robot" / "kuka_lwr4.yaml")
    base = compute_base_parameters(robot)
    problem = optimal_problem(robot, base, args.duration, build("criterion", "logdet"))
    rng = np.random.default_rng(0)
    x = problem.parameterisation.initial_coefficients(robot, rng, 0.3).ravel()

    print(
        f"robot {robot.name}: {base.count} base parameters, {problem.n_variables} variables, "
        f"{len(problem.times)} samples at {problem.rate_hz:g} Hz, "
        f"{len(problem.constraint_labels())} aggregated constraints"
    )

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
    print(
        f"| central finite differences ({2 * x.size} evaluations) | {1e3 * t_fd:.1f}"
        f" | {t_fd / t_analytic:.1f}× slower |"
    )
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
    print(
        f"| full tensors, Pinocchio computeRNEADerivatives per column | {1e3 * t_pin:.1f}"
        f" | {t_pin / t_ours:.1f}× slower |"
    )

    # 2b. the optimiser's VJP on the whole grid: reverse mode vs the forward-mode contraction (baseline)
    grid = [b @ problem.coefficients(x) for b in problem.bases]
    grid_weights = rng.normal(size=(len(problem.times), robot.n_joints, robot.n_parameters))
    t_reverse = median_seconds(lambda: regressor_vjp(robot, *grid, grid_weights), args.repeat)
    t_forward = median_seconds(lambda: forward_mode_vjp(robot, *grid, grid_weights), args.repeat)
    reverse = np.stack(regressor_vjp(robot, *grid, grid_weights))
    forward = forward_mode_vjp(robot, *grid, grid_weights).transpose(0, 2, 1)
    viscous = (
        10 * robot.n_links + robot.friction_terms.index("viscous") * robot.n_joints
        if "viscous" in robot.friction_terms
        else None
    )
    if viscous is not None:  # the baseline leaves out the viscous columns' closed form
        forward[1] += grid_weights[:, np.arange(robot.n_joints), viscous + np.arange(robot.n_joints)]
    print(f"\n| VJP on the {len(problem.times)}-sample grid | time [ms] | ratio |")
    print("|---|---|---|")
    print(f"| reverse mode (regressor_vjp) | {1e3 * t_reverse:.2f} | 1 |")
    print(
        f"| forward-mode tangents contracted (baseline) | {1e3 * t_forward:.2f}"
        f" | {t_forward / t_reverse:.1f}× slower |"
    )
    print(f"largest relative difference: {np.abs(reverse - forward).max() / np.abs(forward).max():.1e}")

    # 3. whole optimisations
    rows = []
    for seed in args.seeds:
        result = quiet_optimizer(args.max_iterations, seed).solve(problem)
        rows.append(result)
        print(
            f"seed {seed}: {result.seconds:.1f} s, {result.iterations} iterations, J = {result.cost:.3f}",
            flush=True,
        )
    seconds = [r.seconds for r in rows]
    print("\n| optimisation (10 s, 7 joints, logdet, all constraints, 1 start) | value |")
    print("|---|---|")
    print(
        f"| median wall time [s] | {statistics.median(seconds):.1f} (min {min(seconds):.1f},"
        f" max {max(seconds):.1f}, {len(seconds)} seeds) |"
    )
    print(f"| median iterations | {statistics.median([r.iterations for r in rows]):.0f} |")
    print(f"| criterion J (best, worst) | {min(r.cost for r in rows):.2f}, {max(r.cost for r in rows):.2f} |")

    # 4. the criteria: does cond converge like logdet, to as good an optimum?
    if not args.skip_criteria:
        compare_criteria(robot, base, args.duration, args.seeds, args.max_iterations)


if __name__ == "__main__":
    main()
