"""ROS 2 domains of this test process: tests that run side by side never share one.

The live tests run real DDS participants on loopback, where every participant of a domain finds every
other one of that domain on the machine: two test processes on one domain would read each other's
``/joint_states``. Each process (each pytest-xdist worker, or the one process of a plain run) takes
a block of :data:`BLOCK` domains of its own: domain ``k`` of the block for the ``k``-th use, and
``ROS_DOMAIN_ID`` (which a :class:`lwrlab.live.dds.Node` without a domain reads) set to its first.

The blocks lie in 1…100, the domains whose ports (7400 + 250 × domain) stay below Linux's ephemeral
range, where another program's socket could hold one. A run's workers take consecutive blocks from
a slot drawn from the run's id (the process id for a plain run), so two runs on one machine (two
developers', say) meet only when their slots coincide.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Mapping

BLOCK = 4
"""Domains per test process: the ``ROS_DOMAIN_ID`` of in-process nodes, then three more."""

FIRST, LAST = 1, 100
"""The domains blocks are taken from."""


def blocks() -> int:
    """How many blocks the domains hold: the most test processes that can run side by side."""
    return (LAST - FIRST + 1) // BLOCK


def ros_domain(k: int = 0, environ: Mapping[str, str] | None = None) -> int:
    """Domain ``k`` (0 ≤ k < :data:`BLOCK`) of this test process's block.

    Parameters
    ----------
    k : which of the block's domains.
    environ : the environment that tells the xdist worker (None: ``os.environ``).
    """
    if not 0 <= k < BLOCK:
        raise ValueError(f"domain {k} of a block of {BLOCK}")
    environ = os.environ if environ is None else environ
    worker = environ.get("PYTEST_XDIST_WORKER", "")  # "gw0", "gw1", … under xdist
    if worker:
        index = int(worker.removeprefix("gw"))
        count = int(environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
        if count > blocks():
            raise RuntimeError(f"{count} xdist workers: at most {blocks()} get ROS domains of their own")
        run = environ.get("PYTEST_XDIST_TESTRUNUID", "")
        slot = int(hashlib.blake2b(run.encode(), digest_size=4).hexdigest(), 16) % (blocks() // count)
        block = slot * count + index
    else:
        block = os.getpid() % blocks()
    return FIRST + BLOCK * block + k
