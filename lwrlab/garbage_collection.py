"""The garbage collector's thresholds of an ``lwrlab`` process.

CPython collects its youngest generation every 700 net allocations of container objects, the
middle one every tenth time, and the oldest one every tenth time after that once the objects that
survived grew by a quarter. Starting a job allocates millions of them
(Hydra and OmegaConf nodes, pandas and matplotlib modules, MLflow's in the tracking companion), so
the collector walks the whole, ever growing, heap of long-lived module objects again and again
while nothing in it is garbage. Measured on a 2-core machine with ``gc.callbacks`` (one run each;
the variation between runs was about 10 %):

====================================================  ================  ======================
work                                                  default (700)     :data:`YOUNGEST_THRESHOLD`
====================================================  ================  ======================
``task=identification`` from a 10 s log               0.24–0.26 s       0.09–0.10 s
the paper's chain (``lwrlab``)                        0.38–0.45 s       0.15 s
the tracking companion importing MLflow               0.20 s            0.13 s
====================================================  ================  ======================

The peak memory of the chain did not change (about 460 MB either way): a young generation of
10 000 objects holds at most a few MB of garbage with cycles before it is collected.

The interpreter's own shutdown collects the whole heap again several times while it clears the
modules: 0.4–0.7 s after an identification had written its last file. :func:`freeze_heap_at_exit`
collects the garbage once (0.1 s: its finalizers run as they would) and freezes what is left, which
the shutdown's collections then skip; the exit hooks, threads and finalizers run as before.
"""

from __future__ import annotations

import atexit
import gc

YOUNGEST_THRESHOLD = 10_000
"""Net allocations of container objects between two collections of the youngest generation."""


def relax_garbage_collection() -> None:
    """Collect the youngest generation every :data:`YOUNGEST_THRESHOLD` allocations instead of 700.

    The older generations keep their thresholds (10 collections of the one below), so they are
    collected 14 times less often too. Child processes that run Python anew (launcher workers)
    keep Python's defaults unless they call this.
    """
    _, middle, oldest = gc.get_threshold()
    gc.set_threshold(YOUNGEST_THRESHOLD, middle, oldest)


def _collect_and_freeze() -> None:
    gc.collect()
    gc.freeze()


def freeze_heap_at_exit() -> None:
    """At exit, collect the garbage once and freeze the rest: the shutdown does not collect it again."""
    atexit.register(_collect_and_freeze)


__all__ = ["YOUNGEST_THRESHOLD", "freeze_heap_at_exit", "relax_garbage_collection"]
