"""BLAS thread limits (lwrlab/numerics/threads.py): applied inside, restored after, honoured by the lab's algebra."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from threadpoolctl import ThreadpoolController, threadpool_limits

from lwrlab.numerics import threads
from lwrlab.numerics.threads import blas_threads, dense_algebra


def blas_thread_counts() -> set[int]:
    """Thread counts of numpy's and scipy's BLAS (another loaded BLAS, e.g. SCS's single-threaded one, keeps its own)."""
    libraries = ThreadpoolController().info()
    return {
        lib["num_threads"]
        for lib in libraries
        if lib["user_api"] == "blas" and ("numpy" in lib["filepath"] or "scipy" in lib["filepath"])
    }


@pytest.fixture
def two_threads():
    """BLAS at 2 threads around the test, so that a limit to 1 is visible (and restored afterwards)."""
    with threadpool_limits(2, user_api="blas"):
        yield


def test_dense_algebra_limits_inside_and_restores_after(two_threads: None) -> None:
    before = blas_thread_counts()
    with dense_algebra():
        assert blas_thread_counts() == {threads.DENSE_ALGEBRA_THREADS}
    assert blas_thread_counts() == before


def test_decorator_reads_the_setting_at_each_call(two_threads: None, monkeypatch: pytest.MonkeyPatch) -> None:
    @dense_algebra()
    def counts() -> set[int]:
        return blas_thread_counts()

    assert counts() == {1}
    monkeypatch.setattr(threads, "DENSE_ALGEBRA_THREADS", 2)
    assert counts() == {2}
    monkeypatch.setattr(threads, "DENSE_ALGEBRA_THREADS", None)
    assert counts() == blas_thread_counts()


def test_none_leaves_blas_alone(two_threads: None) -> None:
    before = blas_thread_counts()
    with blas_threads(None):
        assert blas_thread_counts() == before


def test_lab_algebra_runs_single_threaded(two_threads: None, monkeypatch: pytest.MonkeyPatch) -> None:
    """The least squares run their BLAS calls under the limit, whatever the caller set."""
    from lwrlab.identification import least_squares

    seen = []
    original_lstsq = np.linalg.lstsq

    def spy(*args, **kwargs):
        seen.append(blas_thread_counts())
        return original_lstsq(*args, **kwargs)

    monkeypatch.setattr(least_squares.np.linalg, "lstsq", spy)
    rng = np.random.default_rng(0)
    least_squares.weighted_least_squares(rng.normal(size=(50, 3)), rng.normal(size=50))
    assert seen == [{1}]


_REPORT_BLAS = """
import json, sys
from lwrlab.numerics.threads import limit_process_blas_threads
limited = limit_process_blas_threads()
import numpy, scipy.linalg
from threadpoolctl import threadpool_info
counts = sorted({pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"})
print(json.dumps([limited, counts, limit_process_blas_threads()]))
"""


def _blas_of_a_new_process(env: dict[str, str]) -> list[object]:
    environment = {k: v for k, v in os.environ.items() if k not in threads.BLAS_THREAD_VARIABLES}
    completed = subprocess.run(
        [sys.executable, "-c", _REPORT_BLAS],
        env={**environment, **env},
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(completed.stdout)


def test_a_job_process_loads_blas_with_one_thread_unless_the_user_says_otherwise() -> None:
    assert _blas_of_a_new_process({}) == [True, [threads.PROCESS_BLAS_THREADS], False]  # too late once loaded
    if (os.cpu_count() or 1) >= 2:
        assert _blas_of_a_new_process({"OPENBLAS_NUM_THREADS": "2"}) == [True, [2], False]
