"""The garbage collector's thresholds of an lwrlab process."""

from __future__ import annotations

import gc
import json
import subprocess
import sys

import pytest

from lwrlab.garbage_collection import YOUNGEST_THRESHOLD, relax_garbage_collection

_REPORT_THRESHOLDS = """
import gc, json, sys
import lwrlab.cli
before = gc.get_threshold()
sys.argv = ["lwrlab", "--cfg", "job"]
lwrlab.cli.main()
print(json.dumps([before, gc.get_threshold()]))
"""


@pytest.fixture
def restored_thresholds():
    saved = gc.get_threshold()
    yield
    gc.set_threshold(*saved)


def test_only_the_youngest_threshold_is_raised(restored_thresholds: None) -> None:
    gc.set_threshold(700, 7, 3)
    relax_garbage_collection()
    assert gc.get_threshold() == (YOUNGEST_THRESHOLD, 7, 3)


def test_the_command_line_relaxes_the_collector_of_its_process() -> None:
    completed = subprocess.run(
        [sys.executable, "-c", _REPORT_THRESHOLDS], capture_output=True, text=True, check=True
    )
    before, after = json.loads(completed.stdout.splitlines()[-1])
    assert before[0] != YOUNGEST_THRESHOLD  # Python's default until main runs
    assert after == [YOUNGEST_THRESHOLD, *before[1:]]


_EXIT_WITH_GARBAGE = """
import atexit, gc
gc.disable()  # the cycle below stays until exit
atexit.register(lambda: print("frozen", gc.get_freeze_count() > 0, flush=True))  # runs after lwrlab's
from lwrlab.garbage_collection import freeze_heap_at_exit
freeze_heap_at_exit()
class Noisy:
    def __del__(self):
        print("finalized", flush=True)
garbage = Noisy()
garbage.itself = garbage
del garbage
"""


def test_at_exit_the_garbage_is_finalized_once_then_the_heap_frozen() -> None:
    completed = subprocess.run(
        [sys.executable, "-c", _EXIT_WITH_GARBAGE], capture_output=True, text=True, check=True
    )
    assert completed.stdout.split() == ["finalized", "frozen", "True"]
