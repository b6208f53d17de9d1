"""The geared arms of ``benchmarks/geared_arms.py`` for the tests, and their motions with rests.

The tests import it as ``from geared_logs import geared_arms, warped_multisine`` (pytest puts
``tests/`` on the path, as for ``composing``).
"""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lwrlab.plants.planned_motions import MultisinePath, RestSchedule, WarpedMotion

_PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "geared_arms.py"
_SPEC = importlib.util.spec_from_file_location("geared_arms", _PATH)
assert _SPEC is not None and _SPEC.loader is not None
geared_arms = importlib.util.module_from_spec(_SPEC)
sys.modules["geared_arms"] = geared_arms  # dataclasses look their module up there
_SPEC.loader.exec_module(geared_arms)


def warped_multisine(
    spec: Any,
    move_s: float,
    frequencies: Sequence[float],
    seed: int,
    rests: tuple[float, float] = (0.5, 1.0),
    ramp_s: float = 0.4,
) -> WarpedMotion:
    """A rest, a ramp, a multisine about ``spec.center`` (within its reach, speed and acceleration)
    for ``move_s`` seconds, a ramp and a rest (s)."""
    schedule = RestSchedule(
        (("rest", rests[0]), ("up", ramp_s), ("move", move_s), ("down", ramp_s), ("rest", rests[1]))
    )
    path = MultisinePath.random(
        spec.center,
        list(frequencies),
        spec.reach,
        spec.speed,
        spec.acceleration,
        schedule.path_length,
        np.random.default_rng(seed),
    )
    return WarpedMotion(path, schedule)
