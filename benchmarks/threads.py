"""BLAS threads on the lab's dense algebra: 1 thread against 2, idle and with busy cores, in one run.

Each operation is timed with :data:`lwrlab.numerics.threads.DENSE_ALGEBRA_THREADS` (the limit the
lab's dense algebra runs under) set to 1 and to 2 threads (the two settings take turns within each round, median of ``--repeat``), first on an idle machine,
then while ``k`` other processes spin on ``k`` cores (``--busy 0 1 2``), as when other jobs share
the machine. The operations are those run under :func:`lwrlab.numerics.threads.blas_threads`:

* ``compute_base_parameters`` of the LWR4 (regressor of 400 samples, two 2 800 × 84 QR, lstsq);
* an excitation criterion's QR + SVD (``extreme_singular_pairs``) and ``logdet`` on 7 007 × 57;
* weighted least squares (``weighted_least_squares``) on 3 500 × 57 (50 Hz) and 67 200 × 57 (1 kHz);
* the blocked QR compression (``compress``) of 67 200 × 58.

It prints the median times and the ratio t(2 threads) / t(1 thread): above 1, one thread wins.

Usage::

    .venv/bin/python benchmarks/threads.py --busy 0 1 2 --repeat 5
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from lwrlab.dynamics.base_parameters import compute_base_parameters
from lwrlab.excitation.criteria import extreme_singular_pairs
from lwrlab.identification.compression import compress
from lwrlab.identification.least_squares import weighted_least_squares
from lwrlab.numerics import threads
from plugins.criteria.logdet import LogDet
from plugins.robots.mdh import load_robot_yaml

REPO = Path(__file__).resolve().parents[1]
SPIN = "while True: pass"


def operations() -> dict[str, Callable[[], object]]:
    """The timed operations, on fixed random data of the lab's sizes."""
    robot = load_robot_yaml(REPO / "conf" / "robot" / "kuka_lwr4.yaml")
    rng = np.random.default_rng(0)
    criterion_w = rng.normal(size=(7007, 57))
    small_w, small_tau = rng.normal(size=(3500, 57)), rng.normal(size=3500)
    large_w, large_tau = rng.normal(size=(67200, 57)), rng.normal(size=67200)
    weights = rng.uniform(0.5, 2.0, size=67200)
    return {
        "compute_base_parameters (2 800 × 84)": lambda: compute_base_parameters(robot),
        "criterion QR + SVD (7 007 × 57)": lambda: extreme_singular_pairs(criterion_w),
        "logdet value + gradient (7 007 × 57)": lambda: LogDet().value_and_gradient(criterion_w),
        "least squares 50 Hz (3 500 × 57)": lambda: weighted_least_squares(small_w, small_tau),
        "least squares 1 kHz (67 200 × 57)": lambda: weighted_least_squares(large_w, large_tau, weights),
        "QR compression (67 200 × 58)": lambda: compress(large_w, large_tau),
    }


def median_seconds(function: Callable[[], object], repeat: int) -> dict[int, float]:
    """Median wall time (s) with 1 and with 2 BLAS threads; the settings alternate within each round."""
    times: dict[int, list[float]] = {1: [], 2: []}
    for _ in range(repeat):
        for count in (1, 2):
            threads.DENSE_ALGEBRA_THREADS = count  # what the lab's functions limit BLAS to
            start = time.perf_counter()
            with threads.dense_algebra():  # as the optimiser runs the criteria
                function()
            times[count].append(time.perf_counter() - start)
    threads.DENSE_ALGEBRA_THREADS = 1
    return {count: statistics.median(values) for count, values in times.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--busy",
        type=int,
        nargs="+",
        default=[0, 1, 2],
        help="numbers of cores kept busy by spinning processes",
    )
    parser.add_argument("--repeat", type=int, default=5, help="timed calls per setting (the median counts)")
    args = parser.parse_args()
    ops = operations()
    for function in ops.values():  # warm-up: imports, caches, BLAS thread start
        function()
    print("| operation | busy cores | 1 thread [ms] | 2 threads [ms] | t(2)/t(1) |")
    print("|---|---:|---:|---:|---:|")
    for busy in args.busy:
        spinners = [subprocess.Popen([sys.executable, "-c", SPIN]) for _ in range(busy)]
        try:
            time.sleep(0.5)
            for name, function in ops.items():
                t = median_seconds(function, args.repeat)
                print(
                    f"| {name} | {busy} | {1e3 * t[1]:.1f} | {1e3 * t[2]:.1f} | {t[2] / t[1]:.2f} |",
                    flush=True,
                )
        finally:
            for spinner in spinners:
                spinner.kill()
                spinner.wait()


if __name__ == "__main__":
    main()
