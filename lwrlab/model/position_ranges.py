"""Joint position ranges, with or without position limits.

A continuous joint (URDF ``type="continuous"``: a wheel, the wrist of a Kinova arm) turns without
end: its position limits are infinite (``-inf``, ``+inf`` in :class:`~lwrlab.model.robot.JointLimits`).
Whatever needs a finite range from the limits (random states, the centre of a motion, the fraction of
the range a log covers) asks these functions, which give such a joint one full turn around 0, the
angles it can take; a joint with limits keeps them. Identification only needs the angle, so one turn
shows every configuration of an unbounded joint.

Examples
--------
>>> import numpy as np
>>> lower, upper = np.array([-1.0, -np.inf]), np.array([2.0, np.inf])
>>> unbounded(lower, upper).tolist()
[False, True]
>>> range_center(lower, upper).tolist()
[0.5, 0.0]
>>> [round(float(x), 4) for x in range_span(lower, upper)]
[3.0, 6.2832]
"""

from __future__ import annotations

import numpy as np

FULL_TURN = 2.0 * np.pi
"""rad: the range given to a joint without position limits (one turn, every angle once)."""


def unbounded(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """(N_J,) True for a joint without a (finite) lower or upper position limit."""
    return ~(np.isfinite(np.asarray(lower, dtype=float)) & np.isfinite(np.asarray(upper, dtype=float)))


def finite_range(lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) rad: the limits, one turn (centred on 0, or reaching from the finite side) where a
    limit is missing."""
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    finite_lower, finite_upper = np.isfinite(lower), np.isfinite(upper)
    low = np.where(finite_lower, lower, np.where(finite_upper, upper - FULL_TURN, -0.5 * FULL_TURN))
    high = np.where(finite_upper, upper, low + FULL_TURN)
    return low, high


def range_center(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """(N_J,) rad: the middle of each position range, 0 for a joint without limits."""
    low, high = finite_range(lower, upper)
    return 0.5 * (low + high)


def range_span(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """(N_J,) rad: the width of each position range, one turn (2π) for a joint without limits."""
    low, high = finite_range(lower, upper)
    return high - low
