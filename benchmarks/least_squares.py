"""The one weighted least squares (QR-compressed, then ``lstsq`` on the small triangle) against the
two solvers it replaced, timed in the same run, with the largest difference of the solutions.

* ``lstsq`` on the tall weighted rows: what the least-squares estimators (ols, wls, irls) ran;
* Cholesky of the column-scaled Gram matrix: what payload identification ran (fast, but it squares
  the condition number and fails on a rank-deficient regressor).

Sizes: a 10 s identification at 50 Hz rows (3 500 × 57) and at 1 kHz (67 200 × 57), and the
stacked unloaded + loaded payload problem of eq. (7) at 1 kHz (2 × 28 000 × (57 + 10)). The
columns get LWR4-like scales (1 to 1e3) so the solvers see a realistic conditioning. Every timing
is the median of ``--repeat`` calls under the lab's BLAS thread limit.

Usage::

    .venv/bin/python benchmarks/least_squares.py --repeat 7
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import numpy as np
import scipy.linalg

from lwrlab.identification.least_squares import weighted_least_squares
from lwrlab.numerics.threads import dense_algebra


@dense_algebra()
def tall_lstsq(W: np.ndarray, tau: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The former estimator path: ``lstsq`` on the weighted rows, covariance ``pinv(WᵀPW)``."""
    root = np.sqrt(weights)
    scaled = W * root[:, None]
    phi, *_ = np.linalg.lstsq(scaled, tau * root, rcond=None)
    return phi, np.linalg.pinv(scaled.T @ scaled)


@dense_algebra()
def gram_cholesky(W: np.ndarray, tau: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The former payload path: Cholesky of the column-scaled Gram matrix of the weighted rows."""
    root = np.sqrt(weights)
    scaled_w, scaled_tau = W * root[:, None], tau * root
    scale = np.linalg.norm(scaled_w, axis=0)
    unit = scaled_w / scale
    r = scipy.linalg.cholesky(unit.T @ unit, lower=False)
    y = scipy.linalg.solve_triangular(r, unit.T @ scaled_tau, trans="T")
    r_inverse = scipy.linalg.solve_triangular(r, np.eye(r.shape[0]))
    return scipy.linalg.solve_triangular(r, y) / scale, (r_inverse @ r_inverse.T) / np.outer(scale, scale)


def median_time(call: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    print(
        "| problem | QR + lstsq (s) | tall lstsq (s) | ratio | Gram Cholesky (s) | ratio | max rel. diff of φ |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|")
    for label, rows, columns in [
        ("50 Hz rows", 3500, 57),
        ("1 kHz rows", 67200, 57),
        ("payload eq. (7), 1 kHz", 56000, 67),
    ]:
        W = rng.normal(size=(rows, columns)) * np.logspace(0, 3, columns)
        tau = W @ rng.normal(size=columns) + rng.normal(size=rows)
        weights = np.tile(1.0 / rng.uniform(0.05, 1.0, size=7) ** 2, rows // 7)
        new = median_time(lambda: weighted_least_squares(W, tau, weights), args.repeat)
        old_estimators = median_time(lambda: tall_lstsq(W, tau, weights), args.repeat)
        old_payload = median_time(lambda: gram_cholesky(W, tau, weights), args.repeat)
        phi = weighted_least_squares(W, tau, weights).phi
        difference = max(
            np.max(np.abs(phi - f(W, tau, weights)[0]) / np.abs(phi)) for f in (tall_lstsq, gram_cholesky)
        )
        print(
            f"| {label} ({rows} × {columns}) | {new:.4f} | {old_estimators:.4f} | {old_estimators / new:.2f} | "
            f"{old_payload:.4f} | {old_payload / new:.2f} | {difference:.1e} |"
        )


if __name__ == "__main__":
    main()
