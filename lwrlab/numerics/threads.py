"""BLAS thread limits around small and medium dense algebra (QR, least squares, SVD, compression).

OpenBLAS starts as many threads as cores. On the matrices this lab factors (a few thousand to a
few tens of thousands of rows, at most ~100 columns) the threads barely pay on an idle machine and
cost a lot on a busy one: each thread spin-waits for the others, and a thread that shares its core
with another process stalls the whole call. Measured with ``benchmarks/threads.py`` on a 2-core
machine, as t(2 threads) / t(1 thread) of the median wall time (above 1, one thread wins; "busy":
other processes spinning on that many cores; the "idle" machine had other light jobs):

=====================================  =======  ============  =============
operation                              idle     1 core busy   2 cores busy
=====================================  =======  ============  =============
compute_base_parameters (2 800 × 84)   4.3      7.3           11.6
criterion QR + SVD (7 007 × 57)        1.06     1.03          5.7
logdet value + gradient (7 007 × 57)   0.82     0.93          0.98
least squares, 50 Hz (3 500 × 57)      1.8      1.3           13.5
least squares, 1 kHz (67 200 × 57)     0.82     0.92          1.9
QR compression (67 200 × 58, blocked)  1.7      4.2           31
=====================================  =======  ============  =============

One thread wins or ties everywhere but on the largest least squares and the logdet products on an
idle machine, where two buy at most 1.2× and lose up to 2× as soon as another core is busy; the
base parameters, compression and small least squares lose 2 to 30×. So
:data:`DENSE_ALGEBRA_THREADS` is 1. The limits are entered through a controller built once (the
library scan of ``threadpoolctl.threadpool_limits`` costs ~0.7 ms per call, this ~15 µs).
"""

from __future__ import annotations

import functools
import os
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager
from typing import Protocol

DENSE_ALGEBRA_THREADS: int | None = 1
"""BLAS threads for the dense algebra of base parameters, least squares, criteria and compression
(None: leave BLAS as it is; ``benchmarks/threads.py`` sets it to compare settings)."""


class _BlasController(Protocol):
    """What is used of ``threadpoolctl.ThreadpoolController`` (an untyped package)."""

    def limit(self, *, limits: int, user_api: str) -> AbstractContextManager[object]:
        """A block in which the libraries of ``user_api`` use at most ``limits`` threads."""
        ...


@functools.cache
def _controller() -> _BlasController | None:
    """A threadpoolctl controller over the BLAS libraries numpy and scipy load.

    None without threadpoolctl.
    """
    import numpy  # noqa: F401 - load both BLAS libraries before the scan
    import scipy.linalg  # noqa: F401

    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover - a declared dependency
        return None
    return ThreadpoolController()


@contextmanager
def blas_threads(limit: int | None) -> Iterator[None]:
    """Limit the BLAS threads of numpy and scipy to ``limit`` inside the block (None: leave them)."""
    controller = _controller()
    if limit is None or controller is None:
        yield
        return
    with controller.limit(limits=limit, user_api="blas"):
        yield


@contextmanager
def dense_algebra() -> Iterator[None]:
    """:func:`blas_threads` with :data:`DENSE_ALGEBRA_THREADS` (read at each entry).

    Usable as a block or a decorator.

    Examples
    --------
    >>> import numpy as np
    >>> with dense_algebra():
    ...     r = np.linalg.qr(np.eye(3), mode="r")
    >>> @dense_algebra()
    ... def factor(a):
    ...     return np.linalg.qr(a, mode="r")
    """
    with blas_threads(DENSE_ALGEBRA_THREADS):
        yield


PROCESS_BLAS_THREADS = 1
"""BLAS threads of an ``lwrlab`` job's process, set before numpy loads OpenBLAS.

The blocks above limit the factorisations; the remaining BLAS calls of a job (regressor products,
predictions, the filters' banded solves) are short, and after each one OpenBLAS's idle threads
spin-wait for more work: on two cores they take the core that the tracking companion or a parallel
worker needs. Measured on ``task=identification`` from a 10 s log, tracking on, 2 cores (3 runs
each, alternating): 3.3–3.5 s wall and 4.9–5.0 s CPU with one thread, 4.1–4.9 s and 5.9–6.8 s
with OpenBLAS's default of one per core."""

BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
"""The variables the BLAS libraries numpy and scipy ship with read when they load."""


def limit_process_blas_threads() -> bool:
    """Make BLAS load with :data:`PROCESS_BLAS_THREADS` threads, unless the environment says otherwise.

    Only possible before numpy is imported (returns whether it was): the libraries read the
    variables once, when they load. A user's own ``OPENBLAS_NUM_THREADS`` wins; child processes
    (launcher workers) inherit the choice.
    """
    import sys

    if "numpy" in sys.modules:
        return False
    for variable in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(variable, str(PROCESS_BLAS_THREADS))
    return True
