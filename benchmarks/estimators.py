"""Speed of the estimators on a 10 s, 1 kHz, 7-joint measurement; the SDP with and without compression.

The simulated LWR4 (truth = CAD perturbed by 10 %, consistent) follows the default 10 s exciting
motion, sampled at 1 kHz, with σ_τ = 0.05 N·m torque noise; the base regressor has
(samples − trimmed) × 7 rows. The script times, best of ``--repeat`` (wall clock):

* the QR compression alone (``lwrlab.identification.compression.compress``);
* every estimator's ``fit`` (ols, wls, irls, iv, sdp with each regularisation), with the lab's BLAS
  thread limit (one thread, :mod:`lwrlab.numerics.threads`) and, as the baseline, with BLAS at its
  default thread count, and their ratio;
* the SDP without compression (``compress=False``: the solver sees every row), the baseline,
  measured once in the same run (it takes tens of seconds), and the ratio. Both sides fit the same
  problem, ``regularization=euclidean`` with the fixed weight 1e-2: with ``weight: auto`` (the
  shipped YAML's, cross-validated over row statistics) the SDP always fits from QR factors, whatever
  ``compress`` says, so the baseline would be compressed too. Every SDP row prints the largest data
  dimension cvxpy was handed (the rows the solver sees), and the run stops if the baseline's is not
  every row;

and the relative base-parameter error of each, so speed is not bought with accuracy.

Usage::

    .venv/bin/python benchmarks/estimators.py --repeat 5 [--skip-uncompressed]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import cvxpy as cp
import numpy as np

from lwrlab.dynamics.base_parameters import compute_base_parameters
from lwrlab.dynamics.regressor import regressor
from lwrlab.identification.compression import compress
from lwrlab.identification.context import IdentificationContext
from lwrlab.numerics import threads
from lwrlab.pipeline.build import build
from lwrlab.plants.simulation import perturbed_robot
from plugins.robots.mdh import load_robot_yaml

REPO = Path(__file__).resolve().parents[1]


def best_time(function: Callable[[], object], repeat: int) -> float:
    """Smallest wall-clock time of ``repeat`` calls (s)."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


@contextmanager
def solver_data_rows() -> Iterator[list[int]]:
    """Inside the block, the largest data dimension of every problem cvxpy solves, in order: the rows
    of its longest matrix (``size_metrics.max_data_dimension``), i.e. how many rows the solver sees."""
    seen: list[int] = []
    solve = cp.Problem.solve

    def spy(problem: cp.Problem, *args: object, **kwargs: object) -> object:
        seen.append(int(problem.size_metrics.max_data_dimension))
        return solve(problem, *args, **kwargs)

    cp.Problem.solve = spy
    try:
        yield seen
    finally:
        cp.Problem.solve = solve


def both_settings(function: Callable[[], object], repeat: int) -> tuple[float, float]:
    """Best time with the lab's BLAS limit (:data:`lwrlab.numerics.threads.DENSE_ALGEBRA_THREADS`) and
    with BLAS left at its default threads (the baseline), the two taking turns."""
    limited, default = [], []
    for _ in range(repeat):
        limited.append(best_time(function, 1))
        threads.DENSE_ALGEBRA_THREADS = None
        try:
            default.append(best_time(function, 1))
        finally:
            threads.DENSE_ALGEBRA_THREADS = 1
    return min(limited), min(default)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--duration", type=float, default=10.0, help="s of motion at 1 kHz")
    parser.add_argument(
        "--skip-uncompressed", action="store_true", help="skip the slow uncompressed SDP baseline"
    )
    args = parser.parse_args()

    robot = load_robot_yaml(REPO / "conf" / "robot" / "kuka_lwr4.yaml")
    base = compute_base_parameters(robot)
    truth = perturbed_robot(robot, 0.1, 0.2, np.random.default_rng(0))
    motion = build("trajectory", "multisine", duration=args.duration).sample(robot, 1000.0)  # seed 0
    trim = slice(200, -200)  # the default 0.2 s trimming of the processing
    q, dq, ddq = motion.q[trim], motion.dq[trim], motion.ddq[trim]
    w = base.base_regressor(regressor(robot, q, dq, ddq))
    tau = (truth.inverse_dynamics(q, dq, ddq) + 0.05 * np.random.default_rng(1).normal(size=q.shape)).ravel()
    beta = base.base_values(truth.parameters)
    context = IdentificationContext.from_robot(robot, base, reference_regressor=w)
    print(
        f"{robot.name}: {args.duration:g} s at 1 kHz → W_b {w.shape[0]} rows × {w.shape[1]} base parameters\n"
    )

    def compress_limited() -> object:
        with threads.dense_algebra():  # as the SDP runs it
            return compress(w, tau)

    t_compress, t_compress_default = both_settings(compress_limited, args.repeat)
    # The SDP rows name their weight: the YAML's is `auto` (cross-validated), which fits from row
    # statistics (QR factors) whatever `compress` says; a fixed weight is what `compress` switches.
    estimators = {
        "ols": build("estimator", "ols"),
        "wls": build("estimator", "wls"),
        "irls": build("estimator", "irls"),
        "iv": build("estimator", "iv"),
        "sdp (euclidean, weight 1e-2)": build("estimator", "sdp", regularization="euclidean", weight=1e-2),
        "sdp (entropic, weight 1e-4)": build("estimator", "sdp", regularization="entropic", weight=1e-4),
        "sdp (none)": build("estimator", "sdp", regularization="none", weight=0.0),
        "sdp (shipped YAML: entropic, weight auto)": build("estimator", "sdp"),
    }
    print(
        f"| estimator | fit (s), best of {args.repeat} | BLAS default threads (s) | default / limited "
        "| ‖β̂−β‖/‖β‖ | rows cvxpy sees |"
    )
    print("|---|---:|---:|---:|---:|---:|")
    print(
        f"| QR compression alone | {t_compress:.4f} | {t_compress_default:.4f} "
        f"| {t_compress_default / t_compress:.1f} | | |"
    )
    for name, estimator in estimators.items():
        seconds, default = both_settings(lambda e=estimator: e.fit(w, tau, context=context), args.repeat)
        with solver_data_rows() as rows_seen:  # one more fit, untimed: what cvxpy was handed, if used
            estimator.fit(w, tau, context=context)
        error = np.linalg.norm(estimator.phi_ - beta) / np.linalg.norm(beta)
        rows = str(max(rows_seen)) if rows_seen else ""
        print(f"| {name} | {seconds:.4f} | {default:.4f} | {default / seconds:.1f} | {error:.3e} | {rows} |")
    compressed_name = "sdp (euclidean, weight 1e-2)"
    compressed = best_time(lambda: estimators[compressed_name].fit(w, tau, context=context), args.repeat)
    if not args.skip_uncompressed:
        # The same problem as `compressed_name`, every row handed to cvxpy.
        uncompressed_estimator = build(
            "estimator", "sdp", regularization="euclidean", weight=1e-2, compress=False
        )
        with solver_data_rows() as rows_seen:
            uncompressed = best_time(lambda: uncompressed_estimator.fit(w, tau, context=context), 1)
        if not rows_seen or max(rows_seen) < w.shape[0]:
            seen = max(rows_seen, default=0)
            raise SystemExit(
                f"the uncompressed baseline is not uncompressed: cvxpy saw at most {seen} rows of "
                f"{w.shape[0]} (has the sdp plugin's compress=False path changed?)"
            )
        difference = np.linalg.norm(
            uncompressed_estimator.phi_ - estimators[compressed_name].phi_
        ) / np.linalg.norm(beta)
        print(
            f"| sdp (euclidean, weight 1e-2), uncompressed (baseline, 1 run) | {uncompressed:.3f} | | "
            f"| | {max(rows_seen)} |"
        )
        print(
            f"\nSDP (euclidean, weight 1e-2): compressed {compressed:.3f} s (compression included) "
            f"vs uncompressed {uncompressed:.2f} s: "
            f"{uncompressed / compressed:.1f}× faster; solutions differ by {difference:.1e} (relative to ‖β‖)"
        )


if __name__ == "__main__":
    main()
